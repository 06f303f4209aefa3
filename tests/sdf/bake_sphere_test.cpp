// bake() of a closed sphere mesh: exact distances, analytic comparison, all sign methods.
#include <gtest/gtest.h>

#include "engine/sdf/bake.h"
#include "engine/sdf/winding.h"
#include "sdf/bake_test_util.h"

namespace {

using namespace penumbra;
using namespace penumbra::sdf;

BakeResult bakeOrFail(const assets::MeshData& m, BakeSettings s) {
    BakeResult r = bake(m, s);
    EXPECT_TRUE(r.ok) << r.error;
    return r;
}

// Metric: every stored |d| equals the brute-force mesh distance within 1e-4 voxel; the signed value
// is within the mesh's deviation from the sphere (max sagitta) of the analytic |p| - 1; auto picks
// pseudonormal and finds nothing to repair.
TEST(BakeSphere, DistancesExactAndCloseToAnalytic) {
    const assets::MeshData sphere = test::icosphere(2, 1.0f);
    BakeSettings s;
    s.resolution = 24;
    s.threads = 2;
    const BakeResult r = bakeOrFail(sphere, s);
    ASSERT_TRUE(r.ok);
    EXPECT_EQ(r.signUsed, SignMethod::Pseudonormal);
    EXPECT_NE(r.signReason.find("pseudonormal"), std::string::npos) << r.signReason;
    EXPECT_EQ(r.windingEvaluations, 0u) << r.signReason;  // no inconsistent neighbours on a clean sphere
    const SdfGrid& g = r.grid;
    EXPECT_EQ(std::max({g.dims.x, g.dims.y, g.dims.z}), 24u);
    EXPECT_LE(test::maxDistanceErrorVoxels(sphere, g), 1e-4);

    // Largest distance of the sphere from the mesh: 1 - min over faces of the plane's distance.
    double sagitta = 0;
    for (size_t t = 0; t < sphere.indices.size() / 3; ++t) {
        const glm::dvec3 a(sphere.positions[sphere.indices[3 * t]]),
            b(sphere.positions[sphere.indices[3 * t + 1]]), c(sphere.positions[sphere.indices[3 * t + 2]]);
        sagitta = std::max(sagitta, 1.0 - std::abs(glm::dot(a, glm::normalize(glm::cross(b - a, c - a)))));
    }
    double worst = 0;
    for (uint32_t k = 0; k < g.dims.z; ++k)
        for (uint32_t j = 0; j < g.dims.y; ++j)
            for (uint32_t i = 0; i < g.dims.x; ++i) {
                const double analytic = glm::length(g.voxelCenter(i, j, k)) - 1.0;
                worst = std::max(worst, std::abs(double(g.distances[g.index(i, j, k)]) - analytic));
            }
    EXPECT_LE(worst, sagitta + 1e-6) << "sagitta " << sagitta;
    EXPECT_LT(r.minDistance, -0.85f);  // voxels near the centre are inside, ~0.9 from the surface
    EXPECT_GT(r.maxDistance, 0.0f);
}

// Metric: on a closed mesh all four sign methods give the same sign at every voxel farther than
// 1e-6 from the surface, and that sign is negative exactly inside the sphere (|p| < 1 - sagitta).
TEST(BakeSphere, AllSignMethodsAgreeOnAClosedMesh) {
    const assets::MeshData sphere = test::icosphere(2, 1.0f, glm::vec3(0.1f, -0.2f, 0.3f));
    std::vector<BakeResult> results;
    for (SignMethod m :
         {SignMethod::Auto, SignMethod::Pseudonormal, SignMethod::Winding, SignMethod::Parity}) {
        BakeSettings s;
        s.resolution = 20;
        s.padding = 3;
        s.sign = m;
        s.threads = 2;
        results.push_back(bakeOrFail(sphere, s));
        ASSERT_TRUE(results.back().ok);
        if (m != SignMethod::Auto) {
            EXPECT_EQ(results.back().signUsed, m);
        }
    }
    const SdfGrid& g = results[0].grid;
    for (size_t v = 0; v < g.distances.size(); ++v) {
        if (std::abs(g.distances[v]) < 1e-6f) continue;
        for (size_t r = 1; r < results.size(); ++r) {
            ASSERT_EQ(g.distances[v] < 0, results[r].grid.distances[v] < 0)
                << "method " << r << " voxel " << v;
            ASSERT_EQ(std::abs(g.distances[v]), std::abs(results[r].grid.distances[v]));
        }
    }
    for (uint32_t k = 0; k < g.dims.z; ++k)
        for (uint32_t j = 0; j < g.dims.y; ++j)
            for (uint32_t i = 0; i < g.dims.x; ++i) {
                const double radius = glm::length(g.voxelCenter(i, j, k) - glm::dvec3(0.1f, -0.2f, 0.3f));
                if (radius < 0.9) {
                    EXPECT_LT(g.distances[g.index(i, j, k)], 0.0f);
                }
                if (radius > 1.0) {
                    EXPECT_GT(g.distances[g.index(i, j, k)], 0.0f);
                }
            }
}

// Metric: winding sign on the closed sphere evaluates the winding number at fewer than half of the
// voxels (the surface-free cell rule; at this low resolution the band around the surface is a
// large part of the grid), and still matches exact() at every voxel with |w - 0.5| > 0.2.
TEST(BakeSphere, WindingSignUsesFewEvaluations) {
    const assets::MeshData sphere = test::icosphere(2, 1.0f);
    BakeSettings s;
    s.resolution = 40;
    s.sign = SignMethod::Winding;
    s.threads = 2;
    const BakeResult r = bakeOrFail(sphere, s);
    ASSERT_TRUE(r.ok);
    const SdfGrid& g = r.grid;
    EXPECT_LT(r.windingEvaluations, g.distances.size() / 2)
        << r.windingEvaluations << " of " << g.distances.size();
    std::vector<glm::dvec3> pos;
    for (const auto& p : sphere.positions) pos.push_back(glm::dvec3(p));
    std::vector<glm::uvec3> tris;
    for (size_t t = 0; t < sphere.indices.size() / 3; ++t)
        tris.push_back({sphere.indices[3 * t], sphere.indices[3 * t + 1], sphere.indices[3 * t + 2]});
    const WindingNumber wn(pos, tris);
    for (uint32_t k = 0; k < g.dims.z; ++k)
        for (uint32_t j = 0; j < g.dims.y; ++j)
            for (uint32_t i = 0; i < g.dims.x; ++i) {
                const double w = wn.exact(g.voxelCenter(i, j, k));
                if (std::abs(w - 0.5) > 0.2) {
                    ASSERT_EQ(w > 0.5, g.distances[g.index(i, j, k)] < 0);
                }
            }
}

}  // namespace
