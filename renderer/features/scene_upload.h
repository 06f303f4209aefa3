// Feature "scene_upload": the pass (Transfer) that writes this frame's scene data (the per-view
// block, scene constants, materials, lights, per-object matrices) into frame-graph buffers with
// command-list updates and publishes them as SceneBuffers; and the GPU asset cache that keeps one copy of
// every mesh (interleaved vertex buffer + index buffer) and every material texture across frames, uploaded
// the first time a frame needs it.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "engine/assets/asset_manager.h"
#include "renderer/features/frame_context.h"
#include "renderer/features/gpu_scene.h"
#include "rhi/device.h"

namespace penumbra::render {

struct GpuMesh {
    rhi::BufferHandle vertices;  // GpuVertex[vertexCount]
    rhi::BufferHandle indices;   // uint32_t[indexCount]
    uint32_t vertexCount = 0;
    uint32_t indexCount = 0;
    uint64_t bytes = 0;                        // both buffers' sizes
    float radius = 0.0f;                       // largest vertex distance from the mesh origin
    const assets::MeshData* source = nullptr;  // the asset it was made from (detects replacement)
};

struct GpuTexture {
    rhi::TextureHandle texture;  // RGBA8_SRGB for colour data, RGBA8_UNORM otherwise; one mip
    uint64_t bytes = 0;
    const assets::TextureData* source = nullptr;
};

// One GPU copy per mesh / texture asset id, kept across frames until collect() finds the asset
// gone (or the id now names different data, which is re-uploaded on its next use).
class GpuAssetCache {
public:
    explicit GpuAssetCache(rhi::Device& device) : m_device(device) {}
    ~GpuAssetCache();
    GpuAssetCache(const GpuAssetCache&) = delete;
    GpuAssetCache& operator=(const GpuAssetCache&) = delete;

    // The GPU copy of mesh `id`, uploading `data` on first use. Null with `error` when the mesh
    // has no triangles, is inconsistent, or a buffer cannot be created.
    const GpuMesh* mesh(assets::AssetId id, const assets::MeshData& data, std::string& error);
    // The GPU copy of texture `id`; null with `error` on bad data or a creation failure.
    const GpuTexture* texture(assets::AssetId id, const assets::TextureData& data, std::string& error);
    // A 1x1 white RGBA8_UNORM texture (bound for untextured materials when albedo is written).
    rhi::TextureHandle whiteTexture(std::string& error);

    // Drops every copy whose asset is no longer alive in `assets`.
    void collect(const assets::AssetManager& assets);

    uint64_t meshBytes() const;
    uint64_t textureBytes() const;  // material textures + the white texture
    size_t meshCount() const { return m_meshes.size(); }
    size_t textureCount() const { return m_textures.size(); }

private:
    void release(GpuMesh& m);

    rhi::Device& m_device;
    std::unordered_map<assets::AssetId, GpuMesh> m_meshes;
    std::unordered_map<assets::AssetId, GpuTexture> m_textures;
    rhi::TextureHandle m_white;
};

// A transient per-frame storage buffer of a transfer pass, written by it (CopyDst); adds `size` to
// `bytes`.
fg::BufferRef uploadBuffer(fg::PassBuilder& b, const char* name, uint64_t size, uint64_t& bytes);

// Command-list buffer updates of any size (split into vkCmdUpdateBuffer-sized pieces).
void updateChunked(rhi::CommandList& cmd, rhi::BufferHandle dst, const void* data, uint64_t size);

// Bytes of a per-frame array buffer: at least one element, so that it can always be bound.
template <typename T>
uint64_t arrayBytes(const std::vector<T>& v) {
    return uint64_t(std::max<size_t>(v.size(), 1)) * sizeof(T);
}

// Writes `v` (or one zero element when it is empty) at the start of `dst`.
template <typename T>
void updateArray(rhi::CommandList& cmd, rhi::BufferHandle dst, const std::vector<T>& v) {
    if (v.empty()) {
        const T zero{};
        updateChunked(cmd, dst, &zero, sizeof(T));
    } else {
        updateChunked(cmd, dst, v.data(), uint64_t(v.size()) * sizeof(T));
    }
}

// Adds the "scene_upload" pass and publishes SceneBuffers. `data` must stay alive and unchanged
// until the graph has executed.
void addSceneUpload(FrameContext& fc, const SceneFrameData& data);

}  // namespace penumbra::render
