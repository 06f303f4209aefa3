// Feature "sdf_cull": per-tile object lists (8x8 pixel tiles of the full-resolution frame) that let
// the SDF passes evaluate only the objects that can affect a tile, after mTec 8.2.4 / 8.2.6 / 8.2.8
// (reference 000). The shader side is renderer/shaders/sdf_tiles.glsl.
//
// A list holds every object that may affect any pixel of its tile (conservative): the primary trace
// (bounding sphere, then OBB against the tile frustum), the shadow of each shadowed light (the cone
// from the tile's surface points to the light) and AO (the AO influence radius around the tile's
// surface points). There is no fixed per-tile cap: list storage is sized from the scene.
#pragma once

#include <cstdint>
#include <span>

#include <glm/mat4x4.hpp>

#include "renderer/features/frame_context.h"
#include "renderer/features/sdf_scene.h"

namespace penumbra::render {

inline constexpr uint32_t kSdfTileSize = 8;  // pixels per tile side
// A range's count meaning "every object of the consumer's range": written only when a tile's
// reservation would pass the indices' capacity. sdfTileListCapacity bounds the total of all lists,
// so it is unreachable unless that bound exceeds kSdfTileMaxIndices (e.g. thousands of unbounded
// objects or objects around the camera on a 4K frame): then the indices are capped there and the
// tiles that reserve last loop over every object (correct, slower) instead of the frame failing
// to allocate.
inline constexpr uint32_t kSdfTileAllObjects = 0xffffffffu;
inline constexpr uint64_t kSdfTileMaxIndices = uint64_t(1) << 26;  // 256 MiB of indices
// SdfTileLists::dispatch's classes of tiles, in the order of their dispatch records and index arrays
// (sdf_tile_cull.comp): a list with a baked field (or "all objects"), a list of shape objects only,
// an empty list.
enum class SdfTileClass : uint32_t { Fields = 0, Shapes = 1, Empty = 2 };
inline constexpr uint32_t kSdfTileClasses = 3;
// The uints of the dispatch records in front of the tile indices (one record of 4 per class).
inline constexpr uint32_t kSdfTileDispatchHeader = 4 * kSdfTileClasses;
// The byte offset of a class's indirect dispatch record (x tiles, 1, 1) in SdfTileLists::dispatch.
constexpr uint64_t sdfTileDispatchRecord(SdfTileClass c) { return 16 * uint64_t(c); }
// The index of a class's first tile in SdfTileLists::dispatch (as uints).
constexpr uint32_t sdfTileDispatchFirst(SdfTileClass c, uint32_t tilesX, uint32_t tilesY) {
    return kSdfTileDispatchHeader + uint32_t(c) * tilesX * tilesY;
}

// One set of tile lists. ranges: uvec2 per tile and layer (x first index into `indices`, y count);
// tile index = (y / 8) * tilesX + x / 8; layer L (one per shadowed light for shadows) starts at
// L * tilesX * tilesY. indices: object indices, ascending within a tile.
struct SdfTileLists {
    fg::BufferRef ranges;
    fg::BufferRef indices;
    // The primary lists only (else invalid): the tiles by class (SdfTileClass) for sdf_trace's
    // indirect dispatches, uint[kSdfTileDispatchHeader + kSdfTileClasses * tilesX * tilesY]: each
    // class's dispatch arguments (x tiles, 1, 1) at sdfTileDispatchRecord, its tiles' indices from
    // sdfTileDispatchFirst on (in no particular order).
    fg::BufferRef dispatch;
    uint32_t tilesX = 0, tilesY = 0;
    uint32_t layers = 1;
    uint64_t bytes = 0;  // ranges + indices
    // The culling's working buffers of the frame behind these lists (per-object records, counters,
    // the coarse level, dummy ranges, the tile dispatch), counted on one list of those that share
    // them.
    uint64_t scratchBytes = 0;
    bool valid() const { return ranges.isValid() && indices.isValid(); }
};

// Published on the blackboard by the culling passes; a member that is not valid() was not built
// this frame and its consumer takes its unculled path.
struct SdfCullLists {
    SdfTileLists primary;  // objects [0, tracedCount) for the primary trace
    SdfTileLists shadow;   // casting objects per shadowed light (layers = shadow layers)
    SdfTileLists ao;       // casting objects within the AO distance
};

// ---- the primary lists (pass "sdf_tile_cull") ----------------------------------------------------

struct SdfTileCullDesc {
    std::span<const GpuSdfObject> objects;  // objects [0, tracedCount) of the frame (CPU copy)
    glm::mat4 viewMatrix{1.0f};             // world -> view, as the View block's
    glm::mat4 projMatrix{1.0f};             // view -> clip without jitter (Vulkan y-down clip space)
    float nearPlane = 0.1f;                 // linear depths of the traced rays' ends
    float farPlane = 1000.0f;
};

// Upper bound of the total list length over all tiles for `desc` on a width x height frame: per
// object the tiles of the conservative screen rectangle of its bounding sphere (grown by a tile),
// every tile for unbounded objects and spheres that reach behind the camera. The pass's indices
// buffer holds this many entries (at least one).
uint64_t sdfTileListCapacity(const SdfTileCullDesc& desc, uint32_t width, uint32_t height);

// Adds "sdf_tile_cull_bounds" (compute: per object its world box, bounding sphere and a
// conservative tile rectangle, 80 bytes each), "sdf_tile_cull_clear" (transfer: zeroes the slot
// counters), "sdf_tile_cull_coarse" (compute: the same lists for 64x64 pixel tiles from every
// object) and "sdf_tile_cull" (compute: per 8x8 tile, testing only its coarse tile's list, and the
// tile dispatch; both levels one invocation per tile) and publishes
// SdfCullLists::primary (other members kept). Reads SceneBuffers::view and SdfSceneBuffers::objects;
// desc.objects must describe the uploaded objects. The lists are marked as frame outputs (kept to the end of
// the frame, never aliased after their last use) so that SceneRenderer::readBuffer can read them back and the
// pass runs even while no consumer reads them.
const SdfTileLists& addSdfTileCull(FrameContext& fc, const SdfTileCullDesc& desc);

// What a consumer pass declares and binds (buffers "SdfTileRanges", "SdfTileIndices" of
// sdf_tiles.glsl) for one set of lists. Invalid lists declare nothing and bind `standIn` (when
// given) to both names: the shader's flags say not to read them, but every declared binding must
// be set.
void readSdfTileLists(fg::PassBuilder& b, const SdfTileLists& lists);
void setSdfTileLists(ShaderParams& params, const fg::PassContext& ctx, const SdfTileLists& lists,
                     fg::BufferRef standIn = {});

}  // namespace penumbra::render
