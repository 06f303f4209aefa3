// sdf_tile_cull_effects: the shadow and AO tile lists (renderer/features/sdf_effects_cull.h; read
// through sdf_tiles.glsl by sdf_shadow.comp and sdf_ao.comp). After mTec 8.2.6 / 8.2.8 (reference
// 000). One invocation per 8x8 pixel tile of the full-resolution frame and list (workgroup row y =
// the list, so a SIMD group's lanes are neighbouring tiles building the same kind of list), from the
// tile's surface written by sdf_tile_cull_effects_tiles.comp (the sphere around the tile's visible
// points, the pixel footprint on it and the rays' start offset; no surface -> the list is empty):
//  1. per list (one per shadowed light, then AO), per casting object (params.y & 1), the object's
//     world bounding sphere (its local box through `model`, Frobenius norm; unbounded objects are
//     always kept; computed once per frame by sdf_tile_cull_effects_tiles.comp) against the
//     region the effect's rays can reach from the tile's sphere:
//       shadow, directional: the capsule from the tile sphere along the light direction up to the
//         far plane (the march's tMax); point / sphere light: the capsule from the tile sphere to
//         the light's position (its rays end on the light's sphere). The object's sphere is grown
//         by what sdfConeCull grows its box by (tan(half-angle) * reach + epsilon, at most the
//         light radius + epsilon for sphere lights), mapped through the local box growth
//         (grow / sigma_min, times the Frobenius norm). A tile entirely beyond a light's range
//         gets an empty list (those pixels trace nothing).
//       AO: the object's sphere within maxDistance of the tile's sphere: sdf_ao.comp counts an
//         occluder only when its box is within maxDistance of the pixel's surface point;
//  2. no fixed cap: each list counts its objects, reserves that many slots with an atomicAdd on
//     the frame's counter, then writes them in ascending order. A reservation past the capacity
//     the CPU sized (sdf_effects_cull.cpp says how) writes (0, 0xffffffff) = "all objects": its
//     consumer takes the unculled path. counters: 0 slots reserved, 1 lists over capacity,
//     2 sum of list lengths, 3 lists of tiles with a surface (tests read them back); 4 the largest
//     field voxel (float bits, written by sdf_tile_cull_effects_tiles.comp).
// Loops per invocation: 2 x objects. No barrier: on CPU devices a workgroup with barriers runs as
// coroutines; the earlier form (one workgroup per tile, its first invocations building the lists)
// took 9.4 ms where this pass and its tiles pass take 0.9 ms on the 80-object benchmark scene.
#version 450
layout(local_size_x = 64) in;

#include "scene.glsl"

SCENE_CONSTANTS;
SCENE_LIGHTS;

// Written by sdf_tile_cull_effects_tiles.comp (the same struct).
struct EffectsTile {
    vec4 sphere;   // xyz centre, w radius (< 0: no surface)
    vec4 surface;  // x the largest pixel footprint on it, y the rays' start offset
};
// Per object, also from sdf_tile_cull_effects_tiles.comp: xyz its world bounding sphere's centre, w
// its radius (< 0: unbounded, in every list); x its sphere's growth per unit of cone growth
// (1.7320508 frob / sigma_min; < 0: casts no shadow, in no list).
struct EffectsObject {
    vec4 sphere;
    vec4 growth;
};
layout(set = 2, binding = 0, std430) readonly buffer EffectsTiles { EffectsTile effectsTiles[]; };
layout(set = 2, binding = 4, std430) readonly buffer EffectsObjects { EffectsObject effectsObjects[]; };
layout(set = 2, binding = 1, std430) writeonly buffer EffectsShadowRanges { uvec2 shadowRanges[]; };
layout(set = 2, binding = 2, std430) writeonly buffer EffectsAoRanges { uvec2 aoRanges[]; };
layout(set = 2, binding = 3, std430) writeonly buffer EffectsTileIndices { uint tileIndices[]; };
layout(set = 2, binding = 8, std430) buffer EffectsCullCounters { uint counters[]; };

layout(push_constant) uniform SdfTileCullEffects {
    uvec4 counts;  // x objects, y shadow layers, z flags (1 AO list, 2 hard shadows), w capacity
    uvec4 tiles;   // x tilesX, y tilesY, z tiles
    vec4 params;   // x AO reach (maxDistance), y unused, z pixel footprint per unit distance, w far
} cull;

const uint kHardFlag = 2u;
const uint kAllObjects = 0xffffffffu;

// The tile's surface: sphere (xyz centre, w radius) and the largest pixel footprint on it.
vec4 g_tile;
float g_pixelSize;

