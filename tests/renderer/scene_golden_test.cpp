// Scenes end to end (scene file -> Engine -> SceneRenderer): golden images per backend and
// Vulkan-vs-OpenGL parity, with the rule of the foundation issue (support/golden.h: exact, else
// per-channel |delta| <= 5/255 for all but 0.1 % of pixels and no pixel over 64/255).
//   default        scenes/default.json: the npm bunny, teapot and dragon on a ground plane
//                  (Cook-Torrance, ACES), three lights
//   primitives     scenes/primitives.json after three update steps (the torus spins: app loop,
//                  velocity), Blinn-Phong, Reinhard
//   materials_glb  a glTF binary as the scene: PBR materials, an embedded base-colour texture
//   materials      scenes/materials.json: metallic/roughness sweep, a textured floor (albedo target)
//   shapes         scenes/shapes.json: analytic SDF shapes only (CSG, smooth CSG, repetition),
//                  traced by the sdf_trace pass
#include <cstdio>
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include "engine/engine.h"
#include "engine/scene/mesh_sdf.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

constexpr uint32_t kWidth = 160, kHeight = 90;

struct SceneCase {
    const char* name;
    const char* path;  // relative to the source tree
    int updates;       // engine updates of 0.1 s before the frame
    const char* camera;
};

const SceneCase kScenes[] = {
    {"default", "scenes/default.json", 0, ""},
    {"primitives", "scenes/primitives.json", 3, ""},
    {"materials_glb", "tests/assets/fixtures/scenes/materials.glb", 0, ""},
    {"materials", "scenes/materials.json", 0, ""},
    {"shapes", "scenes/shapes.json", 0, ""},
};

struct Rendered {
    bool ok = false;
    std::string error;
    ImageRGBA8 image;
    render::FrameStats stats;
};

Rendered renderScene(rhi::Device& device, const SceneCase& sc) {
    Rendered r;
    const std::string path = std::string(PENUMBRA_SOURCE_DIR "/") + sc.path;
    if (std::string(sc.path).find("default") != std::string::npos &&
        !std::filesystem::exists(PENUMBRA_SOURCE_DIR "/data/meshes/bunny.ply")) {
        r.error = "data/meshes is missing: run tools/fetch_meshes.sh";
        return r;
    }
    EngineDesc desc;
    desc.loadStaticPlugins = false;
    // The default scene bakes three meshes on load: the tests share one (validated) bake cache.
    desc.cacheDir = PENUMBRA_BINARY_DIR "/test_cache";
    auto engine = Engine::create(desc, r.error);
    // As `penumbra render` does: the scene's render.meshSdf (auto: meshes get occlusion fields when
    // the frame has shadows or AO).
    if (!engine || !engine->loadScene(path, r.error) ||
        !scene::applyMeshSdf(engine->scene(), engine->assets(), engine->settings().meshSdf, r.error))
        return r;
    std::string loopError;
    engine->loop().configure({0.1, 16}, loopError);
    engine->update(0.0);
    for (int i = 0; i < sc.updates; ++i) engine->update(0.1);
    render::SceneRenderer renderer(device);
    render::FrameDesc frame;
    frame.width = kWidth;
    frame.height = kHeight;
    frame.settings = engine->settings();
    frame.camera = scene::findCamera(engine->world(), sc.camera[0] ? sc.camera : engine->settings().camera);
    if (frame.camera == ecs::kNullEntity) {
        r.error = std::string("no camera '") + sc.camera + "'";
        return r;
    }
    r.ok = renderer.render(engine->world(), engine->assets(), frame, r.error) &&
           renderer.readPixels(r.image, r.error);
    r.stats = renderer.lastFrameStats();
    device.waitIdle();
    return r;
}

class MeshScene : public GpuTest {
protected:
    void check(const SceneCase& sc) {
        Rendered r = renderScene(dev(), sc);
        ASSERT_TRUE(r.ok) << sc.path << ": " << r.error;
        ASSERT_EQ(r.image.width, kWidth);
        ASSERT_EQ(r.image.height, kHeight);
        // Independent of the golden: the mesh pass ran and drew something, and the frame is not flat
        // (at least 64 distinct colours: shading varies over the objects).
        std::set<uint32_t> colours;
        for (size_t i = 0; i + 3 < r.image.pixels.size(); i += 4)
            colours.insert(uint32_t(r.image.pixels[i]) | uint32_t(r.image.pixels[i + 1]) << 8 |
                           uint32_t(r.image.pixels[i + 2]) << 16);
        EXPECT_GE(colours.size(), 64u) << sc.name;
        // Something was drawn: by the mesh pass, or traced (SDF objects).
        EXPECT_GT(r.stats.drawCalls + r.stats.sdfObjects, 0u) << sc.name;
        if (r.stats.drawCalls > 0) {
            EXPECT_GT(r.stats.triangles, 0u) << sc.name;
        }
        const std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
        const std::string failure = checkGolden(backend, std::string("scene_") + sc.name, r.image);
        EXPECT_TRUE(failure.empty()) << failure;
    }
};

TEST_P(MeshScene, DefaultMatchesGolden) { check(kScenes[0]); }
TEST_P(MeshScene, PrimitivesMatchesGolden) { check(kScenes[1]); }
TEST_P(MeshScene, MaterialsGlbMatchesGolden) { check(kScenes[2]); }
TEST_P(MeshScene, MaterialsMatchesGolden) { check(kScenes[3]); }
TEST_P(MeshScene, ShapesMatchesGolden) { check(kScenes[4]); }

INSTANTIATE_TEST_SUITE_P(Backends, MeshScene, testing::ValuesIn(gpuBackends()), backendName);

// Backend parity per scene, same rule.
class MeshSceneParity : public testing::TestWithParam<int> {};

TEST_P(MeshSceneParity, VulkanMatchesOpenGL) {
    const SceneCase& sc = kScenes[GetParam()];
    BackendPair pair;
    ASSERT_TRUE(pair.ready());
    auto& vkDevice = pair.vk;
    auto& glDevice = pair.gl;
    Rendered vk = renderScene(*vkDevice, sc);
    Rendered gl = renderScene(*glDevice, sc);
    ASSERT_TRUE(vk.ok) << vk.error;
    ASSERT_TRUE(gl.ok) << gl.error;
    pair.expectNoErrors();
    ImageDiff d = compareImages(vk.image, gl.image);
    std::printf("Vulkan vs OpenGL, scene %s (%ux%u): %s\n", sc.name, kWidth, kHeight, d.summary().c_str());
    RecordProperty("max_delta", d.maxDelta);
    RecordProperty("mean_delta", std::to_string(d.meanDelta));
    if (!d.pass) {
        const std::string dir = goldenOutDir("parity");
        std::filesystem::create_directories(dir);
        writePng(dir + "/scene_" + sc.name + ".vulkan.png", vk.image);
        writePng(dir + "/scene_" + sc.name + ".gl.png", gl.image);
        writePng(dir + "/scene_" + sc.name + ".diff.png", d.diffImage);
    }
    EXPECT_TRUE(d.pass) << d.summary();
}

INSTANTIATE_TEST_SUITE_P(Scenes, MeshSceneParity, testing::Range(0, int(std::size(kScenes))),
                         [](const testing::TestParamInfo<int>& info) {
                             return std::string(kScenes[info.param].name);
                         });

}  // namespace
}  // namespace penumbra::test
