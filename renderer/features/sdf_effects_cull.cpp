// The "sdf_tile_cull_effects" passes (renderer/features/sdf_effects_cull.h): sizes the lists, clears
// the counters and fills the push constants; the tests live in
// renderer/shaders/sdf_tile_cull_effects_tiles.comp (each tile's surface) and
// renderer/shaders/sdf_tile_cull_effects.comp (the lists).
#include "renderer/features/sdf_effects_cull.h"

#include <algorithm>

#include <shaders/sdf_tile_cull_effects.h>
#include <shaders/sdf_tile_cull_effects_tiles.h>

#include "renderer/features/fullscreen.h"
#include "renderer/features/sdf_scene.h"

namespace penumbra::render {

namespace {

namespace program = shaders::sdf_tile_cull_effects;
namespace tile_program = shaders::sdf_tile_cull_effects_tiles;

// Counters 0-3 (SdfEffectsCullCounters) and 4, the frame's largest field voxel (float bits).
constexpr uint64_t kCounterBytes = 32;
constexpr uint64_t kTileBytes = 32;    // EffectsTile: two vec4
constexpr uint64_t kObjectBytes = 32;  // EffectsObject: two vec4

fg::BufferRef storageBuffer(fg::PassBuilder& b, const char* name, uint64_t size) {
    rhi::BufferDesc d;
    d.size = std::max<uint64_t>(size, 16);
    d.debugName = name;
    return b.createBuffer(name, d);
}

// The counters' clear and sdf_tile_cull_effects_tiles.comp (each tile's surface, each object's
// sphere and the largest field voxel: one invocation per tile); returns the buffers it wrote.
struct EffectsTiles {
    fg::BufferRef tiles, objects, counters;
    uint64_t bytes = 0;  // the three buffers' sizes
};

EffectsTiles addEffectsTiles(FrameContext& fc, const EffectsDesc& desc, const SdfTileLists& lists) {
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const uint64_t tiles = uint64_t(lists.tilesX) * lists.tilesY;
    const uint64_t tileBytes = tiles * kTileBytes,
                   objectBytes = uint64_t(sdfScene.objectCount) * kObjectBytes;
    struct Clear {
        fg::BufferRef counters;
    };
    const Clear& clear = fc.graph.addPass<Clear>(
        "sdf_tile_cull_effects_clear", fg::PassKind::Transfer,
        [&](fg::PassBuilder& b, Clear& d) {
            d.counters =
                b.write(storageBuffer(b, "sdf.effects_cull_counters", kCounterBytes), rhi::Access::CopyDst);
        },
        [](const Clear& d, fg::PassContext& ctx) {
            ctx.cmd.fillBuffer(ctx.buffer(d.counters), 0, kCounterBytes, 0u);
        });

    struct Tiles {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        fg::TextureRef depth;
        fg::BufferRef tiles, objects, counters;
    };
    const bool fields = sdfScene.atlas.isValid();
    const rhi::ShaderDesc& tileCs =
        tile_program::compute(fields ? tile_program::Variant::SdfFields : tile_program::Variant::Default);
    const rhi::PipelineHandle tilePipeline = fc.cache.computePipeline(tileCs);
    const rhi::SamplerHandle atlasSampler = sdfAtlasSampler(fc.cache, sdfScene);
    const rhi::SamplerHandle nearest = gbufferSampler(fc.cache);
    const tile_program::PushConstants tilePush{
        glm::uvec4(sdfScene.objectCount, lists.tilesX, lists.tilesY, 0u),
        glm::vec4(0.0f, 0.0f, desc.footprint, 0.0f)};
    const uint32_t groupsX = (lists.tilesX + 7) / 8, groupsY = (lists.tilesY + 7) / 8;
    const Tiles& tileData = fc.graph.addPass<Tiles>(
        "sdf_tile_cull_effects_tiles", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Tiles& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = sdfScene;
            d.depth = b.read(gbuffer.depth, rhi::Access::ShaderSampled);
            b.read(d.scene.view, rhi::Access::UniformRead);
            readSdfScene(b, d.sdf);
            d.tiles = b.write(storageBuffer(b, "sdf.effects_tiles", tileBytes), rhi::Access::ShaderWrite);
            d.objects =
                b.write(storageBuffer(b, "sdf.effects_objects", objectBytes), rhi::Access::ShaderWrite);
            d.counters = b.write(clear.counters, rhi::Access::ShaderRead | rhi::Access::ShaderWrite);
        },
        [&cache = fc.cache, &tileCs, tilePipeline, atlasSampler, nearest, tilePush, groupsX, groupsY](
            const Tiles& d, fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(tilePipeline);
            ShaderParams params(tileCs);
            params.set("View", ctx.buffer(d.scene.view))
                .set("gbufferDepth", ctx.texture(d.depth), nearest)
                .set("EffectsTiles", ctx.buffer(d.tiles))
                .set("EffectsObjects", ctx.buffer(d.objects))
                .set("EffectsCullCounters", ctx.buffer(d.counters));
            setSdfScene(params, ctx, d.sdf, atlasSampler);
            if (!params.bind(ctx.cmd, cache, tilePipeline)) return;
            ctx.cmd.pushConstants(&tilePush, sizeof(tilePush));
            ctx.cmd.dispatch(groupsX, groupsY);
        });

    return {tileData.tiles, tileData.objects, tileData.counters, kCounterBytes + tileBytes + objectBytes};
}

}  // namespace

uint64_t sdfEffectsListCapacity(uint64_t tiles, uint32_t lists, uint32_t objects) {
    return std::max<uint64_t>(tiles * lists * std::min(objects, kSdfEffectsMeanList), 1);
}

