#include "renderer/features/lighting.h"

#include <shaders/deferred_lighting.h>

#include "renderer/features/effects.h"
#include "renderer/features/fullscreen.h"

namespace penumbra::render {

void addLighting(FrameContext& fc) {
    namespace program = shaders::deferred_lighting;
    struct Data {
        SceneBuffers scene;
        GBuffer gb;
        fg::TextureRef output;
        Effects fx;  // absent targets: gbuffer.depth is bound instead (scene.effects says they are off)
    };
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const bool effects = fc.board.has<Effects>();
    using V = program::Variant;
    const V variant = gbuffer.albedo.isValid() ? (effects ? V::AlbedoEffects : V::Albedo)
                                               : (effects ? V::Effects : V::Default);
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
            if (effects) {
                d.fx = *fc.board.find<Effects>();
                for (fg::TextureRef* t : {&d.fx.shadow, &d.fx.ao, &d.fx.thickness, &d.fx.reflection}) {
                    if (t->isValid())
                        b.read(*t, rhi::Access::ShaderSampled);
                    else
                        *t = d.gb.depth;
                }
            }
        },
        [&cache = fc.cache, prog, effects](const Data& d, fg::PassContext& ctx) {
            beginFullscreen(ctx, d.output, prog.pipeline, "lighting");
            ShaderParams params(*prog.vertex, *prog.fragment);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Scene", ctx.buffer(d.scene.scene))
                .set("Materials", ctx.buffer(d.scene.materials))
                .set("Lights", ctx.buffer(d.scene.lights));
            setGBuffer(params, ctx, d.gb, prog.nearest);
            if (effects)
                params.set("effectsShadow", ctx.texture(d.fx.shadow), prog.nearest)
                    .set("effectsAo", ctx.texture(d.fx.ao), prog.nearest)
                    .set("effectsThickness", ctx.texture(d.fx.thickness), prog.nearest)
                    .set("effectsReflection", ctx.texture(d.fx.reflection), prog.nearest);
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
