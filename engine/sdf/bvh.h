// Bounding-volume hierarchy over a triangle mesh for exact closest-point queries.
//
// Build: triangles sorted by the 30-bit Morton code of their box centre (radix sort); a node's
// range is split where the highest differing code bit changes (a spatial-median split; equal codes
// are halved), and the largest part split again until the node has four children, whose bounds it
// holds side by side (one SIMD evaluation per node visit). So the build is a sort plus linear
// passes.
//
// Bounds of a child: its box (float, holding the stored vertices) and, for children of up to
// kPancakeTriangles triangles whose normals roughly agree, a "pancake": a capped cylinder around
// the box centre with the mean normal as axis. For a nearly flat patch it is a thin disk whose
// distance grows with the lateral offset where the box's does not, so a query point far from the
// surface prunes all but the patch it faces.
//
// Triangles are copied into per-leaf packets as float coordinates in the caller's frame (pass
// positions relative to the mesh centre: float then perturbs them by at most 6e-8 of the mesh's
// extent). A leaf's four triangles are first measured together in float (branch-free, SIMD) and
// only those that can beat the current best are measured exactly, in double. Queries take an initial upper
// bound (or a seed triangle, typically the previous voxel's closest triangle) and return the exact closest
// point, its triangle and the triangle feature (face / edge / vertex) that holds it.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include <glm/vec3.hpp>

#include "engine/sdf/distance.h"

namespace penumbra::sdf {

struct ClosestHit {
    double distance = std::numeric_limits<double>::infinity();
    glm::dvec3 point{0};
    uint32_t triangle = UINT32_MAX;  // index into the triangle array given to build()
    TriangleFeature feature = TriangleFeature::Face;
};

// Optional per-query work counters (benchmarks, tests).
struct BvhQueryStats {
    uint64_t nodesVisited = 0;  // 4-wide nodes
    uint64_t trianglesTested = 0;
};

class TriangleBvh {
public:
    static constexpr uint32_t kPancakeTriangles =
        1024;  // leaves of up to this many triangles (a multiple of 4)
    static constexpr uint32_t kMaxLeafTriangles = 4;
    static constexpr uint32_t kEmptyLane = UINT32_MAX;  // Node4::child of an unused lane

    // Builds over the given mesh (copied; the arrays need not outlive the BVH). threads = 0 uses
    // the hardware concurrency. Triangles must reference valid positions.
    void build(const std::vector<glm::dvec3>& positions, const std::vector<glm::uvec3>& triangles,
               uint32_t threads = 1);

    // Closest point on any triangle within maxDistance of p (inclusive). False if there is none
    // (or the BVH is empty); hit is then left unchanged.
    bool closest(const glm::dvec3& p, double maxDistance, ClosestHit& hit,
                 BvhQueryStats* stats = nullptr) const;

    // Closest point on the mesh, starting the search with the exact distance to triangle `seed`
    // (an index into the build() triangles; out-of-range seeds are ignored) as the upper bound.
    ClosestHit closestSeeded(const glm::dvec3& p, uint32_t seed, BvhQueryStats* stats = nullptr) const;

    // Sum over the triangles that the ray origin + t * direction (t > 0) crosses of +1 where it
    // leaves through the front (counter-clockwise) side and -1 where it enters through it. For a
    // closed, consistently oriented mesh this is the winding number at origin; a ray through an
    // edge or a vertex can miscount, so callers take the median of several directions. The
    // direction must have no zero component.
    int signedCrossings(const glm::dvec3& origin, const glm::dvec3& direction) const;

    bool empty() const { return m_nodes.empty(); }
    size_t nodeCount() const { return m_nodes.size(); }
    size_t leafCount() const { return m_packets.size(); }
    size_t triangleCount() const { return m_slotOf.size(); }
    uint32_t depth() const { return m_depth; }  // levels of 4-wide nodes below the root

    // Four children's bounds, structure of arrays. Child c: count[c] == 0 -> node index
    // child[c]; count[c] > 0 -> leaf packet child[c] holding count[c] triangles; unused slots have
    // child[c] == kEmptyLane (and an empty box far away, 1e30). Pancake: axis 0, radius 0 and an
    // infinite axial range when absent.
    struct alignas(16) Node4 {
        float minX[4], minY[4], minZ[4], maxX[4], maxY[4], maxZ[4];
        float axisX[4], axisY[4], axisZ[4], radius[4], axialMin[4], axialMax[4];
        uint32_t child[4], count[4];
    };

    // A leaf's (up to four) triangles, structure of arrays; unused lanes have all corners at 1e30.
    // Slot 4 * packet + lane names one triangle.
    struct alignas(16) LeafPacket {
        float ax[4], ay[4], az[4], bx[4], by[4], bz[4], cx[4], cy[4], cz[4];
    };

private:
    void traverse(const glm::dvec3& p, double& bestSquared, ClosestHit& hit, bool& found,
                  BvhQueryStats* stats) const;

    std::vector<Node4> m_nodes;
    std::vector<LeafPacket> m_packets;    // leaf lanes: child = packet index, count = triangles
    std::vector<uint32_t> m_triangleIds;  // slot -> input triangle index (UINT32_MAX: unused lane)
    std::vector<uint32_t> m_slotOf;       // input triangle index -> slot
    double m_coordinateScale = 0;         // max |coordinate| of the mesh (float-bound slack)
    uint32_t m_depth = 0;
};

}  // namespace penumbra::sdf
