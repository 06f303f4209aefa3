// Meshes as SDFs: scene `sdf` components with "mesh" are baked at load time (AssetManager::bakeSdf:
// one field per mesh and resolution), applyMeshSdf (--mesh-sdf trace) turns every visible mesh of a
// JSON or glTF scene into an SdfRenderer of its baked field, atomically; --mesh-sdf occlusion gives
// meshes an occluder-only field beside their MeshRenderer, and auto resolves from the effects.
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <utility>

#include "engine/assets/primitives.h"
#include "engine/scene/mesh_sdf.h"
#include "engine/sdf/psdf.h"
#include "scene/scene_test_util.h"

namespace penumbra::scene {
namespace {

using test::entityNamed;
using test::parseScene;

class MeshSdfTest : public testing::Test {
protected:
    void SetUp() override {
        assets::MeshData box;
        std::string error;
        ASSERT_TRUE(assets::makeBox(glm::vec3(0.5f), box, error)) << error;
        ASSERT_TRUE(assets::writePly(m_dir.file("box.ply"), box, error)) << error;
        assets::MeshData flat;  // zero-area triangles only
        flat.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
        flat.indices = {0, 1, 2};
        ASSERT_TRUE(assets::writePly(m_dir.file("flat.ply"), flat, error)) << error;
    }
    bool parse(const std::string& text, Scene& out, std::string& error) {
        return parseScene(text, m_assets, out, error, m_dir.file(""));
    }
    const ecs::SdfRenderer* sdfOf(const Scene& s, const std::string& name) {
        return s.world.get<ecs::SdfRenderer>(entityNamed(s.world, name));
    }

    test::TempDir m_dir;
    assets::AssetManager m_assets;
};

TEST(MeshSdfMode, ParsesAndNames) {
    MeshSdfMode m = MeshSdfMode::Trace;
    EXPECT_TRUE(parseMeshSdfMode("off", m));
    EXPECT_EQ(m, MeshSdfMode::Off);
    EXPECT_TRUE(parseMeshSdfMode("trace", m));
    EXPECT_EQ(m, MeshSdfMode::Trace);
    EXPECT_FALSE(parseMeshSdfMode("Trace", m));
    EXPECT_FALSE(parseMeshSdfMode("", m));
    EXPECT_EQ(m, MeshSdfMode::Trace);
    EXPECT_STREQ(toString(MeshSdfMode::Off), "off");
    EXPECT_STREQ(toString(MeshSdfMode::Trace), "trace");
    EXPECT_TRUE(parseMeshSdfMode("occlusion", m));
    EXPECT_EQ(m, MeshSdfMode::Occlusion);
    EXPECT_TRUE(parseMeshSdfMode("auto", m));
    EXPECT_EQ(m, MeshSdfMode::Auto);
    EXPECT_STREQ(toString(MeshSdfMode::Occlusion), "occlusion");
    EXPECT_STREQ(toString(MeshSdfMode::Auto), "auto");
}

// Criterion: an sdf component with "mesh" carries a baked SdfField asset after loading (source
// stays MeshBake); entities sharing a mesh and resolution share one field (one bake, one reference
// each), another resolution is another field; the scene holds the fields, not the meshes, and
// unloading frees everything.
TEST_F(MeshSdfTest, MeshBakeComponentsAreBakedAtLoad) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 2, "entities": [
        {"name": "a", "sdf": {"mesh": "box.ply", "resolution": 20}},
        {"name": "b", "transform": {"position": [2, 0, 0]}, "sdf": {"mesh": "box.ply", "resolution": 20}},
        {"name": "c", "sdf": {"mesh": "box.ply", "resolution": 16, "castShadows": false}}]})",
                      s, error))
        << error;
    const ecs::SdfRenderer* a = sdfOf(s, "a");
    const ecs::SdfRenderer* b = sdfOf(s, "b");
    const ecs::SdfRenderer* c = sdfOf(s, "c");
    ASSERT_TRUE(a && b && c);
    EXPECT_EQ(a->source, ecs::SdfSource::MeshBake);
    EXPECT_EQ(a->bakeMesh, m_dir.file("box.ply"));
    ASSERT_NE(m_assets.sdfField(a->sdf), nullptr);
    EXPECT_EQ(m_assets.sdfField(a->sdf)->header.dims, glm::uvec3(20, 20, 20));
    EXPECT_EQ(a->sdf, b->sdf);
    EXPECT_EQ(m_assets.refCount(a->sdf), 2u);
    ASSERT_NE(m_assets.sdfField(c->sdf), nullptr);
    EXPECT_NE(c->sdf, a->sdf);
    EXPECT_EQ(m_assets.sdfField(c->sdf)->header.dims.x, 16u);
    EXPECT_FALSE(c->castShadows);
    EXPECT_EQ(m_assets.cacheStats().sdfBakes, 2u);
    EXPECT_EQ(m_assets.count(assets::AssetKind::SdfField), 2u);
    EXPECT_EQ(m_assets.count(assets::AssetKind::Mesh), 0u);  // released after baking

    const sdf::SdfSampler sampler(*m_assets.sdfField(a->sdf));
    EXPECT_NEAR(sampler.sample({0, 0, 0}), -0.5, 0.035);  // within half a voxel (1/16)
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

