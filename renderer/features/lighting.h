// Pass "lighting" (Raster): full-screen deferred lighting of the G-buffer into the RGBA8 output:
// world position from linear depth along the camera ray, Cook-Torrance or Blinn-Phong over every
// light (directional, point, sphere), ambient * baseColor * AO, emissive, exposure, tone mapping
// and the sRGB encoding (renderer/shaders/brdf.glsl; CPU reference in lighting_reference.h).
// A frame without geometry has no G-buffer: the pass then only clears the output to the
// background colour, display-encoded on the CPU with the same functions.
#pragma once

#include <array>
#include <string>

#include "renderer/frame_graph/frame_graph.h"
#include "renderer/passes/gbuffer_mesh.h"
#include "renderer/passes/scene_upload.h"
#include "rhi/device.h"

namespace penumbra::render {

class DeferredLightingPass {
public:
    explicit DeferredLightingPass(rhi::Device& device);
    ~DeferredLightingPass();
    DeferredLightingPass(const DeferredLightingPass&) = delete;
    DeferredLightingPass& operator=(const DeferredLightingPass&) = delete;

    // Creates the pipeline variant (albedo from the G-buffer or from the material; output
    // RGBA8_UNORM with the sRGB OETF in the shader, or RGBA8_SRGB encoded by the hardware) on
    // first use.
    bool prepare(bool albedo, bool srgbTarget, std::string& error);

    // Shades the G-buffer into `output` (an RGBA8_UNORM, or with srgbTarget RGBA8_SRGB, target).
    void add(fg::FrameGraph& graph, const SceneBuffers& scene, const GBufferTargets& gbuffer,
             fg::TextureRef output, bool srgbTarget, uint32_t width, uint32_t height);
    // Background only: clears `output` to `encoded` (display-encoded RGBA in [0, 1]).
    void addBackground(fg::FrameGraph& graph, fg::TextureRef output, std::array<float, 4> encoded);

private:
    rhi::Device& m_device;
    struct Variant {
        rhi::ShaderHandle vs, fs;
        rhi::PipelineHandle pipeline;
    };
    static int variantIndex(bool albedo, bool srgbTarget) { return (albedo ? 1 : 0) + (srgbTarget ? 2 : 0); }
    Variant m_variants[4];  // bit 0: base colour from the albedo target; bit 1: RGBA8_SRGB output
    rhi::SamplerHandle m_sampler;
};

}  // namespace penumbra::render
