// Coordinates far from 1 (issue 8, item 12): the BVH never re-enters unused lanes or overruns its
// stack when squared distances overflow float, and bake() works in a normalised frame, so meshes
// of any size whose distances fit 32-bit floats bake exactly; others are refused with a message.
// Also run under the ASan preset (build/asan).
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include "engine/assets/mesh.h"
#include "engine/sdf/bake.h"
#include "engine/sdf/bvh.h"
#include "engine/sdf/distance.h"
#include "sdf/bake_test_util.h"

namespace {

using namespace penumbra;
using namespace penumbra::sdf;
using test::addTriangle;

assets::MeshData rightTriangle(float leg) {
    assets::MeshData m;
    m.positions = {{0, 0, 0}, {leg, 0, 0}, {0, leg, 0}};
    addTriangle(m, 0, 1, 2);
    return m;
}

BakeSettings settings(uint32_t resolution, SignMethod sign = SignMethod::Auto) {
    BakeSettings s;
    s.resolution = resolution;
    s.sign = sign;
    s.threads = 2;
    return s;
}

// Metric: at legs 1e20 and 1e30 the squared distances overflow float (> 3.4e38), so every bound
// is +inf and, with an infinite limit, "inf <= inf" held for the unused lanes, which pointed at
// the root: traversal looped until the stack overran (segfault). Now closest() with an infinite
// limit and closestSeeded() return the exact closest point (brute force within 1e-6 relative) on
// soups with inner nodes and unused lanes.
TEST(BakeCoordinateRange, BvhQueriesWithOverflowingSquaredDistances) {
    for (double leg : {1e19, 1e20, 1e30}) {
        SCOPED_TRACE(leg);
        std::vector<glm::dvec3> positions;
        std::vector<glm::uvec3> triangles;
        for (uint32_t t = 0; t < 23; ++t) {  // 23 triangles: inner nodes plus unused lanes
            const double x = double(float(leg * t));
            const uint32_t base = static_cast<uint32_t>(positions.size());
            positions.push_back({x, 0, 0});
            positions.push_back({x + double(float(leg)), 0, 0});
            positions.push_back({x, double(float(leg)), double(float(leg * 0.25 * (t % 3)))});
            triangles.push_back({base, base + 1, base + 2});
        }
        TriangleBvh bvh;
        bvh.build(positions, triangles, 1);
        ASSERT_FALSE(bvh.empty());
        for (const glm::dvec3 p : {glm::dvec3(0.3, 0.2, 1.0) * leg, glm::dvec3(7.5, -2.0, 3.0) * leg,
                                   glm::dvec3(-40.0, 1.0, -1.0) * leg, glm::dvec3(30.0, 0.5, 0.1) * leg}) {
            double best = INFINITY;
            for (const glm::uvec3& t : triangles) {
                best = std::min(best, std::sqrt(pointTriangleDistanceSquared(
                                          p, positions[t.x], positions[t.y], positions[t.z])));
            }
            ClosestHit hit;
            ASSERT_TRUE(bvh.closest(p, INFINITY, hit));
            EXPECT_NEAR(hit.distance, best, 1e-6 * best);
            for (uint32_t seed : {0u, 11u, 22u}) {
                const ClosestHit seeded = bvh.closestSeeded(p, seed);
                EXPECT_NEAR(seeded.distance, best, 1e-6 * best);
            }
        }
    }
}

// Metric: single triangles with legs 1e19, 1e20, 1e30 and 1e-30 (all finite floats) bake: the
// voxel size is leg / (resolution - 2 * padding), every distance matches brute force within 1e-4
// voxel, the field is positive (a lone triangle encloses nothing), and its largest value is
// below the grid's diagonal.
TEST(BakeCoordinateRange, HugeAndTinyTrianglesBakeExactly) {
    for (float leg : {1e19f, 1e20f, 1e30f, 1e-30f}) {
        SCOPED_TRACE(leg);
        const assets::MeshData m = rightTriangle(leg);
        for (SignMethod sign : {SignMethod::Auto, SignMethod::Winding}) {
            const BakeResult r = bake(m, settings(16, sign));
            ASSERT_TRUE(r.ok) << r.error;
            EXPECT_NEAR(r.grid.voxelSize, double(leg) / 12.0, 1e-12 * double(leg));
            EXPECT_LE(test::maxDistanceErrorVoxels(m, r.grid), 1e-4);
            EXPECT_GE(r.minDistance, 0.0f);
            EXPECT_LE(double(r.maxDistance), r.grid.voxelSize * std::sqrt(16.0 * 16 * 2 + 5 * 5));
        }
    }
}

// Metric: closed cubes of side 1e30 and 1e-30 (auto: pseudonormal, checked by the winding
// number) bake with the right sign: the centre voxels are negative, -(side / 2 - half a voxel)
// within 1e-4 voxel, and the corners of the grid positive.
TEST(BakeCoordinateRange, HugeAndTinyClosedCubes) {
    for (float side : {1e30f, 1e-30f}) {
        SCOPED_TRACE(side);
        const BakeResult r = bake(test::box(glm::vec3(0), glm::vec3(side)), settings(20));
        ASSERT_TRUE(r.ok) << r.error;
        const SdfGrid& g = r.grid;
        ASSERT_EQ(g.dims, glm::uvec3(20));
        const double h = g.voxelSize;
        EXPECT_NEAR(g.distances[g.index(9, 9, 9)], -(double(side) / 2 - h / 2), 1e-4 * h);
        EXPECT_NEAR(g.distances[g.index(10, 10, 10)], -(double(side) / 2 - h / 2), 1e-4 * h);
        EXPECT_GT(g.distances[g.index(0, 0, 0)], 0.0f);
        EXPECT_GT(g.distances[g.index(19, 19, 19)], 0.0f);
        EXPECT_LE(test::maxDistanceErrorVoxels(test::box(glm::vec3(0), glm::vec3(side)), g), 1e-4);
    }
}

// Metric: a mesh whose grid diagonal exceeds the largest float (legs 3e38) and one whose voxel
// would be smaller than the smallest normal float (legs 1e-37 at resolution 64) are refused with
// a message that says why and what to do; no crash.
TEST(BakeCoordinateRange, UnrepresentableExtentsAreRefused) {
    BakeResult r = bake(rightTriangle(3e38f), settings(16));
    EXPECT_FALSE(r.ok);
    EXPECT_NE(r.error.find("too large"), std::string::npos) << r.error;
    EXPECT_NE(r.error.find("largest 32-bit float"), std::string::npos) << r.error;
    r = bake(rightTriangle(1e-37f), settings(64));
    EXPECT_FALSE(r.ok);
    EXPECT_NE(r.error.find("smallest normal 32-bit float"), std::string::npos) << r.error;
    EXPECT_NE(r.error.find("fewer voxels"), std::string::npos) << r.error;
    // The same tiny triangle at a resolution whose voxel is a normal float bakes.
    r = bake(rightTriangle(1e-37f), settings(6, SignMethod::Winding));
    EXPECT_TRUE(r.ok) << r.error;
}

// Metric: a glTF whose node scales a unit triangle by 2^62 (coordinates 4.6e18, squared 2e37 in
// float, the fuzzer's case) loads and bakes; its distances match brute force within 1e-4 voxel.
TEST(BakeCoordinateRange, GltfNodeScale2Pow62) {
    const std::string dir =
        (std::filesystem::temp_directory_path() / ("penumbra_sdf_scale62_" + std::to_string(::getpid())))
            .string();
    std::filesystem::create_directories(dir);
    const std::string path = dir + "/scale62.gltf";
    {
        // One triangle (0,0,0) (1,0,0) (0,1,0), unsigned-short indices, as data: URI.
        std::ofstream f(path);
        f << R"({"asset":{"version":"2.0"},
  "buffers":[{"byteLength":44,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="}],
  "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
  "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
               {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}],
  "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
  "nodes":[{"mesh":0,"scale":[4611686018427387904,4611686018427387904,4611686018427387904]}],
  "scenes":[{"nodes":[0]}],"scene":0})";
    }
    assets::MeshData m;
    std::string error;
    ASSERT_TRUE(assets::loadMesh(path, m, error)) << error;
    std::filesystem::remove_all(dir);
    ASSERT_EQ(m.positions.size(), 3u);
    EXPECT_EQ(m.positions[1].x, std::ldexp(1.0f, 62));
    const BakeResult r = bake(m, settings(16));
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_LE(test::maxDistanceErrorVoxels(m, r.grid), 1e-4);
    EXPECT_GE(r.minDistance, 0.0f);
}

}  // namespace
