// GPU objects cached by content, so passes never create or destroy pipelines, shaders, samplers
// or bind groups themselves and a steady frame loop creates none of them after its first frame.
//
// - Shaders are keyed by the address of their rhi::ShaderDesc (shaderc's generated descs are
//   function-local statics with stable addresses), pipelines by their whole description (shader
//   handles included, debug name excluded), samplers by their state.
// - Bind groups are keyed by (pipeline, set, entries). A frame graph hands a pass the same
//   physical resources frame after frame, so the same key comes back and the group is reused.
//   Groups no pass asked for during `bindGroupRetainFrames` consecutive frames are destroyed
//   (deferred by the RHI): this drops groups whose resources were resized or released.
// Everything is destroyed with the cache. Not thread-safe: one cache per renderer thread.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>

#include "rhi/device.h"

namespace penumbra::render {

class GpuCache {
public:
    explicit GpuCache(rhi::Device& device) : m_device(device) {}
    ~GpuCache();
    GpuCache(const GpuCache&) = delete;
    GpuCache& operator=(const GpuCache&) = delete;

    rhi::Device& device() { return m_device; }

    // Invalid handles (after the device logged why) when creation fails; failures are not cached.
    rhi::ShaderHandle shader(const rhi::ShaderDesc& desc);
    rhi::PipelineHandle computePipeline(const rhi::ShaderDesc& compute);
    // `desc.vertexShader` / `fragmentShader` are ignored: the two descs name the program.
    rhi::PipelineHandle graphicsPipeline(const rhi::ShaderDesc& vertex, const rhi::ShaderDesc& fragment,
                                         rhi::GraphicsPipelineDesc desc);
    rhi::SamplerHandle sampler(const rhi::SamplerDesc& desc);
    rhi::BindGroupHandle bindGroup(rhi::PipelineHandle pipeline, uint32_t set,
                                   std::span<const rhi::BindGroupEntry> entries, std::string_view debugName);

    // Ends a frame: bind groups unused for bindGroupRetainFrames() frames are destroyed.
    void endFrame();
    void setBindGroupRetainFrames(uint32_t frames) { m_retainFrames = frames; }
    uint32_t bindGroupRetainFrames() const { return m_retainFrames; }

    size_t pipelineCount() const { return m_pipelines.size(); }
    size_t bindGroupCount() const { return m_bindGroups.size(); }

private:
    struct CachedGroup {
        rhi::BindGroupHandle handle;
        uint64_t lastUsed = 0;
    };
    rhi::Device& m_device;
    std::unordered_map<const rhi::ShaderDesc*, rhi::ShaderHandle> m_shaders;
    std::unordered_map<std::string, rhi::PipelineHandle> m_pipelines;
    std::unordered_map<std::string, rhi::SamplerHandle> m_samplers;
    std::unordered_map<std::string, CachedGroup> m_bindGroups;
    uint64_t m_frame = 0;
    uint32_t m_retainFrames = 4;
};

}  // namespace penumbra::render
