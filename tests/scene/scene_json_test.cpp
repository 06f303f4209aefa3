// The JSON scene format: every field parsed (values asserted), hierarchy and world matrices,
// shared assets and reference counts, atomic failure, unloading, the spin system, camera lookup.
#include <cmath>

#include <gtest/gtest.h>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtx/norm.hpp>

#include "engine/assets/primitives.h"
#include "engine/image/image.h"
#include "scene/scene_test_util.h"

namespace penumbra::scene {
namespace {

using test::entityNamed;
using test::parseScene;

// A small valid PLY (one triangle) and a 2x2 PNG in a temp folder, for file references.
class SceneJsonTest : public testing::Test {
protected:
    void SetUp() override {
        assets::MeshData tri;
        tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
        tri.indices = {0, 1, 2};
        std::string error;
        ASSERT_TRUE(assets::writePly(m_dir.file("tri.ply"), tri, error)) << error;
        ImageRGBA8 img;
        img.width = img.height = 2;
        img.pixels.assign(16, 200);
        ASSERT_TRUE(writePng(m_dir.file("tex.png"), img, &error)) << error;
    }
    bool parse(const std::string& text, Scene& out, std::string& error, const SceneLoadLimits& limits = {}) {
        return parseScene(text, m_assets, out, error, m_dir.file(""), limits);
    }

    test::TempDir m_dir;
    assets::AssetManager m_assets;
};

constexpr const char* kEveryField = R"({
  "version": 1,
  "description": "every field of the format",
  "render": {"width": 320, "height": 200, "shading": "blinn-phong", "toneMapper": "reinhard",
             "exposure": 1.5, "ambient": [0.1, 0.2, 0.3], "background": [0.4, 0.5, 0.6],
             "camera": "side", "fixedDt": 0.025},
  "materials": {
    "red": {"baseColor": [0.8, 0.1, 0.1], "metallic": 0.25, "roughness": 0.75, "emissive": [1, 2, 3],
            "baseColorTexture": "tex.png", "metallicRoughnessTexture": "tex.png", "normalTexture": "tex.png",
            "occlusionTexture": "tex.png", "emissiveTexture": "tex.png"},
    "glass": {"baseColor": [0.9, 0.9, 1.0, 0.5]}
  },
  "entities": [
    {"name": "main", "transform": {"position": [1, 2, 3]}, "camera": {}},
    {"name": "side", "transform": {"position": [0, 1, 5], "eulerDegrees": [0, 90, 0], "scale": [1, 2, 3]},
     "camera": {"fovYDegrees": 45, "near": 0.5, "far": 50}},
    {"name": "sun", "transform": {"rotation": [0, 0, 0, 2]},
     "light": {"type": "directional", "color": [1, 0.9, 0.8], "intensity": 3, "angularRadiusDegrees": 2,
               "castShadows": false}},
    {"name": "bulb", "light": {"type": "point", "color": [0.5, 0.5, 1], "intensity": 0, "range": 7}},
    {"name": "orb", "light": {"type": "sphere", "radius": 0.25, "range": 12}},
    {"name": "tri", "transform": {"scale": 2}, "mesh": {"file": "tri.ply", "material": "red", "castShadows": false,
                                                         "visible": false}},
    {"name": "ball", "mesh": {"primitive": {"shape": "sphere", "radius": 0.5, "segments": 8, "rings": 4},
                              "material": {"roughness": 0.125}}},
    {"name": "crate", "mesh": {"primitive": {"shape": "box", "halfExtents": [1, 0.5, 0.25]}, "material": "glass"}},
    {"name": "floor", "mesh": {"primitive": {"shape": "plane", "halfSize": [4, 3]}}},
    {"name": "can", "mesh": {"primitive": {"shape": "cylinder", "radius": 0.3, "halfHeight": 0.6, "segments": 12}}},
    {"name": "ring", "mesh": {"primitive": {"shape": "torus", "majorRadius": 1, "minorRadius": 0.2, "rings": 16,
                                             "sides": 8}},
     "spin": {"axis": [0, 0, 2], "degreesPerSecond": 90}},
    {"spin": {"degreesPerSecond": -45}}
  ]
})";

