// Small helpers shared by the scene renderer's passes.
#pragma once

#include <string>
#include <vector>

#include "rhi/device.h"

namespace penumbra::render {

// A bind group for `set` of `pipeline` (layout from the pipeline's reflection).
inline rhi::BindGroupHandle makeBindGroup(rhi::Device& device, rhi::PipelineHandle pipeline, uint32_t set,
                                          std::vector<rhi::BindGroupEntry> entries, std::string name) {
    rhi::BindGroupDesc desc;
    desc.pipeline = pipeline;
    desc.set = set;
    desc.entries = std::move(entries);
    desc.debugName = std::move(name);
    return device.createBindGroup(desc);
}

// Bytes of a texture's texel storage (all mips), as the memory report counts it.
inline uint64_t textureBytes(const rhi::TextureDesc& d) {
    uint64_t total = 0;
    uint64_t w = d.width, h = d.height, z = d.dimension == rhi::TextureDimension::Tex3D ? d.depthOrLayers : 1;
    const uint64_t layers = d.dimension == rhi::TextureDimension::Tex2DArray ? d.depthOrLayers : 1;
    for (uint32_t mip = 0; mip < d.mipLevels; ++mip) {
        total += w * h * z * layers * rhi::formatInfo(d.format).bytesPerTexel;
        w = w > 1 ? w / 2 : 1;
        h = h > 1 ? h / 2 : 1;
        z = z > 1 ? z / 2 : 1;
    }
    return total;
}

// A 2D render target description; the frame graph (transients) or the caller sets the usage.
inline rhi::TextureDesc renderTargetDesc(rhi::Format format, uint32_t width, uint32_t height,
                                         std::string name,
                                         rhi::TextureUsage usage = rhi::TextureUsage::None) {
    rhi::TextureDesc d;
    d.format = format;
    d.width = width;
    d.height = height;
    d.usage = usage;
    d.debugName = std::move(name);
    return d;
}

}  // namespace penumbra::render
