#include "renderer/features/sdf_trace.h"

#include <array>

#include <shaders/sdf_cone_prepass.h>
#include <shaders/sdf_trace.h>
#include <shaders/sdf_trace_empty.h>

#include "renderer/core/shader_params.h"
#include "renderer/features/sdf_cull.h"
#include "renderer/features/sdf_scene.h"
#include "renderer/features/sdf_world_cache.h"

namespace penumbra::render {

// The shader-side sizes of what the C++ writes and chooses: the objects' uniform block holds
// kSdfObjectsUniformCapacity records, the level table a header and every level.
static_assert(sizeof(shaders::sdf_trace::SdfObjectsUniform) ==
              kSdfObjectsUniformCapacity * sizeof(GpuSdfObject));
static_assert(sizeof(shaders::sdf_trace::SdfCacheLevels) >= 16 + kMaxCacheLevels * sizeof(CacheLevelGpu));

namespace {

// trace.accel.x in sdf_trace.comp.
enum : uint32_t {
    kCullFlag = 1,
    kCacheFlag = 2,
    kIdFlag = 4,
    kTileListsFlag = 8,
    kCountEvalsFlag = 16,
    kPrepassFlag = 64,
    kTileDispatchFlag = 128,
};

// "sdf_cone_prepass" (issue 13 item 6): per 8x8 tile of the frame the start of its rays, from
// one conservative cone around them (sdf_cone_prepass.comp). Returns the per-tile buffer
// (uvec2: start bits, evaluations), tilesX * tilesY entries: it follows the frame's size.
fg::BufferRef addConePrepass(FrameContext& fc, const SdfTraceDesc& desc, const SdfTileLists& lists,
                             uint32_t tilesX, uint32_t tilesY) {
    namespace program = shaders::sdf_cone_prepass;
    struct Data {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        SdfTileLists tiles;
        fg::BufferRef starts;
    };
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    const rhi::ShaderDesc& cs = program::compute(sdfSceneVariant<program::Variant>(sdfScene));
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle sampler = sdfAtlasSampler(fc.cache, sdfScene);
    const scene::TraceSettings& s = desc.settings;
    const program::PushConstants push{glm::uvec4(sdfScene.tracedCount, tilesX, tilesY, s.maxSteps),
                                      glm::vec4(s.hitEpsilon, s.fieldSafety, 0.0f, 0.0f),
                                      glm::vec4(desc.nearPlane, desc.farPlane, desc.footprint, 0.0f),
                                      glm::uvec4(lists.valid() ? 1u : 0u, lists.tilesX, 0u, 0u)};
    fg::BufferRef starts;
    fc.graph.addPass<Data>(
        "sdf_cone_prepass", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = sdfScene;
            d.tiles = lists;
            rhi::BufferDesc bd;
            bd.size = uint64_t(tilesX) * tilesY * 2 * sizeof(uint32_t);
            bd.debugName = "sdf.tile_starts";
            d.starts = b.write(b.createBuffer("sdf.tile_starts", bd), rhi::Access::ShaderWrite);
            starts = d.starts;
            b.read(d.scene.view, rhi::Access::UniformRead);
            readSdfScene(b, d.sdf);
            readSdfTileLists(b, d.tiles);
        },
        [&cache = fc.cache, &cs, pipeline, sampler, push, tilesX, tilesY](const Data& d,
                                                                          fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.scene.view)).set("SdfTileStarts", ctx.buffer(d.starts));
            setSdfScene(params, ctx, d.sdf, sampler);
            setSdfTileLists(params, ctx, d.tiles, d.sdf.objects);  // without lists: a stand-in
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            dispatchOver(ctx.cmd, cs, tilesX, tilesY);
        });
    return starts;
}

}  // namespace

namespace {
// The sdf_trace variant of these macros: its enumerator is the PascalCase of its macros in the
// order ALBEDO, AUX, SDF_FIELDS, WORLD_CACHE, SHAPE_PRIMITIVES, SDF_OBJECTS_UBO (sdf_trace.comp lists
// every combination); the table of all 64 is built once, by name.
shaders::sdf_trace::Variant traceProgramVariant(bool albedo, bool aux, bool fields, bool cache,
                                                bool primitives, bool objectsUbo) {
    namespace program = shaders::sdf_trace;
    static const std::array<program::Variant, 64> kTable = variantTable<program::Variant, 6>(
        "sdf_trace.comp", program::kVariantNames, program::kVariantCount,
        {"Albedo", "Aux", "SdfFields", "WorldCache", "ShapePrimitives", "SdfObjectsUbo"});
    return kTable[(albedo ? 1u : 0u) | (aux ? 2u : 0u) | (fields ? 4u : 0u) | (cache ? 8u : 0u) |
                  (primitives ? 16u : 0u) | (objectsUbo ? 32u : 0u)];
}
}  // namespace

