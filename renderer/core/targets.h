// Render-target helpers shared by the renderer's feature modules.
#pragma once

#include <string>

#include "rhi/types.h"

namespace penumbra::render {

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
