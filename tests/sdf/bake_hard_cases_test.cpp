// bake() on hard inputs: single triangle, open quad, interpenetrating boxes, far offsets, a box
// thinner than a voxel, degenerate and duplicate triangles, invalid input and absurd grid sizes.
#include <gtest/gtest.h>

#include <limits>

#include "engine/sdf/bake.h"
#include "sdf/bake_test_util.h"

namespace {

using namespace penumbra;
using namespace penumbra::sdf;
using test::addTriangle;

BakeSettings settings(uint32_t resolution, SignMethod sign = SignMethod::Auto, uint32_t threads = 2) {
    BakeSettings s;
    s.resolution = resolution;
    s.sign = sign;
    s.threads = threads;
    return s;
}

// Metric: all distances exact within 1e-4 voxel; a lone triangle has |w| < 0.5 everywhere, so the
// whole field is positive; auto picks winding because of the 3 boundary edges.
TEST(BakeHardCases, SingleTriangle) {
    assets::MeshData m;
    m.positions = {{0, 0, 0}, {1, 0, 0.2f}, {0.3f, 1, -0.1f}};
    addTriangle(m, 0, 1, 2);
    const BakeResult r = bake(m, settings(16));
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_EQ(r.signUsed, SignMethod::Winding);
    EXPECT_NE(r.signReason.find("3 boundary edges"), std::string::npos) << r.signReason;
    EXPECT_LE(test::maxDistanceErrorVoxels(m, r.grid), 1e-4);
    EXPECT_GE(r.minDistance, 0.0f);
    EXPECT_EQ(r.diagnostics.boundaryEdges, 3u);
}

// Metric: as above for an open quad (4 boundary edges); also a flat mesh (zero z extent) still
// gets a grid at least 1 + 2 * padding voxels thick.
TEST(BakeHardCases, OpenQuad) {
    assets::MeshData m;
    m.positions = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}};
    addTriangle(m, 0, 1, 2);
    addTriangle(m, 0, 2, 3);
    const BakeResult r = bake(m, settings(20));
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_EQ(r.grid.dims.x, 20u);
    EXPECT_EQ(r.grid.dims.z, 5u);
    EXPECT_LE(test::maxDistanceErrorVoxels(m, r.grid), 1e-4);
    EXPECT_GE(r.minDistance, 0.0f);
}

bool insideBox(const glm::dvec3& p, glm::dvec3 lo, glm::dvec3 hi) {
    return p.x > lo.x && p.y > lo.y && p.z > lo.z && p.x < hi.x && p.y < hi.y && p.z < hi.z;
}

// Metric: two closed boxes that overlap: every voxel farther than 1e-6 from the surface is
// negative exactly when it lies in the union. auto must notice that the pseudonormal sign is wrong
// for this self-intersecting mesh (sign changes between voxels away from the surface) and let the
// winding number correct it; an explicit pseudonormal bake is wrong at some voxels (that is why).
TEST(BakeHardCases, InterpenetratingBoxes) {
    const glm::dvec3 aLo(0, 0, 0), aHi(2, 1, 1), bLo(1, -0.5, 0.25), bHi(3, 1.5, 0.75);
    assets::MeshData m = test::box(aLo, aHi);
    test::append(m, test::box(bLo, bHi));
    for (SignMethod method : {SignMethod::Auto, SignMethod::Winding, SignMethod::Pseudonormal}) {
        const BakeResult r = bake(m, settings(32, method));
        ASSERT_TRUE(r.ok) << r.error;
        EXPECT_TRUE(r.diagnostics.closedManifold);
        if (method == SignMethod::Auto) {
            EXPECT_NE(r.signReason.find("inconsistent"), std::string::npos) << r.signReason;
            EXPECT_GT(r.windingEvaluations, 0u);
        }
        EXPECT_LE(test::maxDistanceErrorVoxels(m, r.grid), 1e-4);
        const SdfGrid& g = r.grid;
        size_t wrong = 0;
        for (uint32_t k = 0; k < g.dims.z; ++k)
            for (uint32_t j = 0; j < g.dims.y; ++j)
                for (uint32_t i = 0; i < g.dims.x; ++i) {
                    const float d = g.distances[g.index(i, j, k)];
                    if (std::abs(d) < 1e-6f) continue;
                    const glm::dvec3 p = g.voxelCenter(i, j, k);
                    const bool inside = insideBox(p, aLo, aHi) || insideBox(p, bLo, bHi);
                    wrong += inside != (d < 0);
                }
        if (method == SignMethod::Pseudonormal) {
            EXPECT_GT(wrong, 0u);
        } else {
            EXPECT_EQ(wrong, 0u) << toString(method);
        }
    }
}

