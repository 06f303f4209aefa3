// Scene JSON version 2: the `sdf` component (analytic shapes and CSG trees compiled to shared
// shape-program assets, .psdf fields, meshes to bake), per-object options, instancing, atomic
// failure, and version-1 files loading unchanged. Bad sdf components: tests/malformed/scene/sdf_*.json.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>

#include <glm/gtc/quaternion.hpp>

#include "engine/sdf/psdf.h"
#include "engine/sdf/shape_program.h"
#include "scene/scene_test_util.h"

namespace penumbra::scene {
namespace {

using test::entityNamed;
using test::parseScene;

class SceneSdfTest : public testing::Test {
protected:
    void SetUp() override {
        assets::MeshData tri;
        tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
        tri.indices = {0, 1, 2};
        std::string error;
        ASSERT_TRUE(assets::writePly(m_dir.file("tri.ply"), tri, error)) << error;
        sdf::SdfGrid grid;
        grid.dims = {2, 2, 2};
        grid.voxelSize = 0.5;
        grid.distances = {-0.25f, 0.25f, 0.25f, 0.5f, 0.25f, 0.5f, 0.5f, 0.75f};
        ASSERT_TRUE(sdf::writePsdf(m_dir.file("blob.psdf"), grid, {}, error)) << error;
    }
    bool parse(const std::string& text, Scene& out, std::string& error) {
        return parseScene(text, m_assets, out, error, m_dir.file(""));
    }
    const ecs::SdfRenderer& sdfOf(const Scene& s, const std::string& name) {
        const ecs::Entity e = entityNamed(s.world, name);
        const ecs::SdfRenderer* r = s.world.get<ecs::SdfRenderer>(e);
        EXPECT_NE(r, nullptr) << name;
        static const ecs::SdfRenderer none;
        return r ? *r : none;
    }
    double distance(const Scene& s, const std::string& name, glm::dvec3 p) {
        const sdf::ShapeProgram* prog = m_assets.shapeProgram(sdfOf(s, name).sdf);
        EXPECT_NE(prog, nullptr) << name;
        return prog ? sdf::evaluateShapeProgram(*prog, p) : 0.0;
    }

    test::TempDir m_dir;
    assets::AssetManager m_assets;
};

constexpr const char* kEverySdfForm = R"({
  "version": 2,
  "materials": {"red": {"baseColor": [0.8, 0.1, 0.1]}},
  "entities": [
    {"name": "ball", "sdf": {"shape": {"shape": "sphere", "radius": 0.5,
                                       "transform": {"position": [1, 0, 0], "scale": 2}},
                             "material": "red", "maxSteps": 64, "castShadows": false, "visible": false}},
    {"name": "carved", "transform": {"position": [0, 5, 0]},
     "sdf": {"csg": {"op": "subtract", "children": [
        {"shape": "box", "halfExtents": 1},
        {"shape": "sphere", "radius": 1.25}]}}},
    {"name": "carved twin", "sdf": {"csg": {"op": "subtract", "children": [
        {"shape": "box", "halfExtents": [1, 1, 1]},
        {"shape": "sphere", "radius": 1.25}]}, "material": {"roughness": 0.25}}},
    {"name": "row", "sdf": {"csg": {"op": "repeat", "spacing": [1, 0, 0], "count": [5, 1, 1],
                                    "children": [{"shape": "sphere", "radius": 0.25}]}}},
    {"name": "blend", "sdf": {"csg": {"op": "union", "smoothRadius": 1, "children": [
        {"shape": "sphere", "radius": 1, "transform": {"position": [-1, 0, 0]}},
        {"shape": "sphere", "radius": 1, "transform": {"position": [1, 0, 0]}}]}}},
    {"name": "every shape", "sdf": {"csg": {"op": "intersect", "children": [
        {"shape": "roundedBox", "halfExtents": [3, 3, 3], "rounding": 0.5},
        {"op": "union", "children": [
          {"shape": "capsule", "radius": 0.25, "halfLength": 0.5},
          {"shape": "cylinder", "radius": 0.25, "halfHeight": 0.5},
          {"shape": "torus", "majorRadius": 1, "minorRadius": 0.25, "transform": {"eulerDegrees": [90, 0, 0]}},
          {"shape": "cone", "bottomRadius": 0.5, "halfHeight": 0.5},
          {"shape": "plane", "normal": [0, 2, 0], "offset": -2}]}]}}},
    {"name": "field", "sdf": {"psdf": "blob.psdf"}},
    {"name": "field twin", "sdf": {"psdf": "blob.psdf"}},
    {"name": "bake", "transform": {"scale": [1, 2, 1]}, "sdf": {"mesh": "tri.ply", "resolution": 64}},
    {"name": "bake auto", "sdf": {"mesh": "tri.ply"}}
  ]
})";