TEST_F(SceneJsonTest, ParsesEveryField) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(kEveryField, s, error)) << error;
    const ecs::World& w = s.world;
    EXPECT_EQ(s.sourcePath, "test.json");
    EXPECT_EQ(w.aliveCount(), 12u);
    EXPECT_EQ(w.count<ecs::Transform>(), 12u) << "every scene entity has a Transform";

    const RenderSettings& r = s.settings;
    EXPECT_EQ(r.width, 320u);
    EXPECT_EQ(r.height, 200u);
    EXPECT_EQ(r.shading, ShadingModel::BlinnPhong);
    EXPECT_EQ(r.toneMapper, ToneMapper::Reinhard);
    EXPECT_FLOAT_EQ(r.exposure, 1.5f);
    EXPECT_EQ(r.ambient, glm::vec3(0.1f, 0.2f, 0.3f));
    EXPECT_EQ(r.background, glm::vec3(0.4f, 0.5f, 0.6f));
    EXPECT_EQ(r.camera, "side");
    EXPECT_DOUBLE_EQ(r.fixedDt, 0.025);

    const ecs::Entity main = entityNamed(w, "main");
    ASSERT_FALSE(main.isNull());
    EXPECT_EQ(w.get<ecs::Transform>(main)->position, glm::vec3(1, 2, 3));
    const ecs::Camera* mainCam = w.get<ecs::Camera>(main);
    ASSERT_NE(mainCam, nullptr);
    const ecs::Camera defaults;
    EXPECT_FLOAT_EQ(mainCam->fovY, defaults.fovY);
    EXPECT_FLOAT_EQ(mainCam->nearPlane, defaults.nearPlane);
    EXPECT_FLOAT_EQ(mainCam->farPlane, defaults.farPlane);
    EXPECT_EQ(mainCam->name, "main");

    const ecs::Entity side = entityNamed(w, "side");
    const ecs::Transform* st = w.get<ecs::Transform>(side);
    EXPECT_EQ(st->position, glm::vec3(0, 1, 5));
    EXPECT_EQ(st->scale, glm::vec3(1, 2, 3));
    // 90 degrees about +Y: local -Z (the view direction) becomes -X.
    const glm::vec3 forward = st->rotation * glm::vec3(0, 0, -1);
    EXPECT_NEAR(glm::distance(forward, glm::vec3(-1, 0, 0)), 0.0f, 1e-6f);
    const ecs::Camera* sideCam = w.get<ecs::Camera>(side);
    EXPECT_FLOAT_EQ(sideCam->fovY, glm::radians(45.0f));
    EXPECT_FLOAT_EQ(sideCam->nearPlane, 0.5f);
    EXPECT_FLOAT_EQ(sideCam->farPlane, 50.0f);

    const ecs::Entity sun = entityNamed(w, "sun");
    // [0, 0, 0, 2] normalises to the identity.
    EXPECT_EQ(w.get<ecs::Transform>(sun)->rotation, glm::quat(1, 0, 0, 0));
    const ecs::Light* sunLight = w.get<ecs::Light>(sun);
    ASSERT_NE(sunLight, nullptr);
    EXPECT_EQ(sunLight->type, ecs::LightType::Directional);
    EXPECT_EQ(sunLight->color, glm::vec3(1, 0.9f, 0.8f));
    EXPECT_FLOAT_EQ(sunLight->intensity, 3.0f);
    EXPECT_FLOAT_EQ(sunLight->angularRadius, glm::radians(2.0f));
    EXPECT_FALSE(sunLight->castShadows);

    const ecs::Light* bulb = w.get<ecs::Light>(entityNamed(w, "bulb"));
    EXPECT_EQ(bulb->type, ecs::LightType::Point);
    EXPECT_EQ(bulb->color, glm::vec3(0.5f, 0.5f, 1.0f));
    EXPECT_FLOAT_EQ(bulb->intensity, 0.0f);
    EXPECT_FLOAT_EQ(bulb->range, 7.0f);
    EXPECT_TRUE(bulb->castShadows);
    const ecs::Light* orb = w.get<ecs::Light>(entityNamed(w, "orb"));
    EXPECT_EQ(orb->type, ecs::LightType::Sphere);
    EXPECT_FLOAT_EQ(orb->radius, 0.25f);
    EXPECT_FLOAT_EQ(orb->range, 12.0f);
    EXPECT_FLOAT_EQ(orb->intensity, 1.0f);

    const ecs::Entity tri = entityNamed(w, "tri");
    EXPECT_EQ(w.get<ecs::Transform>(tri)->scale, glm::vec3(2.0f));
    const ecs::MeshRenderer* triMr = w.get<ecs::MeshRenderer>(tri);
    ASSERT_NE(triMr, nullptr);
    EXPECT_FALSE(triMr->castShadows);
    EXPECT_FALSE(triMr->visible);
    const assets::MeshData* triMesh = m_assets.mesh(triMr->mesh);
    ASSERT_NE(triMesh, nullptr);
    EXPECT_EQ(triMesh->positions.size(), 3u);
    const ecs::Material* red = m_assets.material(triMr->material);
    ASSERT_NE(red, nullptr);
    EXPECT_EQ(red->baseColor, glm::vec4(0.8f, 0.1f, 0.1f, 1.0f));
    EXPECT_FLOAT_EQ(red->metallic, 0.25f);
    EXPECT_FLOAT_EQ(red->roughness, 0.75f);
    EXPECT_EQ(red->emissive, glm::vec3(1, 2, 3));
    const assets::TextureData* tex = m_assets.texture(red->baseColorTexture);
    ASSERT_NE(tex, nullptr);
    EXPECT_EQ(tex->width, 2u);
    EXPECT_TRUE(tex->srgb) << "base colour textures are colour data";
    ASSERT_NE(m_assets.texture(red->metallicRoughnessTexture), nullptr);
    EXPECT_FALSE(m_assets.texture(red->metallicRoughnessTexture)->srgb)
        << "metallic-roughness is linear data";
    EXPECT_NE(red->normalTexture, 0u);
    EXPECT_NE(red->occlusionTexture, 0u);
    EXPECT_NE(red->emissiveTexture, 0u);
    EXPECT_TRUE(m_assets.texture(red->emissiveTexture)->srgb);

    const ecs::MeshRenderer* ball = w.get<ecs::MeshRenderer>(entityNamed(w, "ball"));
    ASSERT_NE(m_assets.mesh(ball->mesh), nullptr);
    EXPECT_EQ(m_assets.mesh(ball->mesh)->positions.size(), size_t(9 * 5));
    EXPECT_EQ(m_assets.info(ball->mesh)->key, "primitive:sphere:r=0.5:seg=8:rings=4");
    EXPECT_FLOAT_EQ(m_assets.material(ball->material)->roughness, 0.125f);
    EXPECT_FLOAT_EQ(m_assets.material(ball->material)->metallic, 0.0f);
    EXPECT_TRUE(ball->visible);
    EXPECT_TRUE(ball->castShadows);

    const ecs::MeshRenderer* crate = w.get<ecs::MeshRenderer>(entityNamed(w, "crate"));
    EXPECT_EQ(m_assets.info(crate->mesh)->key, "primitive:box:h=1,0.5,0.25");
    EXPECT_EQ(m_assets.material(crate->material)->baseColor, glm::vec4(0.9f, 0.9f, 1.0f, 0.5f));
    const ecs::MeshRenderer* floor = w.get<ecs::MeshRenderer>(entityNamed(w, "floor"));
    EXPECT_EQ(m_assets.info(floor->mesh)->key, "primitive:plane:h=4,3");
    EXPECT_EQ(floor->material, 0u) << "no material: the renderer's default";
    const ecs::MeshRenderer* can = w.get<ecs::MeshRenderer>(entityNamed(w, "can"));
    EXPECT_EQ(m_assets.info(can->mesh)->key, "primitive:cylinder:r=0.3:hh=0.6:seg=12");
    const ecs::Entity ring = entityNamed(w, "ring");
    EXPECT_EQ(m_assets.info(w.get<ecs::MeshRenderer>(ring)->mesh)->key,
              "primitive:torus:R=1:r=0.2:rings=16:sides=8");
    const Spin* spin = w.get<Spin>(ring);
    ASSERT_NE(spin, nullptr);
    EXPECT_EQ(spin->axis, glm::vec3(0, 0, 1)) << "the axis is normalised";
    EXPECT_FLOAT_EQ(spin->radiansPerSecond, glm::radians(90.0f));
    EXPECT_EQ(w.count<Spin>(), 2u);

    // Reference counts: 1 mesh file, 5 primitives, 3 materials (red, inline, glass); one PNG used by
    // 5 texture slots of one material definition: an sRGB asset (base colour, emissive) and a linear
    // one (metallic-roughness, normal, occlusion), one reference per slot.
    EXPECT_EQ(m_assets.count(assets::AssetKind::Mesh), 6u);
    EXPECT_EQ(m_assets.count(assets::AssetKind::Material), 3u);
    EXPECT_EQ(m_assets.count(assets::AssetKind::Texture), 2u);
    EXPECT_EQ(red->baseColorTexture, red->emissiveTexture);
    EXPECT_EQ(m_assets.refCount(red->baseColorTexture), 2u);
    EXPECT_EQ(red->normalTexture, red->metallicRoughnessTexture);
    EXPECT_EQ(m_assets.refCount(red->normalTexture), 3u);
    EXPECT_EQ(s.assetRefs.size(), size_t(1 + 5 + 3 + 5));
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

