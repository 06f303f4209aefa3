// cleanMesh(): validation, vertex merging, degenerate / duplicate removal, edge topology counts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/sdf/mesh_topology.h"
#include "sdf/bake_test_util.h"

namespace {

using namespace penumbra;
using namespace penumbra::sdf;
using test::addTriangle;

CleanMesh clean(const assets::MeshData& m) {
    CleanMesh out;
    std::string error;
    EXPECT_TRUE(cleanMesh(m, out, error)) << error;
    return out;
}

// Metric: exact counts.
TEST(CleanMesh, ClosedCube) {
    const CleanMesh c = clean(test::box({0, 0, 0}, {1, 2, 3}));
    const MeshDiagnostics& d = c.diagnostics;
    EXPECT_EQ(d.inputTriangles, 12u);
    EXPECT_EQ(d.inputVertices, 8u);
    EXPECT_EQ(d.triangles, 12u);
    EXPECT_EQ(d.vertices, 8u);
    EXPECT_EQ(d.boundaryEdges, 0u);
    EXPECT_EQ(d.nonManifoldEdges, 0u);
    EXPECT_EQ(d.inconsistentEdges, 0u);
    EXPECT_EQ(d.duplicateVerticesMerged, 0u);
    EXPECT_EQ(d.degenerateTrianglesRemoved, 0u);
    EXPECT_EQ(d.duplicateTrianglesRemoved, 0u);
    EXPECT_TRUE(d.closedManifold);
    EXPECT_EQ(d.boundsMin, glm::dvec3(0, 0, 0));
    EXPECT_EQ(d.boundsMax, glm::dvec3(1, 2, 3));
    // Local coordinates relative to the bounding-box centre.
    EXPECT_EQ(c.center, glm::dvec3(0.5, 1, 1.5));
    for (const glm::dvec3& p : c.positions) EXPECT_EQ(std::abs(p.x), 0.5);
}

// Metric: an open quad (2 triangles) has 4 boundary edges and 1 interior edge.
TEST(CleanMesh, OpenQuad) {
    assets::MeshData m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    addTriangle(m, 0, 1, 2);
    addTriangle(m, 0, 2, 3);
    const MeshDiagnostics d = clean(m).diagnostics;
    EXPECT_EQ(d.triangles, 2u);
    EXPECT_EQ(d.boundaryEdges, 4u);
    EXPECT_EQ(d.nonManifoldEdges, 0u);
    EXPECT_FALSE(d.closedManifold);
}

// Metric: a cube stored with 4 separate vertices per face (24) merges 16 duplicates and is then
// closed.
TEST(CleanMesh, MergesDuplicateVertices) {
    const assets::MeshData shared = test::box({-1, -1, -1}, {1, 1, 1});
    assets::MeshData m;
    for (size_t f = 0; f < 6; ++f) {
        const uint32_t base = static_cast<uint32_t>(m.positions.size());
        // corners of the face's two triangles: (0,1,2) and (0,2,3) of a quad
        const uint32_t q[4] = {shared.indices[6 * f], shared.indices[6 * f + 1], shared.indices[6 * f + 2],
                               shared.indices[6 * f + 5]};
        for (uint32_t v : q) m.positions.push_back(shared.positions[v]);
        addTriangle(m, base, base + 1, base + 2);
        addTriangle(m, base, base + 2, base + 3);
    }
    // -0.0 and +0.0 are one position.
    m.positions.push_back({0.0f, 5, 5});
    m.positions.push_back({-0.0f, 5, 5});
    m.positions.push_back({0.0f, 6, 5});
    addTriangle(m, 24, 25, 26);  // becomes degenerate (repeated vertex) after merging
    const MeshDiagnostics d = clean(m).diagnostics;
    EXPECT_EQ(d.inputVertices, 27u);
    EXPECT_EQ(d.duplicateVerticesMerged, 17u);
    EXPECT_EQ(d.vertices, 8u);
    EXPECT_EQ(d.degenerateTrianglesRemoved, 1u);
    EXPECT_TRUE(d.closedManifold);
    EXPECT_EQ(d.boundsMax, glm::dvec3(1, 1, 1));  // the removed triangle does not count
}

// Metric: exact duplicates and re-ordered / flipped copies of a triangle are removed (first kept).
TEST(CleanMesh, RemovesDuplicateTriangles) {
    assets::MeshData m = test::box({0, 0, 0}, {1, 1, 1});
    addTriangle(m, m.indices[0], m.indices[1], m.indices[2]);  // exact copy
    addTriangle(m, m.indices[4], m.indices[5], m.indices[3]);  // rotated copy
    addTriangle(m, m.indices[8], m.indices[7], m.indices[6]);  // flipped copy
    const MeshDiagnostics d = clean(m).diagnostics;
    EXPECT_EQ(d.inputTriangles, 15u);
    EXPECT_EQ(d.duplicateTrianglesRemoved, 3u);
    EXPECT_EQ(d.triangles, 12u);
    EXPECT_TRUE(d.closedManifold);
}

// Metric: repeated indices and collinear corners are removed; valid needles are kept.
TEST(CleanMesh, RemovesDegenerateTriangles) {
    assets::MeshData m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {1, 1e-3f, 0}};
    addTriangle(m, 0, 1, 2);  // collinear
    addTriangle(m, 0, 0, 3);  // repeated index
    addTriangle(m, 0, 1, 3);  // fine
    addTriangle(m, 0, 2, 4);  // needle (height 1e-3), kept
    const CleanMesh c = clean(m);
    EXPECT_EQ(c.diagnostics.degenerateTrianglesRemoved, 2u);
    EXPECT_EQ(c.diagnostics.triangles, 2u);
    EXPECT_EQ(c.diagnostics.vertices, 5u);
    EXPECT_EQ(c.triangles.size(), 2u);
}

