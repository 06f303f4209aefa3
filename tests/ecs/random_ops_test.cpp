// 100k random operations on a World checked against a plain reference model (std::map), with a fixed
// seed: create, destroy (also through stale handles), add/replace/remove/get of three component
// types, views, and iterations that destroy / add / remove while iterating.
#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <vector>

#include "engine/ecs/world.h"

namespace penumbra::ecs {
namespace {

struct CompA {
    int64_t v = 0;
};
struct CompB {
    int64_t v = 0;
};
struct CompC {
    int64_t v = 0;
};

struct RefEntity {
    std::optional<int64_t> a, b, c;
};

class Model {
public:
    std::map<Entity, RefEntity> live;
    std::vector<Entity> everCreated;  // includes dead ones: used as stale handles
};

template <typename T>
std::optional<int64_t>& field(RefEntity& r) {
    if constexpr (std::is_same_v<T, CompA>) return r.a;
    if constexpr (std::is_same_v<T, CompB>) return r.b;
    if constexpr (std::is_same_v<T, CompC>) return r.c;
}

class EcsRandomOps : public ::testing::Test {
protected:
    std::mt19937_64 rng{0xC0FFEEull};
    World world;
    Model model;

    size_t pick(size_t n) { return std::uniform_int_distribution<size_t>(0, n - 1)(rng); }
    int64_t value() { return std::uniform_int_distribution<int64_t>(-1000000, 1000000)(rng); }

    // Any handle ever created: live or stale (or null now and then).
    Entity anyHandle() {
        if (model.everCreated.empty() || pick(50) == 0) return kNullEntity;
        return model.everCreated[pick(model.everCreated.size())];
    }

    template <typename T>
    void checkComponent(Entity e) {
        auto it = model.live.find(e);
        const T* got = world.get<T>(e);
        if (it == model.live.end() || !field<T>(it->second)) {
            ASSERT_EQ(got, nullptr);
            ASSERT_FALSE(world.has<T>(e));
        } else {
            ASSERT_NE(got, nullptr);
            ASSERT_TRUE(world.has<T>(e));
            ASSERT_EQ(got->v, *field<T>(it->second));
        }
    }

    template <typename T>
    void doAdd(Entity e) {
        const int64_t v = value();
        T* r = world.add<T>(e, v);
        auto it = model.live.find(e);
        if (it == model.live.end()) {
            ASSERT_EQ(r, nullptr);
        } else {
            ASSERT_NE(r, nullptr);
            ASSERT_EQ(r->v, v);
            field<T>(it->second) = v;
        }
    }

    template <typename T>
    void doRemove(Entity e) {
        const bool r = world.remove<T>(e);
        auto it = model.live.find(e);
        const bool expected = it != model.live.end() && field<T>(it->second).has_value();
        ASSERT_EQ(r, expected);
        if (expected) field<T>(it->second).reset();
    }

    template <typename... Ts>
    void checkView() {
        std::set<Entity> expected;
        for (auto& [e, r] : model.live) {
            if ((field<Ts>(r).has_value() && ...)) expected.insert(e);
        }
        std::set<Entity> seen;
        for (auto&& tuple : world.view<Ts...>()) {
            const Entity e = std::get<0>(tuple);
            ASSERT_TRUE(seen.insert(e).second) << "visited twice";
            ASSERT_TRUE(model.live.count(e));
        }
        ASSERT_EQ(seen, expected);
    }