TEST_F(SceneJsonTest, DefaultsWithoutRenderSection) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 1})", s, error)) << error;
    const RenderSettings defaults;
    EXPECT_EQ(s.settings.width, defaults.width);
    EXPECT_EQ(s.settings.height, defaults.height);
    EXPECT_EQ(s.settings.shading, defaults.shading);
    EXPECT_EQ(s.settings.toneMapper, defaults.toneMapper);
    EXPECT_EQ(s.settings.camera, "");
    EXPECT_EQ(s.world.aliveCount(), 0u);
    EXPECT_TRUE(s.assetRefs.empty());
}

TEST_F(SceneJsonTest, RotationForms) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 1, "entities": [
        {"name": "q", "transform": {"rotation": [0, 1, 0, 1]}},
        {"name": "ex", "transform": {"eulerDegrees": [90, 0, 0]}},
        {"name": "xy", "transform": {"eulerDegrees": [90, 90, 0]}},
        {"name": "xyz", "transform": {"eulerDegrees": [30, -45, 60]}}]})",
                      s, error))
        << error;
    const auto rot = [&](const char* name) {
        return s.world.get<ecs::Transform>(entityNamed(s.world, name))->rotation;
    };
    const float tol = 1e-6f;  // float rounding of the quaternion products
    EXPECT_NEAR(glm::length(rot("q") * glm::vec3(1, 0, 0) - glm::vec3(0, 0, -1)), 0.0f, tol)
        << "[0, 1, 0, 1] is 90 degrees about +Y after normalisation";
    EXPECT_NEAR(glm::length(rot("ex") * glm::vec3(0, 1, 0) - glm::vec3(0, 0, 1)), 0.0f, tol);
    // X first, then Y (fixed axes): +Y -> +Z (about X) -> +X (about Y).
    EXPECT_NEAR(glm::length(rot("xy") * glm::vec3(0, 1, 0) - glm::vec3(1, 0, 0)), 0.0f, tol);
    const glm::quat expected = glm::angleAxis(glm::radians(60.0f), glm::vec3(0, 0, 1)) *
                               glm::angleAxis(glm::radians(-45.0f), glm::vec3(0, 1, 0)) *
                               glm::angleAxis(glm::radians(30.0f), glm::vec3(1, 0, 0));
    EXPECT_NEAR(std::abs(glm::dot(rot("xyz"), expected)), 1.0f, tol);
}