// Criterion: without "resolution" the automatic medium resolution is used (128 along the longest
// axis for a cube).
TEST_F(MeshSdfTest, AutomaticResolutionIsMedium) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 2, "entities": [{"name": "a", "sdf": {"mesh": "box.ply"}}]})", s, error))
        << error;
    ASSERT_NE(sdfOf(s, "a"), nullptr);
    const sdf::PsdfAsset* field = m_assets.sdfField(sdfOf(s, "a")->sdf);
    ASSERT_NE(field, nullptr);
    EXPECT_EQ(field->header.dims, glm::uvec3(128, 128, 128));
    unloadScene(s, m_assets);
}

// Criterion: a mesh that cannot be baked is a load error naming the JSON pointer, the file and the
// reason; the load is atomic (nothing kept).
TEST_F(MeshSdfTest, BakeErrorIsALoadErrorWithItsPointer) {
    Scene s;
    std::string error;
    EXPECT_FALSE(parse(R"({"version": 2, "entities": [
        {"name": "ok", "sdf": {"mesh": "box.ply", "resolution": 16}},
        {"name": "bad", "sdf": {"mesh": "flat.ply", "resolution": 16}}]})",
                       s, error));
    EXPECT_NE(error.find("test.json: /entities/1/sdf/mesh: "), std::string::npos) << error;
    EXPECT_NE(error.find("flat.ply"), std::string::npos) << error;
    EXPECT_NE(error.find("no non-degenerate triangles"), std::string::npos) << error;
    EXPECT_EQ(m_assets.count(), 0u);
}

// Criterion: Off changes nothing; Trace turns every visible mesh into an SdfRenderer of its baked
// field with the mesh's material and castShadows, bakes each distinct mesh once, leaves invisible
// meshes alone, swaps the scene's mesh references for field references, and unloading frees all.
TEST_F(MeshSdfTest, TraceConvertsEveryVisibleMesh) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 2, "materials": {"red": {"baseColor": [1, 0, 0]}}, "entities": [
        {"name": "cam", "camera": {}},
        {"name": "ball", "mesh": {"primitive": {"shape": "sphere", "radius": 0.5, "segments": 12, "rings": 6},
                                  "material": "red", "castShadows": false}},
        {"name": "ball twin", "transform": {"position": [2, 0, 0]},
         "mesh": {"primitive": {"shape": "sphere", "radius": 0.5, "segments": 12, "rings": 6}}},
        {"name": "file box", "mesh": {"file": "box.ply"}},
        {"name": "hidden", "mesh": {"primitive": {"shape": "torus"}, "visible": false}},
        {"name": "shape", "sdf": {"shape": {"shape": "sphere", "radius": 1}}}]})",
                      s, error))
        << error;
    ASSERT_EQ(s.world.count<ecs::MeshRenderer>(), 4u);

    EXPECT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Off, error, 16)) << error;
    EXPECT_EQ(s.world.count<ecs::MeshRenderer>(), 4u);
    EXPECT_EQ(m_assets.count(assets::AssetKind::SdfField), 0u);

    const ecs::MeshRenderer ballMesh = *s.world.get<ecs::MeshRenderer>(entityNamed(s.world, "ball"));
    ASSERT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Trace, error, 16)) << error;
    EXPECT_EQ(s.world.count<ecs::MeshRenderer>(), 1u);  // the hidden torus
    EXPECT_NE(s.world.get<ecs::MeshRenderer>(entityNamed(s.world, "hidden")), nullptr);
    EXPECT_EQ(s.world.count<ecs::SdfRenderer>(), 4u);
    EXPECT_EQ(m_assets.cacheStats().sdfBakes, 2u);  // sphere, box
    EXPECT_EQ(m_assets.count(assets::AssetKind::SdfField), 2u);

    const ecs::SdfRenderer* ball = sdfOf(s, "ball");
    const ecs::SdfRenderer* twin = sdfOf(s, "ball twin");
    const ecs::SdfRenderer* box = sdfOf(s, "file box");
    ASSERT_TRUE(ball && twin && box);
    EXPECT_EQ(ball->source, ecs::SdfSource::MeshBake);
    EXPECT_EQ(ball->material, ballMesh.material);
    EXPECT_NE(m_assets.material(ball->material), nullptr);
    EXPECT_FALSE(ball->castShadows);
    EXPECT_TRUE(twin->castShadows);
    EXPECT_TRUE(ball->visible);
    EXPECT_EQ(ball->sdf, twin->sdf);
    EXPECT_EQ(m_assets.refCount(ball->sdf), 2u);
    EXPECT_EQ(ball->bakeResolution, 16u);
    ASSERT_NE(m_assets.sdfField(box->sdf), nullptr);
    EXPECT_EQ(box->bakeMesh, m_dir.file("box.ply"));
    EXPECT_EQ(m_assets.sdfField(box->sdf)->header.dims, glm::uvec3(16, 16, 16));
    EXPECT_EQ(sdfOf(s, "shape")->source, ecs::SdfSource::Shapes);  // untouched
    // Only the hidden torus's mesh is still held by the scene.
    EXPECT_EQ(m_assets.count(assets::AssetKind::Mesh), 1u);

    // A second application has nothing left to convert.
    ASSERT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Trace, error, 16)) << error;
    EXPECT_EQ(s.world.count<ecs::SdfRenderer>(), 4u);
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

