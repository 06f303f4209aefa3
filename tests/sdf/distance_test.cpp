// Exact point-triangle distance (region tests) against independent references.
#include <gtest/gtest.h>

#include <random>

#include "engine/sdf/distance.h"
#include "sdf/bake_test_util.h"

namespace {

using namespace penumbra::sdf;
using penumbra::sdf::test::referenceTriangleDistance;

struct Tri {
    glm::dvec3 a, b, c;
};

// Random triangles of several shapes: ordinary, needles (one very short edge), slivers (one
// vertex almost on the opposite edge), tiny and huge ones.
std::vector<Tri> randomTriangles(std::mt19937& rng, int count) {
    std::uniform_real_distribution<double> u(-1, 1);
    auto rv = [&] { return glm::dvec3(u(rng), u(rng), u(rng)); };
    std::vector<Tri> out;
    for (int i = 0; i < count; ++i) {
        const glm::dvec3 a = rv(), b = rv(), c = rv();
        switch (i % 5) {
            case 0:
                out.push_back({a, b, c});
                break;
            case 1:
                out.push_back({a, a + 1e-7 * rv(), c});
                break;  // needle: |ab| ~ 1e-7
            case 2:
                out.push_back({a, b, 0.5 * (a + b) + 1e-8 * rv()});
                break;  // sliver
            case 3:
                out.push_back({a * 1e-3, b * 1e-3, c * 1e-3});
                break;  // tiny
            default:
                out.push_back({a * 1e3, b * 1e3, c * 1e3});
                break;  // huge
        }
    }
    return out;
}

// Metric: |d_regions - d_reference| <= 1e-12 * (|p| + triangle size) at 20000 random points
// around 400 triangles of five shapes; the returned point lies on the triangle (its distance to
// the triangle is ~0) and |p - point|^2 equals the returned squared distance.
TEST(PointTriangleDistance, MatchesIndependentReferenceOnRandomTriangles) {
    std::mt19937 rng(1234);
    const auto tris = randomTriangles(rng, 400);
    std::uniform_real_distribution<double> u(-2, 2);
    for (const Tri& t : tris) {
        const double size =
            std::max({glm::length(t.b - t.a), glm::length(t.c - t.a), glm::length(t.c - t.b)});
        const glm::dvec3 centre = (t.a + t.b + t.c) / 3.0;
        for (int s = 0; s < 50; ++s) {
            const glm::dvec3 p = centre + glm::dvec3(u(rng), u(rng), u(rng)) * size;
            const TriangleClosest c = closestPointOnTriangle(p, t.a, t.b, t.c);
            const double ref = referenceTriangleDistance(p, t.a, t.b, t.c);
            const double tol = 1e-12 * (glm::length(p) + size);
            ASSERT_NEAR(std::sqrt(c.distanceSquared), ref, tol) << "shape " << (&t - tris.data()) % 5;
            ASSERT_NEAR(glm::length(p - c.point), std::sqrt(c.distanceSquared), tol);
            ASSERT_LE(referenceTriangleDistance(c.point, t.a, t.b, t.c), tol);
            ASSERT_EQ(pointTriangleDistanceSquared(p, t.a, t.b, t.c), c.distanceSquared);
        }
    }
}

// Metric: dense sampled minimisation (barycentric lattice of 400 x 400 points) is never below the
// exact distance (by more than 1e-12) and above it by at most the lattice spacing.
TEST(PointTriangleDistance, AgreesWithSampledMinimisation) {
    std::mt19937 rng(99);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    const Tri t{{0, 0, 0}, {1, 0.2, 0}, {0.3, 0.9, 0.4}};
    const int n = 400;
    const double spacing = 1.0 / n * 1.1;  // longest edge ~1.1
    for (int s = 0; s < 20; ++s) {
        const glm::dvec3 p(u(rng), u(rng), u(rng));
        const double exact = std::sqrt(pointTriangleDistanceSquared(p, t.a, t.b, t.c));
        double sampled = INFINITY;
        for (int i = 0; i <= n; ++i) {
            for (int j = 0; i + j <= n; ++j) {
                const double bu = double(i) / n, bv = double(j) / n;
                const glm::dvec3 q = t.a + bu * (t.b - t.a) + bv * (t.c - t.a);
                sampled = std::min(sampled, glm::length(p - q));
            }
        }
        EXPECT_GE(sampled, exact - 1e-12);
        EXPECT_LE(sampled - exact, spacing);
    }
}

// Metric: the reported feature is the Voronoi region the point was placed in.
TEST(PointTriangleDistance, ReportsTheClosestFeature) {
    const glm::dvec3 a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
    struct Case {
        glm::dvec3 p;
        TriangleFeature feature;
        glm::dvec3 point;
    };
    const Case cases[] = {
        {{0.5, 0.5, 1}, TriangleFeature::Face, {0.5, 0.5, 0}},
        {{0.5, 0.5, -3}, TriangleFeature::Face, {0.5, 0.5, 0}},
        {{1, -1, 0.5}, TriangleFeature::Edge01, {1, 0, 0}},
        {{2, 2, 0}, TriangleFeature::Edge12, {1, 1, 0}},
        {{-1, 1, 0.2}, TriangleFeature::Edge20, {0, 1, 0}},
        {{-1, -1, 1}, TriangleFeature::Vertex0, a},
        {{3, -0.5, 0}, TriangleFeature::Vertex1, b},
        {{-0.5, 3, 0}, TriangleFeature::Vertex2, c},
    };
    for (const Case& cs : cases) {
        const TriangleClosest r = closestPointOnTriangle(cs.p, a, b, c);
        EXPECT_EQ(int(r.feature), int(cs.feature)) << cs.p.x << " " << cs.p.y << " " << cs.p.z;
        EXPECT_NEAR(glm::length(r.point - cs.point), 0.0, 1e-15);
    }
    EXPECT_EQ(featureIndex(TriangleFeature::Edge20), 2u);
    EXPECT_EQ(featureIndex(TriangleFeature::Vertex1), 1u);
    EXPECT_TRUE(isEdge(TriangleFeature::Edge12));
    EXPECT_TRUE(isVertex(TriangleFeature::Vertex0));
    EXPECT_FALSE(isEdge(TriangleFeature::Face));
}

// Metric: zero-area triangles (collinear corners, two or three equal corners) give the distance to
// their edges, within 1e-14.
TEST(PointTriangleDistance, DegenerateTrianglesActAsSegments) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-2, 2);
    const Tri degenerate[] = {
        {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}},                    // collinear
        {{0, 0, 0}, {2, 2, 2}, {1, 1, 1}},                    // collinear, middle last
        {{1, 0, 0}, {1, 0, 0}, {0, 1, 0}},                    // two equal corners
        {{0.5, 0.5, 0.5}, {0.5, 0.5, 0.5}, {0.5, 0.5, 0.5}},  // a point
    };
    for (const Tri& t : degenerate) {
        for (int s = 0; s < 200; ++s) {
            const glm::dvec3 p(u(rng), u(rng), u(rng));
            const double expected = std::min({penumbra::sdf::test::segmentDistance(p, t.a, t.b),
                                              penumbra::sdf::test::segmentDistance(p, t.b, t.c),
                                              penumbra::sdf::test::segmentDistance(p, t.c, t.a)});
            const TriangleClosest r = closestPointOnTriangle(p, t.a, t.b, t.c);
            ASSERT_NEAR(std::sqrt(r.distanceSquared), expected, 1e-14 * 4);
            ASSERT_NEAR(glm::length(p - r.point), expected, 1e-14 * 4);
        }
    }
}

// Metric: segment parameter t in [0,1] and the closest point is a + t (b - a).
TEST(PointTriangleDistance, ClosestPointOnSegment) {
    double t = -1;
    glm::dvec3 q = closestPointOnSegment({0.5, 3, 0}, {0, 0, 0}, {1, 0, 0}, t);
    EXPECT_DOUBLE_EQ(t, 0.5);
    EXPECT_DOUBLE_EQ(q.x, 0.5);
    q = closestPointOnSegment({-4, 3, 0}, {0, 0, 0}, {1, 0, 0}, t);
    EXPECT_DOUBLE_EQ(t, 0.0);
    q = closestPointOnSegment({7, 3, 0}, {0, 0, 0}, {1, 0, 0}, t);
    EXPECT_DOUBLE_EQ(t, 1.0);
    EXPECT_DOUBLE_EQ(q.x, 1.0);
    q = closestPointOnSegment({7, 3, 0}, {1, 1, 1}, {1, 1, 1}, t);  // zero length
    EXPECT_DOUBLE_EQ(t, 0.0);
    EXPECT_DOUBLE_EQ(q.y, 1.0);
}

}  // namespace
