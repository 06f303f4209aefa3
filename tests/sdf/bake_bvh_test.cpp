// BVH closest-point queries against brute force.
#include <gtest/gtest.h>

#include <random>

#include "engine/sdf/bvh.h"
#include "engine/sdf/mesh_topology.h"
#include "sdf/bake_test_util.h"

namespace {

using namespace penumbra;
using namespace penumbra::sdf;

struct Soup {
    std::vector<glm::dvec3> positions;
    std::vector<glm::uvec3> triangles;
};

// The BVH stores float coordinates: test soups use float-representable values so its distances
// are compared with brute force on identical geometry.
glm::dvec3 f(const glm::dvec3& p) { return glm::dvec3(glm::vec3(p)); }

Soup fromMesh(const assets::MeshData& m) {
    Soup s;
    for (const auto& p : m.positions) s.positions.push_back(glm::dvec3(p));
    for (size_t t = 0; t < m.indices.size() / 3; ++t) {
        s.triangles.push_back({m.indices[3 * t], m.indices[3 * t + 1], m.indices[3 * t + 2]});
    }
    return s;
}

// A sphere plus a cloud of random small triangles (clustered and spread).
Soup testSoup(std::mt19937& rng) {
    Soup s = fromMesh(test::icosphere(3, 1.0f));
    std::uniform_real_distribution<double> u(-1.5, 1.5), small(-0.05, 0.05);
    for (int t = 0; t < 3000; ++t) {
        const glm::dvec3 c = t % 3 == 0
                                 ? glm::dvec3(0.3, 0.3, 0.3) + glm::dvec3(small(rng), small(rng), small(rng))
                                 : glm::dvec3(u(rng), u(rng), u(rng));
        const uint32_t base = static_cast<uint32_t>(s.positions.size());
        for (int k = 0; k < 3; ++k)
            s.positions.push_back(f(c + glm::dvec3(small(rng), small(rng), small(rng))));
        s.triangles.push_back({base, base + 1, base + 2});
    }
    return s;
}

double bruteForce(const Soup& s, const glm::dvec3& p, uint32_t& bestTriangle) {
    double best = INFINITY;
    for (size_t t = 0; t < s.triangles.size(); ++t) {
        const auto& tri = s.triangles[t];
        const double d =
            test::referenceTriangleDistance(p, s.positions[tri.x], s.positions[tri.y], s.positions[tri.z]);
        if (d < best) {
            best = d;
            bestTriangle = static_cast<uint32_t>(t);
        }
    }
    return best;
}

// Metric: at 2000 random points (inside, near and far from the soup) the BVH distance equals the
// brute-force minimum within 1e-12 (absolute, coordinates ~1), the returned triangle is at that
// distance and the returned point is at that distance from p; for 1, 2 and 3 build threads.
TEST(TriangleBvh, ClosestPointMatchesBruteForce) {
    std::mt19937 rng(42);
    const Soup s = testSoup(rng);
    std::uniform_real_distribution<double> u(-3, 3);
    std::vector<glm::dvec3> points(2000);
    for (auto& p : points) p = glm::dvec3(u(rng), u(rng), u(rng));
    for (uint32_t threads : {1u, 2u, 3u}) {
        TriangleBvh bvh;
        bvh.build(s.positions, s.triangles, threads);
        ASSERT_EQ(bvh.triangleCount(), s.triangles.size());
        ASSERT_LT(bvh.depth(), 96u);
        for (const glm::dvec3& p : points) {
            uint32_t bfTriangle = 0;
            const double expected = bruteForce(s, p, bfTriangle);
            ClosestHit hit;
            ASSERT_TRUE(bvh.closest(p, INFINITY, hit));
            ASSERT_NEAR(hit.distance, expected, 1e-12);
            ASSERT_NEAR(glm::length(p - hit.point), expected, 1e-12);
            const auto& tri = s.triangles[hit.triangle];
            ASSERT_NEAR(test::referenceTriangleDistance(p, s.positions[tri.x], s.positions[tri.y],
                                                        s.positions[tri.z]),
                        expected, 1e-12);
        }
    }
}

// Metric: seeded queries give the brute-force distance whatever the seed (random, far away,
// out of range), and a bound below the true distance finds nothing.
TEST(TriangleBvh, SeededAndBoundedQueries) {
    std::mt19937 rng(5);
    const Soup s = testSoup(rng);
    TriangleBvh bvh;
    bvh.build(s.positions, s.triangles, 2);
    std::uniform_real_distribution<double> u(-3, 3);
    std::uniform_int_distribution<uint32_t> anyTriangle(0, static_cast<uint32_t>(s.triangles.size() - 1));
    BvhQueryStats stats;
    for (int i = 0; i < 500; ++i) {
        const glm::dvec3 p(u(rng), u(rng), u(rng));
        uint32_t bfTriangle = 0;
        const double expected = bruteForce(s, p, bfTriangle);
        for (uint32_t seed : {anyTriangle(rng), bfTriangle, UINT32_MAX}) {
            const ClosestHit hit = bvh.closestSeeded(p, seed, &stats);
            ASSERT_NEAR(hit.distance, expected, 1e-12);
        }
        ClosestHit hit;
        EXPECT_FALSE(bvh.closest(p, expected * 0.999, hit));
        EXPECT_TRUE(bvh.closest(p, expected * 1.001 + 1e-12, hit));
        EXPECT_NEAR(hit.distance, expected, 1e-12);
    }
    EXPECT_GT(stats.nodesVisited, 0u);
    EXPECT_GT(stats.trianglesTested, 0u);
}

// Metric: a seeded query on a fine sphere visits far fewer triangles than there are (pruning works).
TEST(TriangleBvh, PrunesWork) {
    const Soup s = fromMesh(test::icosphere(5, 1.0f));  // 20480 triangles
    TriangleBvh bvh;
    bvh.build(s.positions, s.triangles, 1);
    BvhQueryStats stats;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-2, 2);
    const int queries = 200;
    for (int i = 0; i < queries; ++i)
        bvh.closestSeeded(glm::dvec3(u(rng), u(rng), u(rng)), UINT32_MAX, &stats);
    const double testedPerQuery = double(stats.trianglesTested) / queries;
    EXPECT_LT(testedPerQuery, 0.02 * double(s.triangles.size())) << testedPerQuery;
}

