// sdf_ao: ambient occlusion and bent normal from the frame's SDF objects (renderer/features/sdf_ao.h
// documents the variants and their settings). One invocation per AO pixel (a w x h target, at most
// the frame's size):
//  1. the full-resolution pixel containing the AO pixel's centre (effectsFullPixel) gives depth and
//     normal; background pixels write AO 1 and the zero normal;
//  2. occluders: objects that take part in AO (kSdfObjectCastsShadows) whose bounds box lies within
//     maxDistance of the point (the AO's influence radius: an object beyond it does not occlude,
//     tests/renderer/sdf_ao_test.cpp), up to kListSize of them in a per-pixel list (more: every
//     candidate is evaluated). The candidates are the full-resolution pixel's AO tile list when the
//     frame built one (flag kTileLists, renderer/features/sdf_effects_cull.h), else every object.
//     kNoCull (acceleration culling off): every casting object is evaluated at every step and the
//     ones beyond the influence radius are then ignored (same result, no work saved);
//  3. the variant (default five-tap, MULTI_RAY, CONES) computes the occlusion in [0, 1] and a bent
//     normal; the result is AO = 1 - strength * occlusion.
// Rays and taps start `offset` above the surface along the normal (a few pixel footprints: the
// G-buffer point lies up to the trace's hit epsilon in front of the surface; near a field at least
// the shadows' surface bias, sdf_cone.glsl).
#version 450
#pragma penumbra_variants MULTI_RAY CONES SDF_FIELDS MULTI_RAY+SDF_FIELDS CONES+SDF_FIELDS SHAPE_PRIMITIVES MULTI_RAY+SHAPE_PRIMITIVES CONES+SHAPE_PRIMITIVES SDF_FIELDS+SHAPE_PRIMITIVES MULTI_RAY+SDF_FIELDS+SHAPE_PRIMITIVES CONES+SDF_FIELDS+SHAPE_PRIMITIVES MULTI_RAY+SDF_OBJECTS_UBO CONES+SDF_OBJECTS_UBO SDF_FIELDS+SDF_OBJECTS_UBO MULTI_RAY+SDF_FIELDS+SDF_OBJECTS_UBO CONES+SDF_FIELDS+SDF_OBJECTS_UBO SHAPE_PRIMITIVES+SDF_OBJECTS_UBO MULTI_RAY+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO CONES+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO SDF_FIELDS+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO MULTI_RAY+SDF_FIELDS+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO CONES+SDF_FIELDS+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO SDF_OBJECTS_UBO
layout(local_size_x = 8, local_size_y = 8) in;

#include "scene.glsl"
#include "gbuffer.glsl"
#include "effects.glsl"

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 6
#define SHAPE_RECORDS_BINDING 7
#define SDF_FIELDS_BINDING 8
#define SDF_ATLAS_BINDING 9
#include "sdf_scene.glsl"
#define SDF_TILES_SET 2
#define SDF_TILE_RANGES_BINDING 10
#define SDF_TILE_INDICES_BINDING 11
#include "sdf_tiles.glsl"
#define SDF_CACHE_SET 2
#define SDF_CACHE_DISTANCE_BINDING 12
#define SDF_CACHE_IDS_BINDING 13
#define SDF_CACHE_LEVELS_BINDING 14
#include "sdf_world_cache.glsl"
#include "sdf_cone.glsl"

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1) uniform sampler2D gbufferNormal;
layout(set = 2, binding = 2, rgba8) uniform writeonly image2D aoImage;

layout(push_constant) uniform SdfAo {
    uvec4 counts;  // x objects, y rays (multi-ray), z flags (1 = exact binary visibility), w step limit
    vec4 params;   // x maxDistance, y strength, z field safety, w pixel footprint per unit distance
    vec4 eps;      // x hit epsilon (pixel footprints)
    uvec4 tiles;   // x tilesX, z flags (kTileLists, kNoCull, kCache, kIdField)
} ao;

