// Sampling a grid: trilinear between voxel centres inside, the conservative rule outside (derived
// in docs/FORMATS.md). Checked against the exact distance of analytic spheres: outside the grid
// the rule adds no error beyond the trilinear error at the clamped point, and with exact samples
// it never overestimates; the naive "distance to the box + clamped sample" does.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <map>

#include "engine/sdf/bake.h"
#include "engine/sdf/psdf.h"
#include "sdf/acceptance_support.h"

namespace {

using namespace penumbra::sdf;

struct Sphere {
    glm::dvec3 c;
    double r;
    double signedDistance(const glm::dvec3& p) const { return glm::length(p - c) - r; }
};

// An exact "bake" of the analytic sphere: padding voxels around its bounds, `res` voxels along
// the longest axis of the padded grid.
SdfGrid bakeSphere(const Sphere& s, double voxel, double padding) {
    SdfGrid g;
    const glm::dvec3 lo = s.c - s.r - padding * voxel, hi = s.c + s.r + padding * voxel;
    g.dims = glm::uvec3(glm::ceil((hi - lo) / voxel));
    g.origin = lo;
    g.voxelSize = voxel;
    g.distances.resize(size_t(g.dims.x) * g.dims.y * g.dims.z);
    for (uint32_t k = 0; k < g.dims.z; ++k)
        for (uint32_t j = 0; j < g.dims.y; ++j)
            for (uint32_t i = 0; i < g.dims.x; ++i)
                g.distances[g.index(i, j, k)] = float(s.signedDistance(g.voxelCenter(i, j, k)));
    return g;
}

glm::dvec3 randomOutside(std::mt19937& rng, const glm::dvec3& lo, const glm::dvec3& hi, double reach) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (;;) {
        const glm::dvec3 p = lo - reach + glm::dvec3(u(rng), u(rng), u(rng)) * (hi - lo + 2.0 * reach);
        if (glm::any(glm::lessThan(p, lo)) || glm::any(glm::greaterThan(p, hi))) return p;
    }
}

TEST(PsdfSampling, TrilinearReproducesVoxelCentresAndLinearFieldsExactly) {
    SdfGrid g;
    g.dims = {5, 4, 3};
    g.origin = {10.0, -3.0, 0.5};
    g.voxelSize = 0.5;
    g.distances.resize(60);
    auto f = [](const glm::dvec3& p) { return 0.25 * p.x - 0.5 * p.y + 0.125 * p.z + 1.0; };
    for (uint32_t k = 0; k < 3; ++k)
        for (uint32_t j = 0; j < 4; ++j)
            for (uint32_t i = 0; i < 5; ++i) g.distances[g.index(i, j, k)] = float(f(g.voxelCenter(i, j, k)));
    SdfSampler s(g, g.origin + 0.5, g.origin + 1.0);
    for (uint32_t k = 0; k < 3; ++k)
        for (uint32_t j = 0; j < 4; ++j)
            for (uint32_t i = 0; i < 5; ++i)
                EXPECT_EQ(s.sample(g.voxelCenter(i, j, k)), double(g.distances[g.index(i, j, k)]));
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int n = 0; n < 1000; ++n) {
        const glm::dvec3 p =
            s.sampleBoxMin() + glm::dvec3(u(rng), u(rng), u(rng)) * (s.sampleBoxMax() - s.sampleBoxMin());
        EXPECT_NEAR(s.sample(p), f(p), 1e-6);
        EXPECT_EQ(s.sample(p), s.trilinear(p));
    }
    EXPECT_TRUE(std::isfinite(s.sample(glm::dvec3(std::nan(""), 0, 0))));
}

TEST(PsdfSampling, SingleVoxelGridsWork) {
    SdfGrid g;
    g.dims = {1, 1, 1};
    g.voxelSize = 2.0;
    g.distances = {3.0f};
    SdfSampler s(g, {1, 1, 1}, {1, 1, 1});
    ASSERT_TRUE(s.meshInsideSampleBox());
    EXPECT_EQ(s.sample({1, 1, 1}), 3.0);
    EXPECT_EQ(s.trilinear({1.5, 0.2, 1.9}), 3.0);
    EXPECT_NEAR(s.sample({5, 1, 1}), 5.0, 1e-12);  // sqrt(4^2 + 3^2)
    // Mesh bounds reaching past the single centre: the fallback max(distance to bounds, s - a).
    SdfSampler wide(g, {0.9, 0.9, 0.9}, {1.1, 1.1, 1.1});
    ASSERT_FALSE(wide.meshInsideSampleBox());
    EXPECT_NEAR(wide.sample({5, 1, 1}), 3.9, 1e-12);
    EXPECT_NEAR(wide.sample({1.5, 1, 1}), 2.5, 1e-12);
}

