// Cone-traced visibility through the frame's SDF objects (owned by the sdf_shadow module,
// renderer/features/sdf_shadow.h; also used by sdf_reflection to shadow reflected hits). After
// Wright's distance-field area shadows (reference 001) and mTec 8.2.5 (reference 000), with the
// penumbra from the light's actual size instead of a free sharpness constant.
//
// Use: include after sdf_scene.glsl (which declares sdfObjects and the distance code).
//
// STABLE INTERFACE (other modules call these; change only together with them):
//
//   float sdfConeVisibility(vec3 origin, vec3 dir, float tMin, float tMax, float sinHalfAngle,
//                           uint objectCount, uint maxSteps, float fieldSafety, float epsilon);
//       The visible fraction in [0, 1] of a light seen from `origin` in unit direction `dir` under
//       the cone half-angle asin(sinHalfAngle), marching t in [tMin, tMax] over the objects
//       [0, objectCount) whose params.y has SDF_OBJECT_CASTS_SHADOWS. sinHalfAngle <= 0 is a hard
//       (binary) shadow ray: 0 as soon as the conservative distance drops below `epsilon` (world
//       units; also the smallest step). maxSteps bounds the distance evaluations. fieldSafety as in
//       sdf_scene.glsl (EffectsDesc::trace.fieldSafety).
//
//   float sdfSurfaceBias(vec3 p, float pixelSize, uint objectCount);
//       The offset along the surface normal (world units) that keeps a ray leaving the surface at p
//       from shadowing itself on the surface's own distance error: a quarter pixel footprint
//       (pixelSize = the pixel's world size at p; analytic surfaces are traced to a small fraction
//       of that) and at least 1.5 voxels of the nearest field object (its trilinear surface lies up
//       to a voxel off the baked one, and the safe distance another interpolation bound below
//       that). Start the ray at p + n * bias with tMin = 2 * pixelSize + bias along the light
//       direction: the normal offset moves the shadow sideways by bias * tan(angle of incidence),
//       so it stays small; the start along the ray, which moves nothing, clears the rest.
//
//   float sdfDiscVisible(float x);
//       The visible fraction of a uniform disc of radius 1 cut by a straight edge at signed offset
//       x from its centre (x >= 1 all visible, x <= -1 none).
//
// The estimate. At a march point o + t dir the cone's cross-section is a disc whose edge is
// t sin(halfAngle) from the axis point (the distance from the axis point to the cone's surface);
// the nearest occluder surface is d away (conservative SDF distance, negative inside). Taking the
// occluder locally as a half-space whose boundary is d from the axis, the fraction of the light
// disc it leaves visible is sdfDiscVisible(x) with x = d / (t sin(halfAngle)): the area of a
// circular segment, 0.5 + (x sqrt(1 - x^2) + asin(x)) / pi, i.e. the light is treated as a
// uniform disc of directions (a sphere or sun disc of uniform radiance). The most occluded point
// along the ray (the minimum x) decides the visibility. Only the light's size enters: no tuning
// constant. Known bias: an occluder whose angular size is close to the light's has a curved edge
// across the disc, and the half-space covers more of the disc than it does (the estimate is then
// darker than the exact cap overlap; tests/renderer/sdf_shadow_test.cpp measures it). Inside an
// occluder the distance is that to the nearest face, not to the silhouette edge seen from the
// receiver, so an occluder thinner than the cone's cross-section where the ray crosses it lets
// about half the light through (x >= -thickness / (2 t sin(halfAngle))): thin plates give weak
// umbras, as in every distance-field cone trace.
//
// Culling: an object takes part in a ray only if its bounds box, grown by the cone's radius where
// the cone could reach it, meets the ray in [tMin, tMax]; up to SDF_CONE_LIST objects are kept in
// a list, a ray meeting more boxes marches over all its candidates (correct, slower). The
// candidates are every object [0, objectCount) (sdfConeVisibility), or, in a pass that includes
// sdf_tiles.glsl first, its tile's shadow list (sdfConeSourceTile, issue 13: the lists of
// renderer/features/sdf_effects_cull.h). sdfConeSourceNoCull turns all culling off: every casting
// object at every step, no box test (the benchmarks' "no optimization"). sdfConeTrace marches with
// the source set last; sdfConeVisibility keeps its signature and always starts from every object.
//
// World cache (issue 13; Wright: object distances near the cone's start, the global distance
// beyond): in a pass that includes sdf_world_cache.glsl first, sdfConeUseCache(cache, ids) after
// the source lets the march read the cached world distance at each point (a conservative lower
// bound over all objects). A hard ray steps by it without evaluating objects wherever it is at least
// 4 epsilons (no hit there, and the end-of-march test sees the same). A soft cone does not: there a
// cached distance of at least the cone's radius would leave x >= 1, but its steps (shorter than the
// exact ones by the cache's margins) move every later sample, and the min over samples of the
// penumbra estimate depends on where they fall (measured: 0.13-0.16 % of the lit pixels of
// scenes/default.json over the parity tolerance, sdf_effects_accel_test). With ids, the object the
// id field names for the point's cell, when it is certain and casts shadows, is the nearest occluder
// there and is evaluated alone (the same distance: bitwise-equal shadows in that test); otherwise the
// candidates as without the cache.
#ifndef PENUMBRA_SDF_CONE_GLSL
#define PENUMBRA_SDF_CONE_GLSL

