// Entities (create / destroy / reuse with generation bump, stale handles) and component access.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <unordered_set>
#include <vector>

#include "engine/core/log.h"
#include "engine/ecs/world.h"

namespace penumbra::ecs {

bool addOtherClashForTest(World& world, Entity e);  // view_test.cpp

namespace {

struct Position {
    float x = 0, y = 0, z = 0;
};
struct Health {
    int value = 100;
};
struct Tag {};

// A non-aggregate, move-only component with a constructor.
class Label {
public:
    explicit Label(std::string text) : m_text(std::make_unique<std::string>(std::move(text))) {}
    const std::string& text() const { return *m_text; }

private:
    std::unique_ptr<std::string> m_text;
};

TEST(EcsEntity, NullEntity) {
    World world;
    EXPECT_TRUE(kNullEntity.isNull());
    EXPECT_FALSE(world.alive(kNullEntity));
    EXPECT_FALSE(world.destroy(kNullEntity));
    EXPECT_EQ(world.add<Position>(kNullEntity), nullptr);
    EXPECT_EQ(world.get<Position>(kNullEntity), nullptr);
    EXPECT_FALSE(world.has<Position>(kNullEntity));
    EXPECT_FALSE(world.remove<Position>(kNullEntity));
    EXPECT_EQ(Entity::fromBits(Entity{7, 9}.toBits()), (Entity{7, 9}));
}

TEST(EcsEntity, CreateGivesDistinctAliveEntities) {
    World world;
    std::unordered_set<Entity> seen;
    for (int i = 0; i < 1000; ++i) {
        Entity e = world.create();
        EXPECT_FALSE(e.isNull());
        EXPECT_TRUE(world.alive(e));
        EXPECT_TRUE(seen.insert(e).second);
    }
    EXPECT_EQ(world.aliveCount(), 1000u);
}

TEST(EcsEntity, DestroyReusesIndexWithHigherGeneration) {
    World world;
    Entity a = world.create();
    Entity b = world.create();
    ASSERT_TRUE(world.destroy(a));
    EXPECT_FALSE(world.alive(a));
    EXPECT_TRUE(world.alive(b));
    EXPECT_FALSE(world.destroy(a)) << "double destroy must be rejected";

    Entity c = world.create();
    EXPECT_EQ(c.index, a.index) << "freed index is reused";
    EXPECT_EQ(c.generation, a.generation + 1);
    EXPECT_TRUE(world.alive(c));
    EXPECT_FALSE(world.alive(a)) << "stale handle must not alias the new entity";
    EXPECT_NE(a, c);

    // Many cycles on the same slot keep bumping the generation.
    Entity cur = c;
    for (int i = 0; i < 100; ++i) {
        ASSERT_TRUE(world.destroy(cur));
        Entity next = world.create();
        EXPECT_EQ(next.index, cur.index);
        EXPECT_EQ(next.generation, cur.generation + 1);
        cur = next;
    }
    EXPECT_EQ(world.aliveCount(), 2u);
}

TEST(EcsEntity, StaleHandleRejectedEverywhere) {
    World world;
    Entity a = world.create();
    world.add<Position>(a, 1.f, 2.f, 3.f);
    world.add<Health>(a, 5);
    ASSERT_TRUE(world.destroy(a));
    Entity reused = world.create();
    ASSERT_EQ(reused.index, a.index);
    world.add<Position>(reused, 9.f, 9.f, 9.f);

    EXPECT_FALSE(world.alive(a));
    EXPECT_EQ(world.get<Position>(a), nullptr);
    EXPECT_FALSE(world.has<Position>(a));
    EXPECT_EQ(world.add<Health>(a, 1), nullptr);
    EXPECT_FALSE(world.has<Health>(reused)) << "add through a stale handle must not reach the new entity";
    EXPECT_FALSE(world.remove<Position>(a));
    EXPECT_TRUE(world.has<Position>(reused));
    EXPECT_FALSE(world.destroy(a));
    EXPECT_TRUE(world.alive(reused));
    // A forged handle with a future generation is rejected too.
    EXPECT_FALSE(world.alive(Entity{reused.index, reused.generation + 1}));
    EXPECT_FALSE(world.alive(Entity{12345, 0})) << "index never created";
    EXPECT_EQ(world.get<Position>(Entity{12345, 0}), nullptr);
}

TEST(EcsEntity, DestroyRemovesAllComponents) {
    World world;
    Entity a = world.create();
    Entity b = world.create();
    world.add<Position>(a);
    world.add<Health>(a);
    world.add<Position>(b);
    world.destroy(a);
    EXPECT_EQ(world.count<Position>(), 1u);
    EXPECT_EQ(world.count<Health>(), 0u);
    EXPECT_TRUE(world.has<Position>(b));
}

TEST(EcsEntity, ClearInvalidatesEverything) {
    World world;
    std::vector<Entity> old;
    for (int i = 0; i < 10; ++i) {
        old.push_back(world.create());
        world.add<Health>(old.back(), i);
    }
    ASSERT_TRUE(world.clear());
    EXPECT_EQ(world.aliveCount(), 0u);
    EXPECT_EQ(world.count<Health>(), 0u);
    for (Entity e : old) EXPECT_FALSE(world.alive(e));
    Entity n = world.create();
    EXPECT_EQ(n.index, 0u);
    EXPECT_EQ(n.generation, 1u);
    EXPECT_FALSE(world.has<Health>(old[0]));
}

TEST(EcsEntity, EachEntityVisitsLiveOnes) {
    World world;
    std::vector<Entity> es;
    for (int i = 0; i < 6; ++i) es.push_back(world.create());
    world.destroy(es[1]);
    world.destroy(es[4]);
    std::vector<Entity> seen;
    world.eachEntity([&](Entity e) { seen.push_back(e); });
    EXPECT_EQ(seen, (std::vector<Entity>{es[0], es[2], es[3], es[5]}));
}

TEST(EcsComponents, AddGetHasRemove) {
    World world;
    Entity e = world.create();
    EXPECT_FALSE(world.has<Position>(e));
    EXPECT_EQ(world.get<Position>(e), nullptr);

    Position* p = world.add<Position>(e, 1.f, 2.f, 3.f);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->y, 2.f);
    EXPECT_TRUE(world.has<Position>(e));
    EXPECT_EQ(world.get<Position>(e), p);
    EXPECT_FALSE(world.has<Health>(e));

