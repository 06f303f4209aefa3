#include "renderer/core/gpu_cache.h"

#include <cstring>
#include <type_traits>

namespace penumbra::render {
namespace {

// Appends the bytes of trivially copyable values to a key.
template <typename T>
void put(std::string& key, const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    key.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

}  // namespace

GpuCache::~GpuCache() {
    for (auto& [key, g] : m_bindGroups) m_device.destroy(g.handle);
    for (auto& [key, p] : m_pipelines) m_device.destroy(p);
    for (auto& [key, s] : m_samplers) m_device.destroy(s);
    for (auto& [desc, s] : m_shaders) m_device.destroy(s);
}

rhi::ShaderHandle GpuCache::shader(const rhi::ShaderDesc& desc) {
    if (auto it = m_shaders.find(&desc); it != m_shaders.end()) return it->second;
    rhi::ShaderHandle h = m_device.createShader(desc);
    if (h) m_shaders.emplace(&desc, h);
    return h;
}

rhi::PipelineHandle GpuCache::computePipeline(const rhi::ShaderDesc& compute) {
    rhi::ShaderHandle cs = shader(compute);
    if (!cs) return {};
    std::string key = "C";
    put(key, cs.value);
    if (auto it = m_pipelines.find(key); it != m_pipelines.end()) return it->second;
    rhi::ComputePipelineDesc d;
    d.shader = cs;
    d.debugName = compute.debugName;
    rhi::PipelineHandle h = m_device.createComputePipeline(d);
    if (h) m_pipelines.emplace(std::move(key), h);
    return h;
}

rhi::PipelineHandle GpuCache::graphicsPipeline(const rhi::ShaderDesc& vertex, const rhi::ShaderDesc& fragment,
                                               rhi::GraphicsPipelineDesc desc) {
    desc.vertexShader = shader(vertex);
    desc.fragmentShader = shader(fragment);
    if (!desc.vertexShader || !desc.fragmentShader) return {};
    std::string key = "G";
    put(key, desc.vertexShader.value);
    put(key, desc.fragmentShader.value);
    put(key, uint32_t(desc.vertexBuffers.size()));
    for (const rhi::VertexBufferLayout& v : desc.vertexBuffers) {
        put(key, v.stride);
        put(key, v.perInstance);
    }
    put(key, uint32_t(desc.vertexAttributes.size()));
    for (const rhi::VertexAttribute& a : desc.vertexAttributes) {
        put(key, a.location);
        put(key, a.bufferSlot);
        put(key, a.format);
        put(key, a.offset);
    }
    put(key, desc.topology);
    put(key, desc.cullMode);
    put(key, desc.frontFace);
    put(key, desc.depthTest);
    put(key, desc.depthWrite);
    put(key, desc.depthCompare);
    put(key, uint32_t(desc.colorFormats.size()));
    for (rhi::Format f : desc.colorFormats) put(key, f);
    put(key, uint32_t(desc.blend.size()));
    for (const rhi::BlendState& b : desc.blend) {
        put(key, b.enable);
        put(key, b.srcColor);
        put(key, b.dstColor);
        put(key, b.colorOp);
        put(key, b.srcAlpha);
        put(key, b.dstAlpha);
        put(key, b.alphaOp);
    }
    put(key, desc.depthFormat);
    if (auto it = m_pipelines.find(key); it != m_pipelines.end()) return it->second;
    if (desc.debugName.empty()) desc.debugName = vertex.debugName;
    rhi::PipelineHandle h = m_device.createGraphicsPipeline(desc);
    if (h) m_pipelines.emplace(std::move(key), h);
    return h;
}

rhi::SamplerHandle GpuCache::sampler(const rhi::SamplerDesc& desc) {
    std::string key;
    put(key, desc.minFilter);
    put(key, desc.magFilter);
    put(key, desc.mipFilter);
    put(key, desc.addressU);
    put(key, desc.addressV);
    put(key, desc.addressW);
    put(key, desc.maxLod);
    if (auto it = m_samplers.find(key); it != m_samplers.end()) return it->second;
    rhi::SamplerHandle h = m_device.createSampler(desc);
    if (h) m_samplers.emplace(std::move(key), h);
    return h;
}

rhi::BindGroupHandle GpuCache::bindGroup(rhi::PipelineHandle pipeline, uint32_t set,
                                         std::span<const rhi::BindGroupEntry> entries,
                                         std::string_view debugName) {
    std::string key;
    put(key, pipeline.value);
    put(key, set);
    for (const rhi::BindGroupEntry& e : entries) {
        put(key, e.binding);
        put(key, e.arrayElement);
        put(key, e.buffer.value);
        put(key, e.offset);
        put(key, e.size);
        put(key, e.texture.value);
        put(key, e.sampler.value);
        put(key, e.mip);
        put(key, e.mipCount);
        put(key, e.baseLayer);
        put(key, e.layerCount);
    }
    if (auto it = m_bindGroups.find(key); it != m_bindGroups.end()) {
        it->second.lastUsed = m_frame;
        return it->second.handle;
    }
    rhi::BindGroupDesc d;
    d.pipeline = pipeline;
    d.set = set;
    d.entries.assign(entries.begin(), entries.end());
    d.debugName = std::string(debugName);
    rhi::BindGroupHandle h = m_device.createBindGroup(d);
    if (h) m_bindGroups.emplace(std::move(key), CachedGroup{h, m_frame});
    return h;
}

void GpuCache::endFrame() {
    std::erase_if(m_bindGroups, [&](const auto& kv) {
        if (m_frame - kv.second.lastUsed < m_retainFrames) return false;
        m_device.destroy(kv.second.handle);
        return true;
    });
    ++m_frame;
}

}  // namespace penumbra::render