const uint SDF_OBJECT_CASTS_SHADOWS = 1u;  // GpuSdfObject::params.y (kSdfObjectCastsShadows)
const int SDF_CONE_LIST = 16;

float sdfDiscVisible(float x) {
    x = clamp(x, -1.0, 1.0);
    return clamp(0.5 + (x * sqrt(1.0 - x * x) + asin(x)) / 3.14159265358979, 0.0, 1.0);
}

bool sdfConeUnbounded(uint obj) { return sdfObjects[obj].boundsMax.x >= 1.0e29 || sdfObjects[obj].boundsMin.x <= -1.0e29; }

// The ray o + t d against the object's local box grown by `grow` world units: [enter, exit].
// World distance >= sigma_min * local distance, so growing the local box by grow / sigma_min covers
// every point within `grow` of the world box.
vec2 sdfConeInterval(uint obj, vec3 o, vec3 d, float grow) {
    if (sdfConeUnbounded(obj)) return vec2(-3.0e38, 3.0e38);
    float g = grow / max(sdfObjects[obj].boundsMin.w, 1e-30);
    mat4 w = sdfObjects[obj].worldToLocal;
    vec3 lo = (w * vec4(o, 1.0)).xyz;
    vec3 ld = mat3(w) * d;
    vec3 inv = 1.0 / mix(ld, vec3(1e-30), lessThan(abs(ld), vec3(1e-30)));
    vec3 t0 = (sdfObjects[obj].boundsMin.xyz - g - lo) * inv;
    vec3 t1 = (sdfObjects[obj].boundsMax.xyz + g - lo) * inv;
    vec3 tn = min(t0, t1), tf = max(t0, t1);
    return vec2(max(max(tn.x, tn.y), tn.z), min(min(tf.x, tf.y), tf.z));
}

// Farthest distance from o to the object's world box (bounding sphere of the local box through the
// model matrix; the Frobenius norm bounds the largest singular value).
float sdfConeFarthest(uint obj, vec3 o) {
    mat4 m = sdfObjects[obj].model;
    vec3 lc = 0.5 * (sdfObjects[obj].boundsMin.xyz + sdfObjects[obj].boundsMax.xyz);
    vec3 lh = 0.5 * (sdfObjects[obj].boundsMax.xyz - sdfObjects[obj].boundsMin.xyz);
    float scale = sqrt(dot(m[0].xyz, m[0].xyz) + dot(m[1].xyz, m[1].xyz) + dot(m[2].xyz, m[2].xyz));
    return length((m * vec4(lc, 1.0)).xyz - o) + length(lh) * scale;
}

uint g_coneList[SDF_CONE_LIST];
vec2 g_coneInterval[SDF_CONE_LIST];
int g_coneCount;
bool g_coneOverflow;

// The candidates of the per-ray cull: g_coneFirst / g_coneCandidates index the tile list when
// g_coneFromTile, else the objects [0, g_coneCandidates). g_coneNoCull: no culling at all.
uint g_coneFirst;
uint g_coneCandidates;
bool g_coneFromTile;
bool g_coneNoCull;
bool g_coneCache;  // step by the cached world distance where the cone is clear
bool g_coneIds;    // near occluders, the id field's object alone when it is certain

