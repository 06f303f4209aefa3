// sdf_trace: full-screen sphere tracing of the frame's SDF objects into the G-buffer
// (renderer/features/sdf_trace.h documents the settings, renderer/scene_renderer.h the G-buffer).
// One invocation per pixel:
//  1. the camera ray through the pixel centre; its interval ends at the rasterized depth when a mesh
//     pass ran (RASTER flag: the trace is bounded by the raster depth, so meshes and SDFs occlude
//     each other correctly), else at the far plane;
//  2. culling (acceleration flag CULL, scene::AccelerationSettings::culling): the candidate objects
//     are the pixel's 8x8 tile list (sdf_tiles.glsl, built by sdf_cull; every traced object when
//     the frame has no lists); each one's local bounds box is intersected with the ray, objects it
//     misses are never evaluated, the march starts at the first box entry, and an object is
//     dropped once a step starts past its box or when its box is farther than the best distance
//     so far. Up to kListSize objects are kept in a per-pixel list; a ray crossing more boxes
//     evaluates the whole tile list (correct, slower). Without CULL every object [0, tracedCount)
//     is evaluated at every step (mTec's "no optimization" baseline); the march interval (first
//     box entry on, none when the ray crosses no box) is the same either way;
//  3. sphere tracing with over-relaxation (Keinert et al. 2014): steps of omega * d while the
//     unbounding spheres of consecutive points overlap; when they do not, the step returns to the
//     previous point plus its plain (safe) step and omega becomes 1 for the rest of the ray;
//  4. a hit candidate is d < hitEpsilon pixel footprints at the current distance (at least a few
//     float ulps of the point's coordinates), d the safe distance and, for a field, then also its
//     raw (interpolated) value — when only the safe one is below, the ray goes on with plain steps
//     on the raw value; a ray inside a solid (d <= 0, e.g. a camera inside an object) hits where it
//     is; if the step limit runs out, the point with the smallest d / t (screen-space error) is kept
//     when that error is within 4x the hit threshold (Keinert's hit selection), else the pixel is a
//     miss;
//  5. the hit decision (objectRoot; refineSteps 0: every candidate is a hit where it is): the first
//     root along the ray of the candidate's object on its own raw distance (no interpolation
//     safety), and of every other candidate object whose distance here is below the gap to the best
//     root so far (below hitEpsilon while there is none) — secant steps while the distance falls,
//     regula falsi once a point below zero brackets the root, at most refineSteps evaluations per
//     object, converged within 1e-3 hit epsilons above the surface. The earliest root is the hit,
//     on its object (the first surface at a contact line, e.g. a box standing on the floor, where
//     the union's distance is near zero all along the contact plane); when no object has a root
//     (the distance grows again: the ray passes within hitEpsilon of a silhouette) the march goes
//     on past the candidate object's closest approach. The decision depends only on the ray and the
//     objects, not on where the march's samples landed, so culling, the world cache and
//     over-relaxation leave the picture as it is (tests/renderer/sdf_accel_parity_test.cpp). steps
//     counts every evaluation and never exceeds the step limit;
//  6. the normal is the gradient of the hit object's world distance by central differences over
//     a tetrahedron (4 evaluations) with h = normalEpsilon pixel footprints (at least 1e-5 of the
//     distance from the origin, for float precision, and for fields at least half a voxel);
//     velocity from the object's previous model.
// World cache (flags CACHE, ID; sdf_world_cache.glsl, built by sdf_world_cache): at each step
// whose point lies in a clipmap level, a cached distance above two voxels and two hit epsilons is
// taken as a plain safe step with no object evaluated (such steps have their own limit and do not
// count against the step limit); nearer, when the id field names a traced object for the point's
// cell, that object alone is evaluated (it is the nearest everywhere in the cell); otherwise the
// list (or every object). With ID but not CACHE only the id part is used.
// gbuffer.aux y counts the steps that evaluated objects (at most the step limit; cache steps are
// not counted), or (flag COUNT_EVALUATIONS, tests and benchmarks) the object distance evaluations
// of the pixel: the work the acceleration saves.
#version 450
#pragma penumbra_variants ALBEDO AUX SDF_FIELDS ALBEDO+AUX ALBEDO+SDF_FIELDS AUX+SDF_FIELDS ALBEDO+AUX+SDF_FIELDS
layout(local_size_x = 8, local_size_y = 8) in;

