// Small meshes built in code and brute-force references for the baker tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "engine/assets/mesh.h"
#include "engine/sdf/sdf_grid.h"

namespace penumbra::sdf::test {

inline void addTriangle(assets::MeshData& m, uint32_t a, uint32_t b, uint32_t c) {
    m.indices.insert(m.indices.end(), {a, b, c});
}

// Axis-aligned box, 8 shared vertices, 12 outward-facing (counter-clockwise) triangles.
inline assets::MeshData box(glm::vec3 lo, glm::vec3 hi) {
    assets::MeshData m;
    for (int k = 0; k < 8; ++k) {
        m.positions.push_back(glm::vec3(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z));
    }
    const uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                  {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : faces) {
        addTriangle(m, f[0], f[1], f[2]);
        addTriangle(m, f[0], f[2], f[3]);
    }
    return m;
}

inline void append(assets::MeshData& dst, const assets::MeshData& src) {
    const uint32_t base = static_cast<uint32_t>(dst.positions.size());
    dst.positions.insert(dst.positions.end(), src.positions.begin(), src.positions.end());
    for (uint32_t i : src.indices) dst.indices.push_back(base + i);
}

// Icosphere (subdivided icosahedron projected on the sphere), outward orientation.
inline assets::MeshData icosphere(int subdivisions, float radius = 1.0f, glm::vec3 centre = glm::vec3(0)) {
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    std::vector<glm::dvec3> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                                 {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
    for (auto& p : v) p = glm::normalize(p);
    std::vector<glm::uvec3> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    for (int s = 0; s < subdivisions; ++s) {
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
        auto midpoint = [&](uint32_t a, uint32_t b) {
            const auto key = std::minmax(a, b);
            auto it = mid.find(key);
            if (it != mid.end()) return it->second;
            v.push_back(glm::normalize(v[a] + v[b]));
            const uint32_t id = static_cast<uint32_t>(v.size() - 1);
            mid.emplace(key, id);
            return id;
        };
        std::vector<glm::uvec3> next;
        for (const auto& tri : f) {
            const uint32_t a = midpoint(tri.x, tri.y), b = midpoint(tri.y, tri.z), c = midpoint(tri.z, tri.x);
            next.insert(next.end(), {{tri.x, a, c}, {tri.y, b, a}, {tri.z, c, b}, {a, b, c}});
        }
        f = std::move(next);
    }
    assets::MeshData m;
    for (const auto& p : v) m.positions.push_back(glm::vec3(p * double(radius)) + centre);
    for (const auto& tri : f) addTriangle(m, tri.x, tri.y, tri.z);
    return m;
}

// Removes every triangle whose centroid has z > zCut (an open "bowl").
inline assets::MeshData cutAbove(const assets::MeshData& in, float zCut) {
    assets::MeshData m;
    m.positions = in.positions;
    for (size_t t = 0; t < in.indices.size() / 3; ++t) {
        const float z = (in.positions[in.indices[3 * t]].z + in.positions[in.indices[3 * t + 1]].z +
                         in.positions[in.indices[3 * t + 2]].z) /
                        3.0f;
        if (z <= zCut) addTriangle(m, in.indices[3 * t], in.indices[3 * t + 1], in.indices[3 * t + 2]);
    }
    return m;
}

// Reference point-triangle distance, independent of the region tests under test: the distance to
// the plane if the projection lies inside (same-side tests), else the best of the three segments.
inline double segmentDistance(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
    const glm::dvec3 ab = b - a;
    const double len2 = glm::dot(ab, ab);
    double t = len2 > 0 ? glm::dot(p - a, ab) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    return glm::length(p - (a + t * ab));
}

inline double referenceTriangleDistance(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                        const glm::dvec3& c) {
    const glm::dvec3 n = glm::cross(b - a, c - a);
    const double n2 = glm::dot(n, n);
    double best = std::min({segmentDistance(p, a, b), segmentDistance(p, b, c), segmentDistance(p, c, a)});
    if (n2 > 0) {
        const glm::dvec3 q = p - n * (glm::dot(p - a, n) / n2);
        const double s0 = glm::dot(glm::cross(b - a, q - a), n);
        const double s1 = glm::dot(glm::cross(c - b, q - b), n);
        const double s2 = glm::dot(glm::cross(a - c, q - c), n);
        if (s0 >= 0 && s1 >= 0 && s2 >= 0) best = std::min(best, glm::length(p - q));
    }
    return best;
}

// Brute-force unsigned distance from p (world coordinates) to a mesh.
inline double bruteForceDistance(const assets::MeshData& m, const glm::dvec3& p) {
    double best = INFINITY;
    for (size_t t = 0; t < m.indices.size() / 3; ++t) {
        const glm::dvec3 a(m.positions[m.indices[3 * t]]), b(m.positions[m.indices[3 * t + 1]]),
            c(m.positions[m.indices[3 * t + 2]]);
        best = std::min(best, referenceTriangleDistance(p, a, b, c));
    }
    return best;
}

// Largest |stored| - exact distance over all voxels, in voxels.
inline double maxDistanceErrorVoxels(const assets::MeshData& m, const SdfGrid& g) {
    double worst = 0;
    for (uint32_t k = 0; k < g.dims.z; ++k) {
        for (uint32_t j = 0; j < g.dims.y; ++j) {
            for (uint32_t i = 0; i < g.dims.x; ++i) {
                const double exact = bruteForceDistance(m, g.voxelCenter(i, j, k));
                worst = std::max(worst, std::abs(std::abs(double(g.distances[g.index(i, j, k)])) - exact));
            }
        }
    }
    return worst / g.voxelSize;
}

}  // namespace penumbra::sdf::test
