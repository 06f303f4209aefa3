// sdf_cone_prepass: the coarse-to-fine cone prepass (issue 13 item 6; render.acceleration.prepass,
// renderer/features/sdf_trace.h). One invocation per 8x8 pixel tile of the frame marches one cone
// around the tile's rays: the axis through the middle of its pixel centres (TAA jitter included),
// the slope k (tangent of the half angle) enclosing the rays through its corner pixels. A step from
// axial distance t is safe when the ball of the scene's safe distance d around the axis point
// contains the cone's cross-section over the step: t' = t + (d - k t) / (1 + k). The march stops
// where d <= k t + the hit epsilon (the cone touches a surface), at the far plane or at the step
// limit, and writes t to sdfTileStarts[tile]. Every point of a tile ray at ray distance s has axial
// distance <= s, so each ray of the tile is empty up to s = t: sdf_trace starts it there when its
// first box entry is nearer. d is the objects' safe distance (as the trace's steps take it) over
// the tile's primary list (every traced object without lists: objects the tile's frustum misses
// are never hit by its rays). Invocations run side by side over tiles (no barrier, no shared
// memory), which is what CPU rasterizers' SIMD lanes need.
#version 450
#pragma penumbra_variants SDF_FIELDS SHAPE_PRIMITIVES SDF_FIELDS+SHAPE_PRIMITIVES
layout(local_size_x = 8, local_size_y = 8) in;

#include "scene.glsl"

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 0
#define SHAPE_RECORDS_BINDING 1
#define SDF_FIELDS_BINDING 2
#define SDF_ATLAS_BINDING 3
#include "sdf_scene.glsl"

#define SDF_TILES_SET 2
#define SDF_TILE_RANGES_BINDING 4
#define SDF_TILE_INDICES_BINDING 5
#include "sdf_tiles.glsl"

// Per tile: x the start (a float's bits), y the object distance evaluations the cone took.
layout(set = 2, binding = 6, std430) writeonly buffer SdfTileStarts { uvec2 sdfTileStarts[]; };

layout(push_constant) uniform SdfConePrepass {
    uvec4 counts;    // x traced objects, y tiles per row, z tile rows, w step limit
    vec4 epsilons;   // x hit epsilon (pixel footprints), y field safety factor
    vec4 clip;       // x near, y far (linear depth), z pixel footprint per unit of distance
    uvec4 flags;     // x 1 = the tile lists hold this frame's primary lists (then y tiles per row)
} pc;

// The (unnormalised) ray direction through pixel coordinate c (pixel centres at .5, jittered).
vec3 pixelDirection(vec2 c) {
    vec2 ndc = (c + view.jitter.xy) * view.viewport.zw * 2.0 - 1.0;
    return view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz;
}

void main() {
    uvec2 tile = gl_GlobalInvocationID.xy;
    if (tile.x >= pc.counts.y || tile.y >= pc.counts.z) return;
    ivec2 first = ivec2(tile * 8u);
    ivec2 last = min(first + 7, ivec2(view.viewport.xy) - 1);
    vec3 axisDir = pixelDirection(0.5 * vec2(first + last) + 0.5);
    vec3 axis = normalize(axisDir);
    float k = 0.0;
    for (int c = 0; c < 4; ++c) {
        vec3 u = normalize(pixelDirection(vec2((c & 1) != 0 ? last.x : first.x, (c & 2) != 0 ? last.y : first.y) + 0.5));
        float cosA = max(dot(axis, u), 1e-3);
        k = max(k, sqrt(max(1.0 - cosA * cosA, 0.0)) / cosA);
    }
    k = k * 1.001 + 1e-6;  // rounding of the corner rays' directions
    bool everyObject = pc.flags.x == 0u;
    uint begin = 0u, count = pc.counts.x;
    if (!everyObject) {
        uvec2 range = sdfTileRanges[tile.y * pc.flags.y + tile.x];
        everyObject = range.y == 0xffffffffu;  // the list stands for every object
        if (!everyObject) {
            begin = range.x;
            count = range.y;
        }
    }
    float t = pc.clip.x;  // the near plane: every tile ray's own start is at least this far
    float tEnd = pc.clip.y * length(axisDir);
    vec3 ro = view.position.xyz;
    uint evaluations = 0u;
    for (uint step = 0u; step < pc.counts.w && t < tEnd; ++step) {
        vec3 p = ro + axis * t;
        float d = 3.0e38;
        for (uint i = 0u; i < count; ++i) {
            uint obj = everyObject ? i : sdfTileIndices[begin + i];
            if (obj >= pc.counts.x) continue;  // occluder-only: not traced
            vec3 pl = sdfToLocal(obj, p);
            if (sdfBoxDistance(obj, pl) >= d) continue;  // cannot be nearer than the best so far
            ++evaluations;
            d = min(d, sdfObjects[obj].boundsMin.w * sdfLocalDistance(obj, pl, pc.epsilons.y));
        }
        float reach = k * t + pc.epsilons.x * pc.clip.z * t;
        if (d <= reach) break;
        t += (d - reach) / (1.0 + k);
    }
    sdfTileStarts[tile.y * pc.counts.y + tile.x] = uvec2(floatBitsToUint(t), evaluations);
}
