// Per-tile object lists (renderer/features/sdf_cull.h): 8x8 pixel tiles of the full-resolution
// frame, tile index = (y / 8) * tilesX + x / 8, layer L of a layered list (shadows: one per
// shadowed light) at L * tilesX * tilesY.
//
// Use: define SDF_TILES_SET, SDF_TILE_RANGES_BINDING and SDF_TILE_INDICES_BINDING, then include.
#ifndef PENUMBRA_SDF_TILES_GLSL
#define PENUMBRA_SDF_TILES_GLSL

// Per tile: x the first index into sdfTileIndices, y the count.
layout(set = SDF_TILES_SET, binding = SDF_TILE_RANGES_BINDING, std430) readonly buffer SdfTileRanges {
    uvec2 sdfTileRanges[];
};
// Object indices (into sdfObjects), ascending within a tile.
layout(set = SDF_TILES_SET, binding = SDF_TILE_INDICES_BINDING, std430) readonly buffer SdfTileIndices {
    uint sdfTileIndices[];
};

const uint SDF_TILE_SIZE = 8u;

uint sdfTileIndex(ivec2 fullResPixel, uint tilesX) {
    return uint(fullResPixel.y) / SDF_TILE_SIZE * tilesX + uint(fullResPixel.x) / SDF_TILE_SIZE;
}

#endif
