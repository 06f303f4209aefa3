#include "renderer/features/scene_upload.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <shaders/deferred_lighting.h>
#include <shaders/gbuffer_mesh.h>

namespace penumbra::render {
namespace {

// The CPU mirrors of gpu_scene.h against the structs shaderc generated from scene.glsl.
#define PENUMBRA_SAME_LAYOUT(Cpu, Gpu, member)                    \
    static_assert(offsetof(Cpu, member) == offsetof(Gpu, member), \
                  #Cpu "::" #member " differs from the shader")
static_assert(sizeof(GpuScene) == sizeof(shaders::deferred_lighting::Scene));
PENUMBRA_SAME_LAYOUT(GpuScene, shaders::deferred_lighting::Scene, ambient);
PENUMBRA_SAME_LAYOUT(GpuScene, shaders::deferred_lighting::Scene, background);
PENUMBRA_SAME_LAYOUT(GpuScene, shaders::deferred_lighting::Scene, params);
PENUMBRA_SAME_LAYOUT(GpuScene, shaders::deferred_lighting::Scene, ambientSky);
PENUMBRA_SAME_LAYOUT(GpuScene, shaders::deferred_lighting::Scene, effects);
static_assert(sizeof(GpuMaterial) == sizeof(shaders::deferred_lighting::Material));
PENUMBRA_SAME_LAYOUT(GpuMaterial, shaders::deferred_lighting::Material, baseColor);
PENUMBRA_SAME_LAYOUT(GpuMaterial, shaders::deferred_lighting::Material, emissiveMetal);
PENUMBRA_SAME_LAYOUT(GpuMaterial, shaders::deferred_lighting::Material, params);
PENUMBRA_SAME_LAYOUT(GpuMaterial, shaders::deferred_lighting::Material, subsurface);
static_assert(sizeof(GpuLight) == sizeof(shaders::deferred_lighting::Light));
PENUMBRA_SAME_LAYOUT(GpuLight, shaders::deferred_lighting::Light, positionType);
PENUMBRA_SAME_LAYOUT(GpuLight, shaders::deferred_lighting::Light, directionRange);
PENUMBRA_SAME_LAYOUT(GpuLight, shaders::deferred_lighting::Light, radianceRadius);
PENUMBRA_SAME_LAYOUT(GpuLight, shaders::deferred_lighting::Light, shadow);
static_assert(sizeof(GpuObject) == sizeof(shaders::gbuffer_mesh::Object));
PENUMBRA_SAME_LAYOUT(GpuObject, shaders::gbuffer_mesh::Object, model);
PENUMBRA_SAME_LAYOUT(GpuObject, shaders::gbuffer_mesh::Object, prevModel);
PENUMBRA_SAME_LAYOUT(GpuObject, shaders::gbuffer_mesh::Object, normalMatrix);
PENUMBRA_SAME_LAYOUT(GpuObject, shaders::gbuffer_mesh::Object, info);
#undef PENUMBRA_SAME_LAYOUT

// vkCmdUpdateBuffer's limit per call; larger uploads are split.
constexpr uint64_t kMaxUpdateBytes = 65536;

}  // namespace

fg::BufferRef uploadBuffer(fg::PassBuilder& b, const char* name, uint64_t size, uint64_t& bytes) {
    rhi::BufferDesc desc;
    desc.size = size;
    desc.debugName = name;
    bytes += size;
    return b.write(b.createBuffer(name, desc), rhi::Access::CopyDst);
}

void updateChunked(rhi::CommandList& cmd, rhi::BufferHandle dst, const void* data, uint64_t size) {
    const auto* bytes = static_cast<const uint8_t*>(data);
    for (uint64_t offset = 0; offset < size; offset += kMaxUpdateBytes)
        cmd.updateBuffer(dst, offset, bytes + offset, std::min(kMaxUpdateBytes, size - offset));
}

// ---- GPU asset cache ----------------------------------------------------------------------------

GpuAssetCache::~GpuAssetCache() {
    for (auto& [id, m] : m_meshes) release(m);
    for (auto& [id, t] : m_textures) m_device.destroy(t.texture);
    if (m_white) m_device.destroy(m_white);
}

void GpuAssetCache::release(GpuMesh& m) {
    if (m.vertices) m_device.destroy(m.vertices);
    if (m.indices) m_device.destroy(m.indices);
    m = {};
}

const GpuMesh* GpuAssetCache::mesh(assets::AssetId id, const assets::MeshData& data, std::string& error) {
    auto it = m_meshes.find(id);
    if (it != m_meshes.end()) {
        const GpuMesh& m = it->second;
        if (m.source == &data && m.vertexCount == data.positions.size() &&
            m.indexCount == data.indices.size())
            return &m;
        release(it->second);  // the id now names different data
        m_meshes.erase(it);
    }
    const std::string what = fmt::format("mesh asset {:016x}", id);
    const size_t vertexCount = data.positions.size();
    if (data.indices.empty() || data.indices.size() % 3 != 0) {
        error = what + ": no triangles (index count " + std::to_string(data.indices.size()) +
                " is not a positive multiple of 3)";
        return nullptr;
    }
    if (vertexCount == 0 || vertexCount > 0xffffffffull || data.indices.size() > 0xffffffffull) {
        error = what + ": vertex or index count out of range";
        return nullptr;
    }
    for (size_t i = 0; i < data.indices.size(); ++i) {
        if (data.indices[i] >= vertexCount) {
            error = fmt::format("{}: index {} is {}, but the mesh has {} vertices", what, i, data.indices[i],
                                vertexCount);
            return nullptr;
        }
    }
    const bool hasNormals = data.normals.size() == vertexCount;
    assets::MeshData withNormals;
    const std::vector<glm::vec3>* normals = &data.normals;
    if (!hasNormals) {
        // The asset manager generates normals for every mesh it holds; this covers data built
        // by hand with a missing or partial normal array.
        withNormals.positions = data.positions;
        withNormals.indices = data.indices;
        assets::generateNormals(withNormals);
        normals = &withNormals.normals;
    }
    const bool hasUvs = data.uvs.size() == vertexCount;
    std::vector<GpuVertex> vertices(vertexCount);
    for (size_t i = 0; i < vertexCount; ++i) {
        GpuVertex& v = vertices[i];
        const glm::vec3& p = data.positions[i];
        const glm::vec3& n = (*normals)[i];
        v.position[0] = p.x;
        v.position[1] = p.y;
        v.position[2] = p.z;
        v.normal[0] = n.x;
        v.normal[1] = n.y;
        v.normal[2] = n.z;
        v.uv[0] = hasUvs ? data.uvs[i].x : 0.0f;
        v.uv[1] = hasUvs ? data.uvs[i].y : 0.0f;
    }
    float radius2 = 0.0f;
    for (const glm::vec3& p : data.positions) radius2 = std::max(radius2, glm::dot(p, p));

    GpuMesh m;
    m.source = &data;
    m.vertexCount = uint32_t(vertexCount);
    m.indexCount = uint32_t(data.indices.size());
    m.radius = std::sqrt(radius2);
    using BU = rhi::BufferUsage;
    rhi::BufferDesc vertexDesc{uint64_t(vertexCount) * sizeof(GpuVertex), BU::Vertex | BU::CopyDst,
                               rhi::MemoryType::GpuOnly, fmt::format("mesh.{:016x}.vertices", id)};
    rhi::BufferDesc indexDesc{uint64_t(data.indices.size()) * sizeof(uint32_t), BU::Index | BU::CopyDst,
                              rhi::MemoryType::GpuOnly, fmt::format("mesh.{:016x}.indices", id)};
    m.vertices = m_device.createBuffer(vertexDesc, vertices.data());
    m.indices = m_device.createBuffer(indexDesc, data.indices.data());
    if (!m.vertices || !m.indices) {
        release(m);
        error = what + ": creating its vertex/index buffers failed (" +
                std::to_string(vertexDesc.size + indexDesc.size) + " bytes)";
        return nullptr;
    }
    m.bytes = vertexDesc.size + indexDesc.size;
    return &(m_meshes[id] = m);
}

const GpuTexture* GpuAssetCache::texture(assets::AssetId id, const assets::TextureData& data,
                                         std::string& error) {
    auto it = m_textures.find(id);
    if (it != m_textures.end()) {
        if (it->second.source == &data) return &it->second;
        m_device.destroy(it->second.texture);
        m_textures.erase(it);
    }
    const std::string what = fmt::format("texture asset {:016x}", id);
    if (data.width == 0 || data.height == 0 || data.rgba8.size() != uint64_t(data.width) * data.height * 4) {
        error = fmt::format("{}: {}x{} texels but {} bytes of RGBA8 data", what, data.width, data.height,
                            data.rgba8.size());
        return nullptr;
    }
    rhi::TextureDesc d;
    d.format = data.srgb ? rhi::Format::RGBA8_SRGB : rhi::Format::RGBA8_UNORM;
    d.width = data.width;
    d.height = data.height;
    d.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::CopyDst;
    d.debugName = fmt::format("texture.{:016x}", id);
    GpuTexture t;
    t.source = &data;
    t.texture = m_device.createTexture(d);
    if (!t.texture) {
        error = fmt::format("{}: creating a {}x{} texture failed", what, data.width, data.height);
        return nullptr;
    }
    m_device.writeTexture(t.texture, {}, data.rgba8.data(), data.rgba8.size());
    t.bytes = rhi::textureBytes(d);
    return &(m_textures[id] = t);
}

rhi::TextureHandle GpuAssetCache::whiteTexture(std::string& error) {
    if (m_white) return m_white;
    rhi::TextureDesc d;
    d.format = rhi::Format::RGBA8_UNORM;
    d.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::CopyDst;
    d.debugName = "texture.white";
    m_white = m_device.createTexture(d);
    if (!m_white) {
        error = "creating the 1x1 white texture failed";
        return {};
    }
    const uint8_t white[4] = {255, 255, 255, 255};
    m_device.writeTexture(m_white, {}, white, sizeof(white));
    return m_white;
}

void GpuAssetCache::collect(const assets::AssetManager& assets) {
    for (auto it = m_meshes.begin(); it != m_meshes.end();) {
        if (assets.mesh(it->first) != it->second.source) {
            release(it->second);
            it = m_meshes.erase(it);
        } else {
            ++it;
        }
    }
    for (auto it = m_textures.begin(); it != m_textures.end();) {
        if (assets.texture(it->first) != it->second.source) {
            m_device.destroy(it->second.texture);
            it = m_textures.erase(it);
        } else {
            ++it;
        }
    }
}

uint64_t GpuAssetCache::meshBytes() const {
    uint64_t total = 0;
    for (const auto& [id, m] : m_meshes) total += m.bytes;
    return total;
}

uint64_t GpuAssetCache::textureBytes() const {
    uint64_t total = m_white ? 4 : 0;
    for (const auto& [id, t] : m_textures) total += t.bytes;
    return total;
}

// ---- the pass -----------------------------------------------------------------------------------

void addSceneUpload(FrameContext& fc, const SceneFrameData& data) {
    SceneBuffers& out = fc.board.add<SceneBuffers>();
    fc.graph.addPass<SceneBuffers>(
        "scene_upload", fg::PassKind::Transfer,
        [&](fg::PassBuilder& b, SceneBuffers& d) {
            auto buffer = [&](const char* name, uint64_t size) {
                return uploadBuffer(b, name, size, d.bytes);
            };
            d.view = buffer("scene.view", sizeof(GpuView));
            d.scene = buffer("scene.constants", sizeof(GpuScene));
            d.objects = buffer("scene.objects", arrayBytes(data.objects));
            d.materials = buffer("scene.materials", arrayBytes(data.materials));
            d.lights = buffer("scene.lights", arrayBytes(data.lights));
            out = d;
        },
        [&data](const SceneBuffers& d, fg::PassContext& ctx) {
            updateChunked(ctx.cmd, ctx.buffer(d.view), &data.view, sizeof(GpuView));
            updateChunked(ctx.cmd, ctx.buffer(d.scene), &data.scene, sizeof(GpuScene));
            updateArray(ctx.cmd, ctx.buffer(d.objects), data.objects);
            updateArray(ctx.cmd, ctx.buffer(d.materials), data.materials);
            updateArray(ctx.cmd, ctx.buffer(d.lights), data.lights);
        });
}

}  // namespace penumbra::render