#include "scene.glsl"
#include "gbuffer.glsl"

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

layout(set = 2, binding = 0, r32f) uniform image2D gbufferDepthImage;
layout(set = 2, binding = 1, rg16f) uniform image2D gbufferNormalImage;
layout(set = 2, binding = 2, rgba8) uniform image2D gbufferMaterialImage;
layout(set = 2, binding = 3, rg16f) uniform image2D gbufferVelocityImage;
#ifdef ALBEDO
SCENE_MATERIALS;
layout(set = 2, binding = 4, rgba8) uniform writeonly image2D gbufferAlbedoImage;
#endif
#ifdef AUX
layout(set = 2, binding = 5, rg32f) uniform image2D gbufferAuxImage;
#endif

layout(push_constant) uniform SdfTrace {
    uvec4 counts;    // x objects, y flags (1 = a raster pass wrote the G-buffer), z step limit, w refine steps
    vec4 epsilons;   // x hit epsilon, y normal epsilon (pixel footprints), z over-relaxation omega,
                     // w field safety factor
    vec4 clip;       // x near, y far (linear depth), z pixel footprint per unit of distance
    uvec4 accel;     // x acceleration flags (k*Flag below), y tiles per row of the tile lists
} trace;

const uint kRasterFlag = 1u;
// trace.accel.x
const uint kCullFlag = 1u;        // bounds culling (tile list, per-pixel ray/box list)
const uint kCacheFlag = 2u;       // world cache distance steps far from surfaces
const uint kIdFlag = 4u;          // id field: near a surface evaluate the one object it names
const uint kTileListsFlag = 8u;   // SdfTileRanges / SdfTileIndices hold this frame's primary lists
const uint kCountEvalsFlag = 16u;  // gbuffer.aux y = object evaluations instead of steps
const uint kCacheBoundFlag = 32u;  // the world cache is bound (else stand-ins that are never read)
const int kListSize = 24;
const float kRootTolerance = 1e-3;  // the hit decision's convergence above a surface, in hit epsilons

uint g_list[kListSize];
vec2 g_interval[kListSize];
int g_count;
bool g_overflow;
// The pixel's candidate objects with culling: its tile list, or every traced object (g_tileAll).
uint g_tileFirst, g_tileCount;
bool g_tileAll;
uint g_evaluations;  // object distance evaluations of this pixel (kCountEvalsFlag)

uint tileObject(uint i) { return g_tileAll ? i : sdfTileIndices[g_tileFirst + i]; }

// The objects a pixel's ray considers: its per-pixel list, its tile
// list, or every traced object. candidateObject returns 0xffffffff for a list entry whose box the
// ray had left before tFrom.
uint candidateCount() {
    bool cull = (trace.accel.x & kCullFlag) != 0u;
    return cull ? (g_overflow ? g_tileCount : uint(g_count)) : trace.counts.x;
}
uint candidateObject(uint i, float tFrom) {
    bool cull = (trace.accel.x & kCullFlag) != 0u;
    if (!cull) return i;
    if (g_overflow) return tileObject(i);
    return tFrom > g_interval[i].y ? 0xffffffffu : g_list[i];
}