// Metric: an empty BVH answers nothing; a single triangle works; duplicates (same centroid) build.
TEST(TriangleBvh, EdgeCases) {
    TriangleBvh bvh;
    bvh.build({}, {}, 1);
    ClosestHit hit;
    EXPECT_TRUE(bvh.empty());
    EXPECT_FALSE(bvh.closest({0, 0, 0}, INFINITY, hit));
    EXPECT_EQ(bvh.closestSeeded({0, 0, 0}, 0).triangle, UINT32_MAX);

    bvh.build({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}, 1);
    ASSERT_TRUE(bvh.closest({0.25, 0.25, 2}, INFINITY, hit));
    EXPECT_DOUBLE_EQ(hit.distance, 2.0);
    EXPECT_EQ(hit.feature, TriangleFeature::Face);
    EXPECT_EQ(hit.triangle, 0u);

    // 10000 copies of one triangle: all centroids equal, halving splits keep the depth bounded.
    std::vector<glm::dvec3> pos = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 5, 5}, {6, 5, 5}, {5, 6, 5}};
    std::vector<glm::uvec3> tris(10000, glm::uvec3(0, 1, 2));
    tris.push_back({3, 4, 5});
    bvh.build(pos, tris, 2);
    EXPECT_LT(bvh.depth(), 96u);
    ASSERT_TRUE(bvh.closest({5.2, 5.2, 6}, INFINITY, hit));
    EXPECT_EQ(hit.triangle, 10000u);
    EXPECT_DOUBLE_EQ(hit.distance, 1.0);
}

// Metric: signed ray crossings equal the winding number of closed meshes: 1 inside a sphere, 0
// outside, 2 inside two nested spheres, -1 inside an inverted sphere; at 300 random points and
// three ray directions each (the rays are not axis-aligned).
TEST(TriangleBvh, SignedCrossingsAreTheWindingNumberOfClosedMeshes) {
    Soup outer = fromMesh(test::icosphere(3, 1.0f));
    Soup both = outer;
    const Soup inner = fromMesh(test::icosphere(2, 0.5f));
    const uint32_t base = static_cast<uint32_t>(both.positions.size());
    both.positions.insert(both.positions.end(), inner.positions.begin(), inner.positions.end());
    for (const glm::uvec3& t : inner.triangles) both.triangles.push_back(t + base);
    Soup inverted = outer;
    for (glm::uvec3& t : inverted.triangles) std::swap(t.y, t.z);
    TriangleBvh a, b, c;
    a.build(outer.positions, outer.triangles, 1);
    b.build(both.positions, both.triangles, 2);
    c.build(inverted.positions, inverted.triangles, 1);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    const glm::dvec3 dirs[3] = {{0.75, 0.57, 0.32}, {-0.43, 0.78, 0.45}, {0.28, -0.38, 0.88}};
    int checked = 0;
    for (int i = 0; i < 300; ++i) {
        const glm::dvec3 p(u(rng), u(rng), u(rng));
        const double r = glm::length(p);
        if (std::abs(r - 1.0) < 0.05 || std::abs(r - 0.5) < 0.05) continue;  // polygon vs sphere
        ++checked;
        for (const glm::dvec3& d : dirs) {
            EXPECT_EQ(a.signedCrossings(p, d), r < 1 ? 1 : 0);
            EXPECT_EQ(b.signedCrossings(p, d), (r < 1 ? 1 : 0) + (r < 0.5 ? 1 : 0));
            EXPECT_EQ(c.signedCrossings(p, d), r < 1 ? -1 : 0);
        }
    }
    EXPECT_GT(checked, 200);
}

}  // namespace
