// glTF 2.0 (.gltf / .glb) as one raw mesh: every triangle primitive instanced by the default scene
// (or every root node), with node transforms applied. Parsing and validation (GLB container, JSON
// depth, confined URIs, bufferView / accessor ranges, node graph) are shared with the scene loader:
// see gltf_internal.h.
#include <algorithm>
#include <cstdint>

#include <fmt/format.h>
#include <glm/glm.hpp>

#include "engine/assets/gltf_internal.h"
#include "engine/assets/mesh.h"
#include "engine/assets/mesh_internal.h"

namespace penumbra::assets {
namespace {

class GltfExtractor {
public:
    GltfExtractor(const std::string& path, const tinygltf::Model& model, const MeshLoadLimits& limits,
                  MeshData& out)
        : m_path(path), m_model(model), m_limits(limits), m_out(out) {}

    bool run(std::string& error) {
        std::vector<int> parent;
        if (!gltf::checkBufferViews(m_path, m_model, error) ||
            !gltf::checkNodeGraph(m_path, m_model, parent, error)) {
            return false;
        }
        std::vector<int> roots;
        if (!gltf::chooseRoots(m_path, m_model, parent, roots, error) ||
            !checkInstancedTotals(roots, error)) {
            return false;
        }
        if (m_model.nodes.empty()) {
            // No nodes at all: every mesh once, untransformed.
            for (size_t m = 0; m < m_model.meshes.size(); ++m) {
                if (!addMesh(int(m), glm::dmat4(1.0), error)) {
                    return false;
                }
            }
        } else {
            struct Item {
                int node;
                glm::dmat4 parent;
            };
            std::vector<Item> stack;
            for (auto it = roots.rbegin(); it != roots.rend(); ++it) {
                stack.push_back({*it, glm::dmat4(1.0)});
            }
            while (!stack.empty()) {
                const Item item = stack.back();
                stack.pop_back();
                const tinygltf::Node& node = m_model.nodes[size_t(item.node)];
                gltf::NodeTransform local;
                if (!gltf::readNodeTransform(m_path, m_model, item.node, local, error)) {
                    return false;
                }
                const glm::dmat4 world = item.parent * local.toMatrix();
                if (node.mesh >= 0 && !addMesh(node.mesh, world, error)) {
                    return false;
                }
                for (auto c = node.children.rbegin(); c != node.children.rend(); ++c) {
                    stack.push_back({*c, world});
                }
            }
        }
        if (!m_allNormals) {
            m_out.normals.clear();
        }
        if (!m_allUvs) {
            m_out.uvs.clear();
        }
        return detail::validateMesh(m_out, m_limits, error);
    }

private:
    // Triangles and vertices one instance of a primitive adds, from its accessor counts (not yet
    // validated: readPrimitive checks them when it reads; an out-of-range accessor counts 0 here).
    void primitiveTotals(const tinygltf::Primitive& prim, uint64_t& triangles, uint64_t& vertices) const {
        triangles = vertices = 0;
        const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
        if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
            mode != TINYGLTF_MODE_TRIANGLE_FAN) {
            return;
        }
        auto countOf = [&](int accessor) -> uint64_t {
            return accessor >= 0 && size_t(accessor) < m_model.accessors.size()
                       ? uint64_t(m_model.accessors[size_t(accessor)].count)
                       : 0;
        };
        const auto pos = prim.attributes.find("POSITION");
        vertices = pos == prim.attributes.end() ? 0 : countOf(pos->second);
        const uint64_t indices = prim.indices >= 0 ? countOf(prim.indices) : vertices;
        triangles = mode == TINYGLTF_MODE_TRIANGLES ? indices / 3 : (indices >= 3 ? indices - 2 : 0);
    }

    // Instancing multiplies a mesh's triangles by the number of nodes that use it, so a small file
    // can ask for a huge merged mesh. Before anything is read or merged: the totals over every
    // instance against the limits (saturating arithmetic: accessor counts are not validated yet).
    bool checkInstancedTotals(const std::vector<int>& roots, std::string& error) const {
        std::vector<uint64_t> instances(m_model.meshes.size(), 0);
        uint64_t instanceCount = 0;
        if (m_model.nodes.empty()) {
            std::fill(instances.begin(), instances.end(), 1);
            instanceCount = instances.size();
        } else {
            std::vector<int> stack(roots.begin(), roots.end());
            while (!stack.empty()) {  // every node at most once (checkNodeGraph, chooseRoots)
                const tinygltf::Node& node = m_model.nodes[size_t(stack.back())];
                stack.pop_back();
                if (node.mesh >= 0) {
                    ++instances[size_t(node.mesh)];
                    ++instanceCount;
                }
                stack.insert(stack.end(), node.children.begin(), node.children.end());
            }
        }
        auto saturatingAdd = [](uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; };
        auto saturatingMul = [](uint64_t a, uint64_t b) {
            return b != 0 && a > UINT64_MAX / b ? UINT64_MAX : a * b;
        };
        uint64_t triangles = 0, vertices = 0;
        for (size_t m = 0; m < m_model.meshes.size(); ++m) {
            if (instances[m] == 0) {
                continue;
            }
            for (const tinygltf::Primitive& prim : m_model.meshes[m].primitives) {
                uint64_t t = 0, v = 0;
                primitiveTotals(prim, t, v);
                triangles = saturatingAdd(triangles, saturatingMul(t, instances[m]));
                vertices = saturatingAdd(vertices, saturatingMul(v, instances[m]));
            }
        }
        if (triangles <= m_limits.maxTriangles && vertices <= m_limits.maxVertices) {
            return true;
        }
        // Merged size: position, normal and uv per vertex (32 bytes), three indices per triangle.
        const double mib = (double(vertices) * 32.0 + double(triangles) * 12.0) / double(1u << 20);
        const bool tooManyTriangles = triangles > m_limits.maxTriangles;
        error = fmt::format(
            "{}: the scene instances {} mesh{} with {} triangles and {} vertices in total (about {:.1f} MiB "
            "merged), which exceeds the limit of {} {}; raise {} if this is intended",
            m_path, instanceCount, instanceCount == 1 ? "" : "es", triangles, vertices, mib,
            tooManyTriangles ? m_limits.maxTriangles : m_limits.maxVertices,
            tooManyTriangles ? "triangles" : "vertices",
            tooManyTriangles
                ? "the triangle limit (MeshLoadLimits::maxTriangles, penumbra bake --max-triangles)"
                : "MeshLoadLimits::maxVertices");
        return false;
    }