// Criterion: glTF scenes convert too (their meshes are in-memory assets with stable keys), and a
// real mesh (the bunny, from tools/fetch_meshes.sh) bakes into a field that is negative inside.
TEST_F(MeshSdfTest, TraceConvertsGltfScenesAndRealMeshes) {
    Scene g;
    std::string error;
    ASSERT_TRUE(loadScene(test::sourcePath("tests/assets/fixtures/cube.glb"), m_assets, g, error)) << error;
    const size_t meshes = g.world.count<ecs::MeshRenderer>();
    ASSERT_GT(meshes, 0u);
    ASSERT_TRUE(applyMeshSdf(g, m_assets, MeshSdfMode::Trace, error, 16)) << error;
    EXPECT_EQ(g.world.count<ecs::MeshRenderer>(), 0u);
    EXPECT_EQ(g.world.count<ecs::SdfRenderer>(), meshes);
    for (auto [e, r] : std::as_const(g.world).view<ecs::SdfRenderer>()) {
        EXPECT_NE(m_assets.sdfField(r.sdf), nullptr);
    }
    unloadScene(g, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);

    const std::string bunny = test::npmMesh("bunny.ply");
    if (bunny.empty()) return;
    Scene s;
    ASSERT_TRUE(parse(
        R"({"version": 2, "entities": [{"name": "bunny", "mesh": {"file": ")" + bunny + R"("}}]})", s, error))
        << error;
    ASSERT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Trace, error, 48)) << error;
    const ecs::SdfRenderer* r = sdfOf(s, "bunny");
    ASSERT_NE(r, nullptr);
    const sdf::PsdfAsset* field = m_assets.sdfField(r->sdf);
    ASSERT_NE(field, nullptr);
    EXPECT_EQ(r->bakeMesh, bunny);
    EXPECT_LT(field->header.minDistance, 0.0f);
    EXPECT_GT(field->header.maxDistance, 0.0f);
    unloadScene(s, m_assets);
}

// Criterion: a mesh that cannot be baked fails the conversion with a message naming the entity and
// the reason, and leaves the scene and the asset manager's references as they were.
TEST_F(MeshSdfTest, TraceFailureIsClearAndAtomic) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 2, "entities": [
        {"name": "good", "mesh": {"file": "box.ply"}},
        {"name": "bad", "mesh": {"file": "flat.ply"}}]})",
                      s, error))
        << error;
    const size_t assetsBefore = m_assets.count();
    const size_t refsBefore = s.assetRefs.size();
    EXPECT_FALSE(applyMeshSdf(s, m_assets, MeshSdfMode::Trace, error, 16));
    EXPECT_NE(error.find("entity 'bad'"), std::string::npos) << error;
    EXPECT_NE(error.find("flat.ply"), std::string::npos) << error;
    EXPECT_NE(error.find("no non-degenerate triangles"), std::string::npos) << error;
    EXPECT_EQ(s.world.count<ecs::MeshRenderer>(), 2u);
    EXPECT_EQ(s.world.count<ecs::SdfRenderer>(), 0u);
    EXPECT_EQ(m_assets.count(assets::AssetKind::SdfField), 0u);
    EXPECT_EQ(m_assets.count(), assetsBefore);
    EXPECT_EQ(s.assetRefs.size(), refsBefore);
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

