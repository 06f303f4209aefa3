// Range of .psdf grids and of sampling (issue 8, item 14): sampling far outside the grid never
// overflows (glm::length squared the offset: inf from about 1.3e154 on), and writers and readers
// refuse grids whose distances 32-bit floats cannot hold (the files are in tests/malformed/psdf).
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <vector>

#include "engine/sdf/bake.h"
#include "engine/sdf/psdf.h"
#include "sdf/bake_test_util.h"

namespace {

using namespace penumbra;
using namespace penumbra::sdf;

// Exact distances of a unit sphere at the origin on a 24^3 grid of voxel 0.1.
SdfGrid unitSphereGrid() {
    SdfGrid g;
    g.dims = glm::uvec3(24);
    g.origin = glm::dvec3(-1.2);
    g.voxelSize = 0.1;
    g.distances.resize(24 * 24 * 24);
    for (uint32_t k = 0; k < 24; ++k)
        for (uint32_t j = 0; j < 24; ++j)
            for (uint32_t i = 0; i < 24; ++i)
                g.distances[g.index(i, j, k)] = float(glm::length(g.voxelCenter(i, j, k)) - 1.0);
    return g;
}

// Metric: query points at 1e154 .. 1e308 (finite doubles) sample a finite distance equal to
// |p| - 1 within 1e-12 relative, with the mesh bounds inside the sample box (Pythagorean rule)
// and outside it (box rule); only a point whose distance exceeds the largest double gives inf.
// Before the fix every point beyond ~1.3e154 sampled inf.
TEST(PsdfRange, SamplingFarPointsDoesNotOverflow) {
    const SdfGrid g = unitSphereGrid();
    const SdfSampler inside(g, glm::dvec3(-1), glm::dvec3(1));
    const SdfSampler beyond(g, glm::dvec3(-2), glm::dvec3(2));  // mesh bounds exceed the sample box
    ASSERT_TRUE(inside.meshInsideSampleBox());
    ASSERT_FALSE(beyond.meshInsideSampleBox());
    for (double d : {1e100, 1e154, 1.3e154, 1e155, 1e200, 1e300, 1e308}) {
        for (const glm::dvec3 dir :
             {glm::dvec3(1, 0, 0), glm::dvec3(0, -1, 0), glm::dvec3(0.6, -0.8, 0), glm::dvec3(1, -1, 1)}) {
            const glm::dvec3 p = d * dir;
            const double expected = d * std::sqrt(glm::dot(dir, dir));
            SCOPED_TRACE(testing::Message() << "p = (" << p.x << ", " << p.y << ", " << p.z << ")");
            const double a = inside.sample(p), b = beyond.sample(p);
            ASSERT_TRUE(std::isfinite(a));
            ASSERT_TRUE(std::isfinite(b));
            EXPECT_NEAR(a, expected, 1e-12 * expected);
            EXPECT_NEAR(b, expected, 1e-12 * expected);
        }
    }
    // |p| = 2.4e308 > DBL_MAX: not representable.
    EXPECT_TRUE(std::isinf(inside.sample(glm::dvec3(1.7e308, 1.7e308, 0))));
}

// Metric: the writer refuses grids the reader would refuse (voxel 1e300: diagonal beyond
// FLT_MAX; voxel 1e-40: below FLT_MIN; u8 band 1e39), naming the problem.
TEST(PsdfRange, WriterRefusesUnrepresentableGrids) {
    SdfGrid g;
    g.dims = {4, 3, 2};
    g.distances.assign(24, 0.5f);
    std::vector<uint8_t> bytes;
    std::string error;
    g.voxelSize = 1e300;
    EXPECT_FALSE(encodePsdf(g, {}, bytes, error));
    EXPECT_NE(error.find("largest 32-bit float"), std::string::npos) << error;
    g.voxelSize = 1e-40;
    EXPECT_FALSE(encodePsdf(g, {}, bytes, error));
    EXPECT_NE(error.find("smallest normal 32-bit float"), std::string::npos) << error;
    g.voxelSize = 0.5;
    PsdfWriteOptions u8;
    u8.encoding = PsdfEncoding::U8;
    u8.bandWidth = 1e39;
    EXPECT_FALSE(encodePsdf(g, u8, bytes, error));
    EXPECT_NE(error.find("band width"), std::string::npos) << error;
    EXPECT_TRUE(encodePsdf(g, {}, bytes, error)) << error;
}

// Metric: what the baker accepts the format holds: triangles with legs 1e30 and 1e-30 bake,
// encode, decode and sample back the same values (f32: bit-exact at the voxel centres).
TEST(PsdfRange, ExtremeBakesRoundTrip) {
    for (float leg : {1e30f, 1e-30f}) {
        SCOPED_TRACE(leg);
        assets::MeshData m;
        m.positions = {{0, 0, 0}, {leg, 0, 0}, {0, leg, leg}};
        test::addTriangle(m, 0, 1, 2);
        BakeSettings s;
        s.resolution = 12;
        s.threads = 2;
        const BakeResult r = bake(m, s);
        ASSERT_TRUE(r.ok) << r.error;
        std::vector<uint8_t> bytes;
        std::string error;
        PsdfWriteOptions o;
        o.boundsMin = r.diagnostics.boundsMin;
        o.boundsMax = r.diagnostics.boundsMax;
        ASSERT_TRUE(encodePsdf(r.grid, o, bytes, error)) << error;
        PsdfAsset asset;
        ASSERT_TRUE(decodePsdf(bytes.data(), bytes.size(), "extreme", asset, error)) << error;
        EXPECT_EQ(asset.grid.distances, r.grid.distances);
        EXPECT_EQ(asset.header.voxelSize, r.grid.voxelSize);
    }
}

}  // namespace
