// What every full-screen pass over the G-buffer shares (lighting, debug views, later the SDF
// effects' resolves): the program's cached pipeline for the output's format and a nearest
// sampler, the G-buffer declarations and parameters, and the render pass around one triangle.
#pragma once

#include <initializer_list>

#include "renderer/core/shader_params.h"
#include "renderer/features/frame_context.h"

namespace penumbra::render {

struct FullscreenProgram {
    const rhi::ShaderDesc* vertex = nullptr;
    const rhi::ShaderDesc* fragment = nullptr;
    rhi::PipelineHandle pipeline;  // colour target: the frame's Output format
    rhi::SamplerHandle nearest;    // point sampling for G-buffer texel fetches
};
FullscreenProgram fullscreenProgram(FrameContext& fc, const rhi::ShaderDesc& vertex,
                                    const rhi::ShaderDesc& fragment);
// The nearest (point) sampler for G-buffer texel fetches, shared by full-screen and compute passes.
rhi::SamplerHandle gbufferSampler(GpuCache& cache);

// Declares the frame's G-buffer targets (albedo when present) as sampled reads of the pass.
void readGBuffer(fg::PassBuilder& b, const GBuffer& gb);
// Sets the shader parameters gbufferDepth, gbufferNormal, gbufferMaterial (and gbufferAlbedo).
void setGBuffer(ShaderParams& params, const fg::PassContext& ctx, const GBuffer& gb,
                rhi::SamplerHandle sampler);

// Colour attachment + viewport + scissor over `target`, the pipeline bound: the start of every
// full-screen raster pass. End with drawFullscreen().
void beginFullscreen(fg::PassContext& ctx, fg::TextureRef target, rhi::PipelineHandle pipeline,
                     const char* name);
// The same over several colour targets of one size (the fragment stage's outputs 0, 1, ...).
void beginFullscreen(fg::PassContext& ctx, std::initializer_list<fg::TextureRef> targets,
                     rhi::PipelineHandle pipeline, const char* name);
// Binds `params`, draws the full-screen triangle (renderer/shaders/fullscreen.glsl) and ends the
// render pass (a failed bind draws nothing: the error is logged).
void drawFullscreen(fg::PassContext& ctx, ShaderParams& params, GpuCache& cache,
                    rhi::PipelineHandle pipeline);

}  // namespace penumbra::render
