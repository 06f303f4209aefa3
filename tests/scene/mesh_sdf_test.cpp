// Meshes as SDFs: scene `sdf` components with "mesh" are baked at load time (AssetManager::bakeSdf:
// one field per mesh and resolution), and applyMeshSdf (--mesh-sdf trace) turns every visible
// mesh of a JSON or glTF scene into an SdfRenderer of its baked field, atomically.
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

}  // namespace
}  // namespace penumbra::scene
