// sdf_shadow: cone-traced soft shadows, one layer per shadowed light (renderer/features/sdf_shadow.h
// documents the pass, renderer/shaders/sdf_cone.glsl the visibility estimate). One invocation per
// (low-resolution pixel, layer):
//  1. the full-resolution pixel the low-resolution one stands for (effects.glsl effectsFullPixel);
//     background (depth 0) writes 1;
//  2. the light whose shadow.x is this layer: directional lights toward -direction up to the far
//     plane with the cone half-angle = the sun's angular radius; point lights hard; sphere lights up
//     to the sphere (distance - radius) with half-angle asin(radius / distance), the exact angular
//     radius of a sphere (atan(r / d) is the half-angle of the disc of radius r, slightly wider
//     than the sphere's silhouette); the hard setting forces a binary ray. Outside a light's range
//     the light adds nothing: 1 without a trace. A light entirely below the surface's horizon
//     (n . l < -sin(halfAngle)) is hidden: 0 without a trace;
//  3. the cone trace from the surface point lifted off it by sdfSurfaceBias along the normal (a
//     quarter pixel footprint at the point's depth, at least 1.5 voxels of the nearest field),
//     starting 2 pixel footprints + that bias along the light direction (sdf_cone.glsl says why the
//     normal offset stays small); hard rays stop at a distance below half a pixel footprint;
//  4. the visible fraction into the layer's column block of the R8 strip.
// Culling (issue 13): with the tile lists (flags kTileLists) the per-ray cull starts from the
// full-resolution pixel's tile list of this layer instead of every object; kNoCull evaluates every
// casting object at every step (acceleration.culling off). kCache / kIdField: the world cache and
// id field in the march (sdf_cone.glsl says how; set only when the cache ran this frame).
#version 450
#pragma penumbra_variants SDF_FIELDS SHAPE_PRIMITIVES SDF_FIELDS+SHAPE_PRIMITIVES SDF_FIELDS+SDF_OBJECTS_UBO SHAPE_PRIMITIVES+SDF_OBJECTS_UBO SDF_FIELDS+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO SDF_OBJECTS_UBO
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

#include "scene.glsl"
#include "gbuffer.glsl"
#include "effects.glsl"

SCENE_CONSTANTS;
SCENE_LIGHTS;

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 3
#define SHAPE_RECORDS_BINDING 4
#define SDF_FIELDS_BINDING 5
#define SDF_ATLAS_BINDING 6
#include "sdf_scene.glsl"
#define SDF_TILES_SET 2
#define SDF_TILE_RANGES_BINDING 7
#define SDF_TILE_INDICES_BINDING 8
#include "sdf_tiles.glsl"
#define SDF_CACHE_SET 2
#define SDF_CACHE_DISTANCE_BINDING 9
#define SDF_CACHE_IDS_BINDING 10
#define SDF_CACHE_LEVELS_BINDING 11
#include "sdf_world_cache.glsl"
#include "sdf_cone.glsl"

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1) uniform sampler2D gbufferNormal;
layout(set = 2, binding = 2, r8) uniform writeonly image2D shadowImage;

layout(push_constant) uniform SdfShadow {
    uvec4 counts;  // x SDF objects (all, occluder-only included), y step limit, z layers, w flags (1 hard)
    uvec4 size;    // x, y the output's size of one layer, z, w the full-resolution frame size
    vec4 params;   // x field safety, y pixel footprint per unit of distance, z far plane
    uvec4 tiles;   // x tilesX, y tiles per layer, z flags (kTileLists, kNoCull, kCache, kIdField)
} shadow;

const uint kHardFlag = 1u;
const uint kTileLists = 1u;  // tiles.z: SdfTileRanges / SdfTileIndices hold this frame's lists
const uint kNoCull = 2u;     // tiles.z: culling off
const uint kCache = 4u;      // tiles.z: step by the world cache where the cone is clear
const uint kIdField = 8u;    // tiles.z: near occluders, the id field's object

// The index of the light drawn into `layer` (-1 when none is).
int layerLight(uint layer) {
    for (uint i = 0u; i < scene.params.x; ++i)
        if (int(lights[i].shadow.x) == int(layer)) return int(i);
    return -1;
}

// The candidates of the per-ray cull for the full-resolution pixel `full` in `layer`.
void coneSource(ivec2 full, uint layer) {
    uint count = shadow.counts.x;
    if ((shadow.tiles.z & kNoCull) != 0u)
        sdfConeSourceNoCull(count);
    else if ((shadow.tiles.z & kTileLists) != 0u)
        sdfConeSourceTile(sdfTileRanges[layer * shadow.tiles.y + sdfTileIndex(full, shadow.tiles.x)], count);
    else
        sdfConeSourceAll(count);
    sdfConeUseCache((shadow.tiles.z & kCache) != 0u, (shadow.tiles.z & kIdField) != 0u);
}

float visibility(Light light, vec3 p, vec3 n, float pixelSize) {
    vec3 l;
    float tMax, sinHalf;
    if (light.positionType.w < 0.5) {
        l = -light.directionRange.xyz;
        tMax = shadow.params.z;
        sinHalf = sin(light.shadow.y);
    } else {
        vec3 toLight = light.positionType.xyz - p;
        float dist = length(toLight);
        if (light.directionRange.w > 0.0 && dist >= light.directionRange.w) return 1.0;  // adds nothing
        if (dist <= 0.0) return 1.0;
        l = toLight / dist;
        bool sphere = light.positionType.w > 1.5;
        float radius = sphere ? min(light.radianceRadius.w, dist) : 0.0;
        tMax = dist - radius;
        sinHalf = radius / dist;
    }
    if ((shadow.counts.w & kHardFlag) != 0u) sinHalf = 0.0;
    if (dot(n, l) < -sinHalf) return 0.0;  // the whole light is below the horizon
    float bias = sdfSurfaceBias(p, pixelSize, shadow.counts.x);
    vec3 origin = p + n * bias;
    float epsilon = max(0.5 * pixelSize, 1e-6 * max(length(p), 1.0));
    // A hard ray stops within epsilon of any surface, its receiver's own included: under a grazing
    // light (n.l small) it starts where it has risen epsilon above the receiver's tangent plane
    // (bias + t n.l), so a flat receiver traced exactly onto its surface does not shadow itself.
    float tStart = 2.0 * pixelSize + bias;
    float ndl = dot(n, l);
    if (sinHalf <= 0.0 && ndl > 0.0) tStart = max(tStart, (1.1 * epsilon - bias) / ndl);
    return sdfConeTrace(origin, l, tStart, tMax, sinHalf, shadow.counts.x, shadow.counts.y, shadow.params.x, epsilon);
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (id.x >= shadow.size.x || id.y >= shadow.size.y || id.z >= shadow.counts.z) return;
    ivec2 low = ivec2(id.xy);
    ivec2 out_ = ivec2(low.x + int(id.z * shadow.size.x), low.y);
    ivec2 full = effectsFullPixel(low, ivec2(shadow.size.xy), ivec2(shadow.size.zw));
    float depth = texelFetch(gbufferDepth, full, 0).r;
    int li = layerLight(id.z);
    if (depth <= 0.0 || li < 0) {
        imageStore(shadowImage, out_, vec4(1.0));
        return;
    }
    vec3 ray = effectsPixelRay(full);
    vec3 p = view.position.xyz + depth * ray;
    vec3 n = octDecode(texelFetch(gbufferNormal, full, 0).rg);
    float pixelSize = shadow.params.y * depth * length(ray);
    coneSource(full, id.z);
    imageStore(shadowImage, out_, vec4(visibility(lights[li], p, n, pixelSize)));
}
