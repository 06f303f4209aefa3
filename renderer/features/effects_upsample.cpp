// The effects_upsample pass (renderer/features/effects_upsample.h documents the filter).
#include "renderer/features/effects_upsample.h"

#include <shaders/effects_upsample.h>

#include "renderer/core/shader_params.h"
#include "renderer/features/fullscreen.h"

namespace penumbra::render {

void addEffectsUpsample(FrameContext& fc, const EffectsDesc&) {
    namespace program = shaders::effects_upsample;
    struct Data {
        fg::BufferRef view;
        fg::TextureRef depth, normal, lowShadow, shadow, lowAo, ao;
    };
    const EffectsLowRes& low = *fc.board.find<EffectsLowRes>();
    const Effects& effects = *fc.board.find<Effects>();
    const bool shadow = low.shadow.isValid() && effects.shadow.isValid() && effects.shadowLayers > 0;
    const bool ao = low.ao.isValid() && effects.ao.isValid();
    if (!shadow && !ao) return;
    using V = program::Variant;
    const V variant = shadow && ao ? V::ShadowAo : shadow ? V::Shadow : V::Ao;
    const rhi::ShaderDesc& cs = program::compute(variant);
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle sampler = gbufferSampler(fc.cache);
    const program::PushConstants push{
        glm::uvec4(low.shadowWidth, low.shadowHeight, low.aoWidth, low.aoHeight),
        glm::uvec4(fc.width, fc.height, shadow ? effects.shadowLayers : 0u, 0u)};
    const uint32_t width = fc.width, height = fc.height;
    fc.graph.addPass<Data>(
        "effects_upsample", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            const GBuffer& gb = *fc.board.find<GBuffer>();
            d.view = b.read(fc.board.find<SceneBuffers>()->view, rhi::Access::UniformRead);
            d.depth = b.read(gb.depth, rhi::Access::ShaderSampled);
            d.normal = b.read(gb.normal, rhi::Access::ShaderSampled);
            if (shadow) {
                d.lowShadow = b.read(low.shadow, rhi::Access::ShaderRead);
                d.shadow = b.write(effects.shadow, rhi::Access::ShaderWrite);
            }
            if (ao) {
                d.lowAo = b.read(low.ao, rhi::Access::ShaderRead);
                d.ao = b.write(effects.ao, rhi::Access::ShaderWrite);
            }
        },
        [&cache = fc.cache, &cs, pipeline, sampler, push, width, height, shadow, ao](const Data& d,
                                                                                     fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.view))
                .set("gbufferDepth", ctx.texture(d.depth), sampler)
                .set("gbufferNormal", ctx.texture(d.normal), sampler);
            if (shadow)
                params.setStorage("lowShadowImage", ctx.texture(d.lowShadow))
                    .setStorage("shadowImage", ctx.texture(d.shadow));
            if (ao)
                params.setStorage("lowAoImage", ctx.texture(d.lowAo))
                    .setStorage("aoImage", ctx.texture(d.ao));
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            dispatchOver(ctx.cmd, cs, width, height);
        });
}

}  // namespace penumbra::render
