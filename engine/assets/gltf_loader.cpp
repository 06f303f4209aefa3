// glTF 2.0 (.gltf / .glb) as one raw mesh: every triangle primitive instanced by the default scene
// (or every root node), with node transforms applied. Parsing and validation (GLB container, JSON
// depth, confined URIs, bufferView / accessor ranges, node graph) are shared with the scene loader:
// see gltf_internal.h.
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
        if (!gltf::chooseRoots(m_path, m_model, parent, roots, error)) {
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