// Metric: three triangles sharing one edge make one non-manifold edge (and 6 boundary edges).
TEST(CleanMesh, NonManifoldFin) {
    assets::MeshData m;
    m.positions = {{0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}};
    addTriangle(m, 0, 1, 2);
    addTriangle(m, 1, 0, 3);
    addTriangle(m, 0, 1, 4);
    const MeshDiagnostics d = clean(m).diagnostics;
    EXPECT_EQ(d.nonManifoldEdges, 1u);
    EXPECT_EQ(d.boundaryEdges, 6u);
    EXPECT_FALSE(d.closedManifold);
}

// Metric: a cube with one triangle flipped is still closed but has 3 inconsistent edges.
TEST(CleanMesh, CountsInconsistentlyOrientedEdges) {
    assets::MeshData m = test::box({0, 0, 0}, {1, 1, 1});
    std::swap(m.indices[1], m.indices[2]);
    const MeshDiagnostics d = clean(m).diagnostics;
    EXPECT_TRUE(d.closedManifold);
    EXPECT_EQ(d.inconsistentEdges, 3u);
}

// Metric: failure with a message naming the problem.
TEST(CleanMesh, RejectsInvalidInput) {
    CleanMesh out;
    std::string error;
    assets::MeshData empty;
    EXPECT_FALSE(cleanMesh(empty, out, error));
    EXPECT_NE(error.find("empty"), std::string::npos) << error;

    for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                      -std::numeric_limits<float>::infinity()}) {
        assets::MeshData m = test::box({0, 0, 0}, {1, 1, 1});
        m.positions[5].y = bad;
        error.clear();
        EXPECT_FALSE(cleanMesh(m, out, error));
        EXPECT_NE(error.find("vertex 5"), std::string::npos) << error;
        EXPECT_NE(error.find("non-finite"), std::string::npos) << error;
    }

    assets::MeshData m = test::box({0, 0, 0}, {1, 1, 1});
    m.indices[7] = 8;
    EXPECT_FALSE(cleanMesh(m, out, error));
    EXPECT_NE(error.find("triangle 2 references vertex 8"), std::string::npos) << error;

    m = test::box({0, 0, 0}, {1, 1, 1});
    m.indices.pop_back();
    EXPECT_FALSE(cleanMesh(m, out, error));
    EXPECT_NE(error.find("multiple of 3"), std::string::npos) << error;
}

// Metric: a mesh of only degenerate triangles cleans to zero triangles (bake() then reports it).
TEST(CleanMesh, AllDegenerate) {
    assets::MeshData m;
    m.positions = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
    addTriangle(m, 0, 1, 2);
    addTriangle(m, 0, 0, 1);
    const CleanMesh c = clean(m);
    EXPECT_EQ(c.diagnostics.triangles, 0u);
    EXPECT_EQ(c.diagnostics.degenerateTrianglesRemoved, 2u);
    EXPECT_TRUE(c.triangles.empty());
}

// Metric: the rings list exactly the triangles using each vertex, in increasing order; a closed
// icosphere has no boundary, non-manifold or inconsistent edges.
TEST(CleanMesh, VertexRings) {
    const CleanMesh c = clean(test::icosphere(2));
    ASSERT_EQ(c.ringStart.size(), c.positions.size() + 1);
    ASSERT_EQ(c.ringTriangles.size(), c.triangles.size() * 3);
    for (size_t v = 0; v < c.positions.size(); ++v) {
        std::vector<uint32_t> expected;
        for (size_t t = 0; t < c.triangles.size(); ++t) {
            const glm::uvec3& tri = c.triangles[t];
            if (tri.x == v || tri.y == v || tri.z == v) expected.push_back(static_cast<uint32_t>(t));
        }
        const std::vector<uint32_t> ring(c.ringTriangles.begin() + c.ringStart[v],
                                         c.ringTriangles.begin() + c.ringStart[v + 1]);
        EXPECT_EQ(ring, expected) << v;
    }
    EXPECT_TRUE(c.diagnostics.closedManifold);
    EXPECT_EQ(c.diagnostics.inconsistentEdges, 0u);
    EXPECT_FALSE(c.separateWinding);
}

