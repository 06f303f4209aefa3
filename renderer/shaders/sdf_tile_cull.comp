// sdf_tile_cull: the primary tile lists (renderer/features/sdf_cull.h, read through sdf_tiles.glsl).
// Two levels, one dispatch each: coarse tiles of 64x64 pixels list from all objects, then the 8x8
// pixel tiles list from their coarse tile's list (a coarse tile on the "all objects" fallback hands
// its tiles every object), so a tile tests the objects near it instead of all of them.
// One invocation per tile of the level, a workgroup per 8x8 of them (at the fine level exactly one
// coarse tile, so the tile's lanes loop over the same list in step), with no barrier: on CPU devices
// a workgroup with barriers runs as coroutines, and the earlier workgroup-per-tile form (64
// invocations splitting the objects) cost about 4x this one. Per tile:
//  1. the tile frustum: the camera position and the rays through the tile's outer pixel corners
//     (the ray construction of sdf_trace.comp: forward + ndc.x rayRight + ndc.y rayUp), bounded by
//     the near and far planes (linear depth). The corners enclose every pixel-centre ray of the tile
//     with half a pixel to spare;
//  2. per object in [0, count), from the pass sdf_tile_cull_bounds (sdf_tile_cull_bounds.comp: the
//     world box of each object, its bounding sphere and a conservative tile rectangle): a tile
//     outside the rectangle drops it; unbounded objects (bounds +-1e30) are always listed;
//     otherwise the bounding sphere, then the box itself (an OBB: centre and three half axes)
//     against the six planes with the projected-radius test. A box is dropped only when it lies
//     wholly outside one plane (with a small relative margin): conservative, an object whose box
//     any pixel ray of the tile crosses between near and far is never dropped;
//  3. count + prefix sum, no fixed cap: the tile counts its objects, reserves that many slots with
//     an atomicAdd on the frame's counter (the prefix sum across tiles), then writes them in
//     ascending object order. The CPU sizes the indices from the scene (sdfTileListCapacity, an
//     upper bound of this total, capped at kSdfTileMaxIndices); a reservation past that capacity -
//     unreachable below the cap - writes (0, 0xffffffff), "all objects", and the consumer loops
//     over every object.
//  4. (fine level) the trace's tile dispatch (renderer/features/sdf_cull.h, SdfTileLists::dispatch):
//     the tile appends its index to its class's tiles and counts itself in that class's indirect
//     dispatch arguments. Classes: a list with a baked field (or "all objects"), a list of shape
//     objects only, an empty list. sdf_trace runs the first with the frame's variant, the second
//     with its variant without field code and world cache, and the empty tiles only get the
//     G-buffer's "nothing hit" values (sdf_trace_empty.comp).
// Loops per invocation: twice the candidates (every object at the coarse level, the coarse tile's
// list at the fine level).
#version 450
layout(local_size_x = 64) in;

#include "view.glsl"

// Written by sdf_tile_cull_bounds.comp (the same struct; sdf_cull.cpp checks both layouts).
struct TileCullObject {
    vec4 centre;  // xyz box centre relative to the camera, w bounding radius (< 0: unbounded)
    vec4 axis0;   // xyz half axes of the box in world units (axis0.w: 1 for a baked field, else 0)
    vec4 axis1;
    vec4 axis2;
    uvec4 rect;  // tiles x0, y0, x1, y1 (inclusive; x0 > x1: no tile)
};

layout(set = 2, binding = 0, std430) readonly buffer TileCullObjects { TileCullObject cullObjects[]; };
layout(set = 2, binding = 1, std430) writeonly buffer SdfTileRangesOut { uvec2 rangesOut[]; };
layout(set = 2, binding = 2, std430) writeonly buffer SdfTileIndicesOut { uint indicesOut[]; };
layout(set = 2, binding = 3, std430) buffer SdfTileCounter { uint reserved[]; };
// The coarse level's lists (the fine level's input; unused by the coarse level itself).
layout(set = 2, binding = 4, std430) readonly buffer SdfTileCoarseRanges { uvec2 coarseRanges[]; };
layout(set = 2, binding = 5, std430) readonly buffer SdfTileCoarseIndices { uint coarseIndices[]; };
// The fine level's tile dispatch (cleared by sdf_tile_cull_clear: every argument record (0, 1, 1)):
// per class c the dispatch arguments at [4c, 4c + 3), its tiles' indices from kDispatchHeader + c *
// tilesX * tilesY on. The coarse level leaves it alone.
layout(set = 2, binding = 6, std430) buffer SdfTileDispatchOut { uint dispatchOut[]; };
// SdfTileClass and kSdfTileDispatchHeader (sdf_cull.cpp checks these values).
const uint kClassFields = 0u, kClassShapes = 1u, kClassEmpty = 2u;
const uint kDispatchHeader = 12u;

layout(push_constant) uniform SdfTileCull {
    uvec4 counts;  // x objects [0, x) are culled, y capacity of indicesOut, z tilesX, w tilesY (this level)
    vec4 clip;     // x near, y far (linear depth)
    uvec4 level;   // x tile size in pixels, y 8x8 tiles per tile side, z counter index (1: the fine
                   // level, which also writes the tile dispatch), w coarse tiles per row (0: no input
                   // list, test every object)
} cull;

const uint kAllObjects = 0xffffffffu;