const uint kExactFlag = 1u;
const uint kTileLists = 1u;  // tiles.z: SdfTileRanges / SdfTileIndices hold this frame's AO lists
const uint kNoCull = 2u;     // tiles.z: culling off
const uint kCache = 4u;      // tiles.z: the world cache where the point is beyond maxDistance of all
const uint kIdField = 8u;    // tiles.z: the id field's object where it is certain
const uint kCastsShadows = 1u;  // GpuSdfObject::params.y (kSdfObjectCastsShadows)
const int kListSize = 16;
const float kPi = 3.14159265358979;

uint g_list[kListSize];
int g_count;
bool g_overflow;
// The candidates: the tile list [g_first, g_first + g_candidates) when g_fromTile, else the objects
// [0, g_candidates).
uint g_first;
uint g_candidates;
bool g_fromTile;
bool g_noCull;

uint candidate(uint i) { return g_fromTile ? sdfTileIndices[g_first + i] : i; }

vec3 g_surface;  // the pixel's surface point: occluders count only within maxDistance of it

// Whether the object is within the influence radius (maxDistance) of the surface point.
bool influences(uint obj) { return sdfBoxDistance(obj, sdfToLocal(obj, g_surface)) <= ao.params.x; }

// Collects the occluders within maxDistance of p (their bounds box distance, a lower bound) among
// the candidates of the full-resolution pixel.
void cullObjects(vec3 p, ivec2 pixel) {
    g_surface = p;
    g_count = 0;
    g_overflow = false;
    g_first = 0u;
    g_candidates = ao.counts.x;
    g_fromTile = false;
    g_noCull = (ao.tiles.z & kNoCull) != 0u;
    if (g_noCull) {
        g_overflow = true;
        return;
    }
    if ((ao.tiles.z & kTileLists) != 0u) {
        uvec2 range = sdfTileRanges[sdfTileIndex(pixel, ao.tiles.x)];
        if (range.y != 0xffffffffu) {  // 0xffffffff: the list overflowed, every object
            g_first = range.x;
            g_candidates = range.y;
            g_fromTile = true;
        }
    }
    for (uint i = 0u; i < g_candidates; ++i) {
        uint obj = candidate(i);
        if ((sdfObjects[obj].params.y & kCastsShadows) == 0u) continue;
        if (!influences(obj)) continue;
        if (g_count == kListSize) {
            g_overflow = true;
            return;
        }
        g_list[g_count++] = obj;
    }
}

// Conservative distance from p to the nearest listed occluder (3e38: none). An object whose box is
// farther than the best distance so far is not evaluated. With the world cache (kCache): a cached
// distance of at least maxDistance is returned as it is (every variant reads only distances below
// maxDistance: the taps, cones and rays come out the same); with the id field (kIdField) the object
// the cell names, when certain and taking part in AO, is the nearest occluder and is evaluated alone.
float sceneDistance(vec3 p) {
    if ((ao.tiles.z & (kCache | kIdField)) != 0u) {
        float cached, voxel;
        uint obj;
        if (sdfCacheLookup(p, cached, voxel, obj)) {
            if ((ao.tiles.z & kCache) != 0u && cached >= ao.params.x) return cached;
            if ((ao.tiles.z & kIdField) != 0u && obj < ao.counts.x &&
                (sdfObjects[obj].params.y & kCastsShadows) != 0u && influences(obj)) {
                vec3 pl = sdfToLocal(obj, p);
                float box = sdfBoxDistance(obj, pl);
                float od = sdfObjects[obj].boundsMin.w * sdfLocalDistance(obj, pl, ao.params.z);
                return box > 0.0 ? max(box, od) : od;
            }
        }
    }
    float d = 3.0e38;
    int count = g_overflow ? int(g_candidates) : g_count;
    for (int i = 0; i < count; ++i) {
        uint obj = g_overflow ? candidate(uint(i)) : g_list[i];
        if (g_overflow && (sdfObjects[obj].params.y & kCastsShadows) == 0u) continue;
        vec3 pl = sdfToLocal(obj, p);
        // The larger of two lower bounds (box, object): skipping a box no nearer than the best so far
        // changes nothing, so culled and unculled AO see the same distances.
        float box = sdfBoxDistance(obj, pl);
        if (!g_noCull && box >= d) continue;
        float od = sdfObjects[obj].boundsMin.w * sdfLocalDistance(obj, pl, ao.params.z);
        if (g_noCull && !influences(obj)) continue;  // evaluated (no optimisation), then ignored
        d = min(d, box > 0.0 ? max(box, od) : od);  // box 0: inside the box, the object's sign counts
    }
    return d;
}

