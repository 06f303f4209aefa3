// Engine components (defaults, SDF primitive distances and CSG) and the system Schedule.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "engine/core/log.h"
#include "engine/ecs/components.h"
#include "engine/ecs/schedule.h"
#include "engine/ecs/world.h"

namespace penumbra::ecs {
namespace {

TEST(EcsComponentsEngine, AllAttachToOneEntity) {
    World world;
    Entity e = world.create();
    world.add<Transform>(e);
    world.add<Name>(e, "thing");
    world.add<Camera>(e)->name = "main";
    world.add<MeshRenderer>(e, AssetId(3), AssetId(4));
    world.add<SdfRenderer>(e, AssetId(5), AssetId(6));
    world.add<SdfPrimitive>(e, SdfPrimitive::torus(1.0f, 0.25f));
    world.add<Light>(e)->type = LightType::Sphere;
    world.add<Material>(e)->roughness = 0.25f;
    EXPECT_EQ(world.get<Name>(e)->value, "thing");
    EXPECT_EQ(world.get<Camera>(e)->name, "main");
    EXPECT_EQ(world.get<MeshRenderer>(e)->material, 4u);
    EXPECT_TRUE(world.get<SdfRenderer>(e)->castShadows);
    EXPECT_EQ(world.get<SdfPrimitive>(e)->shape, SdfShape::Torus);
    EXPECT_EQ(world.get<Light>(e)->type, LightType::Sphere);
    EXPECT_EQ(world.get<Material>(e)->baseColorTexture, 0u);
    EXPECT_NEAR(world.get<Camera>(e)->fovY, 3.14159265f / 3.0f, 1e-6f);
    EXPECT_EQ((world.view<Transform, Camera, Light>().count()), 1u);
}

TEST(EcsSdfPrimitive, Distances) {
    const SdfPrimitive s = SdfPrimitive::sphere(2.0f);
    EXPECT_NEAR(s.distance({3, 0, 0}), 1.0f, 1e-6f);
    EXPECT_NEAR(s.distance({0, 0, 0}), -2.0f, 1e-6f);

    const SdfPrimitive b = SdfPrimitive::box({1, 2, 3});
    EXPECT_NEAR(b.distance({2, 0, 0}), 1.0f, 1e-6f);
    EXPECT_NEAR(b.distance({0, 0, 0}), -1.0f, 1e-6f);
    EXPECT_NEAR(b.distance({2, 3, 0}), std::sqrt(2.0f), 1e-6f);  // off the edge

    const SdfPrimitive rb = SdfPrimitive::box({1, 1, 1}, 0.25f);
    EXPECT_NEAR(rb.distance({2, 0, 0}), 1.0f, 1e-6f);
    // Rounded corner: centre of the corner sphere at (0.75, 0.75, 0.75), radius 0.25.
    const glm::vec3 corner(2, 2, 2);
    EXPECT_NEAR(rb.distance(corner), glm::length(corner - glm::vec3(0.75f)) - 0.25f, 1e-6f);

    const SdfPrimitive p = SdfPrimitive::plane({0, 2, 0}, 1.0f);  // normalised to +Y, y = 1
    EXPECT_NEAR(p.distance({5, 3, -2}), 2.0f, 1e-6f);
    EXPECT_NEAR(p.distance({0, 0, 0}), -1.0f, 1e-6f);

    const SdfPrimitive c = SdfPrimitive::capsule(0.5f, 1.0f);
    EXPECT_NEAR(c.distance({1, 0.5f, 0}), 0.5f, 1e-6f);
    EXPECT_NEAR(c.distance({0, 3, 0}), 1.5f, 1e-6f);

    const SdfPrimitive t = SdfPrimitive::torus(2.0f, 0.5f);
    EXPECT_NEAR(t.distance({2, 0, 0}), -0.5f, 1e-6f);
    EXPECT_NEAR(t.distance({0, 0, 0}), 1.5f, 1e-6f);
    EXPECT_NEAR(t.distance({0, 1, 2}), 0.5f, 1e-6f);
}

TEST(EcsSdfPrimitive, CsgCombine) {
    EXPECT_EQ(csgCombine(CsgOp::Union, 1.0f, 2.0f, 0.0f), 1.0f);
    EXPECT_EQ(csgCombine(CsgOp::Intersect, 1.0f, 2.0f, 0.0f), 2.0f);
    EXPECT_EQ(csgCombine(CsgOp::Subtract, 1.0f, 2.0f, 0.0f), 1.0f);
    EXPECT_EQ(csgCombine(CsgOp::Subtract, 1.0f, -3.0f, 0.0f), 3.0f);
    // Smooth variants: bounded by the hard ones, equal to them when far apart.
    for (float a = -2.0f; a <= 2.0f; a += 0.125f) {
        for (float b = -2.0f; b <= 2.0f; b += 0.125f) {
            const float k = 0.5f;
            EXPECT_LE(csgCombine(CsgOp::Union, a, b, k), std::min(a, b) + 1e-6f);
            EXPECT_GE(csgCombine(CsgOp::Intersect, a, b, k), std::max(a, b) - 1e-6f);
            EXPECT_GE(csgCombine(CsgOp::Subtract, a, b, k), std::max(a, -b) - 1e-6f);
            if (std::abs(a - b) >= k) {
                EXPECT_NEAR(csgCombine(CsgOp::Union, a, b, k), std::min(a, b), 1e-6f);
            }
        }
    }
    EXPECT_NEAR(csgCombine(CsgOp::Union, 0.0f, 0.0f, 0.5f), -0.125f, 1e-6f);
}

TEST(EcsSchedule, RunsInOrderAndFlushes) {
    World world;
    Schedule schedule;
    std::vector<std::string> order;
    ASSERT_TRUE(schedule.add("spawn", [&](World& w, double dt) {
        order.push_back("spawn");
        EXPECT_DOUBLE_EQ(dt, 0.5);
        Entity e = w.create();
        w.add<Transform>(e)->position = {1, 2, 3};
    }));
    ASSERT_TRUE(schedule.add("transforms", transformSystem));
    ASSERT_TRUE(schedule.add("cull", [&](World& w, double) {
        order.push_back("cull");
        for (auto [e, t] : w.view<Transform>()) {
            if (t.worldPosition().x > 0.5f) w.destroy(e);
        }
        EXPECT_EQ(w.aliveCount(), 0u) << "applied when the loop ended";
    }));
    ASSERT_TRUE(
        schedule.insertBefore("transforms", "first", [&](World&, double) { order.push_back("first"); }));

    std::vector<std::string> errors;
    auto old = log::setSink([&](log::Severity, std::string_view m) { errors.emplace_back(m); });
    EXPECT_FALSE(schedule.add("cull", [](World&, double) {})) << "duplicate name";
    EXPECT_FALSE(schedule.add("empty", System{}));
    EXPECT_FALSE(schedule.insertBefore("missing", "x", [](World&, double) {}));
    log::setSink(std::move(old));
    EXPECT_EQ(errors.size(), 3u);

    schedule.run(world, 0.5);
    EXPECT_EQ(order, (std::vector<std::string>{"spawn", "first", "cull"}));
    EXPECT_EQ(world.aliveCount(), 0u);
    EXPECT_EQ(schedule.size(), 4u);
    EXPECT_EQ(schedule.systems()[1].name, "first");
    EXPECT_GE(schedule.systems()[0].lastCpuMs, 0.0);
    EXPECT_TRUE(schedule.remove("first"));
    EXPECT_FALSE(schedule.contains("first"));
    EXPECT_FALSE(schedule.remove("first"));
}

}  // namespace
}  // namespace penumbra::ecs
