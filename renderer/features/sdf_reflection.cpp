// Feature "sdf_reflection" (renderer/features/sdf_reflection.h).
#include "renderer/features/sdf_reflection.h"

#include <shaders/sdf_reflection.h>

#include "renderer/core/shader_params.h"
#include "renderer/features/fullscreen.h"
#include "renderer/features/sdf_scene.h"

namespace penumbra::render {

void addSdfReflection(FrameContext& fc, const EffectsDesc& desc) {
    namespace program = shaders::sdf_reflection;
    struct Data {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        GBuffer gb;
        fg::TextureRef reflection;
    };
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    const rhi::ShaderDesc& cs = program::compute(sdfSceneVariant<program::Variant>(sdfScene));
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle point = gbufferSampler(fc.cache);
    const rhi::SamplerHandle fieldSampler = sdfAtlasSampler(fc.cache, sdfScene);
    const scene::TraceSettings& t = desc.trace;
    const program::PushConstants push{glm::uvec4(sdfScene.objectCount, desc.reflections.maxSteps,
                                                 desc.shadows.hard ? 1u : 0u, desc.shadows.maxSteps),
                                      glm::vec4(t.hitEpsilon, t.normalEpsilon, t.fieldSafety, desc.footprint),
                                      glm::vec4(desc.farPlane, desc.reflections.roughnessCutoff, 0.0f, 0.0f)};
    const uint32_t width = fc.width, height = fc.height;
    fc.graph.addPass<Data>(
        "sdf_reflection", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = sdfScene;
            d.gb = *fc.board.find<GBuffer>();
            d.reflection = b.write(fc.board.find<Effects>()->reflection, rhi::Access::ShaderWrite);
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.scene, rhi::Access::UniformRead);
            b.read(d.scene.materials, rhi::Access::ShaderRead);
            b.read(d.scene.lights, rhi::Access::ShaderRead);
            readSdfScene(b, d.sdf);
            for (fg::TextureRef tex : {d.gb.depth, d.gb.normal, d.gb.material})
                b.read(tex, rhi::Access::ShaderSampled);
        },
        [&cache = fc.cache, &cs, pipeline, point, fieldSampler, push, width, height](const Data& d,
                                                                                     fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Scene", ctx.buffer(d.scene.scene))
                .set("Materials", ctx.buffer(d.scene.materials))
                .set("Lights", ctx.buffer(d.scene.lights))
                .set("gbufferDepth", ctx.texture(d.gb.depth), point)
                .set("gbufferNormal", ctx.texture(d.gb.normal), point)
                .set("gbufferMaterial", ctx.texture(d.gb.material), point)
                .setStorage("reflectionImage", ctx.texture(d.reflection));
            setSdfScene(params, ctx, d.sdf, fieldSampler);
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            dispatchOver(ctx.cmd, cs, width, height);
        });
}

}  // namespace penumbra::render
