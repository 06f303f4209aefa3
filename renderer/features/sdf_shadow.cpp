// The "sdf_shadow" pass (renderer/features/sdf_shadow.h): sizes the output, picks the variant and
// fills the push constants; the cone trace lives in renderer/shaders/sdf_shadow.comp and
// sdf_cone.glsl.
#include "renderer/features/sdf_shadow.h"

#include <algorithm>
#include <cmath>

#include <shaders/sdf_shadow.h>

#include "renderer/core/shader_params.h"
#include "renderer/core/targets.h"
#include "renderer/features/fullscreen.h"
#include "renderer/features/sdf_effects_cull.h"
#include "renderer/features/sdf_scene.h"
#include "renderer/features/sdf_world_cache.h"

namespace penumbra::render {

namespace {

namespace program = shaders::sdf_shadow;
// The objects' uniform block holds kSdfObjectsUniformCapacity records (sdf_scene.glsl).
static_assert(sizeof(program::SdfObjectsUniform) == kSdfObjectsUniformCapacity * sizeof(GpuSdfObject));

struct ShadowSize {
    uint32_t width = 0, height = 0;  // one layer
    bool full = true;                // writes Effects::shadow directly
};

ShadowSize shadowSize(const FrameContext& fc, float resolutionScale) {
    const float scale = std::clamp(resolutionScale, 0.0f, 1.0f);
    if (scale >= 1.0f) return {fc.width, fc.height, true};
    return {std::max(1u, uint32_t(std::lround(float(fc.width) * scale))),
            std::max(1u, uint32_t(std::lround(float(fc.height) * scale))), false};
}

}  // namespace

void addSdfShadow(FrameContext& fc, const EffectsDesc& desc) {
    struct Data {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        SdfTileLists lists;
        SdfWorldCacheView cache;  // the world cache, or stand-ins the shader never samples
        fg::TextureRef depth, normal, out;
    };
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    const uint64_t objectsUniform = sdfObjectsUniformBytes(fc.device.info(), sdfScene.objectCount);
    const rhi::ShaderDesc& cs =
        program::compute(sdfSceneVariant<program::Variant>(sdfScene, objectsUniform > 0));
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle atlasSampler = sdfAtlasSampler(fc.cache, sdfScene);
    const rhi::SamplerHandle nearest = gbufferSampler(fc.cache);
    const ShadowSize size = shadowSize(fc, desc.shadows.resolutionScale);
    const uint32_t layers = desc.shadowLayers;
    const SdfCullLists* cull = fc.board.find<SdfCullLists>();
    const SdfTileLists lists = cull && desc.acceleration.culling ? cull->shadow : SdfTileLists{};
    bool cacheBound = false;
    const SdfWorldCacheView cacheView = sdfWorldCacheBinding(fc.board, cacheBound);
    const uint32_t cullFlags = sdfEffectsAccelFlags(desc.acceleration, lists, cacheBound);
    const program::PushConstants push{
        glm::uvec4(sdfScene.objectCount, desc.shadows.maxSteps, layers, desc.shadows.hard ? 1u : 0u),
        glm::uvec4(size.width, size.height, fc.width, fc.height),
        glm::vec4(desc.trace.fieldSafety, desc.footprint, desc.farPlane, 0.0f),
        glm::uvec4(lists.tilesX, lists.tilesX * lists.tilesY, cullFlags, 0u)};

    fg::TextureRef lowRes;
    fc.graph.addPass<Data>(
        "sdf_shadow", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = sdfScene;
            d.depth = b.read(gbuffer.depth, rhi::Access::ShaderSampled);
            d.normal = b.read(gbuffer.normal, rhi::Access::ShaderSampled);
            if (size.full) {
                d.out = fc.board.find<Effects>()->shadow;
            } else {
                using TU = rhi::TextureUsage;
                lowRes = d.out =
                    b.createTexture("sdf_shadow.low",
                                    renderTargetDesc(rhi::Format::R8_UNORM, size.width * layers, size.height,
                                                     "sdf_shadow.low", TU::Storage | TU::Sampled));
            }
            b.write(d.out, rhi::Access::ShaderWrite);
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.scene, rhi::Access::UniformRead);
            b.read(d.scene.lights, rhi::Access::ShaderRead);
            readSdfScene(b, d.sdf, objectsUniform > 0);
            d.lists = lists;
            readSdfTileLists(b, d.lists);
            d.cache = cacheView;
            readSdfWorldCache(b, d.cache);
        },
        [&cache = fc.cache, &cs, pipeline, atlasSampler, nearest, push, size, layers, objectsUniform](
            const Data& d, fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Scene", ctx.buffer(d.scene.scene))
                .set("Lights", ctx.buffer(d.scene.lights))
                .set("gbufferDepth", ctx.texture(d.depth), nearest)
                .set("gbufferNormal", ctx.texture(d.normal), nearest)
                .setStorage("shadowImage", ctx.texture(d.out));
            setSdfScene(params, ctx, d.sdf, atlasSampler, objectsUniform);
            setSdfTileLists(params, ctx, d.lists, d.sdf.objects);
            setSdfWorldCache(params, ctx, d.cache);
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            dispatchOver(ctx.cmd, cs, size.width, size.height, layers);
        });
    if (!size.full) {
        EffectsLowRes copy = *fc.board.find<EffectsLowRes>();
        copy.shadow = lowRes;
        copy.shadowWidth = size.width;
        copy.shadowHeight = size.height;
        fc.board.add(copy);
    }
}

}  // namespace penumbra::render