TEST(PsdfSampling, OutsideTheGridNeverOverestimatesAnExactSphereBake) {
    std::mt19937 rng(11);
    int checked = 0, naiveOver = 0;
    double ratioSum = 0;
    for (const double padding : {2.0, 1.0, 0.5}) {
        for (const Sphere sphere : {Sphere{{0.3, -0.2, 0.1}, 1.0}, Sphere{{1e5, 2.0, -3.0}, 0.4}}) {
            const double voxel = sphere.r / 12.0;
            const SdfGrid g = bakeSphere(sphere, voxel, padding);
            SdfSampler s(g, sphere.c - sphere.r, sphere.c + sphere.r);
            ASSERT_TRUE(s.meshInsideSampleBox());
            for (int n = 0; n < 4000; ++n) {
                const double reach = n % 2 ? 0.2 * voxel : 3.0 * sphere.r;
                const glm::dvec3 p = randomOutside(rng, s.sampleBoxMin(), s.sampleBoxMax(), reach);
                const glm::dvec3 q = glm::clamp(p, s.sampleBoxMin(), s.sampleBoxMax());
                const double exact = sphere.signedDistance(p);
                const double interpError = std::fabs(s.trilinear(q) - sphere.signedDistance(q));
                const double d = s.sample(p);
                ASSERT_GE(d, 0.0);
                // The rule adds nothing to the interpolation error at the clamped point...
                ASSERT_LE(d, exact + interpError + 1e-9 * (1 + std::fabs(exact)))
                    << "p " << p.x << " " << p.y << " " << p.z << " padding " << padding;
                // ... which is a small fraction of a voxel at the padded boundary.
                ASSERT_LT(interpError, 0.05 * voxel);
                const double naive = glm::length(p - q) + s.trilinear(q);
                if (naive > exact + interpError + 1e-6 * voxel) ++naiveOver;
                ratioSum += d / exact;
                ++checked;
            }
        }
    }
    EXPECT_GT(naiveOver, checked / 10) << "the naive sum should overestimate often";
    // Conservative but useful: on average well over half the true distance.
    EXPECT_GT(ratioSum / checked, 0.75);
    RecordProperty("mean_outside_ratio", std::to_string(ratioSum / checked));
}

TEST(PsdfSampling, WithExactSamplesAtTheClampedPointTheRuleIsALowerBound) {
    // Points whose clamp lands exactly on a boundary voxel centre see an exact sample there.
    const Sphere sphere{{0.1, 0.05, -0.2}, 0.8};
    const double voxel = sphere.r / 10.0;
    const SdfGrid g = bakeSphere(sphere, voxel, 2.0);
    SdfSampler s(g, sphere.c - sphere.r, sphere.c + sphere.r);
    std::mt19937 rng(5);
    std::uniform_int_distribution<uint32_t> pick(0, 1 << 30);
    std::uniform_real_distribution<double> len(0.0, 4.0);
    int checked = 0;
    for (int n = 0; n < 20000; ++n) {
        glm::uvec3 idx;
        glm::dvec3 outward(0);
        for (int a = 0; a < 3; ++a) {
            const uint32_t m = pick(rng) % 3;  // 0: min face, 1: interior, 2: max face
            idx[a] = m == 0 ? 0 : m == 2 ? g.dims[a] - 1 : pick(rng) % g.dims[a];
            if (m != 1) outward[a] = (m == 0 ? -1.0 : 1.0) * len(rng) * sphere.r;
        }
        if (outward == glm::dvec3(0)) continue;
        const glm::dvec3 q = g.voxelCenter(idx.x, idx.y, idx.z);
        const glm::dvec3 p = q + outward;
        ASSERT_LE(s.sample(p), sphere.signedDistance(p) + 1e-6 * voxel);
        ++checked;
    }
    EXPECT_GT(checked, 15000);
}

TEST(PsdfSampling, ShallowPaddingUsesTheLipschitzFallbackAndStaysConservative) {
    // Padding 0: the mesh bounds reach half a voxel beyond the box of voxel centres.
    const Sphere sphere{{0.0, 0.0, 0.0}, 1.0};
    const double voxel = 0.1;
    const SdfGrid g = bakeSphere(sphere, voxel, 0.0);
    SdfSampler s(g, sphere.c - sphere.r, sphere.c + sphere.r);
    EXPECT_FALSE(s.meshInsideSampleBox());
    std::mt19937 rng(9);
    for (int n = 0; n < 5000; ++n) {
        const glm::dvec3 p = randomOutside(rng, s.sampleBoxMin(), s.sampleBoxMax(), n % 2 ? voxel : 3.0);
        const glm::dvec3 q = glm::clamp(p, s.sampleBoxMin(), s.sampleBoxMax());
        const double interpError = std::fabs(s.trilinear(q) - sphere.signedDistance(q));
        const double exact = sphere.signedDistance(p), d = s.sample(p);
        ASSERT_LE(std::fabs(d), std::fabs(exact) + interpError + 1e-9);
        if (d != 0) {
            ASSERT_EQ(d > 0, exact > 0) << "sign flipped at " << p.x << " " << p.y << " " << p.z;
        }
    }
}

