#include "renderer/features/lighting.h"

#include <shaders/deferred_lighting.h>

#include "renderer/features/fullscreen.h"

namespace penumbra::render {

void addLighting(FrameContext& fc) {
    namespace program = shaders::deferred_lighting;
    struct Data {
        SceneBuffers scene;
        GBuffer gb;
        fg::TextureRef output;
    };
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const auto variant = gbuffer.albedo.isValid() ? program::Variant::Albedo : program::Variant::Default;
    const FullscreenProgram prog =
        fullscreenProgram(fc, program::vertex(variant), program::fragment(variant));
    fc.graph.addPass<Data>(
        "lighting", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.gb = gbuffer;
            d.output = b.write(fc.board.find<Output>()->color, rhi::Access::ColorTarget);
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.scene, rhi::Access::UniformRead);
            b.read(d.scene.materials, rhi::Access::ShaderRead);
            b.read(d.scene.lights, rhi::Access::ShaderRead);
            readGBuffer(b, d.gb);
        },
        [&cache = fc.cache, prog](const Data& d, fg::PassContext& ctx) {
            beginFullscreen(ctx, d.output, prog.pipeline, "lighting");
            ShaderParams params(*prog.vertex, *prog.fragment);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Scene", ctx.buffer(d.scene.scene))
                .set("Materials", ctx.buffer(d.scene.materials))
                .set("Lights", ctx.buffer(d.scene.lights));
            setGBuffer(params, ctx, d.gb, prog.nearest);
            drawFullscreen(ctx, params, cache, prog.pipeline);
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