// Criterion: every form of the component parses into the SdfRenderer it describes, the compiled
// programs evaluate to the hand-computed distances of their trees (1e-6), identical programs and
// identical .psdf files share one asset (one reference per entity), and unloading frees them all.
TEST_F(SceneSdfTest, EveryFormParses) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(kEverySdfForm, s, error)) << error;

    const ecs::SdfRenderer& ball = sdfOf(s, "ball");
    EXPECT_EQ(ball.source, ecs::SdfSource::Shapes);
    EXPECT_EQ(ball.maxSteps, 64u);
    EXPECT_FALSE(ball.castShadows);
    EXPECT_FALSE(ball.visible);
    ASSERT_NE(m_assets.material(ball.material), nullptr);
    EXPECT_FLOAT_EQ(m_assets.material(ball.material)->baseColor.r, 0.8f);
    // Radius 0.5 at scale 2 centred at (1, 0, 0): radius 1 in the entity's frame.
    EXPECT_NEAR(distance(s, "ball", {1, 0, 0}), -1.0, 1e-6);
    EXPECT_NEAR(distance(s, "ball", {4, 0, 0}), 2.0, 1e-6);

    // The program is in the entity's local frame: the entity Transform places it.
    EXPECT_NEAR(distance(s, "carved", {0, 0, 0}), 1.25, 1e-6);
    EXPECT_NEAR(distance(s, "carved", {3, 0, 0}), 2.0, 1e-6);
    EXPECT_EQ(s.world.get<ecs::Transform>(entityNamed(s.world, "carved"))->position, glm::vec3(0, 5, 0));
    EXPECT_EQ(sdfOf(s, "carved").sdf, sdfOf(s, "carved twin").sdf);  // instancing: one program asset
    EXPECT_EQ(m_assets.refCount(sdfOf(s, "carved").sdf), 2u);
    EXPECT_NE(sdfOf(s, "carved").material, sdfOf(s, "carved twin").material);

    EXPECT_NEAR(distance(s, "row", {2, 0, 0}), -0.25, 1e-6);
    EXPECT_NEAR(distance(s, "row", {4, 0, 0}), 1.75, 1e-6);
    EXPECT_NEAR(distance(s, "blend", {0, 0, 0}), -0.25, 1e-6);
    // Torus turned into the XY plane (ring radius 1), plane y = -2 (the normal is normalised, the
    // offset is along the unit normal), all inside the rounded box.
    EXPECT_NEAR(distance(s, "every shape", {0, 0.9, 0}), -0.15, 1e-6);    // 0.1 from the torus' core circle
    EXPECT_NEAR(distance(s, "every shape", {0, 1.0, 0}), -0.25, 1e-6);    // on the core circle
    EXPECT_NEAR(distance(s, "every shape", {0, -2.25, 0}), -0.25, 1e-6);  // below the plane
    // Nearest: the cone's side (radius 0.375 at y = -0.25, slope 1:2), 0.375 * 2 / sqrt(5) away.
    EXPECT_NEAR(distance(s, "every shape", {0, -0.25, 0.75}), 0.75 / std::sqrt(5.0), 1e-6);
    const sdf::ShapeProgram* every = m_assets.shapeProgram(sdfOf(s, "every shape").sdf);
    ASSERT_NE(every, nullptr);
    EXPECT_TRUE(every->bounds.finite());  // the intersection keeps the rounded box's bounds

    const ecs::SdfRenderer& field = sdfOf(s, "field");
    EXPECT_EQ(field.source, ecs::SdfSource::Field);
    ASSERT_NE(m_assets.sdfField(field.sdf), nullptr);
    EXPECT_EQ(m_assets.sdfField(field.sdf)->header.dims, glm::uvec3(2, 2, 2));
    EXPECT_EQ(field.sdf, sdfOf(s, "field twin").sdf);
    EXPECT_EQ(m_assets.refCount(field.sdf), 2u);

    const ecs::SdfRenderer& bake = sdfOf(s, "bake");
    EXPECT_EQ(bake.source, ecs::SdfSource::MeshBake);
    ASSERT_NE(m_assets.sdfField(bake.sdf), nullptr);  // baked at load (AssetManager::bakeSdf)
    EXPECT_EQ(m_assets.sdfField(bake.sdf)->header.dims.x, 64u);
    EXPECT_EQ(bake.bakeMesh, m_dir.file("tri.ply"));
    EXPECT_EQ(bake.bakeResolution, 64u);
    EXPECT_EQ(sdfOf(s, "bake auto").bakeResolution, 0u);
    EXPECT_EQ(s.world.get<ecs::Transform>(entityNamed(s.world, "bake"))->scale, glm::vec3(1, 2, 1));

    EXPECT_EQ(m_assets.count(assets::AssetKind::ShapeProgram), 5u);  // ball, carved, row, blend, every shape
    EXPECT_EQ(m_assets.count(assets::AssetKind::SdfField), 3u);      // blob.psdf, tri.ply at 64 and automatic
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

