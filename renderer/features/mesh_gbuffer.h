// Pass "gbuffer_mesh" (Raster): draws every visible MeshRenderer into the deferred G-buffer
// (renderer/scene_renderer.h documents the layout): linear depth, octahedral normal, packed
// material (16-bit index, shadow 1, AO 1), velocity in pixels and, when some material of the
// frame has a base-colour texture, albedo. Depth-tested against a transient D32 depth buffer.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "renderer/frame_graph/frame_graph.h"
#include "renderer/passes/scene_upload.h"
#include "rhi/device.h"

namespace penumbra::render {

// The G-buffer of one frame, as refs of the frame graph (albedo invalid when not written).
struct GBufferTargets {
    fg::TextureRef depth;     // R32_FLOAT linear view depth
    fg::TextureRef normal;    // RG16_FLOAT octahedral world normal
    fg::TextureRef material;  // RGBA8_UNORM index low byte / index high byte / shadow / AO
    fg::TextureRef velocity;  // RG16_FLOAT pixels
    fg::TextureRef albedo;    // RGBA8_SRGB, optional
};

// One draw: an uploaded mesh (buffers imported into the graph) and its object slot.
struct MeshDraw {
    fg::BufferRef vertices;
    fg::BufferRef indices;
    uint32_t indexCount = 0;
    uint32_t objectIndex = 0;  // into the objects buffer
    fg::TextureRef baseColor;  // albedo variant: the material's texture (or white); else invalid
};

class GBufferMeshPass {
public:
    explicit GBufferMeshPass(rhi::Device& device);
    ~GBufferMeshPass();
    GBufferMeshPass(const GBufferMeshPass&) = delete;
    GBufferMeshPass& operator=(const GBufferMeshPass&) = delete;

    // Creates the pipeline variant (with or without the albedo target) on first use.
    bool prepare(bool albedo, std::string& error);

    // Adds the pass: clears and writes `targets` (imported by the caller; `targets.albedo` valid
    // selects the albedo variant), depth-tests against a transient "depth" (D32_FLOAT).
    // Returns the bytes of that transient depth buffer.
    uint64_t add(fg::FrameGraph& graph, const SceneBuffers& scene, const GBufferTargets& targets,
                 std::vector<MeshDraw> draws, uint32_t width, uint32_t height);

private:
    rhi::Device& m_device;
    struct Variant {
        rhi::ShaderHandle vs, fs;
        rhi::PipelineHandle pipeline;
    };
    Variant m_variants[2];  // [0] core targets, [1] + albedo
    rhi::SamplerHandle m_sampler;
};

}  // namespace penumbra::render
