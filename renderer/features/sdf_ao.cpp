// The "sdf_ao" pass (renderer/features/sdf_ao.h): picks the shader variant, sizes the target and
// fills the push constants; the algorithms live in renderer/shaders/sdf_ao.comp.
#include "renderer/features/sdf_ao.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <shaders/sdf_ao.h>

#include "renderer/core/shader_params.h"
#include "renderer/core/targets.h"
#include "renderer/features/fullscreen.h"
#include "renderer/features/sdf_effects_cull.h"
#include "renderer/features/sdf_scene.h"
#include "renderer/features/sdf_world_cache.h"

namespace penumbra::render {

namespace {

namespace program = shaders::sdf_ao;
// The objects' uniform block holds kSdfObjectsUniformCapacity records (sdf_scene.glsl).
static_assert(sizeof(program::SdfObjectsUniform) == kSdfObjectsUniformCapacity * sizeof(GpuSdfObject));

// SHAPE_PRIMITIVES (primitives): one-shape programs without the interpreter (sdfShapePrimitivesOnly);
// SDF_OBJECTS_UBO (objectsUniform): the objects as a uniform block (sdfObjectsUniformBytes). The
// enumerator is the PascalCase of the macros in the order MULTI_RAY / CONES, SDF_FIELDS,
// SHAPE_PRIMITIVES, SDF_OBJECTS_UBO (sdf_ao.comp lists every combination); the table of all 24 is
// built once, by name.
program::Variant aoVariant(scene::AoVariant v, bool fields, bool primitives, bool objectsUniform) {
    static const std::array<program::Variant, 24> kTable = [] {
        static constexpr std::array<const char*, 3> kParts = {"SdfFields", "ShapePrimitives",
                                                              "SdfObjectsUbo"};
        std::array<program::Variant, 24> table{};
        const char* const kinds[3] = {"", "MultiRay", "Cones"};
        for (uint32_t kind = 0; kind < 3; ++kind) {
            const auto part = variantTable<program::Variant, 3>("sdf_ao.comp", program::kVariantNames,
                                                                program::kVariantCount, kParts, kinds[kind]);
            std::copy(part.begin(), part.end(), table.begin() + kind * 8);
        }
        return table;
    }();
    const uint32_t kind = v == scene::AoVariant::MultiRay ? 1u : v == scene::AoVariant::Cones ? 2u : 0u;
    return kTable[kind * 8u + (fields ? 1u : 0u) + (primitives ? 2u : 0u) + (objectsUniform ? 4u : 0u)];
}

// Step limit per ray: exact binary rays skip the stretches outside every bounds box, so few steps
// remain; cones march by distance with at least a tenth of the cone radius per step.
uint32_t aoStepLimit(const EffectsDesc& desc, bool exact) {
    static constexpr uint32_t kConeSteps[] = {24, 32, 48, 64};  // low, medium, high, reference
    if (exact) return 256;
    return kConeSteps[std::min(uint32_t(desc.quality), 3u)];
}

}  // namespace

void addSdfAo(FrameContext& fc, const EffectsDesc& desc) {
    struct Data {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        SdfTileLists lists;
        SdfWorldCacheView cache;  // the world cache, or stand-ins the shader never samples
        fg::TextureRef depth, normal, out;
    };
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    const bool fields = sdfScene.atlas.isValid();
    const uint64_t objectsUniform = sdfObjectsUniformBytes(fc.device.info(), sdfScene.objectCount);
    const rhi::ShaderDesc& cs =
        program::compute(aoVariant(desc.ao.variant, fields, sdfScene.shapePrimitives, objectsUniform > 0));
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle atlasSampler = sdfAtlasSampler(fc.cache, sdfScene);
    const rhi::SamplerHandle nearest = gbufferSampler(fc.cache);

    const float scale = std::clamp(desc.ao.resolutionScale, 0.0f, 1.0f);
    const bool full = scale >= 1.0f;
    const uint32_t w = full ? fc.width : std::max(1u, uint32_t(std::lround(float(fc.width) * scale)));
    const uint32_t h = full ? fc.height : std::max(1u, uint32_t(std::lround(float(fc.height) * scale)));
    const bool exact =
        desc.ao.variant == scene::AoVariant::MultiRay && desc.quality == scene::TraceQuality::Reference;
    const SdfCullLists* cull = fc.board.find<SdfCullLists>();
    const SdfTileLists lists = cull && desc.acceleration.culling ? cull->ao : SdfTileLists{};
    bool cacheBound = false;
    const SdfWorldCacheView cacheView = sdfWorldCacheBinding(fc.board, cacheBound);
    const uint32_t cullFlags = sdfEffectsAccelFlags(desc.acceleration, lists, cacheBound);
    const program::PushConstants push{
        glm::uvec4(sdfScene.objectCount, desc.ao.rays, exact ? 1u : 0u, aoStepLimit(desc, exact)),
        glm::vec4(desc.ao.maxDistance, desc.ao.strength, desc.trace.fieldSafety, desc.footprint),
        glm::vec4(desc.trace.hitEpsilon, 0.0f, 0.0f, 0.0f), glm::uvec4(lists.tilesX, 0u, cullFlags, 0u)};

    const Data& pass = fc.graph.addPass<Data>(
        "sdf_ao", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = sdfScene;
            d.depth = b.read(gbuffer.depth, rhi::Access::ShaderSampled);
            d.normal = b.read(gbuffer.normal, rhi::Access::ShaderSampled);
            if (full) {
                d.out = fc.board.find<Effects>()->ao;
            } else {
                using TU = rhi::TextureUsage;
                d.out =
                    b.createTexture("sdf_ao.low", renderTargetDesc(rhi::Format::RGBA8_UNORM, w, h,
                                                                   "sdf_ao.low", TU::Storage | TU::Sampled));
            }
            b.write(d.out, rhi::Access::ShaderWrite);
            b.read(d.scene.view, rhi::Access::UniformRead);
            readSdfScene(b, d.sdf, objectsUniform > 0);
            d.lists = lists;
            readSdfTileLists(b, d.lists);
            d.cache = cacheView;
            readSdfWorldCache(b, d.cache);
        },
        [&cache = fc.cache, &cs, pipeline, atlasSampler, nearest, push, w, h, objectsUniform](
            const Data& d, fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.scene.view))
                .set("gbufferDepth", ctx.texture(d.depth), nearest)
                .set("gbufferNormal", ctx.texture(d.normal), nearest)
                .setStorage("aoImage", ctx.texture(d.out));
            setSdfScene(params, ctx, d.sdf, atlasSampler, objectsUniform);
            setSdfTileLists(params, ctx, d.lists, d.sdf.objects);
            setSdfWorldCache(params, ctx, d.cache);
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            dispatchOver(ctx.cmd, cs, w, h);
        });
    if (!full) {
        EffectsLowRes copy = *fc.board.find<EffectsLowRes>();
        copy.ao = pass.out;
        copy.aoWidth = w;
        copy.aoHeight = h;
        fc.board.add(copy);
    }
}

}  // namespace penumbra::render
