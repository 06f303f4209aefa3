// sdf_tile_cull_effects_tiles: the per-tile half of the shadow and AO tile lists
// (sdf_tile_cull_effects.comp builds the lists from it; renderer/features/sdf_effects_cull.h). One
// invocation per 8x8 pixel tile of the full-resolution frame (a workgroup per 8x8 tiles) writes the
// tile's surface: min / max linear depth of its pixels with depth > 0 (background pixels trace no shadow
// or AO ray; no such pixel: radius -1, every list of the tile is empty), the bounding sphere of the
// frustum slab between those depths (the 8 points of the rays through the tile's outer pixel
// corners at min and max depth: every pixel-centre point lies in their hull), the largest pixel
// footprint on it, and how far a ray's start can leave the surface (the shadows' sdfSurfaceBias: a
// quarter pixel footprint, at least 1.5 voxels of the frame's largest field voxel).
#version 450
#pragma penumbra_variants SDF_FIELDS
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

#include "scene.glsl"

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 2
#define SHAPE_RECORDS_BINDING 3
#define SDF_FIELDS_BINDING 4
#define SDF_ATLAS_BINDING 5
#include "sdf_scene.glsl"

// Per tile: xyz sphere centre, w radius (< 0: no surface); x the largest pixel footprint on it, y
// the rays' start offset. The layout sdf_tile_cull_effects.comp reads.
struct EffectsTile {
    vec4 sphere;
    vec4 surface;
};

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1, std430) writeonly buffer EffectsTiles { EffectsTile effectsTiles[]; };

layout(push_constant) uniform SdfTileCullEffectsTiles {
    uvec4 counts;  // x objects, y tilesX, z tilesY
    vec4 params;   // z pixel footprint per unit distance
} cull;

vec4 g_tile;
float g_pixelSize;

void tileSphere(uvec2 tile, float dmin, float dmax) {
    vec2 lo = vec2(tile * 8u), hi = min(vec2((tile + 1u) * 8u), view.viewport.xy);
    vec3 pts[8];
    float rayLen = 0.0;
    for (int i = 0; i < 4; ++i) {
        vec2 corner = vec2((i & 1) != 0 ? hi.x : lo.x, (i & 2) != 0 ? hi.y : lo.y);
        vec2 ndc = corner * view.viewport.zw * 2.0 - 1.0;
        vec3 ray = view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz;
        rayLen = max(rayLen, length(ray));
        pts[i] = view.position.xyz + dmin * ray;
        pts[i + 4] = view.position.xyz + dmax * ray;
    }
    vec3 c = vec3(0.0);
    for (int i = 0; i < 8; ++i) c += pts[i];
    c *= 0.125;
    float r = 0.0;
    for (int i = 0; i < 8; ++i) r = max(r, length(pts[i] - c));
    g_tile = vec4(c, r * 1.0001 + 1e-6 * length(c));  // float rounding of the corners
    g_pixelSize = cull.params.z * dmax * rayLen;
}

void main() {
    // One invocation per tile (a workgroup: 8x8 tiles), no barrier: on CPU devices a workgroup
    // with barriers runs as coroutines.
    uint lid = gl_LocalInvocationIndex;
    uvec2 tile = gl_WorkGroupID.xy * 8u + uvec2(lid % 8u, lid / 8u);
    if (tile.x >= cull.counts.y || tile.y >= cull.counts.z) return;
    float minDepth = 3.0e38, maxDepth = 0.0;
    ivec2 lo = ivec2(tile * 8u), hi = min(lo + 8, ivec2(view.viewport.xy));
    for (int y = lo.y; y < hi.y; ++y)
        for (int x = lo.x; x < hi.x; ++x) {
            float depth = texelFetch(gbufferDepth, ivec2(x, y), 0).r;
            if (depth > 0.0) {
                minDepth = min(minDepth, depth);
                maxDepth = max(maxDepth, depth);
            }
        }
    EffectsTile t;
    t.sphere = vec4(0.0, 0.0, 0.0, -1.0);
    t.surface = vec4(0.0);
    if (maxDepth > 0.0) {
        float maxVoxel = 0.0;
        for (uint obj = 0u; obj < cull.counts.x; ++obj) maxVoxel = max(maxVoxel, sdfObjectVoxel(obj));
        tileSphere(tile, minDepth, maxDepth);
        t.sphere = g_tile;
        // sdfSurfaceBias: a quarter pixel footprint, at least 1.5 voxels of the nearest field.
        t.surface = vec4(g_pixelSize, max(0.25 * g_pixelSize, 1.5 * maxVoxel), 0.0, 0.0);
    }
    effectsTiles[tile.y * cull.counts.y + tile.x] = t;
}