// Criterion: Occlusion keeps every MeshRenderer and gives each visible shadow-casting mesh an
// occluder-only SdfRenderer of its field (MeshBake, the mesh's material, castShadows) at
// kOcclusionResolution when given 0; meshes that cast no shadows, invisible meshes and entities
// with their own sdf component get none; each distinct mesh is baked once; a second application
// changes nothing; unloading frees everything.
TEST_F(MeshSdfTest, OcclusionAddsOccluderFieldsBesideMeshes) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 2, "materials": {"red": {"baseColor": [1, 0, 0]}}, "entities": [
        {"name": "box", "mesh": {"file": "box.ply", "material": "red"}},
        {"name": "box twin", "transform": {"position": [2, 0, 0]}, "mesh": {"file": "box.ply"}},
        {"name": "no shadow", "mesh": {"file": "box.ply", "castShadows": false}},
        {"name": "hidden", "mesh": {"primitive": {"shape": "torus"}, "visible": false}},
        {"name": "both", "mesh": {"primitive": {"shape": "sphere"}}, "sdf": {"shape": {"shape": "sphere", "radius": 1}}}]})",
                      s, error))
        << error;
    ASSERT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Occlusion, error)) << error;
    EXPECT_EQ(s.world.count<ecs::MeshRenderer>(), 5u);  // all kept
    EXPECT_EQ(s.world.count<ecs::SdfRenderer>(), 3u);   // box, box twin, both (its own)
    EXPECT_EQ(m_assets.cacheStats().sdfBakes, 1u);      // the box once
    const ecs::SdfRenderer* box = sdfOf(s, "box");
    const ecs::SdfRenderer* twin = sdfOf(s, "box twin");
    ASSERT_TRUE(box && twin);
    EXPECT_TRUE(box->occluderOnly);
    EXPECT_EQ(box->source, ecs::SdfSource::MeshBake);
    EXPECT_EQ(box->material, s.world.get<ecs::MeshRenderer>(entityNamed(s.world, "box"))->material);
    EXPECT_TRUE(box->castShadows && box->visible);
    EXPECT_EQ(box->sdf, twin->sdf);
    EXPECT_EQ(m_assets.refCount(box->sdf), 2u);
    EXPECT_EQ(box->bakeResolution, kOcclusionResolution);
    ASSERT_NE(m_assets.sdfField(box->sdf), nullptr);
    EXPECT_EQ(m_assets.sdfField(box->sdf)->header.dims, glm::uvec3(kOcclusionResolution));
    EXPECT_EQ(sdfOf(s, "no shadow"), nullptr);
    EXPECT_EQ(sdfOf(s, "hidden"), nullptr);
    EXPECT_FALSE(sdfOf(s, "both")->occluderOnly);
    EXPECT_EQ(sdfOf(s, "both")->source, ecs::SdfSource::Shapes);

    ASSERT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Occlusion, error)) << error;
    EXPECT_EQ(s.world.count<ecs::SdfRenderer>(), 3u);
    EXPECT_EQ(m_assets.cacheStats().sdfBakes, 1u);
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

// Criterion: under Occlusion a mesh that cannot be baked is skipped (warning), the others still get
// their fields and the call succeeds (occlusion is on by default: a degenerate mesh must not fail a
// scene that rasterizes).
TEST_F(MeshSdfTest, OcclusionSkipsMeshesThatCannotBeBaked) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 2, "entities": [
        {"name": "good", "mesh": {"file": "box.ply"}},
        {"name": "bad", "mesh": {"file": "flat.ply"}}]})",
                      s, error))
        << error;
    ASSERT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Occlusion, error, 16)) << error;
    ASSERT_NE(sdfOf(s, "good"), nullptr);
    EXPECT_TRUE(sdfOf(s, "good")->occluderOnly);
    EXPECT_EQ(sdfOf(s, "bad"), nullptr);
    EXPECT_EQ(s.world.count<ecs::MeshRenderer>(), 2u);
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