// Icosahedron subdivided `levels` times, vertices on the sphere (c, r).
penumbra::assets::MeshData icosphere(const glm::dvec3& c, double r, int levels) {
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    std::vector<glm::dvec3> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                                 {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
    std::vector<glm::uvec3> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    for (auto& p : v) p = glm::normalize(p);
    for (int l = 0; l < levels; ++l) {
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
        auto midpoint = [&](uint32_t a, uint32_t b) {
            const auto key = std::minmax(a, b);
            auto it = mid.find(key);
            if (it != mid.end()) return it->second;
            v.push_back(glm::normalize(v[a] + v[b]));
            return mid[key] = uint32_t(v.size() - 1);
        };
        std::vector<glm::uvec3> next;
        for (const auto& tri : f) {
            const uint32_t ab = midpoint(tri.x, tri.y), bc = midpoint(tri.y, tri.z),
                           ca = midpoint(tri.z, tri.x);
            next.insert(next.end(), {{tri.x, ab, ca}, {tri.y, bc, ab}, {tri.z, ca, bc}, {ab, bc, ca}});
        }
        f = std::move(next);
    }
    penumbra::assets::MeshData m;
    for (const auto& p : v) m.positions.push_back(glm::vec3(c + r * p));
    for (const auto& tri : f) m.indices.insert(m.indices.end(), {tri.x, tri.y, tri.z});
    return m;
}

TEST(PsdfSampling, OutsideRuleOnABakedIcosphereNeverOverestimatesTheMeshDistance) {
    // The whole pipeline: bake() -> .psdf image -> decode -> sample, against a brute-force exact
    // distance to the mesh.
    const penumbra::assets::MeshData mesh = icosphere({0.2, -0.1, 0.3}, 1.0, 3);
    BakeSettings settings;
    settings.resolution = 32;
    const BakeResult baked = bake(mesh, settings);
    ASSERT_TRUE(baked.ok) << baked.error;
    PsdfWriteOptions wo;
    wo.boundsMin = baked.diagnostics.boundsMin;
    wo.boundsMax = baked.diagnostics.boundsMax;
    std::vector<uint8_t> bytes;
    std::string err;
    ASSERT_TRUE(encodePsdf(baked.grid, wo, bytes, err)) << err;
    PsdfAsset asset;
    ASSERT_TRUE(decodePsdf(bytes.data(), bytes.size(), "icosphere", asset, err)) << err;
    const SdfSampler s(asset);
    ASSERT_TRUE(s.meshInsideSampleBox());
    const auto tris = penumbra::acceptance::toTriangles(mesh);
    const double voxel = asset.grid.voxelSize;
    std::mt19937 rng(21);
    for (int n = 0; n < 3000; ++n) {
        const glm::dvec3 p = randomOutside(rng, s.sampleBoxMin(), s.sampleBoxMax(), n % 2 ? voxel : 3.0);
        const glm::dvec3 q = glm::clamp(p, s.sampleBoxMin(), s.sampleBoxMax());
        const double exact = penumbra::acceptance::bruteForceDistance(tris, p);  // outside: positive
        const double interpError =
            std::fabs(s.trilinear(q) - penumbra::acceptance::bruteForceDistance(tris, q));
        ASSERT_LE(s.sample(p), exact + interpError + 1e-6 * voxel);
        ASSERT_LT(interpError, 0.05 * voxel);
    }
}

TEST(PsdfSampling, TheRuleIsContinuousAcrossTheGridBoundary) {
    const Sphere sphere{{0.0, 0.0, 0.0}, 1.0};
    const SdfGrid g = bakeSphere(sphere, 0.1, 2.0);
    SdfSampler s(g, sphere.c - sphere.r, sphere.c + sphere.r);
    const glm::dvec3 onFace{s.sampleBoxMax().x, 0.37, -0.21};
    const double inside = s.sample(onFace - glm::dvec3(1e-9, 0, 0));
    const double outside = s.sample(onFace + glm::dvec3(1e-9, 0, 0));
    EXPECT_NEAR(inside, outside, 1e-6);
}

}  // namespace
