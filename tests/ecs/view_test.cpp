// Views over one, two and three component types, pools of different sizes, const views.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>
#include <vector>

#include "engine/ecs/world.h"

namespace penumbra::ecs {
namespace {

struct A {
    int v = 0;
};
struct B {
    int v = 0;
};
struct C {
    int v = 0;
};

// Entity i gets A if i % 2 == 0, B if i % 3 == 0, C if i % 5 == 0.
struct Fixture {
    World world;
    std::vector<Entity> entities;
    explicit Fixture(int n) {
        for (int i = 0; i < n; ++i) {
            Entity e = world.create();
            entities.push_back(e);
            if (i % 2 == 0) world.add<A>(e, i);
            if (i % 3 == 0) world.add<B>(e, i * 10);
            if (i % 5 == 0) world.add<C>(e, i * 100);
        }
    }
    std::set<Entity> expected(bool a, bool b, bool c) const {
        std::set<Entity> out;
        for (size_t i = 0; i < entities.size(); ++i) {
            if ((!a || i % 2 == 0) && (!b || i % 3 == 0) && (!c || i % 5 == 0)) out.insert(entities[i]);
        }
        return out;
    }
};

TEST(EcsView, SingleComponent) {
    Fixture f(100);
    std::set<Entity> seen;
    for (auto [e, a] : f.world.view<A>()) {
        EXPECT_TRUE(seen.insert(e).second);
        EXPECT_EQ(a.v, int(e.index));
    }
    EXPECT_EQ(seen, f.expected(true, false, false));
}

TEST(EcsView, TwoComponentsDifferentPoolSizes) {
    Fixture f(300);
    EXPECT_GT(f.world.count<A>(), f.world.count<B>());
    std::set<Entity> seen;
    for (auto [e, a, b] : f.world.view<A, B>()) {
        EXPECT_TRUE(seen.insert(e).second);
        EXPECT_EQ(a.v, int(e.index));
        EXPECT_EQ(b.v, int(e.index) * 10);
    }
    EXPECT_EQ(seen, f.expected(true, true, false));
    // Same set whichever order the types are named in (the smallest pool leads either way).
    std::set<Entity> seen2;
    for (auto [e, b, a] : f.world.view<B, A>()) {
        seen2.insert(e);
        EXPECT_EQ(a.v * 10, b.v);
    }
    EXPECT_EQ(seen2, seen);
    EXPECT_EQ((f.world.view<A, B>().sizeHint()), f.world.count<B>());
}

TEST(EcsView, ThreeComponents) {
    Fixture f(1000);
    std::set<Entity> seen;
    f.world.view<A, B, C>().each([&](Entity e, A& a, B& b, C& c) {
        EXPECT_TRUE(seen.insert(e).second);
        EXPECT_EQ(a.v, int(e.index));
        EXPECT_EQ(b.v, a.v * 10);
        EXPECT_EQ(c.v, a.v * 100);
    });
    EXPECT_EQ(seen, f.expected(true, true, true));
    EXPECT_EQ((f.world.view<C, A, B>().count()), seen.size());
}

TEST(EcsView, WritesThroughReferences) {
    Fixture f(60);
    for (auto [e, a, b] : f.world.view<A, B>()) {
        a.v = -1;
        b.v = -2;
    }
    f.world.view<A>().each([](A& a) { a.v += 1; });  // component-only signature
    for (size_t i = 0; i < f.entities.size(); ++i) {
        const A* a = f.world.get<A>(f.entities[i]);
        if (!a) continue;
        EXPECT_EQ(a->v, i % 3 == 0 ? 0 : int(i) + 1);
    }
}

TEST(EcsView, ConstViews) {
    Fixture f(30);
    const World& cw = f.world;
    int sum = 0;
    for (auto [e, a, b] : cw.view<A, B>()) {
        static_assert(std::is_same_v<decltype(a), const A&>);
        sum += a.v + b.v;
    }
    int expectedSum = 0;
    for (Entity e : f.expected(true, true, false)) expectedSum += int(e.index) * 11;
    EXPECT_EQ(sum, expectedSum);

    // Mixed constness on a mutable world.
    for (auto [e, a, b] : f.world.view<const A, B>()) {
        static_assert(std::is_same_v<decltype(a), const A&>);
        static_assert(std::is_same_v<decltype(b), B&>);
        b.v = a.v;
    }
}

TEST(EcsView, EmptyAndMissingPools) {
    World world;
    Entity e = world.create();
    world.add<A>(e);
    EXPECT_EQ((world.view<A, B>().count()), 0u) << "no B at all";
    const World& cw = world;
    EXPECT_EQ(cw.view<C>().count(), 0u) << "const view of a type never added";
    // A view built before the first add sees later additions.
    auto v = world.view<A, C>();
    world.add<C>(e);
    EXPECT_EQ(v.count(), 1u);
}

TEST(EcsView, AfterRemovalsAndReuse) {
    Fixture f(200);
    // Destroy every 4th entity, then reuse the indices with fresh entities having A and B.
    std::set<Entity> expect = f.expected(true, true, false);
    for (size_t i = 0; i < f.entities.size(); i += 4) {
        expect.erase(f.entities[i]);
        f.world.destroy(f.entities[i]);
    }
    for (int i = 0; i < 20; ++i) {
        Entity e = f.world.create();
        f.world.add<A>(e, int(e.index));
        f.world.add<B>(e, int(e.index) * 10);
        expect.insert(e);
    }
    std::set<Entity> seen;
    for (auto [e, a, b] : f.world.view<A, B>()) {
        EXPECT_TRUE(seen.insert(e).second);
        EXPECT_EQ(b.v, a.v * 10);
    }
    EXPECT_EQ(seen, expect);
}

TEST(EcsView, NestedViews) {
    Fixture f(40);
    size_t pairs = 0;
    for (auto [e1, a] : f.world.view<A>()) {
        for (auto [e2, b] : f.world.view<B>()) {
            (void)a;
            (void)b;
            ++pairs;
        }
    }
    EXPECT_EQ(pairs, f.world.count<A>() * f.world.count<B>());
    EXPECT_FALSE(f.world.iterating());
}

}  // namespace

// A component named exactly like world_test.cpp's Clash (both live in an anonymous namespace of
// penumbra::ecs) but with another layout: the world must refuse to mix them up.
namespace {
struct Clash {
    double a = 0, b = 0;
};
}  // namespace

bool addOtherClashForTest(World& world, Entity e) { return world.add<Clash>(e, 1.0, 2.0) != nullptr; }

}  // namespace penumbra::ecs