TEST_F(SceneJsonTest, ParentsResolveInAnyOrderAndWorldMatricesCompose) {
    Scene s;
    std::string error;
    // Children before and after their parents.
    ASSERT_TRUE(parse(R"({"version": 1, "entities": [
        {"name": "c", "parent": "b", "transform": {"position": [0, 0, 3], "scale": 2}},
        {"name": "a", "transform": {"position": [1, 0, 0]}},
        {"name": "b", "parent": "a", "transform": {"position": [0, 2, 0], "eulerDegrees": [0, 90, 0]}},
        {"name": "d", "parent": "a"}]})",
                      s, error))
        << error;
    const ecs::World& w = s.world;
    const ecs::Entity a = entityNamed(w, "a"), b = entityNamed(w, "b"), c = entityNamed(w, "c"),
                      d = entityNamed(w, "d");
    EXPECT_EQ(w.get<ecs::Transform>(c)->parent, b);
    EXPECT_EQ(w.get<ecs::Transform>(b)->parent, a);
    EXPECT_EQ(w.get<ecs::Transform>(d)->parent, a);
    EXPECT_TRUE(w.get<ecs::Transform>(a)->parent.isNull());
    // c's origin: a (1,0,0) + b's offset (0,2,0) + b's rotation (90 about Y) of (0,0,3) = (3,0,0).
    const float tol = 1e-5f;  // float matrix products
    EXPECT_NEAR(glm::distance(w.get<ecs::Transform>(c)->worldPosition(), glm::vec3(4, 2, 0)), 0.0f, tol);
    EXPECT_NEAR(glm::distance(w.get<ecs::Transform>(d)->worldPosition(), glm::vec3(1, 0, 0)), 0.0f, tol);
    // c's local +X (scaled by 2) is rotated onto -Z by b.
    const glm::vec3 cx(w.get<ecs::Transform>(c)->worldMatrix[0]);
    EXPECT_NEAR(glm::distance(cx, glm::vec3(0, 0, -2)), 0.0f, tol);
}

