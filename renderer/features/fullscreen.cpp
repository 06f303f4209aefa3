#include "renderer/features/fullscreen.h"

namespace penumbra::render {

FullscreenProgram fullscreenProgram(FrameContext& fc, const rhi::ShaderDesc& vertex,
                                    const rhi::ShaderDesc& fragment) {
    FullscreenProgram p;
    p.vertex = &vertex;
    p.fragment = &fragment;
    rhi::GraphicsPipelineDesc pd;
    const Output& out = *fc.board.find<Output>();
    pd.colorFormats = {out.format != rhi::Format::Undefined ? out.format
                       : out.srgbTarget                     ? rhi::Format::RGBA8_SRGB
                                                            : rhi::Format::RGBA8_UNORM};
    p.pipeline = fc.cache.graphicsPipeline(vertex, fragment, pd);
    p.nearest = gbufferSampler(fc.cache);
    return p;
}

rhi::SamplerHandle gbufferSampler(GpuCache& cache) {
    rhi::SamplerDesc nearest;
    nearest.minFilter = nearest.magFilter = rhi::Filter::Nearest;
    nearest.debugName = "gbuffer.nearest";
    return cache.sampler(nearest);
}

void readGBuffer(fg::PassBuilder& b, const GBuffer& gb) {
    for (fg::TextureRef t : {gb.depth, gb.normal, gb.material, gb.albedo})
        if (t.isValid()) b.read(t, rhi::Access::ShaderSampled);
}

void setGBuffer(ShaderParams& params, const fg::PassContext& ctx, const GBuffer& gb,
                rhi::SamplerHandle sampler) {
    params.set("gbufferDepth", ctx.texture(gb.depth), sampler)
        .set("gbufferNormal", ctx.texture(gb.normal), sampler)
        .set("gbufferMaterial", ctx.texture(gb.material), sampler);
    if (gb.albedo.isValid()) params.set("gbufferAlbedo", ctx.texture(gb.albedo), sampler);
}

void beginFullscreen(fg::PassContext& ctx, fg::TextureRef target, rhi::PipelineHandle pipeline,
                     const char* name) {
    beginFullscreen(ctx, {target}, pipeline, name);
}

void beginFullscreen(fg::PassContext& ctx, std::initializer_list<fg::TextureRef> targets,
                     rhi::PipelineHandle pipeline, const char* name) {
    const rhi::TextureDesc& size = ctx.textureDesc(*targets.begin());
    rhi::RenderPassDesc rp;
    for (fg::TextureRef target : targets) {
        rhi::ColorAttachment a;
        a.texture = ctx.texture(target);
        a.load = rhi::LoadOp::DontCare;  // every pixel is written
        rp.colorAttachments.push_back(a);
    }
    rp.debugName = name;
    ctx.cmd.beginRenderPass(rp);
    ctx.cmd.setViewport({0, 0, float(size.width), float(size.height), 0, 1});
    ctx.cmd.setScissor({0, 0, size.width, size.height});
    ctx.cmd.bindPipeline(pipeline);
}

void drawFullscreen(fg::PassContext& ctx, ShaderParams& params, GpuCache& cache,
                    rhi::PipelineHandle pipeline) {
    if (params.bind(ctx.cmd, cache, pipeline)) ctx.cmd.draw(3);
    ctx.cmd.endRenderPass();
}

}  // namespace penumbra::render
