// Feature "sdf_thickness" (renderer/features/sdf_thickness.h).
#include "renderer/features/sdf_thickness.h"

#include <shaders/sdf_thickness.h>

#include "renderer/core/shader_params.h"
#include "renderer/features/fullscreen.h"
#include "renderer/features/sdf_scene.h"

namespace penumbra::render {

void addSdfThickness(FrameContext& fc, const EffectsDesc& desc) {
    namespace program = shaders::sdf_thickness;
    struct Data {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        GBuffer gb;
        fg::TextureRef thickness;
    };
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    const rhi::ShaderDesc& cs = program::compute(sdfSceneVariant<program::Variant>(sdfScene));
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle point = gbufferSampler(fc.cache);
    const rhi::SamplerHandle fieldSampler = sdfAtlasSampler(fc.cache, sdfScene);
    const program::PushConstants push{
        glm::uvec4(sdfScene.objectCount, kThicknessSteps, 0u, 0u),
        glm::vec4(desc.trace.hitEpsilon, desc.footprint, desc.trace.fieldSafety, kThicknessCapRadii)};
    const uint32_t width = fc.width, height = fc.height;
    fc.graph.addPass<Data>(
        "sdf_thickness", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = sdfScene;
            d.gb = *fc.board.find<GBuffer>();
            d.thickness = b.write(fc.board.find<Effects>()->thickness, rhi::Access::ShaderWrite);
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.materials, rhi::Access::ShaderRead);
            readSdfScene(b, d.sdf);
            for (fg::TextureRef t : {d.gb.depth, d.gb.normal, d.gb.material})
                b.read(t, rhi::Access::ShaderSampled);
        },
        [&cache = fc.cache, &cs, pipeline, point, fieldSampler, push, width, height](const Data& d,
                                                                                     fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Materials", ctx.buffer(d.scene.materials))
                .set("gbufferDepth", ctx.texture(d.gb.depth), point)
                .set("gbufferNormal", ctx.texture(d.gb.normal), point)
                .set("gbufferMaterial", ctx.texture(d.gb.material), point)
                .setStorage("thicknessImage", ctx.texture(d.thickness));
            setSdfScene(params, ctx, d.sdf, fieldSampler);
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            dispatchOver(ctx.cmd, cs, width, height);
        });
}

}  // namespace penumbra::render