// Criterion: a failure after sdf components leaves the asset manager and the output untouched.
TEST_F(SceneSdfTest, FailureReleasesPrograms) {
    Scene s;
    s.sourcePath = "untouched";
    std::string error;
    EXPECT_FALSE(parse(R"({"version": 2, "entities": [
        {"sdf": {"shape": {"shape": "sphere", "radius": 1}}},
        {"sdf": {"psdf": "blob.psdf"}},
        {"sdf": {"shape": {"shape": "sphere", "radius": 1}, "maxSteps": -1}}]})",
                       s, error));
    EXPECT_NE(error.find("/entities/2/sdf/maxSteps: -1 is out of range [1, 10000]"), std::string::npos)
        << error;
    EXPECT_EQ(m_assets.count(), 0u);
    EXPECT_EQ(s.sourcePath, "untouched");
}

// Criterion: version 1 files load unchanged (every shipped version-1 scene and a document with
// every version-1 component), and version 2 files may use everything version 1 had.
TEST_F(SceneSdfTest, VersionOneStillLoads) {
    const char* v1 = R"({"version": 1, "entities": [
        {"name": "cam", "camera": {}},
        {"name": "m", "mesh": {"primitive": {"shape": "sphere", "radius": 0.5}}},
        {"name": "l", "light": {"type": "point"}}]})";
    Scene a, b;
    std::string error;
    ASSERT_TRUE(parse(v1, a, error)) << error;
    EXPECT_EQ(a.world.count<ecs::MeshRenderer>(), 1u);
    std::string v2 = v1;
    v2.replace(v2.find("\"version\": 1"), 12, "\"version\": 2");
    ASSERT_TRUE(parse(v2, b, error)) << error;
    EXPECT_EQ(b.world.count<ecs::MeshRenderer>(), 1u);
    EXPECT_EQ(b.world.count<ecs::SdfRenderer>(), 0u);
    for (const char* file : {"scenes/primitives.json", "scenes/materials.json"}) {
        Scene f;
        EXPECT_TRUE(loadScene(test::sourcePath(file), m_assets, f, error)) << error;
        unloadScene(f, m_assets);
    }
    unloadScene(a, m_assets);
    unloadScene(b, m_assets);
}

// Criterion: scenes/shapes.json loads with the shapes scenes/README.md describes: eight sdf objects
// of analytic shapes (no meshes), the pillar row bounded at 7 copies, the carved box hollow at its
// centre, the two rings sharing one program.
TEST_F(SceneSdfTest, ShapesSceneLoads) {
    Scene s;
    std::string error;
    ASSERT_TRUE(loadScene(test::sourcePath("scenes/shapes.json"), m_assets, s, error)) << error;
    EXPECT_EQ(s.world.count<ecs::SdfRenderer>(), 8u);
    EXPECT_EQ(s.world.count<ecs::MeshRenderer>(), 0u);
    for (auto [e, r] : std::as_const(s.world).view<ecs::SdfRenderer>()) {
        EXPECT_EQ(r.source, ecs::SdfSource::Shapes);
        EXPECT_NE(m_assets.shapeProgram(r.sdf), nullptr);
        EXPECT_NE(r.material, 0u);
    }
    EXPECT_NEAR(distance(s, "pillars", {6, 0, 0}), -0.3, 1e-6);
    EXPECT_NEAR(distance(s, "pillars", {8, 0, 0}), 1.7, 1e-6);  // no 8th pillar
    EXPECT_EQ(sdfOf(s, "pillars").maxSteps, 256u);
    EXPECT_NEAR(distance(s, "carved box", {0, 0, 0}), 0.75, 1e-6);
    EXPECT_NEAR(distance(s, "floor", {3, 2, -1}), 2.0, 1e-6);
    EXPECT_EQ(sdfOf(s, "ring").sdf, sdfOf(s, "ring copy").sdf);
    EXPECT_EQ(m_assets.count(assets::AssetKind::ShapeProgram), 7u);
}

}  // namespace
}  // namespace penumbra::scene