assets::MeshData flipped(assets::MeshData m) {
    for (size_t t = 0; t < m.indices.size(); t += 3) std::swap(m.indices[t + 1], m.indices[t + 2]);
    return m;
}

// Metric: two concentric closed spheres. Same orientation (nested shells, w = 2 in the middle):
// auto detects the inconsistent pseudonormal field and the winding number corrects it; everything
// within the outer sphere is inside. Inner sphere inverted (a hollow ball, w = 0 in the cavity):
// plain pseudonormal, the cavity is outside. Voxels farther than 0.06 (the mesh's sagitta is
// 0.02) from both spheres are checked.
TEST(BakeHardCases, NestedAndHollowShells) {
    const assets::MeshData outer = test::icosphere(3, 1.0f), inner = test::icosphere(3, 0.5f);
    for (bool hollow : {false, true}) {
        assets::MeshData m = outer;
        test::append(m, hollow ? flipped(inner) : inner);
        const BakeResult r = bake(m, settings(24));
        ASSERT_TRUE(r.ok) << r.error;
        EXPECT_TRUE(r.diagnostics.closedManifold);
        if (hollow) {
            EXPECT_EQ(r.signUsed, SignMethod::Pseudonormal);
            EXPECT_EQ(r.windingEvaluations, 0u) << r.signReason;
        } else {
            EXPECT_NE(r.signReason.find("inconsistent"), std::string::npos) << r.signReason;
        }
        const SdfGrid& g = r.grid;
        size_t wrong = 0, checked = 0;
        for (uint32_t k = 0; k < g.dims.z; ++k)
            for (uint32_t j = 0; j < g.dims.y; ++j)
                for (uint32_t i = 0; i < g.dims.x; ++i) {
                    const double radius = glm::length(g.voxelCenter(i, j, k));
                    if (std::abs(radius - 1.0) < 0.06 || std::abs(radius - 0.5) < 0.06) continue;
                    const bool inside = radius < 1.0 && !(hollow && radius < 0.5);
                    ++checked;
                    wrong += inside != (g.distances[g.index(i, j, k)] < 0);
                }
        EXPECT_GT(checked, g.distances.size() / 2);
        EXPECT_EQ(wrong, 0u) << (hollow ? "hollow" : "nested");
    }
}

// Coordinates on a 1/128 lattice stay exact in float at an offset of 1e5 (ulp 1/128 there).
assets::MeshData latticeMesh(glm::vec3 offset) {
    assets::MeshData m = test::box({0.25f, 0.125f, 0.5f}, {1.5f, 0.875f, 1.0f});
    assets::MeshData tet;
    tet.positions = {{1.0f, 1.0f, 0.25f}, {2.0f, 1.25f, 0.5f}, {1.5f, 2.0f, 0.375f}, {1.375f, 1.5f, 1.25f}};
    addTriangle(tet, 0, 2, 1);
    addTriangle(tet, 0, 1, 3);
    addTriangle(tet, 1, 2, 3);
    addTriangle(tet, 2, 0, 3);
    test::append(m, tet);
    for (glm::vec3& p : m.positions) p += offset;
    return m;
}

