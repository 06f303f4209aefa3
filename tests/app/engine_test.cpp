// penumbra::Engine (embedding API, engine half): scene loading, the update schedule, plugins.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <glm/gtc/quaternion.hpp>

#include "engine/ecs/components.h"
#include "engine/engine.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;

fs::path tempDir(const std::string& name) {
    fs::path dir = fs::path(PENUMBRA_BINARY_DIR) / "test_tmp" / "engine" / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

void writeFile(const fs::path& path, const std::string& text) {
    std::ofstream f(path, std::ios::binary);
    f << text;
}

const char* kStlTetra = R"(solid tetra
facet normal 0 0 0
 outer loop
  vertex 0 0 0
  vertex 1 0 0
  vertex 0 1 0
 endloop
endfacet
facet normal 0 0 0
 outer loop
  vertex 0 0 0
  vertex 0 1 0
  vertex 0 0 1
 endloop
endfacet
facet normal 0 0 0
 outer loop
  vertex 0 0 0
  vertex 0 0 1
  vertex 1 0 0
 endloop
endfacet
facet normal 0 0 0
 outer loop
  vertex 1 0 0
  vertex 0 0 1
  vertex 0 1 0
 endloop
endfacet
endsolid tetra
)";

TEST(Engine, BuildWorldInCodeAndUpdateRunsSpinThenTransforms) {
    std::string error;
    auto engine = Engine::create({}, error);
    ASSERT_TRUE(engine) << error;
    ecs::World& world = engine->world();
    ecs::Entity parent = world.create();
    world.add<ecs::Transform>(parent);
    world.add<scene::Spin>(parent, scene::Spin{{0, 1, 0}, float(M_PI / 2)});  // 90 degrees per second
    ecs::Entity child = world.create();
    world.add<ecs::Transform>(child)->position = {1, 0, 0};
    ASSERT_TRUE(ecs::setParent(world, child, parent));

    std::string loopError;
    ASSERT_TRUE(engine->loop().configure({0.25, 16}, loopError)) << loopError;
    app::FrameTime t = engine->update(1.0);  // four steps of 0.25 s at 90 deg/s: a quarter turn
    EXPECT_EQ(t.steps, 4u);
    // After 1 s at 90 deg/s the child at local +X sits at world -Z (rotation about +Y by 90 deg).
    glm::vec3 p = world.get<ecs::Transform>(child)->worldPosition();
    EXPECT_NEAR(p.x, 0.0f, 1e-5f);
    EXPECT_NEAR(p.z, -1.0f, 1e-5f);
}

// Offline frames (penumbra render --fixed-dt): 1 s frames with the default 1/60 s update step run
// 60 steps each, nothing capped. Criterion: after frame 0 at t = 0 and two frames of 1 s, simTime is
// exactly 2 and a spin of 90 deg/s has turned 180 deg. Real-time update(1.0) stops at 16 steps
// (0.267 s) per frame, which is what the CLI used before.
TEST(Engine, OfflineUpdatesAdvanceExactlyTheFrameTime) {
    std::string error;
    auto engine = Engine::create({}, error);
    ASSERT_TRUE(engine) << error;
    ecs::World& world = engine->world();
    ecs::Entity parent = world.create();
    world.add<ecs::Transform>(parent);
    world.add<scene::Spin>(parent, scene::Spin{{0, 1, 0}, float(M_PI / 2)});
    ecs::Entity child = world.create();
    world.add<ecs::Transform>(child)->position = {1, 0, 0};
    ASSERT_TRUE(ecs::setParent(world, child, parent));

    app::FrameTime t;
    ASSERT_TRUE(engine->updateOffline(0.0, t, error)) << error;
    EXPECT_EQ(t.simTime, 0.0);
    for (int k = 1; k <= 2; ++k) {
        ASSERT_TRUE(engine->updateOffline(1.0, t, error)) << error;
        EXPECT_EQ(t.steps, 60u);
        EXPECT_EQ(t.simTime, double(k));
    }
    EXPECT_EQ(engine->loop().droppedSteps(), 0u);
    glm::vec3 p = world.get<ecs::Transform>(child)->worldPosition();
    EXPECT_NEAR(p.x, -1.0f, 1e-4f);
    EXPECT_NEAR(p.z, 0.0f, 1e-4f);

    EXPECT_FALSE(engine->updateOffline(-1.0, t, error));
    EXPECT_NE(error.find("offline frame time"), std::string::npos) << error;
    EXPECT_EQ(engine->loop().simTime(), 2.0);
}

