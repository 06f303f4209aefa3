// Feature "sdf_cull" (renderer/features/sdf_cull.h): the primary tile lists - the CPU bound that
// sizes them and the passes that build them (renderer/shaders/sdf_tile_cull.comp).
#include "renderer/features/sdf_cull.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <shaders/sdf_tile_cull.h>
#include <shaders/sdf_tile_cull_bounds.h>

#include "renderer/core/shader_params.h"

namespace penumbra::render {
namespace {

namespace program = shaders::sdf_tile_cull;
namespace bounds = shaders::sdf_tile_cull_bounds;
static_assert(sizeof(GpuSdfObject) == sizeof(bounds::SdfObject));
static_assert(offsetof(GpuSdfObject, model) == offsetof(bounds::SdfObject, model));
static_assert(offsetof(GpuSdfObject, boundsMin) == offsetof(bounds::SdfObject, boundsMin));
static_assert(offsetof(GpuSdfObject, boundsMax) == offsetof(bounds::SdfObject, boundsMax));
// The per-object record the two passes share (one struct in both shaders).
static_assert(sizeof(bounds::TileCullObject) == sizeof(program::TileCullObject));
static_assert(offsetof(bounds::TileCullObject, rect) == offsetof(program::TileCullObject, rect));
static_assert(offsetof(bounds::TileCullObject, axis2) == offsetof(program::TileCullObject, axis2));
// The literals the shaders hold for these (GLSL constants do not reach the generated headers):
// sdf_tile_cull_bounds.comp kKindField, sdf_tile_cull.comp kClass* and kDispatchHeader.
static_assert(uint32_t(SdfKind::Field) == 1);
static_assert(uint32_t(SdfTileClass::Fields) == 0 && uint32_t(SdfTileClass::Shapes) == 1 &&
              uint32_t(SdfTileClass::Empty) == 2 && kSdfTileDispatchHeader == 12);
static_assert(sdfTileDispatchRecord(SdfTileClass::Empty) ==
              4 * sizeof(uint32_t) * uint32_t(SdfTileClass::Empty));

bool unbounded(const GpuSdfObject& o) {
    for (int a = 0; a < 3; ++a)
        if (std::abs(o.boundsMin[a]) >= 0.5f * kSdfUnbounded ||
            std::abs(o.boundsMax[a]) >= 0.5f * kSdfUnbounded)
            return true;
    return false;
}

// The coarse level: tiles of kCoarse x kCoarse 8x8 tiles (64x64 pixels).
constexpr uint32_t kCoarse = 8;

// Tiles of `scale` x `scale` 8x8 tiles covered by one object's conservative screen rectangle (see
// sdfTileListCapacity).
uint64_t objectTiles(const GpuSdfObject& o, const SdfTileCullDesc& desc, uint32_t width, uint32_t height,
                     uint32_t scale) {
    const uint32_t tilesX = (width + kSdfTileSize - 1) / kSdfTileSize;
    const uint32_t tilesY = (height + kSdfTileSize - 1) / kSdfTileSize;
    const uint64_t all = uint64_t((tilesX + scale - 1) / scale) * ((tilesY + scale - 1) / scale);
    if (unbounded(o)) return all;
    // The bounding sphere of the box under `model` (its farthest corner, as the shader computes it),
    // grown by 1 % against rounding.
    const glm::dmat4 m(o.model);
    const glm::dvec3 lo(o.boundsMin), hi(o.boundsMax), h = 0.5 * (hi - lo);
    const glm::dvec3 a0 = glm::dvec3(m[0]) * h.x, a1 = glm::dvec3(m[1]) * h.y, a2 = glm::dvec3(m[2]) * h.z;
    double radius = 0.0;
    for (double s1 : {-1.0, 1.0})
        for (double s2 : {-1.0, 1.0}) radius = std::max(radius, glm::length(a0 + s1 * a1 + s2 * a2));
    radius = radius * 1.01 + 1e-6;
    const glm::dvec3 centre = glm::dvec3(glm::dmat4(desc.viewMatrix) * m * glm::dvec4(0.5 * (lo + hi), 1.0));
    const double depth = -centre.z;  // linear view depth
    if (!std::isfinite(depth) || !std::isfinite(radius)) return all;
    const double slack = 1e-3 * (radius + glm::length(centre));  // far beyond the shader's margin
    if (depth + radius + slack < desc.nearPlane || depth - radius - slack > desc.farPlane) return 0;
    // A sphere reaching the camera plane has no bounded projection: every tile.
    if (!(depth - radius > 1e-4 * std::abs(depth) + 1e-6)) return all;
    // In front of the camera the sphere's projection lies in the hull of its view-space cube's
    // projected corners (perspective maps convex sets with depth > 0 to convex sets).
    const glm::dmat4 proj(desc.projMatrix);
    glm::dvec2 pmin(1e300), pmax(-1e300);
    for (int c = 0; c < 8; ++c) {
        const glm::dvec3 corner =
            centre + radius * glm::dvec3(c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1);
        const glm::dvec4 clip = proj * glm::dvec4(corner, 1.0);
        const glm::dvec2 pixel = (glm::dvec2(clip) / clip.w * 0.5 + 0.5) * glm::dvec2(width, height);
        pmin = glm::min(pmin, pixel);
        pmax = glm::max(pmax, pixel);
    }
    // 8x8 tile range grown by one tile each way, clamped to the frame, then in tiles of the level.
    auto range = [scale](double a, double b, uint32_t tiles) -> uint64_t {
        const double t0 = std::max(std::floor(a / kSdfTileSize) - 1.0, 0.0);
        const double t1 = std::min(std::floor(b / kSdfTileSize) + 1.0, double(tiles) - 1.0);
        return t1 >= t0 ? uint64_t(t1) / scale - uint64_t(t0) / scale + 1 : 0;
    };
    return range(pmin.x, pmax.x, tilesX) * range(pmin.y, pmax.y, tilesY);
}

uint64_t tileListCapacity(const SdfTileCullDesc& desc, uint32_t width, uint32_t height, uint32_t scale) {
    uint64_t total = 0;
    for (const GpuSdfObject& o : desc.objects) total += objectTiles(o, desc, width, height, scale);
    return std::max<uint64_t>(total, 1);
}

fg::BufferRef storageBuffer(fg::PassBuilder& b, const char* name, uint64_t size) {
    rhi::BufferDesc d;
    d.size = size;
    d.debugName = name;
    return b.createBuffer(name, d);
}

// "sdf_tile_cull_bounds": per object its camera-relative box, bounding sphere and tile rectangle
// (sdf_tile_cull_bounds.comp), computed once instead of once per tile.
fg::BufferRef addTileBounds(FrameContext& fc, const SdfTileCullDesc& desc, uint32_t count, uint32_t tilesX,
                            uint32_t tilesY, uint64_t& bytes) {
    struct Data {
        fg::BufferRef view, objects, out;
    };
    const rhi::ShaderDesc& cs = bounds::compute();
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const bounds::PushConstants push{glm::uvec4(count, tilesX, tilesY, 0),
                                     glm::vec4(desc.nearPlane, desc.farPlane, 0.0f, 0.0f)};
    const uint64_t size = uint64_t(std::max(count, 1u)) * sizeof(bounds::TileCullObject);
    bytes = size;
    const Data& data = fc.graph.addPass<Data>(
        "sdf_tile_cull_bounds", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.view = b.read(fc.board.find<SceneBuffers>()->view, rhi::Access::UniformRead);
            d.objects = b.read(fc.board.find<SdfSceneBuffers>()->objects, rhi::Access::ShaderRead);
            d.out = b.write(storageBuffer(b, "sdf.tile_cull_objects", size), rhi::Access::ShaderWrite);
        },
        [&cache = fc.cache, &cs, pipeline, push, count](const Data& d, fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.view))
                .set("SdfObjects", ctx.buffer(d.objects))
                .set("TileCullObjects", ctx.buffer(d.out));
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            ctx.cmd.dispatch((count + 63) / 64);
        });
    return data.out;
}

