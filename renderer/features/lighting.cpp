#include "renderer/features/lighting.h"

#include <shaders/deferred_lighting.h>

namespace penumbra::render {

void beginFullscreen(fg::PassContext& ctx, fg::TextureRef target, rhi::PipelineHandle pipeline,
                     const char* name) {
    const rhi::TextureDesc& size = ctx.textureDesc(target);
    rhi::ColorAttachment a;
    a.texture = ctx.texture(target);
    a.load = rhi::LoadOp::DontCare;  // every pixel is written
    rhi::RenderPassDesc rp;
    rp.colorAttachments = {a};
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

void addLighting(FrameContext& fc) {
    namespace program = shaders::deferred_lighting;
    struct Data {
        SceneBuffers scene;
        GBuffer gb;
        fg::TextureRef output;
    };
    const Output& output = *fc.board.find<Output>();
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const bool albedo = gbuffer.albedo.isValid();
    const auto variant = albedo ? program::Variant::Albedo : program::Variant::Default;
    const rhi::ShaderDesc& vs = program::vertex(variant);
    const rhi::ShaderDesc& fs = program::fragment(variant);
    rhi::GraphicsPipelineDesc pd;
    pd.colorFormats = {output.srgbTarget ? rhi::Format::RGBA8_SRGB : rhi::Format::RGBA8_UNORM};
    const rhi::PipelineHandle pipeline = fc.cache.graphicsPipeline(vs, fs, pd);
    rhi::SamplerDesc nearest;
    nearest.minFilter = nearest.magFilter = rhi::Filter::Nearest;
    const rhi::SamplerHandle sampler = fc.cache.sampler(nearest);
    fc.graph.addPass<Data>(
        "lighting", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.gb = gbuffer;
            d.output = b.write(output.color, rhi::Access::ColorTarget);
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.scene, rhi::Access::UniformRead);
            b.read(d.scene.materials, rhi::Access::ShaderRead);
            b.read(d.scene.lights, rhi::Access::ShaderRead);
            for (fg::TextureRef t : {d.gb.depth, d.gb.normal, d.gb.material, d.gb.albedo})
                if (t.isValid()) b.read(t, rhi::Access::ShaderSampled);
        },
        [&cache = fc.cache, &vs, &fs, pipeline, sampler, albedo](const Data& d, fg::PassContext& ctx) {
            beginFullscreen(ctx, d.output, pipeline, "lighting");
            ShaderParams params(vs, fs);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Scene", ctx.buffer(d.scene.scene))
                .set("Materials", ctx.buffer(d.scene.materials))
                .set("Lights", ctx.buffer(d.scene.lights))
                .set("gbufferDepth", ctx.texture(d.gb.depth), sampler)
                .set("gbufferNormal", ctx.texture(d.gb.normal), sampler)
                .set("gbufferMaterial", ctx.texture(d.gb.material), sampler);
            if (albedo) params.set("gbufferAlbedo", ctx.texture(d.gb.albedo), sampler);
            drawFullscreen(ctx, params, cache, pipeline);
        });
}

void addBackground(FrameContext& fc, std::array<float, 4> encoded) {
    struct Data {
        fg::TextureRef output;
    };
    fc.graph.addPass<Data>(
        "lighting", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) {
            d.output = b.write(fc.board.find<Output>()->color, rhi::Access::ColorTarget);
        },
        [encoded](const Data& d, fg::PassContext& ctx) {
            rhi::RenderPassDesc rp;
            rhi::ColorAttachment a;
            a.texture = ctx.texture(d.output);
            a.load = rhi::LoadOp::Clear;
            a.clearColor = encoded;
            rp.colorAttachments = {a};
            rp.debugName = "lighting.background";
            ctx.cmd.beginRenderPass(rp);
            ctx.cmd.endRenderPass();
        });
}

}  // namespace penumbra::render
