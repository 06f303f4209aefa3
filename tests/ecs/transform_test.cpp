// Hierarchy transforms: chains, reparenting, stale parents, cycles; compared with matrices built by
// hand with glm's own translate/rotate/scale.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/core/log.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"

namespace penumbra::ecs {
namespace {

glm::mat4 handLocal(glm::vec3 t, float angle, glm::vec3 axis, glm::vec3 s) {
    glm::mat4 m = glm::translate(glm::mat4(1.0f), t);
    m = glm::rotate(m, angle, axis);
    return glm::scale(m, s);
}

Transform makeTransform(glm::vec3 t, float angle, glm::vec3 axis, glm::vec3 s, Entity parent = kNullEntity) {
    Transform tr;
    tr.position = t;
    tr.rotation = glm::angleAxis(angle, glm::normalize(axis));
    tr.scale = s;
    tr.parent = parent;
    return tr;
}

void expectNear(const glm::mat4& a, const glm::mat4& b, float tol = 1e-5f) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) EXPECT_NEAR(a[c][r], b[c][r], tol) << "column " << c << " row " << r;
}

// Captures warnings and errors while alive.
struct LogCapture {
    std::vector<std::string> messages;
    log::Sink old;
    LogCapture() {
        old = log::setSink([this](log::Severity s, std::string_view m) {
            if (s >= log::Severity::Warning) messages.emplace_back(m);
        });
    }
    ~LogCapture() { log::setSink(std::move(old)); }
};

TEST(EcsTransform, LocalMatrixMatchesGlm) {
    const Transform t = makeTransform({1, 2, 3}, 0.7f, {0.3f, 1.0f, -0.2f}, {2.0f, 0.5f, 1.5f});
    expectNear(t.localMatrix(),
               handLocal({1, 2, 3}, 0.7f, glm::normalize(glm::vec3(0.3f, 1.0f, -0.2f)), {2.0f, 0.5f, 1.5f}));
}

TEST(EcsTransform, ThreeLevelChain) {
    World world;
    Entity root = world.create();
    Entity mid = world.create();
    Entity leaf = world.create();
    // Add the leaf first so that dense order is child before parent: the update must still work.
    world.add<Transform>(leaf, makeTransform({0, 0, 2}, 0.3f, {1, 0, 0}, {1, 1, 1}, mid));
    world.add<Transform>(mid, makeTransform({0, 1, 0}, 1.1f, {0, 0, 1}, {0.5f, 0.5f, 0.5f}, root));
    world.add<Transform>(root, makeTransform({5, 0, 0}, 0.5f, {0, 1, 0}, {2, 2, 2}));

    const TransformUpdateStats stats = updateTransforms(world);
    EXPECT_EQ(stats.updated, 3u);
    EXPECT_EQ(stats.cyclesBroken, 0u);

    const glm::mat4 r = handLocal({5, 0, 0}, 0.5f, {0, 1, 0}, {2, 2, 2});
    const glm::mat4 m = r * handLocal({0, 1, 0}, 1.1f, {0, 0, 1}, {0.5f, 0.5f, 0.5f});
    const glm::mat4 l = m * handLocal({0, 0, 2}, 0.3f, {1, 0, 0}, {1, 1, 1});
    expectNear(world.get<Transform>(root)->worldMatrix, r);
    expectNear(world.get<Transform>(mid)->worldMatrix, m);
    expectNear(world.get<Transform>(leaf)->worldMatrix, l);

    // A point at the leaf's origin, by hand: root scale 2 and yaw 0.5 of mid's offset, etc.
    const glm::vec3 p = world.get<Transform>(leaf)->worldPosition();
    const glm::vec3 byHand = glm::vec3(l * glm::vec4(0, 0, 0, 1));
    EXPECT_NEAR(glm::length(p - byHand), 0.0f, 1e-5f);
}

TEST(EcsTransform, PureTranslationsAddUp) {
    World world;
    Entity a = world.create();
    Entity b = world.create();
    Entity c = world.create();
    world.add<Transform>(a)->position = {1, 0, 0};
    Transform* tb = world.add<Transform>(b);
    tb->position = {0, 2, 0};
    tb->parent = a;
    Transform* tc = world.add<Transform>(c);
    tc->position = {0, 0, 3};
    tc->parent = b;
    updateTransforms(world);
    const glm::vec3 p = world.get<Transform>(c)->worldPosition();
    EXPECT_NEAR(p.x, 1.0f, 1e-6f);
    EXPECT_NEAR(p.y, 2.0f, 1e-6f);
    EXPECT_NEAR(p.z, 3.0f, 1e-6f);
    // Forward of an unrotated transform is -Z.
    EXPECT_NEAR(world.get<Transform>(c)->worldForward().z, -1.0f, 1e-6f);
}