void addSdfEffectsCull(FrameContext& fc, const EffectsDesc& desc) {
    const bool ao = desc.ao.variant != scene::AoVariant::Off;
    const uint32_t layers = desc.shadowLayers;
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    SdfTileLists lists;
    lists.tilesX = (fc.width + kSdfTileSize - 1) / kSdfTileSize;
    lists.tilesY = (fc.height + kSdfTileSize - 1) / kSdfTileSize;
    const uint64_t tiles = uint64_t(lists.tilesX) * lists.tilesY;
    const uint32_t listCount = layers + (ao ? 1u : 0u);
    // Capped below 2^32 - 16: the shader's reservations stay representable.
    const uint64_t capacity =
        std::min<uint64_t>(sdfEffectsListCapacity(tiles, listCount, sdfScene.objectCount), 0xfffffff0u);
    const uint64_t indexBytes = capacity * 4;
    // One layer of ranges per shadowed light; a list kind that is not built gets a dummy (bound,
    // never read).
    const uint64_t shadowRangeBytes = tiles * std::max(layers, 1u) * 8, aoRangeBytes = ao ? tiles * 8 : 16;

    const EffectsTiles tileData = addEffectsTiles(fc, desc, lists);

    // The lists (sdf_tile_cull_effects.comp): one invocation per tile and list, workgroup row y =
    // the list.
    struct Data {
        SceneBuffers scene;
        fg::BufferRef tiles, objects, counters, shadowRanges, aoRanges, indices;
    };
    const rhi::ShaderDesc& cs = program::compute();
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const program::PushConstants push{
        glm::uvec4(sdfScene.objectCount, layers, (ao ? 1u : 0u) | (desc.shadows.hard ? 2u : 0u),
                   uint32_t(capacity)),
        glm::uvec4(lists.tilesX, lists.tilesY, uint32_t(tiles), 0u),
        glm::vec4(std::max(desc.ao.maxDistance, 0.0f), 0.0f, desc.footprint, desc.farPlane)};
    const uint32_t listGroupsX = uint32_t((tiles + 63) / 64);
    const rhi::Access rw = rhi::Access::ShaderRead | rhi::Access::ShaderWrite;
    const Data& data = fc.graph.addPass<Data>(
        "sdf_tile_cull_effects", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.tiles = b.read(tileData.tiles, rhi::Access::ShaderRead);
            d.objects = b.read(tileData.objects, rhi::Access::ShaderRead);
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.scene, rhi::Access::UniformRead);
            b.read(d.scene.lights, rhi::Access::ShaderRead);
            d.counters = b.write(tileData.counters, rw);
            d.shadowRanges = b.write(storageBuffer(b, "sdf.shadow_tile_ranges", shadowRangeBytes),
                                     rhi::Access::ShaderWrite);
            d.aoRanges =
                b.write(storageBuffer(b, "sdf.ao_tile_ranges", aoRangeBytes), rhi::Access::ShaderWrite);
            d.indices =
                b.write(storageBuffer(b, "sdf.effects_tile_indices", indexBytes), rhi::Access::ShaderWrite);
        },
        [&cache = fc.cache, &cs, pipeline, push, listGroupsX, listCount](const Data& d,
                                                                         fg::PassContext& ctx) {
            if (listCount == 0) return;
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Scene", ctx.buffer(d.scene.scene))
                .set("Lights", ctx.buffer(d.scene.lights))
                .set("EffectsTiles", ctx.buffer(d.tiles))
                .set("EffectsObjects", ctx.buffer(d.objects))
                .set("EffectsShadowRanges", ctx.buffer(d.shadowRanges))
                .set("EffectsAoRanges", ctx.buffer(d.aoRanges))
                .set("EffectsTileIndices", ctx.buffer(d.indices))
                .set("EffectsCullCounters", ctx.buffer(d.counters));
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            ctx.cmd.dispatch(listGroupsX, listCount);
        });
    // Kept to the end of the frame (never aliased after their last use) so tests can read them back.
    fc.graph.markOutput(data.counters);
    fc.graph.markOutput(data.indices);
    SdfCullLists all = fc.board.has<SdfCullLists>() ? *fc.board.find<SdfCullLists>() : SdfCullLists{};
    lists.indices = data.indices;
    // The working buffers (counters, per-tile and per-object records, the unused list's ranges),
    // counted on the first list built.
    const uint64_t scratch = tileData.bytes + (layers > 0 ? 0 : shadowRangeBytes) + (ao ? 0 : aoRangeBytes);
    if (layers > 0) {
        all.shadow = lists;
        all.shadow.scratchBytes = scratch;
        all.shadow.ranges = data.shadowRanges;
        all.shadow.layers = layers;
        all.shadow.bytes = shadowRangeBytes + indexBytes;
        fc.graph.markOutput(data.shadowRanges);
    }
    if (ao) {
        all.ao = lists;
        all.ao.ranges = data.aoRanges;
        all.ao.bytes = aoRangeBytes + (layers > 0 ? 0 : indexBytes);  // the indices are shared: counted once
        all.ao.scratchBytes = layers > 0 ? 0 : scratch;
        fc.graph.markOutput(data.aoRanges);
    }
    fc.board.add(all);
    fc.board.add(SdfEffectsCullCounters{data.counters, data.indices, indexBytes});
}

uint32_t sdfEffectsAccelFlags(const scene::AccelerationSettings& accel, const SdfTileLists& lists,
                              bool cacheBound) {
    const uint32_t cull = !accel.culling ? 2u : lists.valid() ? 1u : 0u;
    return cull | (cacheBound && accel.worldCache ? 4u : 0u) | (cacheBound && accel.idField ? 8u : 0u);
}

}  // namespace penumbra::render