    bool addMesh(int meshIndex, const glm::dmat4& world, std::string& error) {
        const tinygltf::Mesh& mesh = m_model.meshes[size_t(meshIndex)];
        const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(glm::dmat3(world)));
        const bool flip = glm::determinant(glm::dmat3(world)) < 0.0;
        for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
            gltf::PrimitiveData prim;
            const uint64_t vertexBudget = m_limits.maxVertices - m_out.positions.size();
            if (!gltf::readPrimitive(m_path, m_model, meshIndex, pi, m_limits, vertexBudget, m_allNormals,
                                     m_allUvs, prim, error)) {
                return false;
            }
            if (!prim.triangles) {
                continue;  // points and lines carry no surface
            }
            const std::vector<uint32_t>& tris = prim.indices;
            if (m_out.indices.size() / 3 + tris.size() / 3 > m_limits.maxTriangles) {
                error = fmt::format("{}: more than {} triangles (limit)", m_path, m_limits.maxTriangles);
                return false;
            }
            const std::vector<float>& pos = prim.positions;
            const std::vector<float>& nrm = prim.normals;
            const std::vector<float>& uv = prim.uvs;
            const size_t vcount = pos.size() / 3;

            const uint32_t baseVertex = uint32_t(m_out.positions.size());
            for (size_t v = 0; v < vcount; ++v) {
                const glm::dvec4 p = world * glm::dvec4(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2], 1.0);
                m_out.positions.emplace_back(float(p.x), float(p.y), float(p.z));
            }
            if (m_allNormals) {
                if (nrm.empty()) {
                    m_allNormals = false;
                    m_out.normals.clear();
                } else {
                    for (size_t v = 0; v < vcount; ++v) {
                        glm::dvec3 n = normalMatrix * glm::dvec3(nrm[3 * v], nrm[3 * v + 1], nrm[3 * v + 2]);
                        const double len = glm::length(n);
                        n = len > 0.0 ? n / len : n;
                        m_out.normals.emplace_back(float(n.x), float(n.y), float(n.z));
                    }
                }
            }
            if (m_allUvs) {
                if (uv.empty()) {
                    m_allUvs = false;
                    m_out.uvs.clear();
                } else {
                    for (size_t v = 0; v < vcount; ++v) {
                        m_out.uvs.emplace_back(uv[2 * v], uv[2 * v + 1]);
                    }
                }
            }
            for (size_t t = 0; t + 2 < tris.size(); t += 3) {
                m_out.indices.push_back(baseVertex + tris[t]);
                m_out.indices.push_back(baseVertex + (flip ? tris[t + 2] : tris[t + 1]));
                m_out.indices.push_back(baseVertex + (flip ? tris[t + 1] : tris[t + 2]));
            }
        }
        return true;
    }

    const std::string& m_path;
    const tinygltf::Model& m_model;
    const MeshLoadLimits& m_limits;
    MeshData& m_out;
    bool m_allNormals = true;
    bool m_allUvs = true;
};

bool loadGltfImpl(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits) {
    gltf::ParseOptions options;
    options.maxFileBytes = limits.maxFileBytes;
    gltf::ParsedGltf parsed;
    if (!gltf::parseGltfFile(path, options, parsed, error)) {
        return false;
    }
    GltfExtractor extractor(path, parsed.model, limits, out);
    return extractor.run(error);
}

}  // namespace

bool loadGltfMesh(const std::string& path, MeshData& out, std::string& error, const MeshLoadLimits& limits) {
    out = MeshData{};
    out.sourcePath = path;
    bool ok = false;
    try {
        ok = loadGltfImpl(path, out, error, limits);
    } catch (const std::exception& e) {
        error = fmt::format("{}: cannot load glTF: {}", path, e.what());
        ok = false;
    }
    if (!ok) {
        out = MeshData{};
        out.sourcePath = path;
    }
    return ok;
}

}  // namespace penumbra::assets