// Relative to the camera position o (no cancellation far from the origin): xyz inward unit normal,
// w offset; p is inside when dot(n, p - o) + w >= 0.
vec4 g_planes[6];

// A side plane through the camera containing the directions `along` and `corner`, facing `inward`.
vec4 sidePlane(vec3 along, vec3 corner, vec3 inward) {
    vec3 n = normalize(cross(along, corner));
    return vec4(dot(n, inward) < 0.0 ? -n : n, 0.0);
}

void tilePlanes(uvec2 tile) {
    uint size = cull.level.x;
    vec2 lo = vec2(tile * size), hi = min(vec2((tile + 1u) * size), view.viewport.xy);
    vec2 ndcLo = lo * view.viewport.zw * 2.0 - 1.0, ndcHi = hi * view.viewport.zw * 2.0 - 1.0;
    vec3 f = view.forward.xyz, r = view.rayRight.xyz, u = view.rayUp.xyz;
    g_planes[0] = sidePlane(u, f + ndcLo.x * r, r);
    g_planes[1] = sidePlane(u, f + ndcHi.x * r, -r);
    g_planes[2] = sidePlane(r, f + ndcLo.y * u, u);
    g_planes[3] = sidePlane(r, f + ndcHi.y * u, -u);
    vec3 fwd = normalize(f);
    g_planes[4] = vec4(fwd, -cull.clip.x);  // linear depth >= near
    g_planes[5] = vec4(-fwd, cull.clip.y);  // linear depth <= far
}

// Whether the object's box may meet the frustum of `tile`.
bool objectInTile(uint obj, uvec2 tile) {
    uvec4 rect = cullObjects[obj].rect;  // in 8x8 tiles
    uvec2 first = tile * cull.level.y, last = first + (cull.level.y - 1u);
    if (any(lessThan(last, rect.xy)) || any(greaterThan(first, rect.zw))) return false;
    vec4 centre = cullObjects[obj].centre;
    if (centre.w < 0.0) return true;  // unbounded (a plane): always listed
    vec3 c = centre.xyz;  // from the camera
    float radius = centre.w;
    vec3 a0 = cullObjects[obj].axis0.xyz, a1 = cullObjects[obj].axis1.xyz, a2 = cullObjects[obj].axis2.xyz;
    // Margin for rounding: relative to the sizes that enter the plane distance.
    float margin = 1e-4 * (radius + length(c)) + 1e-6 * length(view.position.xyz) + 1e-6;
    for (int i = 0; i < 6; ++i)
        if (dot(g_planes[i].xyz, c) + g_planes[i].w < -radius - margin) return false;
    for (int i = 0; i < 6; ++i) {
        vec3 n = g_planes[i].xyz;
        float projected = abs(dot(n, a0)) + abs(dot(n, a1)) + abs(dot(n, a2));
        if (dot(n, c) + g_planes[i].w < -projected - margin) return false;
    }
    return true;
}

// The candidates: every object, or the coarse tile's list (ascending, so this tile's is too).
uint g_first;
bool g_direct;
uint candidate(uint k) { return g_direct ? k : coarseIndices[g_first + k]; }

void main() {
    // Workgroup = 8x8 tiles of the level (at the fine level: one coarse tile, so every invocation
    // loops over the same list; a SIMD group: a row of tiles), invocation = one tile.
    uint lid = gl_LocalInvocationIndex;
    uvec2 tile = gl_WorkGroupID.xy * 8u + uvec2(lid % 8u, lid / 8u);
    if (tile.x >= cull.counts.z || tile.y >= cull.counts.w) return;
    uint tileIndex = tile.y * cull.counts.z + tile.x;
    uint count = cull.counts.x;
    g_first = 0u;
    g_direct = true;
    if (cull.level.w != 0u) {
        uvec2 coarse = coarseRanges[(tile.y / 8u) * cull.level.w + tile.x / 8u];
        if (coarse.y != kAllObjects) {
            g_first = coarse.x;
            count = coarse.y;
            g_direct = false;
        }
    }
    tilePlanes(tile);
    // 1. Count.
    uint n = 0u;
    for (uint k = 0u; k < count; ++k)
        if (objectInTile(candidate(k), tile)) ++n;
    // 2. Reserve the tile's slots (the prefix sum across tiles).
    uint base = n > 0u ? atomicAdd(reserved[cull.level.z], n) : 0u;
    bool overflow = base > cull.counts.y || n > cull.counts.y - base;
    rangesOut[tileIndex] = overflow ? uvec2(0u, kAllObjects) : uvec2(base, n);
    // 3. Write the indices in ascending order (and whether one of them is a baked field).
    bool fields = overflow;
    if (!overflow) {
        uint slot = base;
        for (uint k = 0u; k < count && slot < base + n; ++k) {
            uint obj = candidate(k);
            if (objectInTile(obj, tile)) {
                indicesOut[slot++] = obj;
                fields = fields || cullObjects[obj].axis0.w != 0.0;
            }
        }
    }
    // 4. The tile dispatch (fine level).
    if (cull.level.z == 1u) {
        uint c = overflow || n > 0u ? (fields ? kClassFields : kClassShapes) : kClassEmpty;
        uint at = atomicAdd(dispatchOut[4u * c], 1u);
        dispatchOut[kDispatchHeader + c * cull.counts.z * cull.counts.w + at] = tileIndex;
    }
}
