// Engine components (defaults) and the system Schedule. SDF shapes: tests/sdf/shape_program_test.cpp.
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
    world.add<Light>(e)->type = LightType::Sphere;
    world.add<Material>(e)->roughness = 0.25f;
    EXPECT_EQ(world.get<Name>(e)->value, "thing");
    EXPECT_EQ(world.get<Camera>(e)->name, "main");
    EXPECT_EQ(world.get<MeshRenderer>(e)->material, 4u);
    EXPECT_TRUE(world.get<SdfRenderer>(e)->castShadows);
    EXPECT_EQ(world.get<SdfRenderer>(e)->source, SdfSource::None);
    EXPECT_EQ(world.get<Light>(e)->type, LightType::Sphere);
    EXPECT_EQ(world.get<Material>(e)->baseColorTexture, 0u);
    EXPECT_NEAR(world.get<Camera>(e)->fovY, 3.14159265f / 3.0f, 1e-6f);
    EXPECT_EQ((world.view<Transform, Camera, Light>().count()), 1u);
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