TEST(EcsTransform, Reparenting) {
    World world;
    Entity p1 = world.create();
    Entity p2 = world.create();
    Entity child = world.create();
    world.add<Transform>(p1, makeTransform({10, 0, 0}, 0.0f, {0, 1, 0}, {1, 1, 1}));
    world.add<Transform>(p2, makeTransform({0, -4, 0}, 1.5707964f, {0, 1, 0}, {3, 3, 3}));
    world.add<Transform>(child, makeTransform({1, 0, 0}, 0.0f, {0, 1, 0}, {1, 1, 1}));

    ASSERT_TRUE(setParent(world, child, p1));
    updateTransforms(world);
    expectNear(world.get<Transform>(child)->worldMatrix, handLocal({10, 0, 0}, 0, {0, 1, 0}, {1, 1, 1}) *
                                                             handLocal({1, 0, 0}, 0, {0, 1, 0}, {1, 1, 1}));

    ASSERT_TRUE(setParent(world, child, p2));
    updateTransforms(world);
    const glm::mat4 expected = handLocal({0, -4, 0}, 1.5707964f, {0, 1, 0}, {3, 3, 3}) *
                               handLocal({1, 0, 0}, 0, {0, 1, 0}, {1, 1, 1});
    expectNear(world.get<Transform>(child)->worldMatrix, expected);
    // Rotating +X by 90 degrees about Y gives -Z, scaled by 3: (0, -4, -3).
    const glm::vec3 p = world.get<Transform>(child)->worldPosition();
    EXPECT_NEAR(p.x, 0.0f, 1e-5f);
    EXPECT_NEAR(p.y, -4.0f, 1e-5f);
    EXPECT_NEAR(p.z, -3.0f, 1e-5f);

    ASSERT_TRUE(setParent(world, child, kNullEntity));
    updateTransforms(world);
    expectNear(world.get<Transform>(child)->worldMatrix, handLocal({1, 0, 0}, 0, {0, 1, 0}, {1, 1, 1}));
}

TEST(EcsTransform, DestroyedParentMakesChildARoot) {
    World world;
    Entity parent = world.create();
    Entity child = world.create();
    world.add<Transform>(parent)->position = {5, 5, 5};
    world.add<Transform>(child, makeTransform({1, 0, 0}, 0, {0, 1, 0}, {1, 1, 1}, parent));
    world.destroy(parent);
    Entity reused = world.create();  // takes the parent's index with a new generation
    ASSERT_EQ(reused.index, parent.index);
    world.add<Transform>(reused)->position = {100, 0, 0};
    updateTransforms(world);
    EXPECT_NEAR(world.get<Transform>(child)->worldPosition().x, 1.0f, 1e-6f) << "stale parent is ignored";
}

TEST(EcsTransform, DeepChainNoRecursion) {
    World world;
    const int depth = 100000;
    std::vector<Entity> chain;
    for (int i = 0; i < depth; ++i) chain.push_back(world.create());
    // Deepest first in dense order: the first entity visited walks up the whole chain.
    for (int i = depth - 1; i >= 0; --i) {
        Transform* t = world.add<Transform>(chain[size_t(i)]);
        t->position = {1.0f, 0, 0};  // integer sums stay exact in float
        t->parent = i > 0 ? chain[size_t(i - 1)] : kNullEntity;
    }
    const TransformUpdateStats stats = updateTransforms(world);
    EXPECT_EQ(stats.updated, size_t(depth));
    EXPECT_EQ(world.get<Transform>(chain.back())->worldPosition().x, float(depth));
}