// Five distance taps along unit `dir` (Evans; Quilez): taps at t_k = maxDistance * k / 5, k = 1..5,
// weights w_k = 2^-(k-1). A tap's occlusion is how far the surface is nearer than it would be over
// an open tangent plane, e_k = t_k * cos(dir, n) (t_k along the normal itself):
// occlusion = sum w_k clamp(e_k - d_k, 0, e_k) / sum w_k e_k, in [0, 1].
float fiveTapOcclusion(vec3 o, vec3 dir, float cosTheta) {
    float occ = 0.0, norm = 0.0, w = 1.0;
    for (int k = 1; k <= 5; ++k) {
        float t = ao.params.x * float(k) / 5.0;
        float e = t * max(cosTheta, 0.05);
        float d = sceneDistance(o + dir * t);
        occ += w * clamp(e - d, 0.0, e);
        norm += w * e;
        w *= 0.5;
    }
    return norm > 0.0 ? occ / norm : 0.0;  // maxDistance 0 (API only): nothing occludes, not 0 / 0
}

// Exact binary visibility of the ray o + t dir, t in (0, maxDistance]: sphere tracing over the
// culled occluders; a hit when the distance falls below `hitEps`. A ray that runs out of steps
// counts as unoccluded, and so does one whose free sphere reaches past maxDistance.
bool rayOccluded(vec3 o, vec3 dir, float hitEps) {
    float t = 0.0;
    for (uint s = 0u; s < ao.counts.w && t <= ao.params.x; ++s) {
        float d = sceneDistance(o + dir * t);
        if (d < hitEps) return true;
        if (d > ao.params.x - t) return false;
        t += d;
    }
    return false;
}

// The i-th of n directions of a spherical Fibonacci set over the cosine-weighted hemisphere around
// the z axis (equal weights: sin^2 of the polar angle uniform in (0, 1), golden-angle azimuths).
vec3 fibonacciDirection(uint i, uint n) {
    float s2 = (float(i) + 0.5) / float(n);
    // 2 pi i (1 - 1 / golden ratio), reduced to [0, 2 pi) first: sin and cos of large arguments lose
    // accuracy on some GPUs.
    float phi = 6.28318531 * fract(float(i) * 0.38196601);
    float s = sqrt(s2);
    return vec3(s * cos(phi), s * sin(phi), sqrt(max(1.0 - s2, 0.0)));
}

// An orthonormal frame around n (Duff et al. 2017): columns tangent, bitangent, n.
mat3 tangentFrame(vec3 n) {
    float sgn = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + n.z), b = n.x * n.y * a;
    return mat3(vec3(1.0 + sgn * n.x * n.x * a, sgn * b, -sgn * n.x), vec3(b, sgn + n.y * n.y * a, -n.y), n);
}

// Multi-ray: N = counts.y Fibonacci directions, each a five-tap (mTec's hybrid) or, with the exact
// flag, a binary ray (the ray-traced AO). The bent normal is the mean unoccluded direction, with the
// set's own bias removed (an open surface gives n exactly).
vec4 multiRay(vec3 o, vec3 n, float hitEps) {
    mat3 frame = tangentFrame(n);
    uint rays = ao.counts.y;
    bool exact = (ao.counts.z & kExactFlag) != 0u;
    float visible = 0.0;
    vec3 all = vec3(0.0), open = vec3(0.0);
    for (uint i = 0u; i < rays; ++i) {
        vec3 local = fibonacciDirection(i, rays);
        vec3 dir = frame * local;
        float v = exact ? (rayOccluded(o, dir, hitEps) ? 0.0 : 1.0) : 1.0 - fiveTapOcclusion(o, dir, local.z);
        visible += v;
        all += dir;
        open += v * dir;
    }
    vec3 bent = open - all + n * length(all);
    return vec4(1.0 - visible / float(rays), bent);
}

