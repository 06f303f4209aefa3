// The shipped scenes (scenes/*.json): they load, have what scenes/README.md says, and the meshes of
// the default scene (baked SDF objects) sit on the floor, side by side, fully in view of the "main"
// camera.
#include <algorithm>

#include <gtest/gtest.h>

#include "scene/scene_test_util.h"

namespace penumbra::scene {
namespace {

using test::entityNamed;

size_t countLights(const ecs::World& w, ecs::LightType type) {
    size_t n = 0;
    for (auto [e, l] : w.view<ecs::Light>()) n += l.type == type ? 1 : 0;
    return n;
}

TEST(SceneFiles, DefaultSceneLoads) {
    ASSERT_FALSE(test::npmMesh("bunny.ply").empty());
    assets::AssetManager assets;
    Scene s;
    std::string error;
    ASSERT_TRUE(loadScene(test::sourcePath("scenes/default.json"), assets, s, error)) << error;
    const ecs::World& w = s.world;
    EXPECT_EQ(s.settings.width, 640u);
    EXPECT_EQ(s.settings.height, 360u);
    EXPECT_EQ(s.settings.shading, ShadingModel::CookTorrance);
    EXPECT_EQ(s.settings.toneMapper, ToneMapper::Aces);
    EXPECT_EQ(s.settings.quality, TraceQuality::Medium);
    EXPECT_EQ(s.settings.camera, "main");
    EXPECT_EQ(findCamera(w, ""), entityNamed(w, "main")) << "main is the first camera";
    EXPECT_FALSE(findCamera(w, "top").isNull());
    EXPECT_EQ(w.count<ecs::Camera>(), 2u);
    EXPECT_EQ(countLights(w, ecs::LightType::Directional), 1u);
    EXPECT_EQ(countLights(w, ecs::LightType::Point), 1u);
    EXPECT_EQ(countLights(w, ecs::LightType::Sphere), 1u);  // soft shadows from its radius
    // One rasterized mesh (hybrid), everything else traced.
    EXPECT_EQ(w.count<ecs::MeshRenderer>(), 1u);
    EXPECT_EQ(w.count<ecs::SdfRenderer>(), 8u);

    // The room: analytic shapes (floor, walls, pillars by repetition, a smooth-CSG sculpture).
    for (const char* name : {"floor", "walls", "pillars", "sculpture"}) {
        const ecs::SdfRenderer* sr = w.get<ecs::SdfRenderer>(entityNamed(w, name));
        ASSERT_NE(sr, nullptr) << name;
        EXPECT_EQ(sr->source, ecs::SdfSource::Shapes) << name;
        ASSERT_NE(assets.shapeProgram(sr->sdf), nullptr) << name;
    }
    bool repeat = false, smooth = false;
    for (const sdf::ShapeInstruction& r :
         assets.shapeProgram(w.get<ecs::SdfRenderer>(entityNamed(w, "pillars"))->sdf)->records)
        repeat = repeat || r.op == uint32_t(sdf::ShapeOp::PushRepeat);
    for (const sdf::ShapeInstruction& r :
         assets.shapeProgram(w.get<ecs::SdfRenderer>(entityNamed(w, "sculpture"))->sdf)->records)
        smooth = smooth || r.op == uint32_t(sdf::ShapeOp::SmoothUnion) ||
                 r.op == uint32_t(sdf::ShapeOp::SmoothSubtract);
    EXPECT_TRUE(repeat) << "pillars by domain repetition";
    EXPECT_TRUE(smooth) << "a smooth-CSG shape";

    // The npm meshes as baked fields; the bunny twice, sharing one field asset (instancing).
    std::vector<std::string> files;
    for (auto [e, sr] : w.view<ecs::SdfRenderer>()) {
        if (sr.source != ecs::SdfSource::MeshBake) continue;
        ASSERT_NE(assets.sdfField(sr.sdf), nullptr);
        files.push_back(std::filesystem::path(sr.bakeMesh).filename().string());
    }
    std::sort(files.begin(), files.end());
    EXPECT_EQ(files,
              (std::vector<std::string>{"bunny.ply", "bunny.ply", "dragon_vrip_res2.ply", "teapot.ply"}));
    EXPECT_EQ(w.get<ecs::SdfRenderer>(entityNamed(w, "bunny"))->sdf,
              w.get<ecs::SdfRenderer>(entityNamed(w, "bunny copy"))->sdf);
    EXPECT_EQ(assets.count(assets::AssetKind::SdfField), 3u);

    // Distinct materials on the three meshes.
    std::vector<assets::AssetId> materials;
    for (const char* name : {"bunny", "teapot", "dragon", "floor"}) {
        const ecs::SdfRenderer* sr = w.get<ecs::SdfRenderer>(entityNamed(w, name));
        ASSERT_NE(sr, nullptr) << name;
        ASSERT_NE(assets.material(sr->material), nullptr) << name;
        materials.push_back(sr->material);
    }
    std::sort(materials.begin(), materials.end());
    EXPECT_EQ(std::unique(materials.begin(), materials.end()), materials.end());

    // Placement: each mesh rests on y = 0 (lowest point of its mesh bounds within 0.01 units), the
    // three do not overlap along x, and every corner of its world bounding box is inside the main
    // camera's frustum at the scene's 16:9 aspect.
    const glm::mat4 viewProj =
        test::viewProjection(w, entityNamed(w, "main"), float(s.settings.width) / float(s.settings.height));
    float previousMaxX = -1e30f;
    for (const char* name : {"bunny", "teapot", "dragon"}) {
        glm::vec3 lo, hi;
        test::sdfWorldBounds(w, assets, entityNamed(w, name), lo, hi);
        SCOPED_TRACE(name);
        EXPECT_NEAR(lo.y, 0.0f, 0.01f);
        EXPECT_GT(hi.x - lo.x, 1.5f) << "about 2 units wide";
        EXPECT_LT(hi.x - lo.x, 2.5f);
        EXPECT_GT(lo.x, previousMaxX + 0.1f) << "side by side, left to right";
        previousMaxX = hi.x;
        for (int c = 0; c < 8; ++c) {
            const glm::vec3 corner((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
            EXPECT_TRUE(test::inView(viewProj, corner)) << "corner " << c << " out of view";
        }
        // The top camera sees them too.
        const glm::mat4 topViewProj = test::viewProjection(w, entityNamed(w, "top"), 16.0f / 9.0f);
        EXPECT_TRUE(test::inView(topViewProj, 0.5f * (lo + hi)));
    }

    unloadScene(s, assets);
    EXPECT_EQ(assets.count(), 0u);
}

TEST(SceneFiles, PrimitivesSceneLoads) {
    assets::AssetManager assets;
    Scene s;
    std::string error;
    ASSERT_TRUE(loadScene(test::sourcePath("scenes/primitives.json"), assets, s, error)) << error;
    const ecs::World& w = s.world;
    EXPECT_EQ(s.settings.shading, ShadingModel::BlinnPhong);
    EXPECT_EQ(s.settings.toneMapper, ToneMapper::Reinhard);
    for (auto [e, mr] : w.view<ecs::MeshRenderer>()) {
        ASSERT_EQ(assets.info(mr.mesh)->key.rfind("primitive:", 0), 0u) << "only primitives";
    }
    std::vector<std::string> shapes;
    for (auto [e, mr] : w.view<ecs::MeshRenderer>()) {
        const std::string& key = assets.info(mr.mesh)->key;
        shapes.push_back(key.substr(10, key.find(':', 10) - 10));
    }
    std::sort(shapes.begin(), shapes.end());
    EXPECT_EQ(shapes, (std::vector<std::string>{"box", "cylinder", "plane", "sphere", "torus"}));
    // The torus spins (through its pivot): after 1 s at 45 deg/s its world matrix has turned.
    const ecs::Entity torus = entityNamed(w, "torus");
    ASSERT_FALSE(torus.isNull());
    const ecs::Entity pivot = w.get<ecs::Transform>(torus)->parent;
    ASSERT_NE(w.get<Spin>(pivot), nullptr);
    const glm::mat4 before = w.get<ecs::Transform>(torus)->worldMatrix;
    for (int i = 0; i < 60; ++i) spinSystem(s.world, 1.0 / 60.0);
    ecs::updateTransforms(s.world);
    const glm::mat4 after = w.get<ecs::Transform>(torus)->worldMatrix;
    EXPECT_EQ(glm::vec3(before[3]), glm::vec3(after[3])) << "spinning about its own centre";
    // The torus axis (local +Y) turned 45 degrees about world +Y (tolerance: float, 1e-4 rad).
    const glm::vec3 a0 = glm::normalize(glm::vec3(before[1])), a1 = glm::normalize(glm::vec3(after[1]));
    const float turned = std::acos(std::clamp(
        glm::dot(glm::normalize(glm::vec2(a0.x, a0.z)), glm::normalize(glm::vec2(a1.x, a1.z))), -1.0f, 1.0f));
    EXPECT_NEAR(turned, glm::radians(45.0f), 1e-4f);
    // Everything is in view of the main camera.
    const glm::mat4 viewProj = test::viewProjection(w, findCamera(w, "main"), 16.0f / 9.0f);
    for (auto [e, mr] : w.view<ecs::MeshRenderer>()) {
        if (assets.info(mr.mesh)->key.rfind("primitive:plane", 0) == 0) continue;
        glm::vec3 lo, hi;
        test::worldBounds(w, assets, e, lo, hi);
        EXPECT_TRUE(test::inView(viewProj, lo) && test::inView(viewProj, hi)) << assets.info(mr.mesh)->key;
    }
    unloadScene(s, assets);
    EXPECT_EQ(assets.count(), 0u);
}

}  // namespace
}  // namespace penumbra::scene
