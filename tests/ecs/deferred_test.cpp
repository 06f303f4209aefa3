// Structural changes during iteration: queued, applied when the outermost iteration ends.
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <string>
#include <vector>

#include "engine/core/log.h"
#include "engine/ecs/world.h"

namespace penumbra::ecs {
namespace {

struct Pos {
    int v = 0;
};
struct Vel {
    int v = 0;
};
struct Marker {
    int v = 0;
};

TEST(EcsDeferred, DestroyDuringIterationVisitsEveryLiveEntityOnce) {
    World world;
    std::vector<Entity> es;
    for (int i = 0; i < 500; ++i) {
        es.push_back(world.create());
        world.add<Pos>(es.back(), i);
        world.add<Vel>(es.back(), 1);
    }
    std::map<Entity, int> visits;
    for (auto [e, p, v] : world.view<Pos, Vel>()) {
        ++visits[e];
        EXPECT_TRUE(world.iterating());
        // Destroy the current entity, and another one that the iteration has not reached yet
        // (or has already visited): both must still be visited exactly once.
        if (p.v % 3 == 0) {
            const bool alreadyQueued = world.isPendingDestroy(e);  // by the `other` rule below
            EXPECT_EQ(world.destroy(e), !alreadyQueued);
            EXPECT_TRUE(world.alive(e)) << "applied later";
            EXPECT_TRUE(world.isPendingDestroy(e));
            EXPECT_FALSE(world.destroy(e)) << "already queued";
            EXPECT_NE(world.get<Pos>(e), nullptr) << "components stay until the flush";
        }
        const Entity other = es[size_t(499 - p.v)];
        if (p.v % 7 == 0) world.destroy(other);
        p.v += v.v * 1000;
    }
    EXPECT_FALSE(world.iterating());
    EXPECT_EQ(world.pendingCount(), 0u) << "applied when the iteration ended";
    EXPECT_EQ(visits.size(), es.size());
    for (auto& [e, n] : visits) EXPECT_EQ(n, 1);

    std::set<Entity> expectDead;
    for (int i = 0; i < 500; ++i) {
        if (i % 3 == 0) expectDead.insert(es[size_t(i)]);
        if (i % 7 == 0) expectDead.insert(es[size_t(499 - i)]);
    }
    for (Entity e : es) {
        EXPECT_EQ(world.alive(e), !expectDead.count(e));
        if (world.alive(e)) {
            EXPECT_GE(world.get<Pos>(e)->v, 1000);
        }
    }
    EXPECT_EQ(world.aliveCount(), es.size() - expectDead.size());
    EXPECT_EQ(world.count<Pos>(), world.aliveCount());
    EXPECT_EQ((world.view<Pos, Vel>().count()), world.aliveCount());
}

TEST(EcsDeferred, EachAndNestedIterationFlushAtOutermostEnd) {
    World world;
    std::vector<Entity> es;
    for (int i = 0; i < 10; ++i) {
        es.push_back(world.create());
        world.add<Pos>(es.back(), i);
    }
    world.view<Pos>().each([&](Entity outer, Pos&) {
        for (auto [inner, p] : world.view<Pos>()) {
            if (inner == outer && p.v % 2 == 0) world.destroy(inner);
        }
        EXPECT_TRUE(world.iterating()) << "inner loop ended but the outer one runs";
    });
    EXPECT_EQ(world.aliveCount(), 5u);
    for (int i = 0; i < 10; ++i) EXPECT_EQ(world.alive(es[size_t(i)]), i % 2 == 1);
}

TEST(EcsDeferred, BreakOutOfLoopStillFlushes) {
    World world;
    Entity a = world.create();
    world.add<Pos>(a);
    world.add<Pos>(world.create());
    for (auto [e, p] : world.view<Pos>()) {
        (void)p;
        world.destroy(e);
        break;
    }
    EXPECT_FALSE(world.iterating());
    EXPECT_EQ(world.aliveCount(), 1u);
}

TEST(EcsDeferred, FlushDuringIterationIsRefused) {
    World world;
    world.add<Pos>(world.create());
    std::vector<std::string> errors;
    auto old = log::setSink([&](log::Severity s, std::string_view m) {
        if (s == log::Severity::Error) errors.emplace_back(m);
    });
    for (auto [e, p] : world.view<Pos>()) {
        (void)p;
        world.destroy(e);
        EXPECT_FALSE(world.flush());
        EXPECT_FALSE(world.clear());
        EXPECT_TRUE(world.alive(e));
    }
    log::setSink(std::move(old));
    EXPECT_EQ(errors.size(), 2u);
    EXPECT_EQ(world.aliveCount(), 0u);
    EXPECT_TRUE(world.flush()) << "nothing left, fine outside iteration";
}

TEST(EcsDeferred, HeldViewDoesNotBlockChanges) {
    // Only iterations defer; a view object that is not being iterated does not.
    World world;
    Entity e = world.create();
    world.add<Pos>(e);
    auto view = world.view<Pos>();
    EXPECT_FALSE(world.iterating());
    world.destroy(e);
    EXPECT_FALSE(world.alive(e));
    EXPECT_EQ(view.count(), 0u);
}

// The rule for components: adds (new or replacing) and removes are queued in call order.
TEST(EcsDeferred, AddRemoveDuringIteration) {
    World world;
    std::vector<Entity> es;
    for (int i = 0; i < 100; ++i) {
        es.push_back(world.create());
        world.add<Pos>(es.back(), i);
        if (i % 2 == 0) world.add<Vel>(es.back(), i);
    }
    size_t visited = 0;
    for (auto [e, p] : world.view<Pos>()) {
        ++visited;
        if (p.v % 2 == 0) {
            // Has Vel: remove it (queued) and replace Pos (queued too).
            EXPECT_TRUE(world.remove<Vel>(e));
            EXPECT_TRUE(world.has<Vel>(e)) << "removal is queued";
            Pos* replaced = world.add<Pos>(e, p.v + 1000);
            ASSERT_NE(replaced, nullptr);
            EXPECT_NE(replaced, &p) << "the replacement is a queued value";
            EXPECT_EQ(p.v % 2, 0) << "current value unchanged until the flush";
        } else {
            // No Vel: adding one is queued; the returned pointer is the queued value.
            Vel* staged = world.add<Vel>(e, 0);
            ASSERT_NE(staged, nullptr);
            staged->v = p.v * 2;  // modify the queued value
            EXPECT_FALSE(world.has<Vel>(e)) << "addition is queued";
            EXPECT_EQ(world.get<Vel>(e), nullptr);
            world.add<Marker>(e, 1);
        }
        // A brand new entity with components during iteration is not visited by this loop.
        Entity spawned = world.create();
        EXPECT_TRUE(world.alive(spawned));
        world.add<Pos>(spawned, -1);
    }
    EXPECT_EQ(visited, 100u);
    EXPECT_EQ(world.aliveCount(), 200u);
    EXPECT_EQ(world.count<Pos>(), 200u);
    for (int i = 0; i < 100; ++i) {
        const Entity e = es[size_t(i)];
        if (i % 2 == 0) {
            EXPECT_FALSE(world.has<Vel>(e));
            EXPECT_EQ(world.get<Pos>(e)->v, i + 1000);
            EXPECT_FALSE(world.has<Marker>(e));
        } else {
            ASSERT_TRUE(world.has<Vel>(e));
            EXPECT_EQ(world.get<Vel>(e)->v, i * 2);
            EXPECT_TRUE(world.has<Marker>(e));
        }
    }
    size_t spawnedSeen = 0;
    for (auto [e, p] : world.view<Pos>()) spawnedSeen += p.v == -1;
    EXPECT_EQ(spawnedSeen, 100u);
}

TEST(EcsDeferred, QueuedOperationsApplyInOrder) {
    World world;
    Entity a = world.create();
    Entity b = world.create();
    world.add<Pos>(a);
    world.add<Pos>(b);
    for (auto [e, p] : world.view<Pos>()) {
        (void)p;
        if (e != a) continue;
        world.add<Vel>(a, 1);  // queued add ...
        world.remove<Vel>(a);  // ... then remove: has no Vel yet, so refused
        world.add<Vel>(b, 2);  // queued add to b ...
        world.destroy(b);      // ... then b is destroyed: the add is dropped
        world.add<Marker>(b, 3);
    }
    EXPECT_TRUE(world.has<Vel>(a));
    EXPECT_FALSE(world.alive(b));
    EXPECT_EQ(world.count<Vel>(), 1u);
    EXPECT_EQ(world.count<Marker>(), 0u);

    // Remove then re-add during iteration: present with the new value (call order) ...
    for (auto [e, p] : world.view<Pos>()) {
        (void)p;
        EXPECT_TRUE(world.remove<Vel>(e));
        Vel* v = world.add<Vel>(e, 42);
        EXPECT_EQ(v->v, 42);
        EXPECT_EQ(world.get<Vel>(e)->v, 1) << "old value until the flush";
    }
    ASSERT_TRUE(world.has<Vel>(a));
    EXPECT_EQ(world.get<Vel>(a)->v, 42);
    // ... and add then remove: absent.
    for (auto [e, p] : world.view<Pos>()) {
        (void)p;
        world.add<Vel>(e, 7);
        EXPECT_TRUE(world.remove<Vel>(e));
    }
    EXPECT_FALSE(world.has<Vel>(a));
}

TEST(EcsDeferred, ExplicitFlushAfterManualIteration) {
    World world;
    Entity a = world.create();
    world.add<Pos>(a);
    {
        auto view = world.view<Pos>();
        auto it = view.begin();  // an iterator keeps the iteration open
        world.destroy(a);
        EXPECT_TRUE(world.alive(a));
        EXPECT_EQ(world.pendingCount(), 1u);
    }
    EXPECT_FALSE(world.alive(a)) << "applied when the last iterator went away";
    EXPECT_TRUE(world.flush());
}

TEST(EcsDeferred, EachEntityDefersToo) {
    World world;
    for (int i = 0; i < 5; ++i) world.create();
    int n = 0;
    world.eachEntity([&](Entity e) {
        ++n;
        world.destroy(e);
    });
    EXPECT_EQ(n, 5);
    EXPECT_EQ(world.aliveCount(), 0u);
}

}  // namespace
}  // namespace penumbra::ecs