// Cones (Wright): 9 cones over the hemisphere, each carrying 1/9 of the cosine weight: the central
// cone covers polar angles below asin(1/3) (19.5 deg), 8 cones at 45 deg azimuth steps around polar
// angle asin(sqrt(5/9)) (48.2 deg, the ring's cosine-weighted median), half-angle 25 deg each. A
// cone's visibility is the minimum of d / (t tan(halfAngle)) along its axis (Wright's 1D cone
// intersection, clamped to [0, 1]), marched by the distance with at least a tenth of the cone
// radius per step; the bent normal is the visibility-weighted sum of the axes.
vec4 cones(vec3 o, vec3 n, float tStart) {
    const float tanHalf = 0.46630766;  // tan(25 deg)
    const float ringSin = 0.74535599, ringCos = 0.66666667;
    mat3 frame = tangentFrame(n);
    float visible = 0.0;
    vec3 bent = vec3(0.0);
    for (int c = 0; c < 9; ++c) {
        float phi = float(c) * (kPi / 4.0);
        vec3 local = c == 8 ? vec3(0.0, 0.0, 1.0) : vec3(ringSin * cos(phi), ringSin * sin(phi), ringCos);
        vec3 axis = frame * local;
        float vis = 1.0;
        float t = tStart;
        for (uint s = 0u; s < ao.counts.w && t < ao.params.x && vis > 0.0; ++s) {
            float d = sceneDistance(o + axis * t);
            vis = min(vis, clamp(d / (t * tanHalf), 0.0, 1.0));
            t += max(d, 0.1 * t * tanHalf);
        }
        visible += vis;
        bent += vis * axis;
    }
    return vec4(1.0 - visible / 9.0, bent);
}

void main() {
    ivec2 low = ivec2(gl_GlobalInvocationID.xy);
    ivec2 lowSize = imageSize(aoImage);
    if (low.x >= lowSize.x || low.y >= lowSize.y) return;
    ivec2 fullSize = ivec2(view.viewport.xy);
    ivec2 pixel = effectsFullPixel(low, lowSize, fullSize);
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    if (depth <= 0.0) {
        imageStore(aoImage, low, vec4(1.0, 0.5, 0.5, 0.5));
        return;
    }
    vec3 n = octDecode(texelFetch(gbufferNormal, pixel, 0).rg);
    vec3 p = effectsWorldPosition(pixel, depth);
    float footprint = ao.params.w * depth;
    // Start above the surface: a few hit epsilons (the trace stops up to one in front of it), the
    // shadows' surface bias (1.5 voxels near a field: its safe distance lies up to an interpolation
    // bound below the traced surface, which at small hit epsilons — the reference preset — made
    // every cone start inside and see full occlusion), and enough float ulps of the coordinates.
    float offset = max(max(4.0 * ao.eps.x * footprint, sdfSurfaceBias(p, footprint, ao.counts.x)),
                       2e-5 * max(1.0, length(p)));
    vec3 o = p + n * offset;
    cullObjects(p, pixel);

    vec4 result;  // x occlusion, yzw bent normal (unnormalised)
#if defined(MULTI_RAY)
    result = multiRay(o, n, 0.5 * offset);
#elif defined(CONES)
    result = cones(o, n, offset);
#else
    result = vec4(fiveTapOcclusion(o, n, 1.0), n);
#endif
    vec3 bent = dot(result.yzw, result.yzw) > 1e-12 ? normalize(result.yzw) : n;
    float value = clamp(1.0 - ao.params.y * result.x, 0.0, 1.0);
    imageStore(aoImage, low, vec4(value, bent * 0.5 + 0.5));
}
