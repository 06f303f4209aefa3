// A dense signed distance grid: the baker's output and the .psdf asset's payload.
// Sample i,j,k sits at the voxel centre origin + (i + 0.5, j + 0.5, k + 0.5) * voxelSize, in the
// source mesh's own coordinates and units. Negative = inside.
#pragma once

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

namespace penumbra::sdf {

// Grids whose distances 32-bit floats can hold (the baker refuses to make others, .psdf readers
// and writers refuse them): the voxel size is at least the smallest normal float, so every stored
// distance keeps an absolute precision of 2^-24 voxel or better, and the grid's diagonal (the
// largest distance between a voxel centre and a mesh inside the grid) is at most the largest float.
inline constexpr double kMinVoxelSize = FLT_MIN;     // 1.17549435e-38
inline constexpr double kMaxGridDiagonal = FLT_MAX;  // 3.40282347e+38
// Length of the diagonal of a dims * voxelSize box (inf or NaN for unrepresentable input).
inline double gridDiagonal(const glm::uvec3& dims, double voxelSize) {
    return voxelSize * std::sqrt(double(dims.x) * dims.x + double(dims.y) * dims.y + double(dims.z) * dims.z);
}
inline bool gridRangeRepresentable(const glm::uvec3& dims, double voxelSize) {
    return voxelSize >= kMinVoxelSize && gridDiagonal(dims, voxelSize) <= kMaxGridDiagonal;
}

struct SdfGrid {
    glm::uvec3 dims{0, 0, 0};
    glm::dvec3 origin{0, 0, 0};  // minimum corner of voxel (0,0,0); double: meshes far from the origin
    double voxelSize = 0;
    std::vector<float> distances;  // x fastest, then y, then z

    size_t index(uint32_t i, uint32_t j, uint32_t k) const { return (size_t(k) * dims.y + j) * dims.x + i; }
    glm::dvec3 voxelCenter(uint32_t i, uint32_t j, uint32_t k) const {
        return origin + (glm::dvec3(i, j, k) + 0.5) * voxelSize;
    }
    bool empty() const { return distances.empty(); }
};

}  // namespace penumbra::sdf
