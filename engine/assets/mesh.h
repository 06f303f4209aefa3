// Raw triangle meshes as loaded from files (PLY, OBJ, glTF/GLB), in the file's own coordinates
// and units. Loaders validate everything (see shared/design.md "Malformed-asset policy") and never
// crash: on bad input they return false with one message naming the file, the element and why.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace penumbra::assets {

struct MeshData {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;  // empty or one per position
    std::vector<glm::vec2> uvs;      // empty or one per position
    std::vector<uint32_t> indices;   // triangle list, 3 per triangle, each < positions.size()
    std::string sourcePath;

    size_t triangleCount() const { return indices.size() / 3; }
};

// Caps on what one load may produce, checked before the memory is allocated. For glTF they apply
// to the merged mesh, i.e. to the totals over every node instance (counted before merging).
struct MeshLoadLimits {
    uint64_t maxFileBytes = 256ull << 20;  // whole-file cap
    uint64_t maxVertices = 64ull << 20;
    uint64_t maxTriangles = 16ull << 20;  // 16 Mi: 192 MiB of indices (penumbra bake --max-triangles)
};

// Loads by extension: .ply (ascii / binary little and big endian), .obj, .gltf, .glb. Polygons are
// triangulated (fans); glTF: every triangle primitive of every mesh instanced by the default scene
// (or all nodes if none), with node transforms applied. Positions must be finite.
bool loadMesh(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits = {});

bool loadPly(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits = {});
bool loadObj(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits = {});
bool loadGltfMesh(const std::string& path, MeshData& out, std::string& error,
                  const MeshLoadLimits& limits = {});

// Writers used by tools and tests (binary little-endian PLY, OBJ).
bool writePly(const std::string& path, const MeshData& mesh, std::string& error);
bool writeObj(const std::string& path, const MeshData& mesh, std::string& error);

}  // namespace penumbra::assets
