// Mesh clean-up and topology diagnostics for the baker: merges duplicate vertices, removes
// degenerate and duplicate triangles, counts boundary and non-manifold edges. Works in double
// precision relative to the mesh's bounding-box centre so meshes far from the origin keep their
// precision.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "engine/assets/mesh.h"

namespace penumbra::sdf {

struct MeshDiagnostics {
    uint64_t inputTriangles = 0;
    uint64_t inputVertices = 0;
    uint64_t triangles = 0;  // after clean-up
    uint64_t vertices = 0;   // after merging
    uint64_t duplicateVerticesMerged = 0;
    uint64_t degenerateTrianglesRemoved = 0;  // zero area (incl. repeated vertex indices)
    uint64_t duplicateTrianglesRemoved = 0;   // same three vertices as an earlier triangle
    uint64_t boundaryEdges = 0;               // edges used by exactly one triangle
    uint64_t nonManifoldEdges = 0;            // edges used by more than two triangles
    bool closedManifold = false;              // no boundary and no non-manifold edges
    uint64_t inconsistentEdges = 0;           // two-triangle edges traversed in the same direction by both
    uint64_t oppositeDuplicateTriangles = 0;  // of the duplicates: the ones with flipped orientation
    // Sum over the kept triangles (a, b, c) of a . (b x c) / 6, about the bounds centre: for a closed,
    // consistently oriented mesh the enclosed volume, negative when its triangles face inward.
    double signedVolume = 0;
    // Closed manifold, no inconsistent edges and signedVolume < 0: the whole mesh is inside out.
    bool inwardOriented = false;
    glm::dvec3 boundsMin{0}, boundsMax{0};
};

// A cleaned mesh in local double coordinates: world = center + local.
struct CleanMesh {
    glm::dvec3 center{0};
    std::vector<glm::dvec3> positions;
    std::vector<glm::uvec3> triangles;
    MeshDiagnostics diagnostics;
    // Triangles around each vertex (compressed rows): ringTriangles[ringStart[v] .. ringStart[v + 1]).
    std::vector<uint32_t> ringStart;
    std::vector<uint32_t> ringTriangles;
    // For inside/outside tests: the input's non-degenerate triangles with duplicates reduced to
    // their net orientation (a triangle and its flipped copy cancel, two equal copies stay two),
    // so its winding number equals the input's everywhere. Only set when that differs from
    // `triangles` (separateWinding; it may then be empty: everything cancelled).
    bool separateWinding = false;
    std::vector<glm::uvec3> windingTriangles;
};

// Fails (false + error) on an empty mesh, NaN/inf coordinates, or indices out of range.
bool cleanMesh(const assets::MeshData& mesh, CleanMesh& out, std::string& error);
// The same on `threads` threads (0 = hardware concurrency); the result does not depend on it.
bool cleanMesh(const assets::MeshData& mesh, CleanMesh& out, std::string& error, uint32_t threads);

}  // namespace penumbra::sdf