TEST(EcsTransform, CycleIsReportedAndBroken) {
    World world;
    Entity a = world.create();
    Entity b = world.create();
    Entity c = world.create();
    Entity d = world.create();
    world.add<Transform>(a)->position = {1, 0, 0};
    world.add<Transform>(b)->position = {0, 1, 0};
    world.add<Transform>(c)->position = {0, 0, 1};
    world.add<Transform>(d)->position = {2, 0, 0};
    // a -> b -> c -> a, and d hangs off c.
    world.get<Transform>(a)->parent = b;
    world.get<Transform>(b)->parent = c;
    world.get<Transform>(c)->parent = a;
    world.get<Transform>(d)->parent = c;

    LogCapture capture;
    TransformUpdateStats stats = updateTransforms(world);
    EXPECT_EQ(stats.cyclesBroken, 1u);
    EXPECT_EQ(stats.updated, 4u);
    ASSERT_EQ(capture.messages.size(), 1u);
    EXPECT_NE(capture.messages[0].find("cycle"), std::string::npos) << capture.messages[0];

    // Exactly one link was cut; the rest is a consistent chain.
    int roots = 0;
    for (Entity e : {a, b, c}) roots += world.get<Transform>(e)->parent.isNull();
    EXPECT_EQ(roots, 1);
    for (Entity e : {a, b, c, d}) {
        const Transform* t = world.get<Transform>(e);
        const glm::mat4 expected = t->parent.isNull()
                                       ? t->localMatrix()
                                       : world.get<Transform>(t->parent)->worldMatrix * t->localMatrix();
        expectNear(t->worldMatrix, expected);
    }
    // Broken for good: the next update reports nothing.
    capture.messages.clear();
    stats = updateTransforms(world);
    EXPECT_EQ(stats.cyclesBroken, 0u);
    EXPECT_TRUE(capture.messages.empty());
}

TEST(EcsTransform, SelfParentIsACycle) {
    World world;
    Entity a = world.create();
    world.add<Transform>(a)->parent = a;
    LogCapture capture;
    EXPECT_EQ(updateTransforms(world).cyclesBroken, 1u);
    EXPECT_TRUE(world.get<Transform>(a)->parent.isNull());
}

TEST(EcsTransform, SetParentRefusesCyclesAndBadEntities) {
    World world;
    Entity a = world.create();
    Entity b = world.create();
    Entity c = world.create();
    Entity noTransform = world.create();
    world.add<Transform>(a);
    world.add<Transform>(b);
    world.add<Transform>(c);
    ASSERT_TRUE(setParent(world, b, a));
    ASSERT_TRUE(setParent(world, c, b));

    LogCapture capture;
    EXPECT_FALSE(setParent(world, a, c)) << "a -> c -> b -> a";
    EXPECT_FALSE(setParent(world, a, a));
    EXPECT_FALSE(setParent(world, a, noTransform));
    EXPECT_FALSE(setParent(world, noTransform, a));
    Entity dead = world.create();
    world.destroy(dead);
    EXPECT_FALSE(setParent(world, a, dead));
    EXPECT_EQ(capture.messages.size(), 5u);
    EXPECT_TRUE(world.get<Transform>(a)->parent.isNull()) << "unchanged";
    EXPECT_EQ(updateTransforms(world).cyclesBroken, 0u);
}

TEST(EcsTransform, ManyRandomHierarchiesMatchRecursiveReference) {
    World world;
    std::vector<Entity> es;
    uint32_t seed = 12345;
    auto rnd = [&]() {
        seed = seed * 1664525u + 1013904223u;
        return seed >> 8;
    };
    for (int i = 0; i < 2000; ++i) {
        Entity e = world.create();
        es.push_back(e);
        Transform t = makeTransform({float(rnd() % 7) - 3.f, float(rnd() % 5) - 2.f, float(rnd() % 3)},
                                    float(rnd() % 628) / 100.f, {1.f, float(rnd() % 3), 0.5f},
                                    {1.f + float(rnd() % 3) * 0.1f, 1.f, 1.f});
        // Parents always earlier in creation order: a forest without cycles.
        if (i > 0 && rnd() % 4 != 0) t.parent = es[rnd() % size_t(i)];
        world.add<Transform>(e, t);
    }
    // Shuffle dense order by removing and re-adding some transforms.
    for (int i = 0; i < 500; ++i) {
        Entity e = es[rnd() % es.size()];
        Transform t = *world.get<Transform>(e);
        world.remove<Transform>(e);
        world.add<Transform>(e, t);
    }
    updateTransforms(world);
    // Reference: walk up, multiplying locals.
    for (Entity e : es) {
        glm::dmat4 m(1.0);
        for (Entity cur = e; !cur.isNull();) {
            const Transform* t = world.get<Transform>(cur);
            m = glm::dmat4(t->localMatrix()) * m;
            cur = t->parent;
        }
        const glm::mat4& got = world.get<Transform>(e)->worldMatrix;
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) ASSERT_NEAR(got[c][r], m[c][r], 1e-3 * (1.0 + std::abs(m[c][r])));
    }
}

}  // namespace
}  // namespace penumbra::ecs