void sdfConeSourceAll(uint objectCount) {
    g_coneFirst = 0u;
    g_coneCandidates = objectCount;
    g_coneFromTile = false;
    g_coneNoCull = false;
    g_coneCache = false;
    g_coneIds = false;
}

// After a sdfConeSource* call; without sdf_world_cache.glsl both stay off.
void sdfConeUseCache(bool cache, bool ids) {
#ifdef SDF_CACHE_SET
    g_coneCache = cache;
    g_coneIds = ids;
#endif
}

void sdfConeSourceNoCull(uint objectCount) {
    sdfConeSourceAll(objectCount);
    g_coneNoCull = true;
}

#ifdef SDF_TILES_SET
// range = the tile list's (first, count); count 0xffffffff: the list overflowed, every object.
void sdfConeSourceTile(uvec2 range, uint objectCount) {
    sdfConeSourceAll(objectCount);
    if (range.y == 0xffffffffu) return;
    g_coneFirst = range.x;
    g_coneCandidates = range.y;
    g_coneFromTile = true;
}
#endif

uint sdfConeCandidate(uint i) {
#ifdef SDF_TILES_SET
    if (g_coneFromTile) return sdfTileIndices[g_coneFirst + i];
#endif
    return i;
}

// Fills the list of objects the cone can meet; returns false when none can. Without culling the
// "list" is every candidate (g_coneOverflow).
bool sdfConeCull(vec3 o, vec3 d, float tMin, float tMax, float tanHalf, float epsilon, uint objectCount) {
    g_coneCount = 0;
    g_coneOverflow = false;
    if (g_coneNoCull) {
        g_coneOverflow = true;
        g_coneCount = int(g_coneCandidates);
        return g_coneCount > 0;
    }
    for (uint i = 0u; i < g_coneCandidates; ++i) {
        uint obj = sdfConeCandidate(i);
        if ((sdfObjects[obj].params.y & SDF_OBJECT_CASTS_SHADOWS) == 0u) continue;
        float reach = sdfConeUnbounded(obj) ? 0.0 : min(tMax, sdfConeFarthest(obj, o));
        vec2 iv = sdfConeInterval(obj, o, d, tanHalf * reach + epsilon);
        if (iv.x > iv.y || iv.y < tMin || iv.x > tMax) continue;
        if (g_coneCount < SDF_CONE_LIST) {
            g_coneList[g_coneCount] = obj;
            g_coneInterval[g_coneCount] = iv;
            ++g_coneCount;
        } else {
            g_coneOverflow = true;
        }
    }
    if (g_coneOverflow) g_coneCount = int(g_coneCandidates);
    return g_coneCount > 0;
}

// Conservative distance to the nearest listed occluder at the march point (ray parameter t).
float sdfConeDistance(vec3 p, float t, float fieldSafety) {
    float d = 3.0e38;
    for (int i = 0; i < g_coneCount; ++i) {
        uint obj;
        if (!g_coneOverflow) {
            if (t > g_coneInterval[i].y) continue;  // the cone has left this (grown) box for good
            obj = g_coneList[i];
        } else {
            obj = sdfConeCandidate(uint(i));
            if ((sdfObjects[obj].params.y & SDF_OBJECT_CASTS_SHADOWS) == 0u) continue;
        }
        vec3 pl = sdfToLocal(obj, p);
        // Both the box distance and the object's distance are lower bounds of the distance to the
        // solid: the larger one counts, so skipping an object whose box is no nearer than the best so
        // far changes nothing (culled and unculled marches see the same distances).
        float box = sdfBoxDistance(obj, pl);
        if (!g_coneNoCull && box >= d) continue;
        float od = sdfObjects[obj].boundsMin.w * sdfLocalDistance(obj, pl, fieldSafety);
        d = min(d, box > 0.0 ? max(box, od) : od);  // box 0: inside the box, the object's sign counts
    }
    return d;
}