// Metric: the same mesh baked at the origin and at (1e5, -1e5, 1e5): identical dims and voxel
// size, origins differing by the offset, |d| within 1e-4 voxel (in fact bitwise equal), same signs.
TEST(BakeHardCases, FarFromOrigin) {
    const glm::vec3 offset(1e5f, -1e5f, 1e5f);
    for (SignMethod method : {SignMethod::Auto, SignMethod::Winding}) {
        const BakeResult near = bake(latticeMesh(glm::vec3(0)), settings(24, method));
        const BakeResult far = bake(latticeMesh(offset), settings(24, method));
        ASSERT_TRUE(near.ok && far.ok) << near.error << far.error;
        ASSERT_EQ(near.grid.dims, far.grid.dims);
        EXPECT_EQ(near.grid.voxelSize, far.grid.voxelSize);
        EXPECT_NEAR(glm::length(far.grid.origin - near.grid.origin - glm::dvec3(offset)), 0.0, 1e-9);
        double worst = 0;
        for (size_t v = 0; v < near.grid.distances.size(); ++v) {
            worst = std::max(worst, double(std::abs(near.grid.distances[v] - far.grid.distances[v])));
        }
        EXPECT_LE(worst / near.grid.voxelSize, 1e-4);
        EXPECT_LT(near.minDistance, 0.0f);
    }
    // Far mesh distances are exact too (brute force in double from the float coordinates).
    const assets::MeshData farMesh = latticeMesh(offset);
    const BakeResult far = bake(farMesh, settings(12));
    ASSERT_TRUE(far.ok);
    EXPECT_LE(test::maxDistanceErrorVoxels(farMesh, far.grid), 1e-4);
}

// Metric: a closed box 0.1 voxel thick (next to a cube that fixes the grid so voxel centres lie at
// z = (m + 0.5) h). No voxel farther than 0.2 voxel from the mesh is negative unless its centre is
// inside a box; centres inside are negative (a slab placed across a plane of centres has some,
// the other has none); for auto, winding and parity.
TEST(BakeHardCases, BoxThinnerThanAVoxel) {
    const double h = 1.0 / 16;  // x extent 1.75 at resolution 32 with padding 2
    const glm::dvec3 anchorLo(1.5, 0, -0.5), anchorHi(1.75, 0.25, 0.5);
    for (bool straddle : {false, true}) {
        const double z0 = straddle ? 0.45 * h : 0.6 * h;
        const glm::dvec3 slabLo(0, 0, z0), slabHi(1, 0.75, z0 + 0.1 * h);
        assets::MeshData m = test::box(glm::vec3(slabLo), glm::vec3(slabHi));
        test::append(m, test::box(glm::vec3(anchorLo), glm::vec3(anchorHi)));
        for (SignMethod method : {SignMethod::Auto, SignMethod::Winding, SignMethod::Parity}) {
            const BakeResult r = bake(m, settings(32, method));
            ASSERT_TRUE(r.ok) << r.error;
            const SdfGrid& g = r.grid;
            ASSERT_NEAR(g.voxelSize, h, 1e-12);
            size_t negative = 0, insideCentres = 0, slabCentres = 0;
            for (uint32_t k = 0; k < g.dims.z; ++k)
                for (uint32_t j = 0; j < g.dims.y; ++j)
                    for (uint32_t i = 0; i < g.dims.x; ++i) {
                        const glm::dvec3 p = g.voxelCenter(i, j, k);
                        const float d = g.distances[g.index(i, j, k)];
                        const bool inSlab =
                            insideBox(p, slabLo, glm::dvec3(slabHi.x, slabHi.y, z0 + 0.1 * h));
                        const bool inside = inSlab || insideBox(p, anchorLo, anchorHi);
                        insideCentres += inside;
                        slabCentres += inSlab;
                        negative += d < 0;
                        if (!inside && std::abs(d) > 0.2 * h) {
                            ASSERT_GT(d, 0.0f) << i << " " << j << " " << k;
                        }
                        if (inside) {
                            ASSERT_LT(d, 0.0f) << toString(method);
                        }
                    }
            EXPECT_EQ(negative, insideCentres) << toString(method);
            EXPECT_EQ(slabCentres > 0, straddle);
        }
    }
}

