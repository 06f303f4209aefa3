// glTF files as scenes (default camera and light when missing) and the "gltf" component of the JSON
// scene format (nodes instanced under an entity).
#include <gtest/gtest.h>

#include "scene/scene_test_util.h"

namespace penumbra::scene {
namespace {

using test::entityNamed;

const std::string kHierarchy = test::sourcePath("tests/assets/fixtures/hierarchy.gltf");
const std::string kCameraLights = test::sourcePath("tests/assets/fixtures/scenes/camera_lights.gltf");

TEST(GltfScene, FileWithoutCameraOrLightGetsDefaults) {
    assets::AssetManager assets;
    Scene s;
    std::string error;
    ASSERT_TRUE(loadScene(kHierarchy, assets, s, error)) << error;
    const ecs::World& w = s.world;
    EXPECT_EQ(s.sourcePath, kHierarchy);
    EXPECT_EQ(s.settings.width, RenderSettings{}.width) << "glTF scenes use default render settings";
    ASSERT_GT(w.count<ecs::MeshRenderer>(), 0u);
    EXPECT_FALSE(s.assetRefs.empty());

    const ecs::Entity cam = entityNamed(w, "default camera");
    ASSERT_FALSE(cam.isNull());
    EXPECT_EQ(findCamera(w, ""), cam);
    EXPECT_EQ(w.count<ecs::Camera>(), 1u);
    const ecs::Entity light = entityNamed(w, "default light");
    ASSERT_FALSE(light.isNull());
    ASSERT_NE(w.get<ecs::Light>(light), nullptr);
    EXPECT_EQ(w.get<ecs::Light>(light)->type, ecs::LightType::Directional);
    EXPECT_LT(w.get<ecs::Transform>(light)->worldForward().y, -0.5f) << "the default light shines down";

    // Every mesh's world bounding box is inside the default camera's frustum (16:9 and 1:1), and
    // the camera looks at the centre of all of them.
    glm::vec3 all0(1e30f), all1(-1e30f);
    for (float aspect : {16.0f / 9.0f, 1.0f}) {
        const glm::mat4 viewProj = test::viewProjection(w, cam, aspect);
        for (auto [e, mr] : w.view<ecs::MeshRenderer>()) {
            glm::vec3 lo, hi;
            test::worldBounds(w, assets, e, lo, hi);
            all0 = glm::min(all0, lo);
            all1 = glm::max(all1, hi);
            for (int c = 0; c < 8; ++c) {
                const glm::vec3 corner((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
                EXPECT_TRUE(test::inView(viewProj, corner)) << "aspect " << aspect << " corner " << c;
            }
        }
    }
    const ecs::Transform* ct = w.get<ecs::Transform>(cam);
    const glm::vec3 toCentre = glm::normalize(0.5f * (all0 + all1) - ct->worldPosition());
    EXPECT_GT(glm::dot(ct->worldForward(), toCentre), 0.9999f);
    unloadScene(s, assets);
    EXPECT_EQ(assets.count(), 0u);
}

TEST(GltfScene, FileWithCamerasAndLightsGetsNoDefaults) {
    assets::AssetManager assets;
    Scene s;
    std::string error;
    ASSERT_TRUE(loadScene(kCameraLights, assets, s, error)) << error;
    EXPECT_GT(s.world.count<ecs::Camera>(), 0u);
    EXPECT_GT(s.world.count<ecs::Light>(), 0u);
    EXPECT_TRUE(entityNamed(s.world, "default camera").isNull());
    EXPECT_TRUE(entityNamed(s.world, "default light").isNull());
    EXPECT_FALSE(findCamera(s.world, "Overview").isNull());
    unloadScene(s, assets);
    EXPECT_EQ(assets.count(), 0u);
}

TEST(GltfScene, MalformedFileLeavesEverythingUnchanged) {
    assets::AssetManager assets;
    Scene out;
    out.sourcePath = "untouched";
    std::string error;
    const std::string path = test::sourcePath("tests/malformed/gltf/node_cycle.gltf");
    EXPECT_FALSE(loadScene(path, assets, out, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_EQ(out.sourcePath, "untouched");
    EXPECT_EQ(assets.count(), 0u);
}

TEST(GltfScene, ComponentInstancesNodesUnderTheEntity) {
    assets::AssetManager assets;
    Scene s;
    std::string error;
    ASSERT_TRUE(test::parseScene(R"({"version": 1, "render": {"camera": "Overview"}, "entities": [
        {"name": "holder", "transform": {"position": [0, 5, 0], "scale": 2}, "gltf": "tests/assets/fixtures/hierarchy.gltf"},
        {"name": "lights", "parent": "holder", "gltf": "tests/assets/fixtures/scenes/camera_lights.gltf"}]})",
                                 assets, s, error))
        << error;
    const ecs::World& w = s.world;
    const ecs::Entity holder = entityNamed(w, "holder");
    const ecs::Entity root = entityNamed(w, "root");
    ASSERT_FALSE(root.isNull());
    EXPECT_EQ(w.get<ecs::Transform>(root)->parent, holder);
    const glm::mat4 expected =
        w.get<ecs::Transform>(holder)->worldMatrix * w.get<ecs::Transform>(root)->localMatrix();
    const glm::mat4 actual = w.get<ecs::Transform>(root)->worldMatrix;
    for (int c = 0; c < 4; ++c) {
        for (int r = 0; r < 4; ++r) EXPECT_NEAR(actual[c][r], expected[c][r], 1e-5f) << c << "," << r;
    }
    // Cameras imported from the glTF can be the render camera; JSON scenes never get default ones.
    EXPECT_EQ(s.settings.camera, "Overview");
    EXPECT_FALSE(findCamera(w, "Overview").isNull());
    EXPECT_TRUE(entityNamed(w, "default camera").isNull());
    // The second file's roots hang under "lights", which hangs under "holder".
    const ecs::Entity sunNode = entityNamed(w, "SunNode");
    ASSERT_FALSE(sunNode.isNull());
    EXPECT_EQ(w.get<ecs::Transform>(sunNode)->parent, entityNamed(w, "lights"));
    EXPECT_FALSE(s.assetRefs.empty());
    unloadScene(s, assets);
    EXPECT_EQ(assets.count(), 0u);
}

TEST(GltfScene, FailureAfterAGltfComponentReleasesItsAssets) {
    assets::AssetManager assets;
    Scene s;
    std::string error;
    EXPECT_FALSE(test::parseScene(R"({"version": 1, "entities": [
        {"name": "holder", "gltf": "tests/assets/fixtures/scenes/camera_lights.gltf"},
        {"name": "holder"}]})",
                                  assets, s, error));
    EXPECT_NE(error.find("test.json: /entities/1/name: duplicate entity name 'holder'"), std::string::npos)
        << error;
    EXPECT_EQ(assets.count(), 0u);
    EXPECT_EQ(s.world.aliveCount(), 0u);
}

}  // namespace
}  // namespace penumbra::scene
