// Pieces shared by the glTF mesh loader (gltf_loader.cpp) and the glTF scene loader
// (gltf_scene.cpp), implemented in gltf_common.cpp (internal to engine/assets):
//  - parseGltfFile(): the whole-file cap, the GLB container check, the JSON depth cap, the URI
//    checks and tinygltf with file-system callbacks confined to the asset's directory; images are
//    never decoded by tinygltf (their encoded bytes can be collected instead),
//  - overflow-safe validation of bufferViews, accessors (types, strides, ranges, sparse data,
//    finiteness) and the node graph (child indices, two parents, cycles),
//  - node transforms and triangle primitives read through those checks.
// Every message starts with "<path>: ".
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <tiny_gltf.h>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

#include "engine/assets/mesh.h"

namespace penumbra::assets::gltf {

struct ParseOptions {
    uint64_t maxFileBytes = 0;
    bool collectImages = false;  // keep the encoded bytes of uri / data: images (see ParsedGltf)
    bool keepJson = false;       // keep the document as nlohmann::json (extensions tinygltf drops)
    bool hashContent = false;    // compute AssetManager::contentHash of the file bytes
};

struct ParsedGltf {
    tinygltf::Model model;
    nlohmann::json json;      // with keepJson
    std::string contentHash;  // with hashContent
    // With collectImages: per image index, the encoded bytes of images given by a uri (data: or a
    // file read through the confined callbacks); `imageRead[i]` is 0 when none were delivered (a
    // bufferView image, whose bytes come from the validated bufferView, or an unreadable file).
    std::vector<std::vector<uint8_t>> imageBytes;
    std::vector<char> imageRead;
};

// Reads, checks and parses a .gltf / .glb file. False with one message on any failure.
bool parseGltfFile(const std::string& path, const ParseOptions& options, ParsedGltf& out, std::string& error);

// error = "<path>: <message>"; returns false.
bool fail(const std::string& path, std::string& error, std::string_view message);

// Every bufferView lies inside its buffer.
bool checkBufferViews(const std::string& path, const tinygltf::Model& model, std::string& error);

// Node mesh indices and child indices in range, one parent per node, no cycles. Fills `parent`
// (-1 for roots).
bool checkNodeGraph(const std::string& path, const tinygltf::Model& model, std::vector<int>& parent,
                    std::string& error);

// The root nodes to instance: the default scene's, else scene 0's, else every node without a parent.
// A scene listing a node twice is refused (the schema requires unique roots), so with
// checkNodeGraph every node is instanced at most once.
bool chooseRoots(const std::string& path, const tinygltf::Model& model, const std::vector<int>& parent,
                 std::vector<int>& roots, std::string& error);

// A node's local transform as written in the file: a matrix, or translation / rotation / scale.
struct NodeTransform {
    bool isMatrix = false;
    glm::dmat4 matrix{1.0};  // with isMatrix (column-major, as in glTF)
    glm::dvec3 translation{0.0};
    glm::dquat rotation{1.0, 0.0, 0.0, 0.0};  // normalised
    glm::dvec3 scale{1.0};

    glm::dmat4 toMatrix() const;
};

// Reads and checks (sizes, finiteness, non-zero quaternion) node `index`'s transform.
bool readNodeTransform(const std::string& path, const tinygltf::Model& model, int index, NodeTransform& out,
                       std::string& error);

enum class Role { Position, Normal, TexCoord, Indices };

// Reads accessors with full validation.
class AccessorReader {
public:
    AccessorReader(const std::string& path, const tinygltf::Model& model) : m_path(path), m_model(model) {}

    // Reads accessor `index` as `role`: validates types, ranges and sparse data; returns the
    // components as floats (attributes) or the values as indices.
    bool read(int index, Role role, uint64_t maxCount, std::vector<float>& floats,
              std::vector<uint32_t>& ints, std::string& error) const;

private:
    bool applySparse(int index, const tinygltf::Accessor& acc, uint64_t elem, std::vector<unsigned char>& raw,
                     std::string& error) const;
    bool sparseView(int index, const char* what, int view, int offset, uint64_t count, uint64_t elem,
                    const unsigned char*& data, std::string& error) const;

    const std::string& m_path;
    const tinygltf::Model& m_model;
};

// One primitive's vertex data and triangle-list indices (strips and fans converted, in the
// primitive's own space).
struct PrimitiveData {
    bool triangles = false;         // false: points or lines (no surface; nothing else is filled)
    std::vector<float> positions;   // 3 per vertex
    std::vector<float> normals;     // 3 per vertex, or empty
    std::vector<float> uvs;         // 2 per vertex (TEXCOORD_0), or empty
    std::vector<uint32_t> indices;  // 3 per triangle, each < vertex count
};

// Reads primitive `primIndex` of mesh `meshIndex`. NORMAL / TEXCOORD_0 are read only when wanted.
// `vertexBudget` caps the vertex count of the attributes read; the index count is capped by the
// triangle limit.
bool readPrimitive(const std::string& path, const tinygltf::Model& model, int meshIndex, size_t primIndex,
                   const MeshLoadLimits& limits, uint64_t vertexBudget, bool wantNormals, bool wantUvs,
                   PrimitiveData& out, std::string& error);

}  // namespace penumbra::assets::gltf