// Distance to the nearest object at world point p; `nearest` is its object, `second` a lower bound
// of the other objects' distances. `only` (the id field's object for p's cell, else 0xffffffff) is
// the nearest object everywhere around p: it alone is evaluated and bounds the others too. With
// culling, objects whose box the ray had left before `tFrom` (the point the last step started from)
// are skipped: the step from tFrom to here may have crossed a box the current point is already
// past, and the over-relaxation check needs every surface near that segment; an object whose box
// is farther than the best distance so far is not evaluated. Without culling every traced object
// is evaluated. (Each call site of the distance code is inlined by the compiler, so the shader
// keeps few of them: this loop, the normal's and the refinement's.)
float sceneDistance(vec3 p, float tFrom, float safety, uint only, out uint nearest, out float second) {
    float d = 3.0e38;
    second = 3.0e38;  // the nearest distance of the other objects (a lower bound)
    nearest = 0xffffffffu;
    bool one = only != 0xffffffffu;
    bool cull = (trace.accel.x & kCullFlag) != 0u && !one;
    uint count = one ? 1u : candidateCount();
    for (uint i = 0u; i < count; ++i) {
        uint obj = one ? only : candidateObject(i, tFrom);
        if (obj == 0xffffffffu) continue;  // the ray had left this box for good
        vec3 pl = sdfToLocal(obj, p);
        if (cull) {
            float box = sdfBoxDistance(obj, pl);
            if (box >= d) {  // cannot be nearer than the best so far; its box bounds `second`
                second = min(second, box);
                continue;
            }
        }
        ++g_evaluations;
        float di = sdfObjects[obj].boundsMin.w * sdfLocalDistance(obj, pl, safety);
        if (di < d) {
            second = d;
            d = di;
            nearest = obj;
        } else {
            second = min(second, di);
        }
    }
    if (one) second = d;  // the nearest everywhere in the cell: the others are at least as far
    return d;
}

// The hit decision for one object: the first root of its raw distance (an interpolated field without
// the safety bound) along the ray after t0, where it is s0, before tEnd; -1 when there is none
// (a near miss, or no root before tEnd). Every object is searched on its own, so the result does not
// depend on where the march's samples landed (culling, the world cache and over-relaxation all move
// them), and where surfaces touch (a box standing on the floor) the ray's first surface wins: the
// union's distance is near zero all along a contact plane, its own roots are not. Steps: the secant
// root estimate through the previous point while the distance falls (exact for a plane at any angle,
// where plain steps crawl at grazing angles; short of the root where the distance is convex), else a
// plain step; a point below zero brackets the root and regula falsi closes the bracket (a bisection
// when the far end moved twice). Converged: a point at most tol above the surface, or a bracket
// narrower than 1e-5 t (its outer end). The distance growing again without a root is a near miss (a
// ray that passes within eps of a silhouette is not widened onto it; tPast: a point the object has
// no root before). Every evaluation counts
// against the step limit; a search that the limit cuts short takes its best point when it is within
// eps / 10 or bracketed.
float objectRoot(uint obj, vec3 ro, vec3 rd, float t0, float s0, bool known, float gate, float tEnd, float tol,
                 float eps, uint stepLimit, bool countFirst, inout uint steps, out float tPast, out float sFirst) {
    tPast = t0;
    sFirst = s0;
    float ta = t0, sa = s0, tp = t0, sp = s0, tb = t0, sb = 0.0;
    bool bracket = false, prev = false, pending = known;
    // A field's interpolated distance bends at its trilinear cells: its secant steps go at most one
    // voxel (or the plain step) at a time, so they do not overshoot the parts a cell resolves.
    float voxel = sdfObjectVoxel(obj);
    int side = 0;  // the end of the bracket that moved last: 1 a, -1 b, -2 b twice
    // r = -1: the distance at t0 when the caller does not know it (the loop's one evaluation site:
    // a CPU device runs every site of a loop at every iteration, so the search keeps a single one).
    for (int r = known ? 0 : -1; r < int(trace.counts.w); ++r) {
        if (pending) {
            pending = false;
            sFirst = sa;
            if (sa >= gate) return -1.0;  // no candidate: farther than the gap to the best root
            if (sa <= tol) return t0;  // on the surface, or inside (a ray that starts in a solid)
        }
        if (r >= 0 && steps >= stepLimit) break;
        if (bracket && tb - ta <= 1e-5 * tb) return ta;
        float tr;
        if (r < 0) {
            tr = t0;
        } else if (bracket) {
            tr = side == -2 ? 0.5 * (ta + tb) : ta - sa * (tb - ta) / (sb - sa);
            if (!(tr > ta && tr < tb)) tr = 0.5 * (ta + tb);
        } else {
            tr = prev && sa < sp ? ta + sa * (ta - tp) / (sp - sa) : ta + sa;
            if (voxel > 0.0) tr = min(tr, ta + max(sa, voxel));
            tr = min(tr, tEnd);
        }
        float sr = sdfObjectDistance(obj, ro + rd * tr, 0.0);
        ++g_evaluations;
        if (r >= 0 || countFirst) ++steps;
        if (r < 0) {
            sa = sr;
            sp = sr;
            pending = true;
            continue;
        }
        if (sr >= 0.0 && sr <= tol) return tr;
        if (sr < 0.0) {
            tb = tr;
            sb = sr;
            bracket = true;
            side = side == -1 ? -2 : -1;
        } else if (bracket) {
            ta = tr;
            sa = sr;
            side = 1;
        } else if (sr >= sa || tr >= tEnd) {
            // No root before tPast: tr when the spheres of a and tr overlap (a root between them
            // would need tr - ta >= sa + sr, the distance being 1-Lipschitz), else a's sphere, at
            // least half an eps on (the march's own least step near a surface).
            tPast = tr - ta < sa + sr ? tr : ta + max(sa, 0.5 * eps);
            return -1.0;  // past a minimum above the surface, or no root before tEnd
        } else {
            tp = ta;
            sp = sa;
            ta = tr;
            sa = sr;
            prev = true;
        }
    }
    if (pending) {  // refineSteps 0 (the loop ran only the first evaluation, or not at all)
        sFirst = sa;
        if (sa >= gate) return -1.0;
        return t0;  // every candidate is a hit where it is
    }
    return bracket || sa <= 0.1 * eps ? ta : -1.0;
}