TEST_F(SceneJsonTest, NamedMaterialsAndPrimitivesAreShared) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 1,
        "materials": {"red": {"baseColor": [1, 0, 0], "roughness": 0.3},
                      "alsoRed": {"baseColor": [1, 0, 0], "roughness": 0.3}},
        "entities": [
          {"name": "one", "mesh": {"primitive": {"shape": "sphere"}, "material": "red"}},
          {"name": "two", "mesh": {"primitive": {"shape": "sphere"}, "material": "red"}}]})",
                      s, error))
        << error;
    const ecs::MeshRenderer* one = s.world.get<ecs::MeshRenderer>(entityNamed(s.world, "one"));
    const ecs::MeshRenderer* two = s.world.get<ecs::MeshRenderer>(entityNamed(s.world, "two"));
    EXPECT_EQ(one->material, two->material);
    EXPECT_EQ(m_assets.refCount(one->material), 2u);
    EXPECT_EQ(one->mesh, two->mesh);
    EXPECT_EQ(m_assets.refCount(one->mesh), 2u);
    EXPECT_EQ(m_assets.count(), 2u) << "one sphere mesh, one material; unused materials create no asset";
    EXPECT_EQ(s.assetRefs.size(), 4u);

    // A second scene with the same content shares the assets with the first.
    Scene s2;
    ASSERT_TRUE(parse(R"({"version": 1, "entities": [
          {"mesh": {"primitive": {"shape": "sphere", "radius": 0.5}, "material": {"baseColor": [1, 0, 0],
                                                                                 "roughness": 0.3}}}]})",
                      s2, error))
        << error;
    EXPECT_EQ(m_assets.refCount(one->material), 3u);
    EXPECT_EQ(m_assets.refCount(one->mesh), 3u);
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.refCount(one->material), 1u);
    EXPECT_EQ(m_assets.count(), 2u);
    unloadScene(s2, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

TEST_F(SceneJsonTest, SameNameDifferentContentInTwoScenesDoesNotCollide) {
    Scene s1, s2;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 1, "materials": {"m": {"baseColor": [1, 0, 0]}},
        "entities": [{"name": "x", "mesh": {"primitive": {"shape": "box"}, "material": "m"}}]})",
                      s1, error))
        << error;
    ASSERT_TRUE(parse(R"({"version": 1, "materials": {"m": {"baseColor": [0, 0, 1]}},
        "entities": [{"name": "x", "mesh": {"primitive": {"shape": "box"}, "material": "m"}}]})",
                      s2, error))
        << error;
    const auto* m1 = m_assets.material(s1.world.get<ecs::MeshRenderer>(entityNamed(s1.world, "x"))->material);
    const auto* m2 = m_assets.material(s2.world.get<ecs::MeshRenderer>(entityNamed(s2.world, "x"))->material);
    ASSERT_TRUE(m1 && m2);
    EXPECT_EQ(m1->baseColor, glm::vec4(1, 0, 0, 1));
    EXPECT_EQ(m2->baseColor, glm::vec4(0, 0, 1, 1));
    unloadScene(s1, m_assets);
    unloadScene(s2, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

TEST_F(SceneJsonTest, FailureOnTheLastEntityChangesNothing) {
    // `out` already holds a loaded scene, and the asset manager that scene's assets.
    Scene out;
    std::string error;
    ASSERT_TRUE(parse(R"({"version": 1, "entities": [{"name": "keep", "camera": {}}]})", out, error))
        << error;
    const auto before = out.world.aliveCount();
    // Every entity but the last loads assets (a file, primitives, a material and textures).
    const std::string bad = R"({"version": 1, "materials": {"t": {"baseColorTexture": "tex.png"}},
        "entities": [
          {"name": "a", "mesh": {"file": "tri.ply", "material": "t"}},
          {"name": "b", "mesh": {"primitive": {"shape": "torus"}, "material": "t"}},
          {"name": "c", "parent": "a", "mesh": {"primitive": {"shape": "box"}}},
          {"name": "d", "mesh": {"primitive": {"shape": "sphere"}, "material": "missing"}}]})";
    EXPECT_FALSE(parse(bad, out, error));
    EXPECT_NE(error.find("test.json: /entities/3/mesh/material: unknown material 'missing'"),
              std::string::npos)
        << error;
    EXPECT_EQ(m_assets.count(), 0u) << "every reference taken during the attempt is released";
    EXPECT_EQ(out.world.aliveCount(), before);
    EXPECT_FALSE(entityNamed(out.world, "keep").isNull());
    EXPECT_TRUE(entityNamed(out.world, "a").isNull());
    EXPECT_TRUE(out.assetRefs.empty());
    EXPECT_EQ(out.sourcePath, "test.json");

    // The same with a scene holding assets: their reference counts are unchanged.
    Scene holder;
    ASSERT_TRUE(
        parse(R"({"version": 1, "entities": [{"mesh": {"primitive": {"shape": "torus"}}}]})", holder, error))
        << error;
    const assets::AssetId torus = holder.assetRefs.at(0);
    EXPECT_FALSE(parse(bad, out, error));
    EXPECT_EQ(m_assets.count(), 1u);
    EXPECT_EQ(m_assets.refCount(torus), 1u);
    unloadScene(holder, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
}

