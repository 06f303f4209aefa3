// Wavefront OBJ through Debian's tinyobjloader (the shared library provides the implementation).
// The file is read here (size cap, directory and missing-file checks) and handed over as a stream;
// materials are never opened (mesh-only loader, and `mtllib ../../x` must not read outside files).
// tinyobjloader does not range-check face indices, so its output is validated before use.
#include <istream>
#include <streambuf>

#include <fmt/format.h>
#include <tiny_obj_loader.h>

#include "engine/assets/mesh.h"
#include "engine/assets/mesh_internal.h"

namespace penumbra::assets {
namespace {

// Read-only stream over the bytes already in memory.
class MemoryBuffer : public std::streambuf {
public:
    MemoryBuffer(char* begin, size_t size) { setg(begin, begin, begin + size); }
};

class NoMaterials : public tinyobj::MaterialReader {
public:
    bool operator()(const std::string&, std::vector<tinyobj::material_t>*, std::map<std::string, int>*,
                    std::string*, std::string*) override {
        return true;
    }
};

std::string firstLine(const std::string& s) {
    std::string line = s.substr(0, s.find('\n'));
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) {
        line.pop_back();
    }
    return line;
}

bool loadObjImpl(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits) {
    detail::FileBytes bytes;
    if (!detail::readWholeFile(path, limits.maxFileBytes, bytes, error)) {
        return false;
    }
    MemoryBuffer buffer(bytes.data(), bytes.size());
    std::istream stream(&buffer);
    tinyobj::attrib_t attrib;
    std::vector<tinyobj::shape_t> shapes;
    std::vector<tinyobj::material_t> materials;
    std::string warn;
    std::string err;
    NoMaterials noMaterials;
    if (!tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &stream, &noMaterials, false, false)) {
        error = fmt::format("{}: invalid OBJ: {}", path,
                            err.empty() ? std::string("parse error") : firstLine(err));
        return false;
    }

    if (attrib.vertices.size() % 3 != 0) {
        error = fmt::format("{}: invalid OBJ: vertex array size {} is not a multiple of 3", path,
                            attrib.vertices.size());
        return false;
    }
    const size_t vertexCount = attrib.vertices.size() / 3;
    if (vertexCount > limits.maxVertices) {
        error = fmt::format("{}: too many vertices ({}, limit {})", path, vertexCount, limits.maxVertices);
        return false;
    }
    const size_t normalCount = attrib.normals.size() / 3;
    const size_t uvCount = attrib.texcoords.size() / 2;

    out.positions.resize(vertexCount);
    for (size_t i = 0; i < vertexCount; ++i) {
        out.positions[i] =
            glm::vec3(attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]);
    }

    // Normals and texture coordinates are indexed per face corner in OBJ; they are kept (one per
    // position, from the first corner that references the position) only when every corner has one.
    bool allNormals = normalCount > 0;
    bool allUvs = uvCount > 0;
    std::vector<int> cornerNormal(allNormals ? vertexCount : 0, -1);
    std::vector<int> cornerUv(allUvs ? vertexCount : 0, -1);

    size_t faceNumber = 0;
    for (const tinyobj::shape_t& shape : shapes) {
        const tinyobj::mesh_t& mesh = shape.mesh;
        size_t cornerTotal = 0;
        for (unsigned char n : mesh.num_face_vertices) {
            cornerTotal += n;
        }
        if (cornerTotal != mesh.indices.size()) {
            error = fmt::format(
                "{}: invalid OBJ: shape '{}' has inconsistent face data (a face with more than 255 "
                "vertices?)",
                path, shape.name);
            return false;
        }
        size_t corner = 0;
        for (unsigned char n : mesh.num_face_vertices) {
            ++faceNumber;
            for (size_t k = 0; k < n; ++k) {
                const tinyobj::index_t& idx = mesh.indices[corner + k];
                if (idx.vertex_index < 0 || size_t(idx.vertex_index) >= vertexCount) {
                    error =
                        fmt::format("{}: face {} references vertex index {} out of range (vertex count {})",
                                    path, faceNumber, int64_t(idx.vertex_index) + 1, vertexCount);
                    return false;
                }
                const size_t v = size_t(idx.vertex_index);
                if (allNormals) {
                    if (idx.normal_index < 0 || size_t(idx.normal_index) >= normalCount) {
                        allNormals = false;
                    } else if (cornerNormal[v] < 0) {
                        cornerNormal[v] = idx.normal_index;
                    }
                }
                if (allUvs) {
                    if (idx.texcoord_index < 0 || size_t(idx.texcoord_index) >= uvCount) {
                        allUvs = false;
                    } else if (cornerUv[v] < 0) {
                        cornerUv[v] = idx.texcoord_index;
                    }
                }
            }
            if (n >= 3) {
                if (out.indices.size() / 3 + (n - 2) > limits.maxTriangles) {
                    error = fmt::format("{}: more than {} triangles (limit)", path, limits.maxTriangles);
                    return false;
                }
                const uint32_t first = uint32_t(mesh.indices[corner].vertex_index);
                for (size_t k = 1; k + 1 < n; ++k) {
                    out.indices.push_back(first);
                    out.indices.push_back(uint32_t(mesh.indices[corner + k].vertex_index));
                    out.indices.push_back(uint32_t(mesh.indices[corner + k + 1].vertex_index));
                }
            }
            corner += n;
        }
    }
    if (out.indices.empty()) {
        error =
            fmt::format("{}: no faces found: not an OBJ mesh ({} vertices, 0 triangles)", path, vertexCount);
        return false;
    }

    if (allNormals) {
        out.normals.resize(vertexCount, glm::vec3(0.0f));
        for (size_t v = 0; v < vertexCount; ++v) {
            if (cornerNormal[v] >= 0) {
                const size_t n = size_t(cornerNormal[v]);
                out.normals[v] =
                    glm::vec3(attrib.normals[3 * n], attrib.normals[3 * n + 1], attrib.normals[3 * n + 2]);
            }
        }
    }
    if (allUvs) {
        out.uvs.resize(vertexCount, glm::vec2(0.0f));
        for (size_t v = 0; v < vertexCount; ++v) {
            if (cornerUv[v] >= 0) {
                const size_t t = size_t(cornerUv[v]);
                out.uvs[v] = glm::vec2(attrib.texcoords[2 * t], attrib.texcoords[2 * t + 1]);
            }
        }
    }
    return detail::validateMesh(out, limits, error);
}

}  // namespace

bool loadObj(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits) {
    out = MeshData{};
    out.sourcePath = path;
    bool ok = false;
    try {
        ok = loadObjImpl(path, out, error, limits);
    } catch (const std::exception& e) {
        error = fmt::format("{}: cannot load OBJ: {}", path, e.what());
        ok = false;
    }
    if (!ok) {
        out = MeshData{};
        out.sourcePath = path;
    }
    return ok;
}

}  // namespace penumbra::assets