// The gradient of the object's world distance over a tetrahedron of offsets h (4 evaluations).
vec3 objectNormal(uint obj, vec3 p, float h) {
    vec3 g = vec3(0.0);
    for (int i = 0; i < 4; ++i) {
        vec3 k = vec3((i == 0 || i == 3) ? 1.0 : -1.0, (i == 2 || i == 3) ? 1.0 : -1.0,
                      (i == 1 || i == 3) ? 1.0 : -1.0);
        g += k * sdfObjectDistance(obj, p + k * h, 0.0);
    }
    return normalize(g);
}

vec2 clipToPixel(vec4 clip) { return (clip.xy / clip.w * 0.5 + 0.5) * view.viewport.xy; }

void main() {
    // Each run of 8 consecutive invocations (a SIMD group on CPU devices, which run a group at the
    // pace of its slowest ray) traces a 2x4 block of the 8x8 tile instead of a row of 8: nearby
    // rays take similar step counts, and compact blocks are more alike than rows (objects scene:
    // 8.6 instead of 9.7 steps for the slowest ray of a group, at 3.8 on average). The tile stays
    // the workgroup, and every 32 consecutive invocations still cover 8x4 pixels.
    uint block = gl_LocalInvocationIndex / 8u, lane = gl_LocalInvocationIndex % 8u;
    ivec2 pixel = ivec2(gl_WorkGroupID.xy * 8u + uvec2(block % 4u * 2u + lane % 2u, block / 4u * 4u + lane / 2u));
    if (pixel.x >= int(view.viewport.x) || pixel.y >= int(view.viewport.y)) return;
    bool raster = (trace.counts.y & kRasterFlag) != 0u;

    // The ray through the pixel centre (moved by the TAA jitter, 0 without TAA); dir has unit
    // component along the view direction, so the linear depth of a point at ray parameter t (unit
    // direction) is t / |dir|.
    vec2 ndc = (vec2(pixel) + 0.5 + view.jitter.xy) * view.viewport.zw * 2.0 - 1.0;
    vec3 dir = view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz;
    float dirLength = length(dir);
    vec3 rd = dir / dirLength;
    vec3 ro = view.position.xyz;

    float rasterDepth = raster ? imageLoad(gbufferDepthImage, pixel).r : 0.0;
    float tMin = trace.clip.x * dirLength;
    float tMax = (rasterDepth > 0.0 ? rasterDepth : trace.clip.y) * dirLength;

    // Culling by the objects' bounds (or, without culling, every object from the near plane on).
    g_count = 0;
    g_overflow = false;
    g_evaluations = 0u;
    bool cull = (trace.accel.x & kCullFlag) != 0u;
    float tStart = tMax;
    uint stepLimit = trace.counts.z;
    g_tileAll = (trace.accel.x & kTileListsFlag) == 0u;
    g_tileFirst = 0u;
    g_tileCount = trace.counts.x;
    if (cull && !g_tileAll) {
        uvec2 range = sdfTileRanges[sdfTileIndex(pixel, trace.accel.y)];
        g_tileAll = range.y == 0xffffffffu;  // the list stands for every object
        if (!g_tileAll) {
            g_tileFirst = range.x;
            g_tileCount = range.y;
        }
    }
    // The ray's interval is the same with and without culling: the march starts at the first box
    // entry and runs only when a box is crossed (one pass over the objects per ray, outside the
    // step loop). Marching from the near plane instead would spend the step limit on empty space
    // and change the picture (grazing floors at the horizon ran out of steps), so the baseline
    // differs from culling only in the work per step.
    bool crossed = false;
    uint candidates = cull ? g_tileCount : trace.counts.x;
    for (uint i = 0u; i < candidates; ++i) {
        uint obj = cull ? tileObject(i) : i;
        if (obj >= trace.counts.x) continue;  // not traced (occluder-only): never in a primary list
        vec2 iv = sdfRayInterval(obj, ro, rd);
        if (iv.x > iv.y || iv.y < tMin || iv.x > tMax) continue;
        tStart = min(tStart, max(iv.x, tMin));
        stepLimit = max(stepLimit, sdfObjects[obj].params.x);
        crossed = true;
        if (!cull) continue;  // no per-pixel list: every object at every step
        if (g_count < kListSize) {
            g_list[g_count] = obj;
            g_interval[g_count] = iv;
            ++g_count;
        } else {
            g_overflow = true;
        }
    }

    float safety = trace.epsilons.w;
    float footprint = trace.clip.z;
    uint steps = 0u, cacheSteps = 0u;
    bool hit = false;
    uint hitObject = 0xffffffffu;
    float t = tStart;
    if (crossed) {
        float omega = trace.epsilons.z;
        float prevRadius = 0.0, stepLength = 0.0, prevT = t;
        float bestError = 3.0e38, bestT = t;
        uint bestObject = 0xffffffffu;
        // World cache steps do not count against the step limit (the object steps then end where
        // the unaccelerated trace's do); they have their own limit, so the loop stays bounded.
        uint counted = 1u;
        bool useCache = (trace.accel.x & kCacheBoundFlag) != 0u;
        for (; steps < stepLimit && t <= tMax; steps += counted) {
            counted = 1u;
            vec3 p = ro + rd * t;
            vec3 pa = abs(p);
            // At least a few float ulps of the point's coordinates (scenes far from the origin)
            // and of the distance travelled.
            float eps = max(trace.epsilons.x * footprint * t, max(1e-6 * t, 4.8e-7 * max(max(pa.x, pa.y), pa.z)));
            // The world cache: far from every surface a plain step of its distance with no
            // object evaluated; near one, with the id field, only the object it names.
            float cached = 0.0, cacheVoxel;
            uint only = 0xffffffffu, cacheObject;
            bool cacheStep = false;
            if (useCache && sdfCacheLookup(p, cached, cacheVoxel, cacheObject)) {
                // Beyond two voxels the cached lower bound (the exact distance less at most about
                // one voxel of margin and cell extent) is at least about half the exact step;
                // beyond two hit epsilons the point is no hit candidate, so every candidate and
                // near miss is decided on the objects' distances, as without the cache.
                cacheStep = (trace.accel.x & kCacheFlag) != 0u && cached > 2.0 * max(cacheVoxel, eps) &&
                            cacheSteps < stepLimit;
                if (!cacheStep && (trace.accel.x & kIdFlag) != 0u && cacheObject < trace.counts.x)
                    only = cacheObject;  // NONE, UNCERTAIN and occluder-only objects: the list
            }
            uint nearest = 0xffffffffu;
            float second = cached;
            float d = cacheStep ? cached : sceneDistance(p, min(prevT, t), safety, only, nearest, second);
            float radius = abs(d);
            bool sorFail = omega > 1.0 && radius + prevRadius < stepLength;
            if (sorFail) {
                // The spheres do not overlap: the over-relaxed step may have skipped a surface.
                // Back to the previous point, plain step from there, no more over-relaxation.
                t = prevT + prevRadius;
                stepLength = prevRadius;
                omega = 1.0;
                prevT = t;
                continue;
            }
            if (cacheStep) {
                // A plain safe step (the cached value bounds every object's distance from below;
                // as the previous radius it keeps the next over-relaxation check conservative).
                counted = 0u;
                ++cacheSteps;
                prevRadius = d;
                prevT = t;
                stepLength = d;
                t += d;
                continue;
            }
            if (d < eps) {
                // Within eps of a surface by the safe distance. A field's safe distance lies up to
                // its interpolation bound below the interpolated one, so the raw value decides.
                // This step counts here (with the hit decision's evaluations after it, each
                // within the step limit), not at the loop's end.
                counted = 0u;
                ++steps;
                // The hit decision (objectRoot): the first root along the ray of each object that
                // could be crossed before the best root so far — the candidate's object first (its
                // raw distance: for a field evaluated by the search, for a shape the step's own;
                // not below eps: no candidate, below zero: inside), then every candidate whose raw
                // distance here is below the gap to that root (below eps while there is none). The
                // earliest root is the hit, on its object; none is a near miss and the march goes
                // on. One loop with one call, so the shader keeps one search (a CPU device runs
                // every evaluation site of the march loop at every step).
                float raw = d, nearPast = t, best = 3.0e38;
                uint rootObject = 0xffffffffu;
                bool inside = false;
                float tol = max(kRootTolerance * eps, 1e-6 * t);
                int count = int(candidateCount());
                for (int i = -1; i < count; ++i) {
                    if (i >= 0 && (trace.counts.w == 0u || steps >= stepLimit)) break;
                    uint obj = i < 0 ? nearest : candidateObject(uint(max(i, 0)), t);
                    float gap = rootObject != 0xffffffffu ? best - t : eps;
                    if (i >= 0) {
                        if (obj == nearest || obj == 0xffffffffu) continue;
                        if (sdfBoxDistance(obj, sdfToLocal(obj, ro + rd * t)) >= gap) continue;
                    }
                    bool known = i < 0 && !(safety > 0.0 && sdfObjectVoxel(nearest) > 0.0);
                    float past, first;
                    float tj = objectRoot(obj, ro, rd, t, d, known, gap, i < 0 ? tMax : min(best, tMax), tol, eps,
                                          stepLimit, i >= 0, steps, past, first);
                    if (i < 0) {
                        raw = first;
                        nearPast = past;
                        inside = raw <= 0.0;
                        if (inside || raw >= eps) break;
                    }
                    if (tj >= 0.0 && tj < best) {
                        best = tj;
                        rootObject = obj;
                    }
                }
                if (inside) {
                    // Inside the solid (a ray that starts inside, e.g. a camera in an object or
                    // behind the near plane's cut): a hit where it is.
                    hit = true;
                    hitObject = nearest;
                    break;
                }
                if (rootObject != 0xffffffffu) {
                    hit = true;
                    hitObject = rootObject;
                    t = max(best, tMin);
                    break;
                }
                // Not on the surface (yet): a plain step on the raw value (never past the other
                // objects' safe distance), without over-relaxation from here on. A near miss stays
                // the best candidate for the step-limit rule (a ray stuck in a gap narrower than
                // the hit epsilon then hits where it entered it instead of showing a hole).
                float nearErr = raw / max(t, 1e-6);
                if (nearErr < bestError) {
                    bestError = nearErr;
                    bestT = t;
                    bestObject = nearest;
                }
                omega = 1.0;
                prevRadius = 0.0;
                stepLength = 0.0;
                prevT = t;
                // Past the nearest object's closest approach in one step when the hit decision
                // found where its distance grows again (no root before there), else its distance;
                // never past the other objects' safe distance, at least half an eps.
                t += max(min(max(raw, nearPast - t), second), 0.5 * eps);
                continue;
            }
            float err = d / max(t, 1e-6);
            if (err < bestError) {
                bestError = err;
                bestT = t;
                bestObject = nearest;
            }
            prevRadius = radius;
            prevT = t;
            stepLength = omega * d;
            t += stepLength;
        }
        if (!hit && steps >= stepLimit && bestObject != 0xffffffffu &&
            bestError <= 4.0 * trace.epsilons.x * footprint && bestT <= tMax) {
            hit = true;
            t = bestT;
            hitObject = bestObject;
        }
        hit = hit && t <= tMax;
    }

    vec3 p = ro + rd * t;
    if (hit) g_evaluations += 4u;  // the normal's tetrahedron
    float work = float((trace.accel.x & kCountEvalsFlag) != 0u ? g_evaluations : steps);
    if (hit) {
        // Fields: at least half a voxel, so the gradient spans the trilinear cells around the
        // point instead of one cell's piecewise-linear facet.
        float h = max(max(trace.epsilons.y * footprint * t, 1e-5 * max(length(p), 1.0)), 0.5 * sdfObjectVoxel(hitObject));
        vec3 n = objectNormal(hitObject, p, h);
        if (any(isnan(n))) n = -rd;
        uvec4 info = sdfObjects[hitObject].info;
        imageStore(gbufferDepthImage, pixel, vec4(t / dirLength));
        imageStore(gbufferNormalImage, pixel, vec4(octEncode(n), 0.0, 0.0));
        // b,a: the object + 1 for sdf_surface (0 past the 16-bit range: such objects keep the factor).
        imageStore(gbufferMaterialImage, pixel, packMaterial(info.z, hitObject < 65535u ? hitObject + 1u : 0u));
        vec3 local = sdfToLocal(hitObject, p);
        vec4 prevClip = view.prevViewProj * (sdfObjects[hitObject].prevModel * vec4(local, 1.0));
        vec4 clip = view.viewProj * vec4(p, 1.0);
        vec2 velocity = prevClip.w > 1e-6 ? clipToPixel(clip) - clipToPixel(prevClip) : vec2(0.0);
        imageStore(gbufferVelocityImage, pixel, vec4(velocity, 0.0, 0.0));
#ifdef ALBEDO
        imageStore(gbufferAlbedoImage, pixel, packAlbedo(materials[info.z].baseColor.rgb));
#endif
#ifdef AUX
        imageStore(gbufferAuxImage, pixel, vec4(float(info.w), work, 0.0, 0.0));
#endif
    } else if (!raster) {
        // Nothing else wrote this pixel this frame: the G-buffer's "nothing hit" values.
        imageStore(gbufferDepthImage, pixel, vec4(0.0));
        imageStore(gbufferNormalImage, pixel, vec4(0.0));
        imageStore(gbufferMaterialImage, pixel, vec4(0.0));  // material 0, no SDF object
        imageStore(gbufferVelocityImage, pixel, vec4(0.0));
#ifdef ALBEDO
        imageStore(gbufferAlbedoImage, pixel, vec4(0.0));
#endif
#ifdef AUX
        imageStore(gbufferAuxImage, pixel, vec4(-1.0, work, 0.0, 0.0));
#endif
    }
#ifdef AUX
    else {
        // A mesh pixel or the background behind a mesh pass: keep the id the mesh pass wrote, add
        // the steps this ray took.
        imageStore(gbufferAuxImage, pixel, vec4(imageLoad(gbufferAuxImage, pixel).x, work, 0.0, 0.0));
    }
#endif
}