// Metric: a flipped duplicate cancels in the winding triangles (net orientation), an equal copy
// stays; rings skip the removed duplicates and are renumbered.
TEST(CleanMesh, WindingTrianglesKeepNetOrientation) {
    assets::MeshData m = test::box({0, 0, 0}, {1, 1, 1});
    addTriangle(m, m.indices[2], m.indices[1], m.indices[0]);  // flipped copy of triangle 0
    addTriangle(m, m.indices[3], m.indices[4], m.indices[5]);  // equal copy of triangle 1
    const CleanMesh c = clean(m);
    EXPECT_EQ(c.diagnostics.duplicateTrianglesRemoved, 2u);
    EXPECT_EQ(c.diagnostics.oppositeDuplicateTriangles, 1u);
    EXPECT_EQ(c.triangles.size(), 12u);
    ASSERT_TRUE(c.separateWinding);
    // triangle 0 cancelled, triangle 1 twice, the other 10 once
    EXPECT_EQ(c.windingTriangles.size(), 12u);
    EXPECT_EQ(std::count(c.windingTriangles.begin(), c.windingTriangles.end(), c.triangles[0]), 0);
    EXPECT_EQ(std::count(c.windingTriangles.begin(), c.windingTriangles.end(), c.triangles[1]), 2);
    EXPECT_EQ(c.ringTriangles.size(), 36u);
}

// Metric: identical output (triangles, positions, rings, winding triangles, diagnostics) for 1 and
// 3 threads on a 327k-triangle sphere with duplicate, flipped, degenerate and merged-vertex extras
// (large enough to be split in parts).
TEST(CleanMesh, ThreadCountDoesNotChangeTheResult) {
    assets::MeshData m = test::icosphere(7);
    const size_t n = m.indices.size() / 3;
    for (size_t t = 0; t < n; t += 997) {
        const uint32_t a = m.indices[3 * t], b = m.indices[3 * t + 1], c = m.indices[3 * t + 2];
        if (t % 3 == 0) addTriangle(m, a, b, c);  // duplicate
        if (t % 3 == 1) addTriangle(m, a, c, b);  // flipped duplicate
        if (t % 3 == 2) addTriangle(m, a, a, b);  // degenerate
        m.positions.push_back(m.positions[a]);    // duplicate vertex, used by a copy
        addTriangle(m, static_cast<uint32_t>(m.positions.size() - 1), c, b);
    }
    CleanMesh one, three;
    std::string error;
    ASSERT_TRUE(cleanMesh(m, one, error, 1)) << error;
    ASSERT_TRUE(cleanMesh(m, three, error, 3)) << error;
    EXPECT_EQ(one.triangles, three.triangles);
    EXPECT_EQ(one.positions, three.positions);
    EXPECT_EQ(one.ringStart, three.ringStart);
    EXPECT_EQ(one.ringTriangles, three.ringTriangles);
    EXPECT_EQ(one.separateWinding, three.separateWinding);
    EXPECT_EQ(one.windingTriangles, three.windingTriangles);
    const MeshDiagnostics &a = one.diagnostics, &b = three.diagnostics;
    EXPECT_EQ(a.triangles, b.triangles);
    EXPECT_EQ(a.vertices, b.vertices);
    EXPECT_EQ(a.duplicateVerticesMerged, b.duplicateVerticesMerged);
    EXPECT_EQ(a.degenerateTrianglesRemoved, b.degenerateTrianglesRemoved);
    EXPECT_EQ(a.duplicateTrianglesRemoved, b.duplicateTrianglesRemoved);
    EXPECT_EQ(a.oppositeDuplicateTriangles, b.oppositeDuplicateTriangles);
    EXPECT_EQ(a.boundaryEdges, b.boundaryEdges);
    EXPECT_EQ(a.nonManifoldEdges, b.nonManifoldEdges);
    EXPECT_EQ(a.inconsistentEdges, b.inconsistentEdges);
    EXPECT_GT(a.duplicateTrianglesRemoved, 200u);
    EXPECT_GT(a.oppositeDuplicateTriangles, 100u);
    EXPECT_GT(a.degenerateTrianglesRemoved, 100u);
    EXPECT_GT(a.duplicateVerticesMerged, 300u);
    EXPECT_TRUE(one.separateWinding);
}

}  // namespace