TEST(Engine, FailedSceneLoadKeepsTheCurrentScene) {
    fs::path dir = tempDir("keep");
    writeFile(dir / "good.json", R"({"version": 1, "entities": [{"name": "cam", "camera": {}}]})");
    writeFile(dir / "bad.json", R"({"version": 1, "entities": [{"name": "x", "light": {"type": "laser"}}]})");
    std::string error;
    auto engine = Engine::create({}, error);
    ASSERT_TRUE(engine) << error;
    ASSERT_TRUE(engine->loadScene((dir / "good.json").string(), error)) << error;
    EXPECT_EQ(engine->world().aliveCount(), 1u);
    EXPECT_FALSE(engine->loadScene((dir / "bad.json").string(), error));
    EXPECT_NE(error.find("bad.json"), std::string::npos) << error;
    EXPECT_NE(error.find("laser"), std::string::npos) << error;
    EXPECT_EQ(engine->world().aliveCount(), 1u);
    EXPECT_NE(scene::findCamera(engine->world(), "cam"), ecs::kNullEntity);
}

TEST(Engine, UnloadReleasesSceneAssets) {
    fs::path dir = tempDir("unload");
    writeFile(dir / "s.json", R"({"version": 1, "entities": [
        {"name": "a", "mesh": {"primitive": {"shape": "sphere"}}},
        {"name": "b", "mesh": {"primitive": {"shape": "sphere"}}}]})");
    std::string error;
    auto engine = Engine::create({}, error);
    ASSERT_TRUE(engine) << error;
    ASSERT_TRUE(engine->loadScene((dir / "s.json").string(), error)) << error;
    EXPECT_GE(engine->assets().count(assets::AssetKind::Mesh), 1u);
    engine->unloadScene();
    EXPECT_EQ(engine->assets().count(), 0u);
    EXPECT_EQ(engine->world().aliveCount(), 0u);
}

TEST(Engine, RefusesMissingPluginDirectory) {
    std::string error;
    EngineDesc desc;
    desc.pluginDir = "/nonexistent/penumbra/plugins";
    EXPECT_FALSE(Engine::create(desc, error));
    EXPECT_NE(error.find("/nonexistent/penumbra/plugins"), std::string::npos) << error;
}

// A mesh importer from a run-time plugin (plugins/stl_importer, loaded with dlopen) serves scene
// loading: the scene references an .stl file, which only the plugin can read.
TEST(Engine, SceneUsesMeshImporterFromSharedLibraryPlugin) {
    fs::path dir = tempDir("stl");
    writeFile(dir / "tetra.stl", kStlTetra);
    writeFile(dir / "s.json",
              R"({"version": 1, "entities": [{"name": "t", "mesh": {"file": "tetra.stl"}}]})");

    std::string error;
    auto plain = Engine::create({}, error);
    ASSERT_TRUE(plain) << error;
    EXPECT_FALSE(plain->loadScene((dir / "s.json").string(), error));
    EXPECT_NE(error.find("tetra.stl"), std::string::npos) << error;

    EngineDesc desc;
    desc.pluginDir = PENUMBRA_PLUGIN_DIR;
    auto engine = Engine::create(desc, error);
    ASSERT_TRUE(engine) << error;
    ASSERT_TRUE(engine->plugins().isLoaded("stl_importer"));
    ASSERT_TRUE(engine->loadScene((dir / "s.json").string(), error)) << error;
    ecs::Entity t = ecs::kNullEntity;
    engine->world().view<const ecs::MeshRenderer>().each(
        [&](ecs::Entity e, const ecs::MeshRenderer&) { t = e; });
    ASSERT_NE(t, ecs::kNullEntity);
    const assets::MeshData* mesh = engine->assets().mesh(engine->world().get<ecs::MeshRenderer>(t)->mesh);
    ASSERT_NE(mesh, nullptr);
    EXPECT_EQ(mesh->positions.size(), 4u);  // welded corners
    EXPECT_EQ(mesh->triangleCount(), 4u);
    EXPECT_EQ(mesh->normals.size(), 4u);  // generated by the asset manager
}

}  // namespace
}  // namespace penumbra