// Metric: degenerate and duplicate triangles change nothing: the bake equals the clean cube's
// bitwise, and the diagnostics count them.
TEST(BakeHardCases, DegenerateAndDuplicateTriangles) {
    const assets::MeshData cube = test::box({0, 0, 0}, {1, 1, 1});
    assets::MeshData dirty = cube;
    dirty.positions.push_back({0.5f, 0.5f, 0.0f});                          // on the bottom face
    dirty.positions.push_back({0.0f, 0.0f, 0.0f});                          // duplicate of vertex 0
    addTriangle(dirty, 0, 1, 1);                                            // repeated index
    addTriangle(dirty, 0, 8, 3);                                            // collinear (on the diagonal)
    addTriangle(dirty, 9, 0, 1);                                            // repeated after merging
    addTriangle(dirty, cube.indices[3], cube.indices[4], cube.indices[5]);  // duplicate
    addTriangle(dirty, cube.indices[5], cube.indices[4], cube.indices[3]);  // flipped duplicate
    const BakeResult a = bake(cube, settings(16));
    const BakeResult b = bake(dirty, settings(16));
    ASSERT_TRUE(a.ok && b.ok) << a.error << b.error;
    EXPECT_EQ(b.diagnostics.degenerateTrianglesRemoved, 3u);
    EXPECT_EQ(b.diagnostics.duplicateTrianglesRemoved, 2u);
    EXPECT_EQ(b.diagnostics.duplicateVerticesMerged, 1u);
    EXPECT_TRUE(b.diagnostics.closedManifold);
    EXPECT_EQ(b.signUsed, SignMethod::Pseudonormal);
    EXPECT_EQ(a.grid.dims, b.grid.dims);
    EXPECT_EQ(a.grid.distances, b.grid.distances);
}

// Metric: ok == false with one clear message for each kind of invalid input.
TEST(BakeHardCases, RejectsInvalidInputWithClearErrors) {
    auto expectError = [](const assets::MeshData& m, const BakeSettings& s, const char* needle) {
        const BakeResult r = bake(m, s);
        EXPECT_FALSE(r.ok);
        EXPECT_TRUE(r.grid.empty());
        EXPECT_NE(r.error.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.error;
    };
    const assets::MeshData cube = test::box({0, 0, 0}, {1, 1, 1});
    for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
        assets::MeshData m = cube;
        m.positions[3].z = bad;
        expectError(m, settings(16), "vertex 3 has a non-finite coordinate");
    }
    expectError(assets::MeshData{}, settings(16), "empty");
    assets::MeshData flat;
    flat.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
    addTriangle(flat, 0, 1, 2);
    addTriangle(flat, 0, 1, 1);
    {
        const BakeResult r = bake(flat, settings(16));
        EXPECT_FALSE(r.ok);
        EXPECT_NE(r.error.find("no non-degenerate triangles (2 degenerate removed)"), std::string::npos)
            << r.error;
        EXPECT_EQ(r.diagnostics.degenerateTrianglesRemoved, 2u);
    }
    expectError(cube, settings(4), "must exceed twice the padding");
    BakeSettings s = settings(0);
    s.voxelSize = -1;
    expectError(cube, s, "not a positive finite number");
    s.voxelSize = std::numeric_limits<double>::quiet_NaN();
    expectError(cube, s, "not a positive finite number");
    s.voxelSize = 9e-4;  // 1116^3 voxels
    expectError(cube, s, "exceeds the limit");
    s.voxelSize = 1e-6;
    expectError(cube, s, "voxels along axis");
    expectError(cube, settings(100000), "voxels along axis");
    s = settings(16);
    s.padding = 1u << 30;
    expectError(cube, s, "padding");
}

}  // namespace