float segmentDistance(vec3 p, vec3 a, vec3 b) {
    vec3 ab = b - a;
    float len2 = dot(ab, ab);
    float t = len2 > 0.0 ? clamp(dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
    return length(p - (a + t * ab));
}

// Light of a shadow layer (-1: none draws into it).
int layerLight(uint layer) {
    for (uint i = 0u; i < scene.params.x; ++i)
        if (int(lights[i].shadow.x) == int(layer)) return int(i);
    return -1;
}

// The reach region of one list: the capsule [a, b] around which an object's sphere must come
// within `radius` + its own grown radius; `tanHalf` / `growMax` / `epsilon` give the cone growth.
struct Region {
    vec3 a, b;
    float radius;   // the tile sphere, grown by the rays' start offset
    float tanHalf;  // directional: the cone's tan(half-angle); growth tanHalf * reach
    float growMax;  // point / sphere: the growth bound (light radius); < 0 for directional
    float epsilon;  // the cone's smallest width (sdf_shadow.comp: half a pixel footprint)
    float tMax;
    bool empty;
};

Region shadowRegion(uint layer, float bias) {
    Region g;
    g.empty = true;
    int li = layerLight(layer);
    if (li < 0) return g;
    Light light = lights[li];
    vec3 c = g_tile.xyz;
    g.radius = g_tile.w + bias;
    g.epsilon = max(0.5 * g_pixelSize, 1e-6 * max(length(c) + g.radius, 1.0));
    bool hard = (cull.counts.z & kHardFlag) != 0u;
    g.a = c;
    if (light.positionType.w < 0.5) {
        float s = hard ? 0.0 : clamp(sin(light.shadow.y), 0.0, 0.999);
        g.tanHalf = s / sqrt(1.0 - s * s);
        g.tMax = cull.params.w;
        g.b = c - light.directionRange.xyz * g.tMax;
        g.growMax = -1.0;
    } else {
        vec3 lp = light.positionType.xyz;
        float range = light.directionRange.w;
        if (range > 0.0 && length(lp - c) - g.radius >= range) return g;  // adds nothing anywhere
        g.b = lp;
        g.tanHalf = 0.0;
        // tan(asin(rho / d)) * (d - rho) = rho sqrt((d - rho) / (d + rho)) <= rho
        g.growMax = (light.positionType.w > 1.5 && !hard) ? max(light.radianceRadius.w, 0.0) : 0.0;
        g.tMax = 3.0e38;
    }
    g.empty = false;
    return g;
}

bool inShadowList(uint obj, Region g) {
    vec4 s = effectsObjects[obj].sphere;
    float growth = effectsObjects[obj].growth.x;
    if (growth < 0.0) return false;
    if (s.w < 0.0) return true;
    float grow = g.growMax >= 0.0 ? g.growMax
                                  : g.tanHalf * min(g.tMax, length(s.xyz - g.a) + g.radius + s.w);
    grow += g.epsilon;
    // sdfConeInterval grows the local box by grow / sigma_min on every axis: its world sphere.
    float grown = s.w + grow * growth;
    return segmentDistance(s.xyz, g.a, g.b) <= (g.radius + grown) * 1.0001;
}

bool inAoList(uint obj, float reach) {
    vec4 s = effectsObjects[obj].sphere;
    if (effectsObjects[obj].growth.x < 0.0) return false;
    if (s.w < 0.0) return true;
    return length(s.xyz - g_tile.xyz) <= (reach + s.w) * 1.0001;
}

// Counts, reserves and writes one list; returns its range.
uvec2 buildList(bool ao, Region g, float aoReach) {
    uint n = 0u;
    for (uint obj = 0u; obj < cull.counts.x; ++obj)
        if (ao ? inAoList(obj, aoReach) : inShadowList(obj, g)) ++n;
    atomicAdd(counters[2], n);
    atomicAdd(counters[3], 1u);
    uint first = atomicAdd(counters[0], n);
    if (first > cull.counts.w || n > cull.counts.w - first) {
        atomicAdd(counters[1], 1u);
        return uvec2(0u, kAllObjects);
    }
    uint k = first;
    for (uint obj = 0u; obj < cull.counts.x; ++obj)
        if (ao ? inAoList(obj, aoReach) : inShadowList(obj, g)) tileIndices[k++] = obj;
    return uvec2(first, n);
}

void main() {
    uint tileIndex = gl_GlobalInvocationID.x, job = gl_WorkGroupID.y;
    uint tiles = cull.tiles.z;
    if (tileIndex >= tiles) return;
    uint layers = cull.counts.y;
    bool ao = job == layers;
    EffectsTile t = effectsTiles[tileIndex];
    g_tile = t.sphere;
    g_pixelSize = t.surface.x;
    Region g;
    g.empty = t.sphere.w < 0.0;
    // sdfSurfaceBias: a quarter pixel footprint, at least 1.5 voxels of the frame's largest field
    // voxel (counters[4], the tiles pass's atomicMax).
    float bias = max(t.surface.y, 1.5 * uintBitsToFloat(counters[4]));
    if (!g.empty && !ao) g = shadowRegion(job, bias);
    uvec2 range = uvec2(0u);
    if (!g.empty) range = buildList(ao, g, g_tile.w + cull.params.x);
    if (ao)
        aoRanges[tileIndex] = range;
    else
        shadowRanges[job * tiles + tileIndex] = range;
}
