// Issue 10, "memory follows the scene": the field atlas holds only the fields a frame draws, one
// slot per asset however many instances use it, and the frame's SDF passes run only when the scene
// has SDF objects. Both backends, under validation.
//   - one field object: the atlas is at most a quarter of the default scene's (3 fields);
//   - 100 instances of one baked field: one slot, the same atlas bytes as one instance;
//   - a frame without that field (the entity hidden) frees its slot; a mesh-only scene has no
//     sdf_upload / sdf_trace pass and no atlas.
#include <algorithm>
#include <filesystem>

#include <gtest/gtest.h>

#include "engine/assets/primitives.h"
#include "engine/engine.h"
#include "renderer/scene_renderer.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

constexpr uint32_t kWidth = 96, kHeight = 54;

bool hasPass(const render::FrameStats& stats, const std::string& name) {
    return std::any_of(stats.passes.begin(), stats.passes.end(),
                       [&](const fg::PassTiming& p) { return p.name == name; });
}

class SdfMemory : public GpuTest {
protected:
    // Renders the engine's scene once and returns the frame's statistics.
    render::FrameStats renderOnce(Engine& engine, render::SceneRenderer& renderer) {
        render::FrameDesc frame;
        frame.width = kWidth;
        frame.height = kHeight;
        frame.settings = engine.settings();
        frame.camera = scene::findCamera(engine.world(), engine.settings().camera);
        EXPECT_NE(frame.camera, ecs::kNullEntity);
        std::string error;
        engine.update(0.0);
        EXPECT_TRUE(renderer.render(engine.world(), engine.assets(), frame, error)) << error;
        render::FrameStats stats = renderer.lastFrameStats();
        dev().waitIdle();
        return stats;
    }

    // A camera, a light and `count` instances of one field baked from a procedural sphere mesh.
    std::unique_ptr<Engine> instancedScene(uint32_t count, std::vector<ecs::Entity>& instances) {
        std::string error;
        EngineDesc desc;
        desc.loadStaticPlugins = false;
        std::unique_ptr<Engine> engine = Engine::create(desc, error);
        EXPECT_TRUE(engine) << error;
        assets::AssetManager& assets = engine->assets();
        ecs::World& world = engine->world();
        assets::MeshData sphere;
        EXPECT_TRUE(assets::makeSphere(0.5f, 24, 12, sphere, error)) << error;
        const assets::AssetId mesh = assets.addMesh("test:sphere", std::move(sphere), error);
        EXPECT_NE(mesh, 0u) << error;
        sdf::BakeSettings bake;
        bake.resolution = 32;
        const assets::AssetId field = assets.bakeSdf(mesh, bake, error);
        EXPECT_NE(field, 0u) << error;
        const ecs::Entity cam = world.create();
        world.add<ecs::Transform>(cam)->position = {0.0f, 0.0f, 30.0f};
        world.add<ecs::Camera>(cam)->farPlane = 100.0f;
        world.add<ecs::Name>(cam)->value = "cam";
        engine->settings().camera = "cam";
        for (uint32_t i = 0; i < count; ++i) {
            const ecs::Entity e = world.create();
            ecs::Transform& t = *world.add<ecs::Transform>(e);
            t.position = {float(i % 10) * 2.0f - 9.0f, float(i / 10) * 2.0f - 9.0f, 0.0f};
            ecs::SdfRenderer& sr = *world.add<ecs::SdfRenderer>(e);
            sr.sdf = field;
            sr.source = ecs::SdfSource::Field;
            instances.push_back(e);
        }
        return engine;
    }
};