    // An iteration over A that randomly destroys, adds B and removes C for visited entities; the
    // model applies the same operations after the loop, in the same order.
    void iterateAndMutate() {
        struct Op {
            int kind;  // 0 destroy, 1 add B, 2 remove C
            Entity e;
            int64_t v;
        };
        std::vector<Op> ops;
        std::set<Entity> visited;
        for (auto [e, a] : world.view<CompA>()) {
            ASSERT_TRUE(visited.insert(e).second);
            ASSERT_EQ(a.v, *model.live.at(e).a);
            const size_t r = pick(10);
            const Entity target = pick(4) == 0 ? anyHandle() : e;
            if (r == 0) {
                const bool ok = world.destroy(target);
                const bool live = model.live.count(target) > 0;
                bool queued = false;
                for (const Op& op : ops) queued |= op.kind == 0 && op.e == target;
                ASSERT_EQ(ok, live && !queued);
                if (ok) ops.push_back({0, target, 0});
            } else if (r == 1) {
                const int64_t v = value();
                CompB* b = world.add<CompB>(target, v);
                ASSERT_EQ(b != nullptr, model.live.count(target) > 0);
                if (b) ops.push_back({1, target, v});
            } else if (r == 2) {
                const bool ok = world.remove<CompC>(target);
                auto it = model.live.find(target);
                ASSERT_EQ(ok, it != model.live.end() && it->second.c.has_value());
                if (ok) ops.push_back({2, target, 0});
            }
        }
        // Every entity that had A when the iteration began was visited exactly once.
        size_t withA = 0;
        for (auto& [e, r] : model.live) withA += r.a.has_value();
        ASSERT_EQ(visited.size(), withA);
        // Apply to the model in call order, as the world does.
        for (const Op& op : ops) {
            auto it = model.live.find(op.e);
            if (it == model.live.end()) continue;
            if (op.kind == 0) model.live.erase(it);
            if (op.kind == 1) it->second.b = op.v;
            if (op.kind == 2) it->second.c.reset();
        }
        ASSERT_EQ(world.pendingCount(), 0u);
    }

    void fullCheck() {
        ASSERT_EQ(world.aliveCount(), model.live.size());
        size_t na = 0, nb = 0, nc = 0;
        for (auto& [e, r] : model.live) {
            ASSERT_TRUE(world.alive(e));
            na += r.a.has_value();
            nb += r.b.has_value();
            nc += r.c.has_value();
        }
        ASSERT_EQ(world.count<CompA>(), na);
        ASSERT_EQ(world.count<CompB>(), nb);
        ASSERT_EQ(world.count<CompC>(), nc);
        for (Entity e : model.everCreated) {
            ASSERT_EQ(world.alive(e), model.live.count(e) > 0);
            checkComponent<CompA>(e);
            checkComponent<CompB>(e);
            checkComponent<CompC>(e);
        }
    }
};

TEST_F(EcsRandomOps, HundredThousandOperationsMatchReferenceModel) {
    const int kOps = 100000;
    for (int i = 0; i < kOps; ++i) {
        const size_t op = pick(100);
        if (op < 20) {
            Entity e = world.create();
            ASSERT_FALSE(e.isNull());
            ASSERT_FALSE(model.live.count(e)) << "handle reused while alive";
            model.live[e] = {};
            model.everCreated.push_back(e);
        } else if (op < 30) {
            Entity e = anyHandle();
            const bool expected = model.live.erase(e) > 0;
            ASSERT_EQ(world.destroy(e), expected);
        } else if (op < 45) {
            doAdd<CompA>(anyHandle());
        } else if (op < 55) {
            doAdd<CompB>(anyHandle());
        } else if (op < 62) {
            doAdd<CompC>(anyHandle());
        } else if (op < 67) {
            doRemove<CompA>(anyHandle());
        } else if (op < 72) {
            doRemove<CompB>(anyHandle());
        } else if (op < 76) {
            doRemove<CompC>(anyHandle());
        } else if (op < 95) {
            Entity e = anyHandle();
            ASSERT_EQ(world.alive(e), model.live.count(e) > 0);
            checkComponent<CompA>(e);
            checkComponent<CompB>(e);
            checkComponent<CompC>(e);
        } else if (op < 98) {
            switch (pick(4)) {
                case 0:
                    checkView<CompA>();
                    break;
                case 1:
                    checkView<CompA, CompB>();
                    break;
                case 2:
                    checkView<CompC, CompB>();
                    break;
                default:
                    checkView<CompA, CompB, CompC>();
                    break;
            }
        } else if (op < 99) {
            iterateAndMutate();
        } else if (pick(20) == 0) {
            // Rarely: everything goes.
            ASSERT_TRUE(world.clear());
            model.live.clear();
        }
        if (HasFatalFailure()) FAIL() << "at operation " << i;
        if (i % 10000 == 0) {
            fullCheck();
            if (HasFatalFailure()) FAIL() << "full check at operation " << i;
        }
    }
    fullCheck();
    EXPECT_GT(model.everCreated.size(), 10000u);
}

}  // namespace
}  // namespace penumbra::ecs