// One level of the lists: its input (every object, or the coarse level's lists) and output.
struct CullLevel {
    fg::BufferRef objects, counter;  // TileCullObject[]; the reservation counters (uint[4])
    fg::BufferRef dispatch;          // the fine level's tile dispatch (SdfTileLists::dispatch)
    fg::BufferRef ranges, indices;   // in: the coarse lists (invalid: none); out: this level's
    uint32_t count = 0;              // objects
    uint64_t capacity = 0;           // entries of this level's indices
    glm::uvec2 tiles{0};             // tiles of this level
    uint32_t scale = 1;              // 8x8 tiles per tile side
    uint32_t coarseTilesX = 0;       // coarse tiles per row of the input lists (0: none)
    uint64_t bytes = 0;              // this level's ranges + indices (addCullLevel's output)
};

// "sdf_tile_cull" at one level (sdf_tile_cull.comp); returns its ranges, indices and the counter.
CullLevel addCullLevel(FrameContext& fc, const SdfTileCullDesc& desc, const CullLevel& in, const char* pass,
                       const std::string& prefix) {
    struct Data {
        fg::BufferRef view, objects, counter, inRanges, inIndices, ranges, indices, dispatch;
    };
    // One invocation per tile, a workgroup per 8x8 tiles (at the fine level: per coarse tile).
    static_assert(kCoarse == 8, "sdf_tile_cull.comp's workgroups are 8x8 tiles, one coarse tile");
    const rhi::ShaderDesc& cs = program::compute();
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const glm::uvec2 groups = (in.tiles + 7u) / 8u;
    const program::PushConstants push{
        glm::uvec4(in.count, uint32_t(in.capacity), in.tiles.x, in.tiles.y),
        glm::vec4(desc.nearPlane, desc.farPlane, 0.0f, 0.0f),
        glm::uvec4(kSdfTileSize * in.scale, in.scale, in.scale == 1 ? 1 : 0, in.coarseTilesX)};
    const uint64_t rangeBytes = uint64_t(in.tiles.x) * in.tiles.y * 8, indexBytes = in.capacity * 4;
    const rhi::Access rw = rhi::Access::ShaderRead | rhi::Access::ShaderWrite;
    const std::string rangesName = prefix + "_ranges", indicesName = prefix + "_indices";
    const Data& data = fc.graph.addPass<Data>(
        pass, fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.view = b.read(fc.board.find<SceneBuffers>()->view, rhi::Access::UniformRead);  // tile planes
            d.objects = b.read(in.objects, rhi::Access::ShaderRead);
            d.counter = b.write(in.counter, rw);
            d.dispatch = b.write(in.dispatch, rw);  // written by the fine level only
            // Without input lists the object records stand in for them (bound, never read).
            d.inRanges = in.ranges.isValid() ? b.read(in.ranges, rhi::Access::ShaderRead) : d.objects;
            d.inIndices = in.indices.isValid() ? b.read(in.indices, rhi::Access::ShaderRead) : d.objects;
            d.ranges = b.write(storageBuffer(b, rangesName.c_str(), rangeBytes), rhi::Access::ShaderWrite);
            d.indices = b.write(storageBuffer(b, indicesName.c_str(), indexBytes), rhi::Access::ShaderWrite);
        },
        [&cache = fc.cache, &cs, pipeline, push, groups](const Data& d, fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.view))
                .set("TileCullObjects", ctx.buffer(d.objects))
                .set("SdfTileCounter", ctx.buffer(d.counter))
                .set("SdfTileCoarseRanges", ctx.buffer(d.inRanges))
                .set("SdfTileCoarseIndices", ctx.buffer(d.inIndices))
                .set("SdfTileRangesOut", ctx.buffer(d.ranges))
                .set("SdfTileIndicesOut", ctx.buffer(d.indices))
                .set("SdfTileDispatchOut", ctx.buffer(d.dispatch));
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            ctx.cmd.dispatch(groups.x, groups.y);
        });
    CullLevel out = in;
    out.counter = data.counter;
    out.dispatch = data.dispatch;
    out.ranges = data.ranges;
    out.indices = data.indices;
    out.bytes = rangeBytes + indexBytes;
    return out;
}

}  // namespace