TEST_P(SdfMemory, HundredInstancesOfOneFieldUseOneSlot) {
    std::vector<ecs::Entity> one, hundred;
    std::unique_ptr<Engine> a = instancedScene(1, one);
    std::unique_ptr<Engine> b = instancedScene(100, hundred);
    ASSERT_TRUE(a && b);
    render::SceneRenderer ra(dev()), rb(dev());
    const render::FrameStats sa = renderOnce(*a, ra);
    const render::FrameStats sb = renderOnce(*b, rb);
    EXPECT_EQ(sa.sdfObjects, 1u);
    EXPECT_EQ(sb.sdfObjects, 100u);
    EXPECT_EQ(sa.atlas.slots, 1u);
    EXPECT_EQ(sb.atlas.slots, 1u) << "100 instances of one asset occupy one slot";
    EXPECT_GT(sa.atlas.bytes, 0u);
    EXPECT_EQ(sb.atlas.bytes, sa.atlas.bytes) << "instances add no atlas memory";
    EXPECT_EQ(sb.memory.sdfAtlas, sb.atlas.bytes);
    EXPECT_TRUE(hasPass(sb, "sdf_trace"));

    // Hidden: the field is no longer drawn, so its slot is freed (the texture is kept).
    for (ecs::Entity e : hundred) b->world().get<ecs::SdfRenderer>(e)->visible = false;
    const render::FrameStats hidden = renderOnce(*b, rb);
    EXPECT_EQ(hidden.sdfObjects, 0u);
    EXPECT_EQ(hidden.atlas.slots, 0u);
    EXPECT_FALSE(hasPass(hidden, "sdf_trace")) << "no SDF object: no trace pass";
    EXPECT_FALSE(hasPass(hidden, "sdf_upload"));
}

TEST_P(SdfMemory, OneObjectSceneHasAFarSmallerAtlasThanTheDefaultScene) {
    if (!std::filesystem::exists(PENUMBRA_SOURCE_DIR "/data/meshes/bunny.ply"))
        FAIL() << "data/meshes is missing: run tools/fetch_meshes.sh";
    std::string error;
    EngineDesc desc;
    desc.loadStaticPlugins = false;
    desc.cacheDir = PENUMBRA_BINARY_DIR "/test_cache";  // the default scene's bakes, shared by the tests
    std::unique_ptr<Engine> full = Engine::create(desc, error);
    ASSERT_TRUE(full && full->loadScene(PENUMBRA_SOURCE_DIR "/scenes/default.json", error)) << error;
    render::SceneRenderer rf(dev());
    const render::FrameStats sf = renderOnce(*full, rf);
    EXPECT_EQ(sf.atlas.slots, 3u) << "bunny (two instances), teapot, dragon";

    // The same scene with only the teapot's field drawn.
    for (auto [e, sr] : full->world().view<ecs::SdfRenderer>()) {
        const ecs::Name* n = full->world().get<ecs::Name>(e);
        if (sr.source == ecs::SdfSource::MeshBake && (!n || n->value != "teapot")) sr.visible = false;
    }
    render::SceneRenderer ro(dev());
    const render::FrameStats so = renderOnce(*full, ro);
    EXPECT_EQ(so.atlas.slots, 1u);
    std::printf("atlas: default scene %llu bytes (fill %.2f), teapot only %llu bytes (fill %.2f)\n",
                (unsigned long long)sf.atlas.bytes, sf.atlas.fill, (unsigned long long)so.atlas.bytes,
                so.atlas.fill);
    EXPECT_LE(so.atlas.bytes * 4, sf.atlas.bytes)
        << "a one-field frame's atlas is at most 1/4 of the default";

    // A mesh-only scene: no SDF pass, no atlas.
    std::unique_ptr<Engine> meshes = Engine::create(desc, error);
    ASSERT_TRUE(meshes && meshes->loadScene(PENUMBRA_SOURCE_DIR "/scenes/primitives.json", error)) << error;
    render::SceneRenderer rm(dev());
    const render::FrameStats sm = renderOnce(*meshes, rm);
    EXPECT_FALSE(hasPass(sm, "sdf_trace"));
    EXPECT_FALSE(hasPass(sm, "sdf_upload"));
    EXPECT_EQ(sm.atlas.bytes, 0u);
    EXPECT_EQ(sm.memory.sdfAtlas, 0u);
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfMemory, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test