// Criterion: a flat mesh (a floor plane: smallest bounds extent under 1 % of the largest) gets no
// occlusion field, nor is it baked; a thin but not flat box still does.
TEST_F(MeshSdfTest, OcclusionSkipsFlatMeshes) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 2, "entities": [
        {"name": "floor", "mesh": {"primitive": {"shape": "plane", "halfSize": 20}}},
        {"name": "slab", "mesh": {"primitive": {"shape": "box", "halfExtents": [2, 0.05, 2]}}}]})",
                      s, error))
        << error;
    ASSERT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Occlusion, error, 16)) << error;
    EXPECT_EQ(sdfOf(s, "floor"), nullptr);
    ASSERT_NE(sdfOf(s, "slab"), nullptr);  // 0.1 / 4 = 2.5 % thick: not flat
    EXPECT_EQ(m_assets.cacheStats().sdfBakes, 1u);
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

// Criterion: Auto is Occlusion exactly when the settings turn on an effect meshes can occlude
// (shadows enabled with a shadow-casting light, or an AO variant) and a visible mesh exists;
// otherwise Off (nothing baked). Off, Trace and Occlusion resolve to themselves.
TEST_F(MeshSdfTest, AutoResolvesFromTheEffects) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 2, "entities": [
        {"name": "sun", "light": {"type": "directional", "castShadows": false}},
        {"name": "box", "mesh": {"file": "box.ply"}}]})",
                      s, error))
        << error;
    EXPECT_EQ(resolveMeshSdfMode(s, MeshSdfMode::Trace), MeshSdfMode::Trace);
    EXPECT_EQ(resolveMeshSdfMode(s, MeshSdfMode::Off), MeshSdfMode::Off);
    EXPECT_EQ(resolveMeshSdfMode(s, MeshSdfMode::Occlusion), MeshSdfMode::Occlusion);
    EXPECT_EQ(s.settings.meshSdf, MeshSdfMode::Auto);  // the default
    // No shadow-casting light and AO off: nothing to occlude.
    EXPECT_EQ(resolveMeshSdfMode(s, MeshSdfMode::Auto), MeshSdfMode::Off);
    ASSERT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Auto, error)) << error;
    EXPECT_EQ(s.world.count<ecs::SdfRenderer>(), 0u);
    // AO on: occlusion.
    s.settings.ao.variant = AoVariant::Cones;
    EXPECT_EQ(resolveMeshSdfMode(s, MeshSdfMode::Auto), MeshSdfMode::Occlusion);
    // A shadow-casting light with shadows enabled: occlusion; shadows disabled: off.
    s.settings.ao.variant = AoVariant::Off;
    s.world.get<ecs::Light>(entityNamed(s.world, "sun"))->castShadows = true;
    EXPECT_EQ(resolveMeshSdfMode(s, MeshSdfMode::Auto), MeshSdfMode::Occlusion);
    s.settings.shadows.enabled = false;
    EXPECT_EQ(resolveMeshSdfMode(s, MeshSdfMode::Auto), MeshSdfMode::Off);
    s.settings.shadows.enabled = true;
    // No visible mesh: off.
    s.world.get<ecs::MeshRenderer>(entityNamed(s.world, "box"))->visible = false;
    EXPECT_EQ(resolveMeshSdfMode(s, MeshSdfMode::Auto), MeshSdfMode::Off);
    s.world.get<ecs::MeshRenderer>(entityNamed(s.world, "box"))->visible = true;
    ASSERT_TRUE(applyMeshSdf(s, m_assets, MeshSdfMode::Auto, error, 16)) << error;
    ASSERT_NE(sdfOf(s, "box"), nullptr);
    EXPECT_TRUE(sdfOf(s, "box")->occluderOnly);
    unloadScene(s, m_assets);
}

// Criterion: the render block's "meshSdf" reads all four modes (default auto).
TEST_F(MeshSdfTest, SceneSettingReadsEveryMode) {
    for (const char* name : {"off", "trace", "occlusion", "auto"}) {
        Scene s;
        std::string error;
        ASSERT_TRUE(
            parse(std::string(R"({"version": 2, "render": {"meshSdf": ")") + name + R"("}})", s, error))
            << error;
        EXPECT_STREQ(toString(s.settings.meshSdf), name);
    }
}

}  // namespace
}  // namespace penumbra::scene