TEST_F(SceneJsonTest, UnloadReleasesEverything) {
    Scene s;
    std::string error;
    ASSERT_TRUE(parse(kEveryField, s, error)) << error;
    EXPECT_GT(m_assets.count(), 0u);
    unloadScene(s, m_assets);
    EXPECT_EQ(m_assets.count(), 0u);
    EXPECT_EQ(s.world.aliveCount(), 0u);
    EXPECT_TRUE(s.assetRefs.empty());
    EXPECT_TRUE(s.sourcePath.empty());
    EXPECT_EQ(s.settings.width, RenderSettings{}.width);
    unloadScene(s, m_assets);  // twice is harmless
    EXPECT_EQ(m_assets.count(), 0u);
}

TEST_F(SceneJsonTest, LoadJsonSceneResolvesPathsAgainstTheFileFolder) {
    const std::string path = m_dir.write(
        "scene.json", R"({"version": 1, "entities": [{"name": "t", "mesh": {"file": "./sub/../tri.ply"}}]})");
    Scene s;
    std::string error;
    ASSERT_TRUE(loadScene(path, m_assets, s, error)) << error;
    EXPECT_EQ(s.sourcePath, path);
    const ecs::MeshRenderer* mr = s.world.get<ecs::MeshRenderer>(entityNamed(s.world, "t"));
    ASSERT_NE(mr, nullptr);
    EXPECT_EQ(m_assets.info(mr->mesh)->sourcePath, m_dir.file("tri.ply"));
    unloadScene(s, m_assets);
}

