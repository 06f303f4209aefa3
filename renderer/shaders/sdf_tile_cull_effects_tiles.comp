// sdf_tile_cull_effects_tiles: the per-tile half of the shadow and AO tile lists
// (sdf_tile_cull_effects.comp builds the lists from it; renderer/features/sdf_effects_cull.h). One
// invocation per 8x8 pixel tile of the full-resolution frame (a workgroup per 8x8 tiles) writes the
// tile's surface: min / max linear depth of its pixels with depth > 0 (background pixels trace no
// shadow or AO ray; no such pixel: radius -1, every list of the tile is empty), the bounding sphere
// of the frustum slab between those depths (the 8 points of the rays through the tile's outer pixel
// corners at min and max depth: every pixel-centre point lies in their hull), the largest pixel
// footprint on it, and how far a ray's start can leave the surface (the shadows' sdfSurfaceBias: a
// quarter pixel footprint; sdf_tile_cull_effects.comp raises it to 1.5 of the frame's largest field
// voxel). Its invocations also write, once per frame, each object's world bounding sphere and
// growth for the lists, and the largest field voxel (counters[4]).
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

// Per object: xyz world bounding sphere centre, w radius (< 0: unbounded); x the sphere's growth
// per unit of cone growth (< 0: casts no shadow). The layout sdf_tile_cull_effects.comp reads.
struct EffectsObject {
    vec4 sphere;
    vec4 growth;
};

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1, std430) writeonly buffer EffectsTiles { EffectsTile effectsTiles[]; };
layout(set = 2, binding = 6, std430) writeonly buffer EffectsObjects {
    EffectsObject effectsObjects[];
};
layout(set = 2, binding = 7, std430) buffer EffectsCullCounters { uint counters[]; };

const uint kCastsShadows = 1u;  // GpuSdfObject::params.y (kSdfObjectCastsShadows)

bool unboundedObject(uint obj) {
    return any(greaterThanEqual(abs(sdfObjects[obj].boundsMin.xyz), vec3(0.5e30))) ||
           any(greaterThanEqual(abs(sdfObjects[obj].boundsMax.xyz), vec3(0.5e30)));
}

// World bounding sphere of the object's local box (as sdf_cone.glsl's sdfConeFarthest), and the
// Frobenius norm of its model (bounds the largest singular value) in `frob`.
vec4 objectSphere(uint obj, out float frob) {
    mat4 m = sdfObjects[obj].model;
    vec3 lc = 0.5 * (sdfObjects[obj].boundsMin.xyz + sdfObjects[obj].boundsMax.xyz);
    vec3 lh = 0.5 * (sdfObjects[obj].boundsMax.xyz - sdfObjects[obj].boundsMin.xyz);
    frob = sqrt(dot(m[0].xyz, m[0].xyz) + dot(m[1].xyz, m[1].xyz) + dot(m[2].xyz, m[2].xyz));
    return vec4((m * vec4(lc, 1.0)).xyz, length(lh) * frob);
}

// The object's record for the lists.
EffectsObject effectsObject(uint obj) {
    EffectsObject e;
    e.sphere = vec4(0.0);
    e.growth = vec4(-1.0, 0.0, 0.0, 0.0);
    if ((sdfObjects[obj].params.y & kCastsShadows) == 0u) return e;
    e.growth.x = 0.0;
    if (unboundedObject(obj)) {
        e.sphere.w = -1.0;
        return e;
    }
    float frob;
    e.sphere = objectSphere(obj, frob);
    // sdfConeInterval grows the local box by grow / sigma_min on every axis: its world sphere.
    e.growth.x = 1.7320508 * frob / max(sdfObjects[obj].boundsMin.w, 1e-30);
    return e;
}

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
    // The objects' records and the largest field voxel, objects spread over every invocation.
    uint invocation = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 8u + gl_GlobalInvocationID.x;
    uint invocations = gl_NumWorkGroups.x * gl_NumWorkGroups.y * 64u;
    for (uint obj = invocation; obj < cull.counts.x; obj += invocations) {
        effectsObjects[obj] = effectsObject(obj);
        float v = sdfObjectVoxel(obj);
        if (v > 0.0) atomicMax(counters[4], floatBitsToUint(v));  // positive floats order as bits
    }
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
        tileSphere(tile, minDepth, maxDepth);
        t.sphere = g_tile;
        // A quarter pixel footprint (the lists pass raises it to 1.5 of the largest field voxel).
        t.surface = vec4(g_pixelSize, 0.25 * g_pixelSize, 0.0, 0.0);
    }
    effectsTiles[tile.y * cull.counts.y + tile.x] = t;
}
