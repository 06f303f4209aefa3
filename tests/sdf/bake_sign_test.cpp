// Sign on open and non-manifold meshes against brute-force winding numbers; grid placement,
// threads, progress.
#include <gtest/gtest.h>

#include <cstdio>

#include "engine/sdf/bake.h"
#include "engine/sdf/winding.h"
#include "sdf/bake_test_util.h"

namespace {

using namespace penumbra;
using namespace penumbra::sdf;

WindingNumber windingOf(const assets::MeshData& m, std::vector<glm::dvec3>& pos,
                        std::vector<glm::uvec3>& tris) {
    for (const auto& p : m.positions) pos.push_back(glm::dvec3(p));
    for (size_t t = 0; t < m.indices.size() / 3; ++t)
        tris.push_back({m.indices[3 * t], m.indices[3 * t + 1], m.indices[3 * t + 2]});
    return WindingNumber(pos, tris);
}

struct Agreement {
    size_t counted = 0, agree = 0;
    double fraction() const { return counted ? double(agree) / double(counted) : 1.0; }
};

// Voxels with |w - 0.5| > 0.2 (w = exact winding number): how many have sign(d) == (w > 0.5).
Agreement agreement(const SdfGrid& g, const WindingNumber& wn) {
    Agreement a;
    for (uint32_t k = 0; k < g.dims.z; ++k)
        for (uint32_t j = 0; j < g.dims.y; ++j)
            for (uint32_t i = 0; i < g.dims.x; ++i) {
                const double w = wn.exact(g.voxelCenter(i, j, k));
                if (std::abs(w - 0.5) <= 0.2) continue;
                ++a.counted;
                a.agree += (w > 0.5) == (g.distances[g.index(i, j, k)] < 0);
            }
    return a;
}

struct OpenCase {
    const char* name;
    assets::MeshData mesh;
};

std::vector<OpenCase> openMeshes() {
    std::vector<OpenCase> cases;
    // A bowl: sphere with its top cap removed (large hole, w varies smoothly across it).
    cases.push_back({"bowl", test::cutAbove(test::icosphere(3, 1.0f), 0.5f)});
    // A nearly closed sphere (one triangle missing).
    assets::MeshData holed = test::icosphere(3, 1.0f, glm::vec3(0.05f, 0.0f, -0.1f));
    holed.indices.erase(holed.indices.begin() + 30, holed.indices.begin() + 33);
    cases.push_back({"holed sphere", holed});
    // Non-manifold: a closed box with a fin (an extra quad sharing one of its edges).
    assets::MeshData fin = test::box({0, 0, 0}, {1, 1, 1});
    fin.positions.push_back({1.6f, 0.0f, 1.4f});
    fin.positions.push_back({1.6f, 1.0f, 1.4f});
    // box vertex 5 = (1,0,1), 7 = (1,1,1)
    test::addTriangle(fin, 5, 8, 9);
    test::addTriangle(fin, 5, 9, 7);
    cases.push_back({"box with fin", fin});
    return cases;
}

// Metric (acceptance rule): auto agrees with the exact winding number (inside if w > 0.5) at
// >= 99.9 % of voxel centres with |w - 0.5| > 0.2, on three open / non-manifold meshes. The
// pseudonormal and parity agreements on the same meshes are printed (not asserted).
TEST(BakeSign, AutoMatchesBruteForceWindingOnOpenMeshes) {
    for (const OpenCase& c : openMeshes()) {
        std::vector<glm::dvec3> pos;
        std::vector<glm::uvec3> tris;
        const WindingNumber wn = windingOf(c.mesh, pos, tris);
        for (SignMethod method : {SignMethod::Auto, SignMethod::Pseudonormal, SignMethod::Parity}) {
            BakeSettings s;
            s.resolution = 28;
            s.padding = 3;
            s.sign = method;
            s.threads = 2;
            const BakeResult r = bake(c.mesh, s);
            ASSERT_TRUE(r.ok) << r.error;
            const Agreement a = agreement(r.grid, wn);
            std::printf(
                "[ sign     ] %-13s %-12s agreement %.4f%% of %zu voxels (%llu winding evaluations of %zu)\n",
                c.name, toString(method), 100.0 * a.fraction(), a.counted,
                static_cast<unsigned long long>(r.windingEvaluations), r.grid.distances.size());
            if (method == SignMethod::Auto) {
                EXPECT_EQ(r.signUsed, SignMethod::Winding) << c.name;
                EXPECT_FALSE(r.diagnostics.closedManifold);
                EXPECT_GT(a.counted, r.grid.distances.size() / 2) << c.name;
                EXPECT_GE(a.fraction(), 0.999) << c.name;
            }
        }
    }
}

// Metric: the hierarchical sign equals the sign of the per-voxel fast winding number at every voxel
// with |w_fast - 0.5| > 0.05 (the rule only skips evaluations, it does not change answers
// away from the level set), on the bowl at two resolutions and with 1 and 3 threads; the rule
// evaluates fewer than 2/3 of the voxels (the bowl fills much of this small grid).
TEST(BakeSign, SurfaceFreeCellRuleMatchesPerVoxelEvaluation) {
    const assets::MeshData bowl = test::cutAbove(test::icosphere(3, 1.0f), 0.3f);
    std::vector<glm::dvec3> pos;
    std::vector<glm::uvec3> tris;
    const WindingNumber wn = windingOf(bowl, pos, tris);
    for (uint32_t resolution : {24u, 41u}) {
        for (uint32_t threads : {1u, 3u}) {
            BakeSettings s;
            s.resolution = resolution;
            s.sign = SignMethod::Winding;
            s.threads = threads;
            const BakeResult r = bake(bowl, s);
            ASSERT_TRUE(r.ok) << r.error;
            const SdfGrid& g = r.grid;
            size_t mismatches = 0;
            for (uint32_t k = 0; k < g.dims.z; ++k)
                for (uint32_t j = 0; j < g.dims.y; ++j)
                    for (uint32_t i = 0; i < g.dims.x; ++i) {
                        const double w = wn.fast(g.voxelCenter(i, j, k));
                        if (std::abs(w - 0.5) <= 0.05) continue;
                        mismatches += (w > 0.5) != (g.distances[g.index(i, j, k)] < 0);
                    }
            EXPECT_EQ(mismatches, 0u) << "resolution " << resolution << " threads " << threads;
            EXPECT_LT(r.windingEvaluations, g.distances.size() * 2 / 3);
        }
    }
}

// Metric: bitwise identical grids for 1, 2 and 5 threads (every sign method).
TEST(BakeSign, ThreadCountDoesNotChangeTheResult) {
    const assets::MeshData bowl = test::cutAbove(test::icosphere(2, 1.0f), 0.2f);
    for (SignMethod method : {SignMethod::Winding, SignMethod::Pseudonormal, SignMethod::Parity}) {
        std::vector<float> reference;
        for (uint32_t threads : {1u, 2u, 5u}) {
            BakeSettings s;
            s.resolution = 22;
            s.sign = method;
            s.threads = threads;
            const BakeResult r = bake(bowl, s);
            ASSERT_TRUE(r.ok) << r.error;
            if (reference.empty()) {
                reference = r.grid.distances;
            } else {
                EXPECT_EQ(reference, r.grid.distances) << toString(method) << " threads " << threads;
            }
        }
    }
}

// Metric: exact placement rules. resolution: longest padded axis == resolution, mesh centred,
// >= padding voxels of margin on every side; voxelSize: used as given; automatic: the documented
// per-quality resolution.
TEST(BakeSign, GridPlacement) {
    const assets::MeshData cube = test::box({-1, 2, 10}, {3, 4, 11});  // extents 4 x 2 x 1
    BakeSettings s;
    s.resolution = 36;
    s.padding = 2;
    s.threads = 1;
    BakeResult r = bake(cube, s);
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_EQ(r.grid.dims, glm::uvec3(36, 20, 12));
    EXPECT_DOUBLE_EQ(r.grid.voxelSize, 4.0 / 32);
    const glm::dvec3 gridCentre = r.grid.origin + 0.5 * glm::dvec3(r.grid.dims) * r.grid.voxelSize;
    EXPECT_NEAR(glm::length(gridCentre - glm::dvec3(1, 3, 10.5)), 0.0, 1e-12);
    EXPECT_NEAR(r.grid.origin.x, -1 - 2 * r.grid.voxelSize, 1e-12);
    // Farthest voxel centre: a grid corner, 1.5 voxels outside the box on every axis.
    EXPECT_FLOAT_EQ(r.maxDistance, float(1.5 * 0.125 * std::sqrt(3.0)));

    s.resolution = 0;
    s.voxelSize = 0.25;
    r = bake(cube, s);
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_EQ(r.grid.dims, glm::uvec3(16 + 4, 8 + 4, 4 + 4));
    EXPECT_DOUBLE_EQ(r.grid.voxelSize, 0.25);

    s.voxelSize = 0;
    for (BakeQuality q : {BakeQuality::Low, BakeQuality::Medium, BakeQuality::High}) {
        s.quality = q;
        r = bake(cube, s);
        ASSERT_TRUE(r.ok) << r.error;
        EXPECT_EQ(std::max({r.grid.dims.x, r.grid.dims.y, r.grid.dims.z}),
                  automaticResolution(r.diagnostics, q));
    }
    MeshDiagnostics d;
    d.boundsMax = glm::dvec3(1, 1, 1);
    EXPECT_EQ(automaticResolution(d, BakeQuality::Low), 64u);
    EXPECT_EQ(automaticResolution(d, BakeQuality::Medium), 128u);
    EXPECT_EQ(automaticResolution(d, BakeQuality::High), 256u);
    d.boundsMax = glm::dvec3(1, 1, 0);  // flat: unchanged
    EXPECT_EQ(automaticResolution(d, BakeQuality::Medium), 128u);
    d.boundsMax = glm::dvec3(1, 0.1, 0.1);  // thin rod: shortest axis gets >= 16 voxels, capped at 2x
    EXPECT_EQ(automaticResolution(d, BakeQuality::Medium), 160u);
    d.boundsMax = glm::dvec3(1, 0.05, 0.05);
    EXPECT_EQ(automaticResolution(d, BakeQuality::Medium), 256u);
}

// Metric: progress values are in [0, 1] and non-decreasing, phases are "distance" then "sign", the
// last call is (1, "sign"); parse / print of sign method names round-trip.
TEST(BakeSign, ProgressAndNames) {
    const assets::MeshData bowl = test::cutAbove(test::icosphere(2, 1.0f), 0.2f);
    for (SignMethod method : {SignMethod::Auto, SignMethod::Pseudonormal}) {
        std::vector<std::pair<double, std::string>> calls;
        BakeSettings s;
        s.resolution = 24;
        s.sign = method;
        s.progress = [&](double p, const char* phase) { calls.emplace_back(p, phase); };
        const BakeResult r = bake(bowl, s);
        ASSERT_TRUE(r.ok) << r.error;
        ASSERT_GE(calls.size(), 2u);
        EXPECT_EQ(calls.front().second, "distance");
        EXPECT_EQ(calls.back().second, "sign");
        EXPECT_EQ(calls.back().first, 1.0);
        bool seenSign = false;
        for (size_t i = 0; i < calls.size(); ++i) {
            EXPECT_GE(calls[i].first, 0.0);
            EXPECT_LE(calls[i].first, 1.0);
            if (i) {
                EXPECT_GE(calls[i].first, calls[i - 1].first);
            }
            EXPECT_TRUE(calls[i].second == "distance" || calls[i].second == "sign") << calls[i].second;
            if (calls[i].second == "sign") seenSign = true;
            if (seenSign) {
                EXPECT_EQ(calls[i].second, "sign");
            }
        }
        EXPECT_GT(r.timings.distanceMs, 0.0);
    }
    for (SignMethod m :
         {SignMethod::Auto, SignMethod::Winding, SignMethod::Pseudonormal, SignMethod::Parity}) {
        SignMethod parsed = SignMethod::Auto;
        EXPECT_TRUE(parseSignMethod(toString(m), parsed));
        EXPECT_EQ(parsed, m);
    }
    SignMethod parsed = SignMethod::Winding;
    EXPECT_FALSE(parseSignMethod("bogus", parsed));
    EXPECT_EQ(parsed, SignMethod::Winding);
}

}  // namespace