bool addSdfTrace(FrameContext& fc, const SdfTraceDesc& desc) {
    namespace program = shaders::sdf_trace;
    namespace empty = shaders::sdf_trace_empty;
    struct Data {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        GBuffer gb;
        SdfTileLists tiles;        // invalid: the shader loops over every traced object
        SdfWorldCacheView cache;   // the world cache (WORLD_CACHE variants), or none
        fg::BufferRef tileStarts;  // the cone prepass's, or invalid (a stand-in is bound)
        fg::BufferRef dispatch;    // the tile lists' classes (the tile dispatch), or invalid
    };
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    const bool albedo = gbuffer.albedo.isValid(), aux = gbuffer.aux.isValid();
    bool cacheRan = false;
    const SdfWorldCacheView cacheIn = sdfWorldCacheBinding(fc.board, cacheRan);
    const bool cacheBound = (desc.accel.worldCache || desc.accel.idField) && cacheRan;
    // The WORLD_CACHE variants hold the cache lookup (a frame without the cache binds none), the
    // SHAPE_PRIMITIVES ones evaluate one-shape programs without the interpreter, the
    // SDF_OBJECTS_UBO ones read the objects as a uniform block (bound over the frame's objects).
    const uint64_t objectsUboBytes = sdfObjectsUniformBytes(fc.device.info(), sdfScene.objectCount);
    const bool objectsUbo = objectsUboBytes > 0;
    const bool fields = sdfScene.atlas.isValid();
    const rhi::ShaderDesc& cs = program::compute(
        traceProgramVariant(albedo, aux, fields, cacheBound, sdfScene.shapePrimitives, objectsUbo));
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle sampler = sdfAtlasSampler(fc.cache, sdfScene);
    const scene::TraceSettings& s = desc.settings;
    const SdfCullLists* cullLists = fc.board.find<SdfCullLists>();
    const bool tiles = desc.accel.culling && cullLists && cullLists->primary.valid();
    const SdfTileLists tileLists = tiles ? cullLists->primary : SdfTileLists{};
    // The tile dispatch (with tile lists): the tiles whose list holds a baked field run the frame's
    // variant, those of shape objects only the variant without field code and without the world
    // cache (sdf_trace.comp says why), and (without a mesh pass) sdf_trace_empty writes the empty
    // tiles' "nothing hit" values; with a mesh pass they keep its values.
    const bool tileDispatch = tiles && tileLists.dispatch.isValid();
    const rhi::ShaderDesc& shapesCs =
        tileDispatch ? program::compute(traceProgramVariant(albedo, aux, false, false,
                                                            sdfScene.shapePrimitives, objectsUbo))
                     : cs;
    const rhi::PipelineHandle shapesPipeline =
        &shapesCs == &cs ? pipeline : fc.cache.computePipeline(shapesCs);
    const rhi::ShaderDesc& emptyCs =
        empty::compute(aux ? (albedo ? empty::Variant::AlbedoAux : empty::Variant::Aux)
                           : (albedo ? empty::Variant::Albedo : empty::Variant::Default));
    const rhi::PipelineHandle emptyPipeline =
        tileDispatch && !desc.raster ? fc.cache.computePipeline(emptyCs) : rhi::PipelineHandle{};
    const uint32_t flags = (desc.accel.culling ? kCullFlag : 0u) | (tiles ? kTileListsFlag : 0u) |
                           (desc.countEvaluations ? kCountEvalsFlag : 0u) |
                           (desc.accel.worldCache ? kCacheFlag : 0u) | (desc.accel.idField ? kIdFlag : 0u) |
                           (desc.accel.prepass ? kPrepassFlag : 0u) | (tileDispatch ? kTileDispatchFlag : 0u);
    const uint32_t tilesX = (fc.width + 7) / 8, tilesY = (fc.height + 7) / 8;
    const fg::BufferRef tileStarts =
        desc.accel.prepass ? addConePrepass(fc, desc, tileLists, tilesX, tilesY) : fg::BufferRef{};
    const program::PushConstants push{
        glm::uvec4(sdfScene.tracedCount, desc.raster ? 1u : 0u, s.maxSteps, s.refineSteps),
        glm::vec4(s.hitEpsilon, s.normalEpsilon, s.overRelaxation, s.fieldSafety),
        glm::vec4(desc.nearPlane, desc.farPlane, desc.footprint, 0.0f),
        glm::uvec4(flags, tileLists.tilesX, tilesX, 0u)};
    const empty::PushConstants emptyPush{
        glm::uvec4(tilesX, sdfTileDispatchFirst(SdfTileClass::Empty, tilesX, tilesY), 0u, 0u)};
    const uint32_t width = fc.width, height = fc.height;
    fc.graph.addPass<Data>(
        "sdf_trace", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = sdfScene;
            d.gb = gbuffer;
            d.tiles = tileLists;
            if (cacheBound) d.cache = cacheIn;
            if (tileStarts.isValid()) d.tileStarts = b.read(tileStarts, rhi::Access::ShaderRead);
            if (tileDispatch)
                d.dispatch = b.read(tileLists.dispatch, rhi::Access::ShaderRead | rhi::Access::IndirectRead);
            const rhi::Access rw = rhi::Access::ShaderRead | rhi::Access::ShaderWrite;
            for (fg::TextureRef t :
                 {d.gb.depth, d.gb.normal, d.gb.material, d.gb.velocity, d.gb.albedo, d.gb.aux})
                if (t.isValid()) b.write(t, rw);
            b.read(d.scene.view, rhi::Access::UniformRead);
            if (albedo) b.read(d.scene.materials, rhi::Access::ShaderRead);
            readSdfScene(b, d.sdf, objectsUbo);
            readSdfTileLists(b, d.tiles);
            if (cacheBound) readSdfWorldCache(b, d.cache);
        },
        [&cache = fc.cache, &cs, &shapesCs, &emptyCs, pipeline, shapesPipeline, emptyPipeline, sampler, push,
         emptyPush, width, height, tilesX, tilesY, albedo, aux, cacheBound,
         objectsUboBytes](const Data& d, fg::PassContext& ctx) {
            // The G-buffer images every program here writes.
            auto setGBuffer = [&](ShaderParams& params) {
                params.set("View", ctx.buffer(d.scene.view))
                    .setStorage("gbufferDepthImage", ctx.texture(d.gb.depth))
                    .setStorage("gbufferNormalImage", ctx.texture(d.gb.normal))
                    .setStorage("gbufferMaterialImage", ctx.texture(d.gb.material))
                    .setStorage("gbufferVelocityImage", ctx.texture(d.gb.velocity));
                if (albedo) params.setStorage("gbufferAlbedoImage", ctx.texture(d.gb.albedo));
                if (aux) params.setStorage("gbufferAuxImage", ctx.texture(d.gb.aux));
            };
            // One sdf_trace program (the frame's variant, or the one without field code and cache).
            auto bindTrace = [&](const rhi::ShaderDesc& program, rhi::PipelineHandle handle, bool withFields,
                                 bool withCache) {
                ctx.cmd.bindPipeline(handle);
                ShaderParams params(program);
                setGBuffer(params);
                if (albedo) params.set("Materials", ctx.buffer(d.scene.materials));
                SdfSceneBuffers sdf = d.sdf;
                if (!withFields) sdf.atlas = {};  // no field bindings in that variant
                setSdfScene(params, ctx, sdf, sampler, objectsUboBytes);
                // Without tile lists the object buffer stands in (read-only, already declared here).
                setSdfTileLists(params, ctx, d.tiles, d.sdf.objects);
                if (withCache) setSdfWorldCache(params, ctx, d.cache);
                params.set("SdfTileStarts",
                           ctx.buffer(d.tileStarts.isValid() ? d.tileStarts : d.sdf.objects));
                params.set("SdfTileDispatch", ctx.buffer(d.dispatch.isValid() ? d.dispatch : d.sdf.objects));
                return params.bind(ctx.cmd, cache, handle);
            };
            if (!d.dispatch.isValid()) {
                if (!bindTrace(cs, pipeline, d.sdf.atlas.isValid(), cacheBound)) return;
                ctx.cmd.pushConstants(&push, sizeof(push));
                dispatchOver(ctx.cmd, cs, width, height);
                return;
            }
            const rhi::BufferHandle dispatch = ctx.buffer(d.dispatch);
            for (SdfTileClass c : {SdfTileClass::Fields, SdfTileClass::Shapes}) {
                const bool shapes = c == SdfTileClass::Shapes;
                if (!bindTrace(shapes ? shapesCs : cs, shapes ? shapesPipeline : pipeline,
                               d.sdf.atlas.isValid() && !shapes, cacheBound && !shapes))
                    return;
                program::PushConstants classPush = push;
                classPush.accel.w = sdfTileDispatchFirst(c, tilesX, tilesY);
                ctx.cmd.pushConstants(&classPush, sizeof(classPush));
                ctx.cmd.dispatchIndirect(dispatch, sdfTileDispatchRecord(c));
            }
            if (!emptyPipeline.isValid()) return;
            ctx.cmd.bindPipeline(emptyPipeline);
            ShaderParams fill(emptyCs);
            setGBuffer(fill);
            fill.set("SdfTileDispatch", ctx.buffer(d.dispatch));
            if (!fill.bind(ctx.cmd, cache, emptyPipeline)) return;
            ctx.cmd.pushConstants(&emptyPush, sizeof(emptyPush));
            ctx.cmd.dispatchIndirect(dispatch, sdfTileDispatchRecord(SdfTileClass::Empty));
        });
    return objectsUbo;
}

}  // namespace penumbra::render