// The distance the march uses at p (ray parameter t): the cached world distance when it is at least
// `clear` (> 0: hard rays only), the id field's object when the cell names one that casts shadows,
// else the nearest candidate.
float sdfConeStepDistance(vec3 p, float t, float clear, uint objectCount, float fieldSafety) {
#ifdef SDF_CACHE_SET
    if (g_coneCache || g_coneIds) {
        float cached, voxel;
        uint obj;
        if (sdfCacheLookup(p, cached, voxel, obj)) {
            if (g_coneCache && clear > 0.0 && cached >= clear) return cached;
            if (g_coneIds && obj < objectCount && (sdfObjects[obj].params.y & SDF_OBJECT_CASTS_SHADOWS) != 0u) {
                vec3 pl = sdfToLocal(obj, p);
                float box = sdfBoxDistance(obj, pl);
                float od = sdfObjects[obj].boundsMin.w * sdfLocalDistance(obj, pl, fieldSafety);
                return box > 0.0 ? max(box, od) : od;
            }
        }
    }
#endif
    return sdfConeDistance(p, t, fieldSafety);
}

// sdfConeVisibility over the candidates of the last sdfConeSource* call.
float sdfConeTrace(vec3 origin, vec3 dir, float tMin, float tMax, float sinHalfAngle, uint objectCount, uint maxSteps,
                   float fieldSafety, float epsilon) {
    bool hard = sinHalfAngle <= 0.0;
    float s = clamp(sinHalfAngle, 0.0, 0.999);
    float tanHalf = s / sqrt(1.0 - s * s);
    if (tMax <= tMin || !sdfConeCull(origin, dir, tMin, tMax, tanHalf, epsilon, objectCount)) return 1.0;
    float xMin = 1.0;
    float t = tMin;
    float d = 3.0e38;
    for (uint step = 0u; step < maxSteps && t < tMax; ++step) {
        d = sdfConeStepDistance(origin + dir * t, t, hard ? 4.0 * epsilon : -1.0, objectCount, fieldSafety);
        if (hard) {
            if (d < epsilon) return 0.0;
            t += max(d, epsilon);
            continue;
        }
        float radius = t * s;  // from the axis point to the cone's surface
        // Outside an occluder the cone counts as at least epsilon wide: near its apex a step of
        // epsilon could otherwise jump a wall thinner than that unseen (d / radius stays large while
        // the radius is tiny). Inside (d < 0) the true radius keeps a thin wall's umbra dark.
        xMin = min(xMin, d / (d > 0.0 ? max(radius, epsilon) : max(radius, 1e-30)));
        if (xMin <= -1.0) return 0.0;
        // Plain sphere-tracing steps outside; inside an occluder |d| (the way out) still never
        // skips a deeper point by more than the sampling already does. At least a tenth of the
        // cone's radius and epsilon, so a ray along a surface does not stall.
        t += max(abs(d), max(0.1 * radius, epsilon));
    }
    // Out of steps while still creeping along a surface (a ray meeting it at a grazing angle takes
    // ever smaller steps): a hard ray within a few epsilons of it is taken as blocked.
    if (hard) return t < tMax && d < 4.0 * epsilon ? 0.0 : 1.0;
    return sdfDiscVisible(xMin);
}

float sdfConeVisibility(vec3 origin, vec3 dir, float tMin, float tMax, float sinHalfAngle, uint objectCount,
                        uint maxSteps, float fieldSafety, float epsilon) {
    sdfConeSourceAll(objectCount);
    return sdfConeTrace(origin, dir, tMin, tMax, sinHalfAngle, objectCount, maxSteps, fieldSafety, epsilon);
}

float sdfSurfaceBias(vec3 p, float pixelSize, uint objectCount) {
    float bias = 0.25 * pixelSize;
#ifdef SDF_FIELDS
    float nearest = 3.0e38;
    float voxel = 0.0;
    for (uint obj = 0u; obj < objectCount; ++obj) {
        float v = sdfObjectVoxel(obj);
        if (v <= 0.0) continue;
        vec3 pl = sdfToLocal(obj, p);
        float box = sdfBoxDistance(obj, pl);
        if (box > 2.0 * v || box >= nearest) continue;
        float d = abs(sdfObjectDistance(obj, p, 0.0));
        if (d < nearest) {
            nearest = d;
            voxel = v;
        }
    }
    bias = max(bias, 1.5 * voxel);
#endif
    return bias;
}

#endif
