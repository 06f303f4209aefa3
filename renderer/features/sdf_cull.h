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

#include "renderer/features/frame_context.h"

namespace penumbra::render {

inline constexpr uint32_t kSdfTileSize = 8;  // pixels per tile side

// One set of tile lists. ranges: uvec2 per tile and layer (x first index into `indices`, y count);
// tile index = (y / 8) * tilesX + x / 8; layer L (one per shadowed light for shadows) starts at
// L * tilesX * tilesY. indices: object indices, ascending within a tile.
struct SdfTileLists {
    fg::BufferRef ranges;
    fg::BufferRef indices;
    uint32_t tilesX = 0, tilesY = 0;
    uint32_t layers = 1;
    uint64_t bytes = 0;  // ranges + indices
    bool valid() const { return ranges.isValid() && indices.isValid(); }
};

// Published on the blackboard by the culling passes; a member that is not valid() was not built
// this frame and its consumer takes its unculled path.
struct SdfCullLists {
    SdfTileLists primary;  // objects [0, tracedCount) for the primary trace
    SdfTileLists shadow;   // casting objects per shadowed light (layers = shadow layers)
    SdfTileLists ao;       // casting objects within the AO distance
};

}  // namespace penumbra::render