TEST_F(SceneJsonTest, LoadSceneRefusesUnknownExtensionsAndDirectories) {
    Scene s;
    std::string error;
    EXPECT_FALSE(loadScene(m_dir.file("tri.ply"), m_assets, s, error));
    EXPECT_NE(error.find("unknown scene file type '.ply' (expected .json, .gltf or .glb)"), std::string::npos)
        << error;
    std::filesystem::create_directories(m_dir.file("folder.json"));
    EXPECT_FALSE(loadScene(m_dir.file("folder.json"), m_assets, s, error));
    EXPECT_NE(error.find("folder.json"), std::string::npos) << error;
    EXPECT_NE(error.find("is a directory"), std::string::npos) << error;
    EXPECT_FALSE(loadScene(m_dir.file("absent.json"), m_assets, s, error));
    EXPECT_NE(error.find("absent.json: cannot open file"), std::string::npos) << error;
    EXPECT_EQ(m_assets.count(), 0u);
}

TEST_F(SceneJsonTest, FileSizeLimitIsCheckedBeforeReading) {
    const std::string path =
        m_dir.write("big.json", R"({"version": 1, "description": ")" + std::string(200, 'x') + "\"}");
    SceneLoadLimits limits;
    limits.maxFileBytes = 100;
    Scene s;
    std::string error;
    EXPECT_FALSE(loadJsonScene(path, m_assets, s, error, limits));
    EXPECT_NE(error.find("big.json: file too large"), std::string::npos) << error;
    limits.maxFileBytes = 1000;
    EXPECT_TRUE(loadJsonScene(path, m_assets, s, error, limits)) << error;
}

TEST(SceneNames, RoundTrip) {
    for (ShadingModel m : {ShadingModel::CookTorrance, ShadingModel::BlinnPhong}) {
        ShadingModel back = ShadingModel::CookTorrance;
        ASSERT_TRUE(parseShadingModel(shadingModelName(m), back));
        EXPECT_EQ(back, m);
    }
    for (ToneMapper t : {ToneMapper::Clamp, ToneMapper::Reinhard, ToneMapper::Aces}) {
        ToneMapper back = ToneMapper::Clamp;
        ASSERT_TRUE(parseToneMapper(toneMapperName(t), back));
        EXPECT_EQ(back, t);
    }
    EXPECT_STREQ(shadingModelName(ShadingModel::CookTorrance), "cook-torrance");
    EXPECT_STREQ(shadingModelName(ShadingModel::BlinnPhong), "blinn-phong");
    EXPECT_STREQ(toneMapperName(ToneMapper::Aces), "aces");
    ShadingModel m;
    ToneMapper t;
    EXPECT_FALSE(parseShadingModel("phong", m));
    EXPECT_FALSE(parseToneMapper("ACES", t)) << "names are case-sensitive";
}