    const World& cw = world;
    const Position* cp = cw.get<Position>(e);
    ASSERT_NE(cp, nullptr);
    EXPECT_EQ(cp->z, 3.f);

    EXPECT_TRUE(world.remove<Position>(e));
    EXPECT_FALSE(world.has<Position>(e));
    EXPECT_FALSE(world.remove<Position>(e));
    EXPECT_FALSE(world.remove<Health>(e)) << "never added";
    EXPECT_TRUE(world.alive(e)) << "removing a component keeps the entity";
}

TEST(EcsComponents, AddReplacesExisting) {
    World world;
    Entity e = world.create();
    world.add<Health>(e, 10);
    Health* h = world.add<Health>(e, 20);
    ASSERT_NE(h, nullptr);
    EXPECT_EQ(h->value, 20);
    EXPECT_EQ(world.count<Health>(), 1u);
}

TEST(EcsComponents, EmptyAndMoveOnlyTypes) {
    World world;
    Entity a = world.create();
    Entity b = world.create();
    EXPECT_NE(world.add<Tag>(a), nullptr);
    EXPECT_TRUE(world.has<Tag>(a));
    EXPECT_FALSE(world.has<Tag>(b));

    world.add<Label>(a, "first");
    world.add<Label>(b, "second");
    EXPECT_EQ(world.get<Label>(a)->text(), "first");
    world.remove<Label>(a);  // swap-remove moves b's label
    EXPECT_EQ(world.get<Label>(b)->text(), "second");
}

TEST(EcsComponents, SwapRemoveKeepsOthersIntact) {
    World world;
    std::vector<Entity> es;
    for (int i = 0; i < 50; ++i) {
        es.push_back(world.create());
        world.add<Health>(es.back(), i);
    }
    for (int i = 0; i < 50; i += 3) world.remove<Health>(es[size_t(i)]);
    for (int i = 0; i < 50; ++i) {
        const Health* h = world.get<Health>(es[size_t(i)]);
        if (i % 3 == 0) {
            EXPECT_EQ(h, nullptr);
        } else {
            ASSERT_NE(h, nullptr);
            EXPECT_EQ(h->value, i);
        }
    }
}

TEST(EcsComponents, SparsePagesFarApart) {
    World world;
    std::vector<Entity> es;
    for (int i = 0; i < 10000; ++i) es.push_back(world.create());
    // Only a few entities in distant pages get the component.
    world.add<Health>(es[9999], 1);
    world.add<Health>(es[5], 2);
    EXPECT_EQ(world.get<Health>(es[9999])->value, 1);
    EXPECT_EQ(world.get<Health>(es[5])->value, 2);
    EXPECT_FALSE(world.has<Health>(es[4096]));
    EXPECT_FALSE(world.has<Health>(es[8000]));
}

TEST(EcsComponents, ComponentTypeIdentity) {
    constexpr ComponentType a = componentType<Position>();
    constexpr ComponentType b = componentType<Health>();
    EXPECT_NE(a.key, b.key);
    EXPECT_NE(a.name.find("Position"), std::string_view::npos) << a.name;
    EXPECT_EQ(componentType<Position>().key, a.key);
}

struct Clash {
    int v = 0;
};

TEST(EcsComponents, SameNameDifferentLayoutIsRefused) {
    World world;
    Entity e = world.create();
    ASSERT_NE(world.add<Clash>(e, 5), nullptr);
    std::vector<std::string> errors;
    auto old = log::setSink([&](log::Severity s, std::string_view m) {
        if (s == log::Severity::Error) errors.emplace_back(m);
    });
    EXPECT_FALSE(addOtherClashForTest(world, e));
    log::setSink(std::move(old));
    ASSERT_EQ(errors.size(), 1u);
    EXPECT_NE(errors[0].find("Clash"), std::string::npos) << errors[0];
    EXPECT_EQ(world.get<Clash>(e)->v, 5) << "the first type's data is untouched";
}

TEST(EcsComponents, MoveWorld) {
    World world;
    Entity e = world.create();
    world.add<Health>(e, 7);
    World moved = std::move(world);
    EXPECT_TRUE(moved.alive(e));
    EXPECT_EQ(moved.get<Health>(e)->value, 7);
}

}  // namespace
}  // namespace penumbra::ecs
