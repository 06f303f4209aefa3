// The sphere-tracing march of sdf_trace.comp (its header describes the algorithm step by step),
// shared with the box trace's fragment shader (sdf_box_trace.frag) so both decide hits with the same
// code: the candidate lists, sceneDistance, the hit decision objectRoot, objectNormal and the march
// loop sdfMarch.
//
// Use: declare a push constant block named `trace` whose first members are sdf_trace.comp's
// (uvec4 counts, vec4 epsilons, vec4 clip, uvec4 accel), include sdf_scene.glsl and, unless
// SDF_MARCH_NO_TILES is defined, sdf_tiles.glsl (the tile lists), unless SDF_MARCH_NO_CACHE, also
// sdf_world_cache.glsl; SDF_MARCH_LIST_SIZE (default 24) sizes the per-pixel candidate list.
#ifndef PENUMBRA_SDF_MARCH_GLSL
#define PENUMBRA_SDF_MARCH_GLSL

#ifndef SDF_MARCH_LIST_SIZE
#define SDF_MARCH_LIST_SIZE 24
#endif

// trace.accel.x
const uint kCullFlag = 1u;        // bounds culling (tile list, per-pixel ray/box list)
const uint kCacheFlag = 2u;       // world cache distance steps far from surfaces
const uint kIdFlag = 4u;          // id field: near a surface evaluate the one object it names
const uint kTileListsFlag = 8u;   // SdfTileRanges / SdfTileIndices hold this frame's primary lists
const uint kCountEvalsFlag = 16u;  // gbuffer.aux y = object evaluations instead of steps
const uint kCacheBoundFlag = 32u;  // the world cache is bound (else stand-ins that are never read)
const int kListSize = SDF_MARCH_LIST_SIZE;
const float kRootTolerance = 1e-3;  // the hit decision's convergence above a surface, in hit epsilons

uint g_list[kListSize];
vec2 g_interval[kListSize];
int g_count;
bool g_overflow;
// The pixel's candidate objects with culling: its tile list, or every traced object (g_tileAll).
uint g_tileFirst, g_tileCount;
bool g_tileAll;
uint g_evaluations;  // object distance evaluations of this pixel (kCountEvalsFlag)

#ifdef SDF_MARCH_NO_TILES
uint tileObject(uint i) { return i; }
#else
uint tileObject(uint i) { return g_tileAll ? i : sdfTileIndices[g_tileFirst + i]; }
#endif

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
// no root before) — but only where the last step cannot have passed a root: a secant step beyond the
// previous point's sphere that lands where the distance grew with the two spheres not overlapping
// is discarded, and the search goes on from the previous point with plain steps only. So a thin
// sliver of the object (a grazing ray clipping a silhouette, a field's concave cell) is found
// whatever point the search started from; plain steps crawl along a grazing ray, so such a search
// may take eight times the refineSteps evaluations. Every evaluation counts
// against the step limit; a search that the limit cuts short takes its best point when it is within
// eps / 10 or bracketed.
float objectRoot(uint obj, vec3 ro, vec3 rd, float t0, float s0, bool known, float gate, float tEnd, float tol,
                 float eps, uint stepLimit, bool countFirst, inout uint steps, out float tPast, out float sFirst) {
    tPast = t0;
    sFirst = s0;
    float ta = t0, sa = s0, tp = t0, sp = s0, tb = t0, sb = 0.0;
    bool bracket = false, prev = false, pending = known;
    bool plain = false;  // secant steps off: one jumped a possible root (below)
    // A field's interpolated distance bends at its trilinear cells: its secant steps go at most one
    // voxel (or the plain step) at a time, so they do not overshoot the parts a cell resolves.
    float voxel = sdfObjectVoxel(obj);
    int side = 0;  // the end of the bracket that moved last: 1 a, -1 b, -2 b twice
    // r = -1: the distance at t0 when the caller does not know it (the loop's one evaluation site:
    // a CPU device runs every site of a loop at every iteration, so the search keeps a single one).
    int limit = int(trace.counts.w);
    for (int r = known ? 0 : -1; r < limit; ++r) {
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
            tr = !plain && prev && sa < sp ? ta + sa * (ta - tp) / (sp - sa) : ta + sa;
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
        } else if (sr >= sa && tr - ta >= sa + sr && tr > ta + sa) {
            // A secant step that went past a's sphere and landed where the distance grew, the
            // spheres of a and tr not overlapping: the distance has a minimum between them that
            // may lie below zero (a thin sliver of a silhouette or of a field's cell), so the
            // search does not conclude from it. It goes on from a with plain (safe) steps, which
            // cannot pass a root: whether the ray hits no longer depends on where the search
            // started (the full-screen union march and box mode's single-object march start
            // elsewhere). A step clamped to tEnd with the distance still falling is not redone.
            // Plain steps crawl where a ray grazes a surface: the search gets eight times its
            // evaluations from here (the march's step limit still bounds them all; at twice,
            // culled and unculled marches of the 40-object scene ran out at different points
            // and split on 2 px).
            if (!plain) limit = 8 * int(trace.counts.w);
            plain = true;
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

// The march along the ray ro + t rd (rd unit) from t (the first box entry, at least tMin) to tMax
// with at most stepLimit object steps, over the candidates set up by the caller (g_list / g_count /
// g_overflow / the tile list, or every traced object without CULL). Returns whether it hit; then t
// is the hit's ray parameter and hitObject its object. steps counts the steps that evaluated
// objects (sdf_trace.comp, steps 3-5).
bool sdfMarch(vec3 ro, vec3 rd, float tMin, float tMax, uint stepLimit, inout float t, out uint hitObject,
              inout uint steps) {
    float safety = trace.epsilons.w;
    float footprint = trace.clip.z;
    uint cacheSteps = 0u;
    bool hit = false;
    hitObject = 0xffffffffu;
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
#ifndef SDF_MARCH_NO_CACHE
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
#endif
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
        if (t > tMax && stepLength > radius) {
            // An over-relaxed step past the ray's end (the far plane, or a mesh's depth just
            // behind a surface) is never checked by the spheres' overlap: the plain step instead,
            // and no more over-relaxation.
            t = prevT + radius;
            stepLength = radius;
            omega = 1.0;
        }
    }
    if (!hit && steps >= stepLimit && bestObject != 0xffffffffu &&
        bestError <= 4.0 * trace.epsilons.x * footprint && bestT <= tMax) {
        hit = true;
        t = bestT;
        hitObject = bestObject;
    }
    hit = hit && t <= tMax;
    return hit;
}

#endif