TEST(SpinSystem, IsDeterministicAndIntegratesTheRate) {
    const auto makeWorld = [](ecs::World& w) {
        const ecs::Entity e = w.create();
        w.add<ecs::Transform>(e);
        w.add<Spin>(e, Spin{glm::normalize(glm::vec3(1, 2, 3)), glm::radians(90.0f)});
        const ecs::Entity still = w.create();
        w.add<ecs::Transform>(still);
        return e;
    };
    ecs::World w1, w2;
    const ecs::Entity e1 = makeWorld(w1);
    const ecs::Entity e2 = makeWorld(w2);
    for (int i = 0; i < 60; ++i) {
        spinSystem(w1, 1.0 / 60.0);
        spinSystem(w2, 1.0 / 60.0);
    }
    const glm::quat q1 = w1.get<ecs::Transform>(e1)->rotation;
    const glm::quat q2 = w2.get<ecs::Transform>(e2)->rotation;
    EXPECT_EQ(q1, q2) << "same inputs, bit-identical result";
    // 60 steps of 1/60 s at 90 deg/s: 90 degrees about the axis (float accumulation, 1e-5).
    const glm::quat expected = glm::angleAxis(glm::radians(90.0f), glm::normalize(glm::vec3(1, 2, 3)));
    EXPECT_NEAR(std::abs(glm::dot(q1, expected)), 1.0f, 1e-5f);
    EXPECT_NEAR(glm::length(q1), 1.0f, 1e-6f);
    for (auto [e, t] : w1.view<ecs::Transform>()) {
        if (e != e1) {
            EXPECT_EQ(t.rotation, glm::quat(1, 0, 0, 0)) << "entities without Spin do not move";
        }
    }
    spinSystem(w1, 0.0);
    EXPECT_EQ(w1.get<ecs::Transform>(e1)->rotation, q1) << "dt = 0 changes nothing";
}

TEST(FindCamera, ByNameOrFirstInEntityOrder) {
    ecs::World w;
    EXPECT_TRUE(findCamera(w, "").isNull()) << "no camera at all";
    const ecs::Entity plain = w.create();
    w.add<ecs::Transform>(plain);
    const ecs::Entity a = w.create();
    const ecs::Entity b = w.create();
    const ecs::Entity c = w.create();
    // Components added in reverse order, so pool order differs from entity order.
    w.add<ecs::Camera>(c, ecs::Camera{});
    w.add<ecs::Name>(c, std::string("third"));
    ecs::Camera named;
    named.name = "by-camera-name";
    w.add<ecs::Camera>(b, named);
    w.add<ecs::Camera>(a, ecs::Camera{});
    w.add<ecs::Name>(a, std::string("first"));
    EXPECT_EQ(findCamera(w, ""), a);
    EXPECT_EQ(findCamera(w, "first"), a);
    EXPECT_EQ(findCamera(w, "by-camera-name"), b);
    EXPECT_EQ(findCamera(w, "third"), c);
    EXPECT_TRUE(findCamera(w, "missing").isNull());
    w.add<ecs::Name>(plain, std::string("plain"));
    EXPECT_TRUE(findCamera(w, "plain").isNull()) << "a named entity without a Camera is not a camera";
    w.destroy(a);
    EXPECT_EQ(findCamera(w, ""), b);
}

}  // namespace
}  // namespace penumbra::scene
