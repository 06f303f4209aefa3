// A dense signed distance grid: the baker's output and the .psdf asset's payload.
// Sample i,j,k sits at the voxel centre origin + (i + 0.5, j + 0.5, k + 0.5) * voxelSize, in the
// source mesh's own coordinates and units. Negative = inside.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

namespace penumbra::sdf {

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