uint64_t sdfTileListCapacity(const SdfTileCullDesc& desc, uint32_t width, uint32_t height) {
    return tileListCapacity(desc, width, height, 1);
}

const SdfTileLists& addSdfTileCull(FrameContext& fc, const SdfTileCullDesc& desc) {
    SdfTileLists lists;
    lists.tilesX = (fc.width + kSdfTileSize - 1) / kSdfTileSize;
    lists.tilesY = (fc.height + kSdfTileSize - 1) / kSdfTileSize;
    const uint32_t count =
        std::min<uint32_t>(uint32_t(desc.objects.size()), fc.board.find<SdfSceneBuffers>()->tracedCount);
    const uint64_t fine = std::min(sdfTileListCapacity(desc, fc.width, fc.height), kSdfTileMaxIndices);
    const uint64_t coarse =
        std::min(tileListCapacity(desc, fc.width, fc.height, kCoarse), kSdfTileMaxIndices);

    uint64_t boundsBytes = 0;
    const fg::BufferRef objects = addTileBounds(fc, desc, count, lists.tilesX, lists.tilesY, boundsBytes);
    constexpr uint64_t kCounterBytes = 16;
    const uint64_t dispatchBytes =
        (kSdfTileDispatchHeader + uint64_t(kSdfTileClasses) * lists.tilesX * lists.tilesY) * 4;
    struct Clear {
        fg::BufferRef counter, dispatch;
    };
    const Clear& clear = fc.graph.addPass<Clear>(
        "sdf_tile_cull_clear", fg::PassKind::Transfer,
        [&](fg::PassBuilder& b, Clear& d) {
            d.counter = b.write(storageBuffer(b, "sdf.tile_counter", kCounterBytes), rhi::Access::CopyDst);
            d.dispatch = b.write(storageBuffer(b, "sdf.tile_dispatch", dispatchBytes), rhi::Access::CopyDst);
        },
        [](const Clear& d, fg::PassContext& ctx) {
            ctx.cmd.fillBuffer(ctx.buffer(d.counter), 0, kCounterBytes, 0u);
            // Every class's dispatch record (0 tiles, 1, 1); the tile indices are written before
            // they are read.
            std::array<uint32_t, kSdfTileDispatchHeader> records{};
            for (uint32_t c = 0; c < kSdfTileClasses; ++c) {
                const uint64_t record = sdfTileDispatchRecord(SdfTileClass(c)) / 4;
                records[record + 1] = records[record + 2] = 1;
            }
            ctx.cmd.updateBuffer(ctx.buffer(d.dispatch), 0, records.data(), sizeof(records));
        });

    // Coarse tiles from every object (counter 0), then the 8x8 tiles from their coarse tile's list
    // (counter 1).
    const glm::uvec2 coarseTiles = (glm::uvec2(lists.tilesX, lists.tilesY) + (kCoarse - 1)) / kCoarse;
    CullLevel level{objects, clear.counter, clear.dispatch, {}, {}, count, coarse, coarseTiles, kCoarse, 0};
    const CullLevel coarseLists = addCullLevel(fc, desc, level, "sdf_tile_cull_coarse", "sdf.tile_coarse");
    level = {objects,
             coarseLists.counter,
             coarseLists.dispatch,
             coarseLists.ranges,
             coarseLists.indices,
             count,
             fine,
             glm::uvec2(lists.tilesX, lists.tilesY),
             1,
             coarseTiles.x};
    const CullLevel fineLists = addCullLevel(fc, desc, level, "sdf_tile_cull", "sdf.tile");
    lists.ranges = fineLists.ranges;
    lists.indices = fineLists.indices;
    lists.dispatch = fineLists.dispatch;
    lists.bytes = fineLists.bytes;
    lists.scratchBytes = boundsBytes + kCounterBytes + coarseLists.bytes + dispatchBytes;
    fc.graph.markOutput(lists.ranges);
    fc.graph.markOutput(lists.indices);
    fc.graph.markOutput(lists.dispatch);

    const SdfCullLists* previous = fc.board.find<SdfCullLists>();
    SdfCullLists all = previous ? *previous : SdfCullLists{};
    all.primary = lists;
    return fc.board.add<SdfCullLists>(all).primary;
}

void readSdfTileLists(fg::PassBuilder& b, const SdfTileLists& lists) {
    if (!lists.valid()) return;
    b.read(lists.ranges, rhi::Access::ShaderRead);
    b.read(lists.indices, rhi::Access::ShaderRead);
}

void setSdfTileLists(ShaderParams& params, const fg::PassContext& ctx, const SdfTileLists& lists,
                     fg::BufferRef standIn) {
    if (!lists.valid() && !standIn.isValid()) return;
    params.set("SdfTileRanges", ctx.buffer(lists.valid() ? lists.ranges : standIn))
        .set("SdfTileIndices", ctx.buffer(lists.valid() ? lists.indices : standIn));
}

}  // namespace penumbra::render
