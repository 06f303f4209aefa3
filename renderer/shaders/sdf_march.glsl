// The sphere-tracing march of sdf_trace.comp (its header describes the algorithm step by step),
// shared with the box trace's fragment shader (sdf_box_trace.frag) so both decide hits with the same
// code: the candidate lists, sceneDistance, the hit decision's root search RootSearch
// and the march loop sdfMarch (the hit's normal: sdfObjectNormal, sdf_scene.glsl).
//
// Use: declare a push constant block named `trace` whose first members are sdf_trace.comp's
// (uvec4 counts, vec4 epsilons, vec4 clip, uvec4 accel), include sdf_scene.glsl and, unless
// SDF_MARCH_NO_TILES is defined, sdf_tiles.glsl (the tile lists), unless SDF_MARCH_NO_CACHE, also
// sdf_world_cache.glsl (with the frame's cache bound: the march looks it up at every step);
// SDF_MARCH_LIST_SIZE (default 24) sizes the per-pixel candidate list.
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
float g_nearestUncapped;  // sceneDistance's nearest object's distance without sdfFieldRootDistance
float g_nearestRaw;  // and its raw value (a field's filtered value, no safety bound: the hit decision's)
// Boxes ahead (culled march): the march point's ray parameter, the hit epsilon there, and the ray
// distance from it to the nearest candidate box that the ray enters only more than an eps ahead.
float g_marchT, g_marchEps, g_ahead;
// The over-relaxation check's objects: those whose box the ray had entered by g_enteredBy (the last
// march point plus its eps), and the least of their distances at the march point (box distances
// for the ones not evaluated); every object without culling. g_aheadRule: the last sceneDistance
// left the boxes ahead out (a culled per-pixel list, not the id field's object alone).
float g_enteredBy, g_enteredMin;
bool g_aheadRule;

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

// Whether the ray's part (t, t + gap) may cross the box of candidate i (object obj): the hit
// decision's scan searches no other object whose box the ray misses, has left, or enters only
// after t + gap (the same ray/box interval with culling and without: the per-pixel list's, or
// computed here). Every root lies in its object's box, so this saves only evaluations; with it,
// the scan's skip by the march's bound `second` (which includes the boxes ahead along the ray)
// changes no step count.
bool candidateCrossed(uint i, uint obj, vec3 ro, vec3 rd, float t, float gap) {
    bool list = (trace.accel.x & kCullFlag) != 0u && !g_overflow;
    vec2 iv = list ? g_interval[i] : sdfRayInterval(obj, ro, rd);
    return iv.x <= iv.y && iv.y >= t && iv.x - t < gap;
}

// An object's local distance for the march (sdfLocalDistance; the hit decision evaluates with
// fieldSafety 0 and rootBound false: a field's raw value). With rootBound (a march step, while the
// hit decision searches: trace.counts.w > 0) a field's value is also at most sdfFieldRootDistance,
// so that no step passes a part of the surface that the decision's cell walk would find (where the
// trilinear interpolant bulges out of the baked surface by up to its interpolation bound): whether
// a ray hits a field then does not depend on where its steps landed. raw: the raw value (the hit
// decision's: fieldSafety 0, no rootBound).
float marchLocalDistance(uint obj, vec3 pl, float safety, bool rootBound, out float uncapped,
                         out float raw) {
    uvec4 info = sdfObjects[obj].info;
#ifdef SDF_FIELDS
    if (info.x == SDF_KIND_FIELD) {
        SdfField f = sdfFields[info.y];
        raw = sdfFieldDistanceOf(f, pl);
        bool bounds = rootBound && trace.counts.w > 0u;
        float bound = safety > 0.0 || bounds ? sdfFieldInterpolationBoundOf(f, pl) : 0.0;
        uncapped = raw - safety * bound;
        return bounds ? min(uncapped, sdfFieldRootDistance(f, pl, raw, bound)) : uncapped;
    }
#endif
    uncapped = sdfShapeDistance(info, pl);
    raw = uncapped;
    return uncapped;
}

// The march's distance to the nearest object at world point p (safe distances: fields with their
// safety bound and rootBound); `nearest` is its object, `second` a lower bound of the other
// objects' distances. `only` (the id field's object for p's cell, else 0xffffffff) is evaluated
// alone: it is the nearest object everywhere around p and bounds the others too. With culling,
// objects whose box the ray had left before `tFrom` (the point the last step started from) are
// skipped: the step from tFrom to here may have crossed a box the current point is already past,
// and the over-relaxation check needs every surface near that segment; an object whose box is
// farther than the best distance so far is not evaluated. With culling (and the per-pixel list) an
// object whose box the ray enters more than an eps ahead of p is not evaluated either: no surface
// of it lies on the ray before that entry, so g_ahead, the ray distance to the nearest such entry,
// bounds how far the march may step along the ray (it bounds `second` too, a bound along the ray
// only, for the near-miss step), while the returned distance and its sphere (the over-relaxation
// check's backward radius) cover the objects entered so far. g_enteredMin leaves out the objects
// entered since the last march point: the step from there ended at most at their entry (sdfMarch),
// so they need no sphere reaching back over it. Without culling every traced object is evaluated.
float sceneDistance(vec3 p, float tFrom, float safety, uint only, out uint nearest, out float second) {
    float d = 3.0e38;
    second = 3.0e38;  // the nearest distance of the other objects (a lower bound)
    nearest = 0xffffffffu;
    g_nearestUncapped = 3.0e38;
    g_nearestRaw = 3.0e38;
    g_ahead = 3.0e38;
    g_enteredMin = 3.0e38;
    bool one = only != 0xffffffffu;
    bool cull = (trace.accel.x & kCullFlag) != 0u && !one;
    bool ahead = cull && !g_overflow;  // the per-pixel list: boxes ahead are left out
    g_aheadRule = ahead;
    uint count = one ? 1u : candidateCount();
    for (uint i = 0u; i < count; ++i) {
        uint obj = one ? only : candidateObject(i, tFrom);
        if (obj == 0xffffffffu) continue;  // the ray had left this box for good
        if (ahead && g_interval[i].x > g_marchT + g_marchEps) {
            // The ray enters this box only ahead: none of its surface lies on the ray before the
            // entry (at least an eps on, so that a march point just short of an entry moves on).
            g_ahead = min(g_ahead, g_interval[i].x - g_marchT);
            continue;
        }
        bool entered = !ahead || g_interval[i].x <= g_enteredBy;
        vec3 pl = sdfToLocal(obj, p);
        if (cull) {
            float box = sdfBoxDistance(obj, pl);
            if (box >= d) {  // cannot be nearer than the best so far; its box bounds `second`
                second = min(second, box);
                if (entered) g_enteredMin = min(g_enteredMin, box);
                continue;
            }
        }
        ++g_evaluations;
        float ui, ri;
        float di = sdfObjects[obj].boundsMin.w * marchLocalDistance(obj, pl, safety, true, ui, ri);
        if (entered) g_enteredMin = min(g_enteredMin, di);
        if (di < d || one) {
            second = d;
            d = di;
            nearest = obj;
            g_nearestUncapped = sdfObjects[obj].boundsMin.w * ui;
            g_nearestRaw = sdfObjects[obj].boundsMin.w * ri;
        } else {
            second = min(second, di);
        }
    }
    if (one) second = d;  // the nearest everywhere in the cell: the others are at least as far
    second = min(second, g_ahead);  // along the ray, the boxes ahead bound the others too
    return d;
}

// The hit decision for one object (RootSearch, rootStart / rootNext / rootTake): the first root of
// its raw distance (an interpolated field without the safety bound) along the ray after t0, where
// it is s0, before tEnd; -1 when there is none (a near miss, or no root before tEnd). Every object
// is searched on its own, so the result does not depend on where the march's samples landed
// (culling, the world cache and over-relaxation all move them), and where surfaces touch (a box
// standing on the floor) the ray's first surface wins: the union's distance is near zero all along
// a contact plane, its own roots are not. Steps: the secant root estimate through the previous
// point while the distance falls (exact for a plane at any angle, where plain steps crawl at
// grazing angles; short of the root where the distance is convex), else a plain step; a point below
// zero brackets the root and regula falsi closes the bracket (Illinois: the value of an end that
// stayed twice is halved). Converged: a point within tol of the surface (either side), or a bracket
// narrower than 1e-5 t (its outer end). The distance growing again without a root is a near miss (a
// ray that passes within eps of a silhouette is not widened onto it; tPast: a point the object has
// no root before) — but only where the last step cannot have passed a root: a secant step beyond
// the previous point's sphere that lands where the distance grew with the two spheres not
// overlapping is discarded, and the search goes on from the previous point with plain steps only.
// So a thin sliver of the object (a grazing ray clipping a silhouette, a field's concave cell) is
// found whatever point the search started from; plain steps crawl along a grazing ray, so such a
// search may take eight times the refineSteps evaluations. Every evaluation but a scanned
// candidate's first (its gate, sdfMarch) counts against the step limit; a search that the limit
// cuts short takes its best point when it is within eps / 10 or bracketed.
//
// A baked field's search walks its cells instead (cellStep): from t0 (or where the ray enters the
// field's box of voxel centres B) through each trilinear cell the ray crosses, the first root of the
// interpolant of the cell's eight stored values along the ray (a cubic: cellRootPiece and
// cellPieceRoot), exactly, without the filter and without steps that could pass a thin part; a cell
// whose values are all above zero has none. Each cell shares the face the walk enters it by with
// the cell before, so a step reads only the four values of its far face (cellFaceValues). The walk
// is bounded by the march's step limit only (each cell one step), and it ends at a root, at tEnd or
// where the ray leaves B, or (the candidate's own object, whose near miss lets the march go on)
// after a cell whose values are all at least eps: its far side is tPast. So the first root of a
// field, and the hit, do not depend on where the search starts: the tile's cone, the world cache,
// culling and over-relaxation all move that point. The march's own steps on a field are bounded by
// the distance to the interpolant's zero set as well (marchLocalDistance), so that no step passes a
// part of it before a search starts.
//
// The search is a resumable state machine: rootNext says where to evaluate next (or that the
// search is over), the decision loop of sdfMarch evaluates the object there (objectRawDistance) or
// walks a cell (cellStep), and rootTake takes the value; each candidate's search runs in a loop of
// its own (a field's walk in one that holds only cellStep), and the decision starts them in turn.
struct RootSearch {
    uint obj;
    float t0, gate, tEnd, tol, eps;
    // Started by the decision's scan (not the candidate's own first search): its first evaluation
    // (the gate) does not count against the step limit, and a field's walk does not end past a far
    // cell (cellStep).
    bool scanned;
    // A candidate searched against a root found already: its first root before tEnd, so a near
    // miss does not end it; it goes on with plain steps from there.
    bool untilEnd;
    float ta, sa, tp, sp, tb, sb, tr, voxel;
    bool bracket, prev, pending, plain, done;
    int side;  // the end of the bracket that moved last: 1 a, -1 b
    int r, limit;
    float tPast, sFirst, result;
    // A field's cell walk (cells, cellStep): the current cell; the walk reuses the secant search's
    // fields (few registers: a CPU device keeps every lane's state of the loop live): ta where the
    // walk is, tb where it ends, sb and tp the walk's point with the smallest value / t (the
    // step-limit rule's candidate: its error and t); voxel is the world size of a stored unit.
    bool cells;
    ivec3 cell;
    ivec3 cellBase, cellLast;  // the slot's first atlas texel, and its last cell (dims - 2)
    vec3 xo, xd;  // the ray in the field slot's voxel coordinates (cellRay)
    // The values of the face that the walk enters the current cell by (its corners in the order
    // of the two other axes, cellFaceValues), its axis, and the side bit of the cell's far face
    // on that axis (the face cellStep reads).
    vec4 face;
    int faceAxis, faceSide;
    // The walk ended in the cell of its root, between ta and tb: the cubic and its piece there
    // (cellRootPiece), solved after the walk's loop (cellPieceRoot).
    bool rootCell;
    vec4 cubic, piece;
};

#ifdef SDF_FIELDS
// The stored values of the face of a cell (its first atlas texel `base`) on axis a, side bit `side`
// (0: the face at the cell's lower coordinate): its corner j at the other two axes' bits (j & 1,
// j >> 1), in axis order.
vec4 cellFaceValues(ivec3 base, int a, int side) {
    vec4 v;
    for (int j = 0; j < 4; ++j) {
        int u = j & 1, w = j >> 1;
        ivec3 o = a == 0 ? ivec3(side, u, w) : (a == 1 ? ivec3(u, side, w) : ivec3(u, w, side));
        v[j] = texelFetch(sdfAtlas, base + o, 0).r;
    }
    return v;
}

// The ray ro + rd t in the voxel coordinates of a field object's slot f: x = xo + xd t.
void cellRay(uint obj, SdfField f, vec3 ro, vec3 rd, out vec3 xo, out vec3 xd) {
    xo = ((sdfObjects[obj].worldToLocal * vec4(ro, 1.0)).xyz - f.origin.xyz) / f.origin.w;
    xd = (mat3(sdfObjects[obj].worldToLocal) * rd) / f.origin.w;
}
#endif

#ifdef SDF_FIELDS
// The first root in s in [0, 1] of the trilinear interpolant of the corners c (index x + 2y + 4z, c[0]
// > 0 is not assumed) along the segment u(s) = ua + (ub - ua) s of the cell's unit cube, in two
// parts. Along a line the interpolant is a cubic; its extrema split [0, 1] into monotone pieces, and
// the first piece whose far end is not above zero holds the root. cellRootPiece finds that piece:
// false when there is none (no root), else the cubic's coefficients (a0 + a1 s + a2 s^2 + a3 s^3 as
// x, y, z, w) and the piece (lo, hi, f(lo), f(hi); lo = hi = 0 when the segment starts on or below
// zero). cellPieceRoot then finds the root on it by regula falsi (Illinois). The walk (cellStep)
// only looks for the piece, cell after cell; the one solve runs after its loop (sdfMarch): a CPU
// device runs a loop's body at least once per pass, whether a lane needs it or not.
bool cellRootPiece(float c[8], vec3 ua, vec3 ub, out vec4 cubic, out vec4 piece) {
    float k0 = c[0], k1 = c[1] - c[0], k2 = c[2] - c[0], k3 = c[4] - c[0];
    float k4 = c[3] - c[2] - c[1] + c[0];  // xy
    float k5 = c[6] - c[4] - c[2] + c[0];  // yz
    float k6 = c[5] - c[4] - c[1] + c[0];  // xz
    float k7 = c[7] - c[6] - c[5] - c[3] + c[1] + c[2] + c[4] - c[0];
    vec3 d = ub - ua;
    float p = ua.x, q = ua.y, r = ua.z, P = d.x, Q = d.y, R = d.z;
    float a3 = k7 * P * Q * R;
    float a2 = k4 * P * Q + k5 * Q * R + k6 * P * R + k7 * (p * Q * R + q * P * R + r * P * Q);
    float a1 = k1 * P + k2 * Q + k3 * R + k4 * (p * Q + q * P) + k5 * (q * R + r * Q) + k6 * (p * R + r * P) +
               k7 * (p * q * R + p * r * Q + q * r * P);
    float a0 = k0 + k1 * p + k2 * q + k3 * r + k4 * p * q + k5 * q * r + k6 * p * r + k7 * p * q * r;
    cubic = vec4(a0, a1, a2, a3);
    piece = vec4(0.0, 0.0, a0, a0);
    if (a0 <= 0.0) return true;
    // The extrema: 3 a3 s^2 + 2 a2 s + a1 = 0 within (0, 1), in order.
    float e0 = 2.0, e1 = 2.0;
    float A = 3.0 * a3, B = 2.0 * a2, C = a1;
    if (abs(A) > 1e-12 * (abs(B) + abs(C))) {
        float disc = B * B - 4.0 * A * C;
        if (disc >= 0.0) {
            float h = -0.5 * (B + (B >= 0.0 ? sqrt(disc) : -sqrt(disc)));
            float r0 = h / A, r1 = h != 0.0 ? C / h : r0;
            e0 = min(r0, r1);
            e1 = max(r0, r1);
        }
    } else if (B != 0.0) {
        e0 = -C / B;
    }
    float lo = 0.0, flo = a0;
    for (int i = 0; i < 3; ++i) {
        float hi = i == 0 ? e0 : (i == 1 ? e1 : 1.0);
        if (!(hi > lo && hi < 1.0) && i < 2) continue;
        float fhi = ((a3 * hi + a2) * hi + a1) * hi + a0;
        if (fhi <= 0.0) {
            piece = vec4(lo, hi, flo, fhi);  // f(lo) > 0 >= f(hi), monotone between
            return true;
        }
        lo = hi;
        flo = fhi;
    }
    return false;
}

// The root on a piece of cellRootPiece (its hi end when the piece is empty).
float cellPieceRoot(vec4 cubic, vec4 piece) {
    float a0 = cubic.x, a1 = cubic.y, a2 = cubic.z, a3 = cubic.w;
    float lo = piece.x, hi = piece.y, flo = piece.z, fhi = piece.w;
    int side = 0;
    for (int k = 0; k < 24 && hi - lo > 1e-7; ++k) {
        float m = (lo * fhi - hi * flo) / (fhi - flo);
        if (!(m > lo && m < hi)) m = 0.5 * (lo + hi);
        float fm = ((a3 * m + a2) * m + a1) * m + a0;
        if (fm > 0.0) {
            lo = m;
            flo = fm;
            if (side == 1) fhi *= 0.5;
            side = 1;
        } else {
            hi = m;
            fhi = fm;
            if (side == -1) flo *= 0.5;
            side = -1;
        }
    }
    return hi;
}
#endif

// known: s0 is the object's raw distance at t0 (else the first evaluation is at t0).
void rootStart(inout RootSearch s, uint obj, vec3 ro, vec3 rd, float t0, float s0, bool known, float gate,
               float tEnd, float tol, float eps, bool scanned) {
    s.obj = obj;
    s.t0 = t0;
    s.gate = gate;
    s.tEnd = tEnd;
    s.tol = tol;
    s.eps = eps;
    s.scanned = scanned;
    s.untilEnd = false;
    s.tPast = t0;
    s.sFirst = s0;
    s.ta = t0;
    s.sa = s0;
    s.tp = t0;
    s.sp = s0;
    s.tb = t0;
    s.sb = 0.0;
    s.tr = t0;
    s.bracket = false;
    s.prev = false;
    s.pending = known;
    s.plain = false;  // secant steps off: one jumped a possible root (rootTake)
    s.done = false;
    // A field's interpolated distance bends at its trilinear cells: its secant steps go at most one
    // voxel (or the plain step) at a time, so they do not overshoot the parts a cell resolves.
    s.voxel = sdfObjectVoxel(obj);
    s.side = 0;
    // r = -1: the distance at t0 when the caller does not know it.
    s.r = known ? 0 : -1;
    s.limit = int(trace.counts.w);
    s.result = -1.0;
    s.cells = false;
    s.rootCell = false;
#ifdef SDF_FIELDS
    uvec4 info = sdfObjects[obj].info;
    if (info.x == SDF_KIND_FIELD && s.limit > 0) {
        // The walk covers the ray's part in the field's box of voxel centres B from t0 to tEnd.
        SdfField f = sdfFields[info.y];
        ivec3 dims = ivec3(f.dims.xyz);
        vec3 xo, xd;
        cellRay(obj, f, ro, rd, xo, xd);
        s.xo = xo;
        s.xd = xd;
        vec3 inv = 1.0 / xd;
        vec3 ta = (vec3(0.0) - xo) * inv, tb = (f.dims.xyz - 1.0 - xo) * inv;
        vec3 tn = min(ta, tb), tf = max(ta, tb);
        float enter = max(max(tn.x, tn.y), tn.z), exit = min(min(tf.x, tf.y), tf.z);
        float start = max(t0, enter), end = min(tEnd, exit);
        if (all(greaterThanEqual(dims, ivec3(2))) && start < end) {
            s.cells = true;
            s.ta = start;
            s.tb = end;
            s.sb = 3.0e38;
            s.tp = t0;
            s.cell = clamp(ivec3(floor(xo + xd * start)), ivec3(0), dims - 2);
            s.cellBase = ivec3(f.uvwOffset.xyz);
            s.cellLast = dims - 2;
            // The first cell's face x = 0; its first step reads the face x = 1.
            s.face = cellFaceValues(s.cellBase + s.cell, 0, 0);
            s.faceAxis = 0;
            s.faceSide = 1;
        }
    }
#endif
}

void rootFinish(inout RootSearch s, float result) {
    s.result = result;
    s.done = true;
}

// The search's next point (s.tr): true when it is to be evaluated there, false when the search is
// over (s.result: the root, or -1).
bool rootNext(inout RootSearch s, uint steps, uint stepLimit) {
    if (s.done) return false;
    if (s.r < s.limit || (s.cells && !s.pending)) {
        if (s.pending) {
            s.pending = false;
            s.sFirst = s.sa;
            if (s.sa >= s.gate) {  // no candidate: farther than the gap to the best root
                rootFinish(s, -1.0);
                return false;
            }
            if (s.sa <= s.tol) {  // on the surface, or inside (a ray that starts in a solid)
                rootFinish(s, s.t0);
                return false;
            }
        }
        if (s.r < 0 || steps < stepLimit) {
            if (s.bracket && s.tb - s.ta <= 1e-5 * s.tb) {
                rootFinish(s, s.ta);
                return false;
            }
            float tr;
            if (s.r < 0) {
                tr = s.t0;
            } else if (s.cells) {
                tr = s.ta;  // the next cell (cellStep)
            } else if (s.bracket) {
                tr = s.ta - s.sa * (s.tb - s.ta) / (s.sb - s.sa);
                if (!(tr > s.ta && tr < s.tb)) tr = 0.5 * (s.ta + s.tb);
            } else {
                bool secant = !s.plain && s.prev && s.sa < s.sp;
                tr = secant ? s.ta + s.sa * (s.ta - s.tp) / (s.sp - s.sa) : s.ta + s.sa;
                if (s.voxel > 0.0) tr = min(tr, s.ta + max(s.sa, s.voxel));
                tr = min(tr, s.tEnd);
            }
            s.tr = tr;
            return true;
        }
    }
    // Out of evaluations (refineSteps, or the step limit).
    if (s.pending) {  // refineSteps 0 (only the first evaluation ran, or none)
        s.sFirst = s.sa;
        rootFinish(s, s.sa >= s.gate ? -1.0 : s.t0);  // every candidate is a hit where it is
    } else if (s.cells) {
        s.tPast = s.ta;
        rootFinish(s, -1.0);
    } else {
        rootFinish(s, s.bracket || s.sa <= 0.1 * s.eps ? s.ta : -1.0);
    }
    return false;
}

// The object's raw distance sr at s.tr.
void rootTake(inout RootSearch s, float sr, inout uint steps) {
    if (s.r >= 0) ++steps;  // the gate of a scanned candidate does not count (sdfMarch)
    int r = s.r;
    s.r += 1;
    float tr = s.tr;
    if (r < 0) {
        s.sa = sr;
        s.sp = sr;
        s.pending = true;
        return;
    }
    if (abs(sr) <= s.tol) {
        // Within tol of the surface, on either side: float rounding of the distance near a root
        // puts a converged estimate on either side, and a point just inside would otherwise
        // start a slow regula falsi from that side.
        rootFinish(s, tr);
    } else if (sr < 0.0) {
        s.tb = tr;
        s.sb = sr;
        s.bracket = true;
        if (s.side == -1) s.sa *= 0.5;  // b moved twice: Illinois
        s.side = -1;
    } else if (s.bracket) {
        if (s.side == 1) s.sb *= 0.5;  // a moved twice: Illinois
        s.ta = tr;
        s.sa = sr;
        s.side = 1;
    } else if (sr >= s.sa && tr - s.ta >= s.sa + sr && tr > s.ta + s.sa) {
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
        if (!s.plain) s.limit = 8 * int(trace.counts.w);
        s.plain = true;
    } else if (sr >= s.sa || tr >= s.tEnd) {
        // No root before tPast: tr when the spheres of a and tr overlap (a root between them
        // would need tr - ta >= sa + sr, the distance being 1-Lipschitz), else a's sphere, at
        // least half an eps on (the march's own least step near a surface).
        s.tPast = tr - s.ta < s.sa + sr ? tr : s.ta + max(s.sa, 0.5 * s.eps);
        if (s.untilEnd && tr < s.tEnd && s.tPast == tr) {
            // Past a minimum above the surface, but the object may come nearer again before the
            // best root: on from tr with plain (safe) steps.
            if (!s.plain) s.limit = 8 * int(trace.counts.w);
            s.plain = true;
            s.prev = false;
            s.ta = tr;
            s.sa = sr;
        } else {
            rootFinish(s, -1.0);  // past a minimum above the surface, or no root before tEnd
        }
    } else {
        s.tp = s.ta;
        s.sp = s.sa;
        s.ta = tr;
        s.sa = sr;
        s.prev = true;
    }
}

#ifdef SDF_FIELDS
// One cell of a field's walk (s.cells): its eight stored values, the first root of their trilinear
// interpolant along the ray within the cell, else on to the next cell. The walk ends at a root, at
// s.tb (the search's end or the ray leaving B), or, unless the search runs until its end (a
// candidate of a decision that has a root already), past a cell whose every value is at least eps
// at least half an eps after t0: the object's surface is then certainly not crossed before tPast,
// whatever point the walk started from. Counts as one step.
void cellStep(inout RootSearch s, vec3 ro, vec3 rd, inout uint steps) {
    ++steps;
    s.r += 1;
    vec3 xo = s.xo, xd = s.xd;
    // The cell's eight values: its far face on s.faceAxis read here, the other face kept from the
    // cell before (corner k = x + 2y + 4z; constant indices only: a CPU device would keep a
    // dynamically indexed vector in memory).
    int a = s.faceAxis, farSide = s.faceSide;
    vec4 f = cellFaceValues(s.cellBase + s.cell, a, farSide);
    float c[8];
    float cmin = 3.0e38;
    for (int k = 0; k < 8; ++k) {
        float cx = (k & 1) == farSide ? f[k >> 1] : s.face[k >> 1];
        int jy = (k & 1) | ((k >> 2) << 1);  // the corner's index on a face of the y axis
        float cy = ((k >> 1) & 1) == farSide ? f[jy] : s.face[jy];
        float cz = (k >> 2) == farSide ? f[k & 3] : s.face[k & 3];
        c[k] = a == 0 ? cx : (a == 1 ? cy : cz);
        cmin = min(cmin, c[k]);
    }
    // Where the ray leaves the cell (the axis that it crosses first) or the walk ends.
    float tc = s.ta;
    vec3 tb = (vec3(s.cell) + step(vec3(0.0), xd) - xo) / xd;
    tb = mix(tb, vec3(3.0e38), equal(xd, vec3(0.0)));
    float tOut = max(min(min(min(tb.x, tb.y), tb.z), s.tb), tc);
    vec3 ua = xo + xd * tc - vec3(s.cell);
    if (cmin <= 0.0) {
        vec4 cubic, piece;
        if (cellRootPiece(c, ua, xo + xd * tOut - vec3(s.cell), cubic, piece)) {
            // The root lies in this cell, at tc + u (tOut - tc) with u = cellPieceRoot(cubic, piece),
            // solved once the walk's loop is over (sdfMarch).
            s.cubic = cubic;
            s.piece = piece;
            s.ta = tc;
            s.tb = tOut;
            s.rootCell = true;
            s.done = true;
            return;
        }
    }
    // The interpolant where the ray enters the cell: a candidate for the step-limit rule.
    vec3 u = clamp(ua, vec3(0.0), vec3(1.0));
    vec4 cx = mix(vec4(c[0], c[2], c[4], c[6]), vec4(c[1], c[3], c[5], c[7]), u.x);
    vec2 cy = mix(cx.xz, cx.yw, u.y);
    float err = max(mix(cy.x, cy.y, u.z), 0.0) * s.voxel / max(tc, 1e-6);
    if (err < s.sb) {
        s.sb = err;
        s.tp = tc;
    }
    // On across the face the ray leaves by (no dynamic component index: a CPU device would keep
    // the vector in memory).
    bvec3 leaves = tb.x <= tb.y && tb.x <= tb.z ? bvec3(true, false, false)
                                                : (tb.y <= tb.z ? bvec3(false, true, false) : bvec3(false, false, true));
    ivec3 next = s.cell + ivec3(leaves) * ivec3(sign(xd));
    bool far = cmin * s.voxel >= s.eps && tOut >= s.t0 + 0.5 * s.eps;
    if (tOut >= s.tb || any(lessThan(next, ivec3(0))) || any(greaterThan(next, s.cellLast)) ||
        (far && !s.scanned)) {
        s.tPast = tOut;
        rootFinish(s, -1.0);
        return;
    }
    // The face crossed: the next cell's first face, its far face on the same axis.
    int la = leaves.x ? 0 : (leaves.y ? 1 : 2);
    int side = (leaves.x ? xd.x : (leaves.y ? xd.y : xd.z)) > 0.0 ? 1 : 0;
    for (int j = 0; j < 4; ++j) {
        int u = j & 1, w = j >> 1;
        float fx = side == 1 ? c[1 | (u << 1) | (w << 2)] : c[(u << 1) | (w << 2)];
        float fy = side == 1 ? c[u | 2 | (w << 2)] : c[u | (w << 2)];
        float fz = side == 1 ? c[u | (w << 1) | 4] : c[u | (w << 1)];
        s.face[j] = la == 0 ? fx : (la == 1 ? fy : fz);
    }
    s.faceAxis = la;
    s.faceSide = side;
    s.cell = next;
    s.ta = tOut;
}
#endif

// The step-limit rule's candidate (sdfMarch): the point with the smallest screen-space error
// d / t so far, and its object.
void keepBestCandidate(float err, float t, uint object, inout float bestError, inout float bestT,
                       inout uint bestObject) {
    if (err < bestError) {
        bestError = err;
        bestT = t;
        bestObject = object;
    }
}

// A near miss of object `nearest` at the march point t (raw: its raw distance there, not below
// zero; past: a point it has no root before, t when unknown; second: the other objects' lower
// bound): a plain step on the raw value, past the object's closest approach in one step when the
// hit decision found where its distance grows again, never past the others' safe distance, at
// least half an eps; no over-relaxation from here on. A near miss stays the best candidate for
// the step-limit rule (a ray stuck in a gap narrower than the hit epsilon then hits where it
// entered it instead of showing a hole).
void nearMissStep(uint nearest, float raw, float past, float second, float eps, inout float t,
                  inout float omega, inout float prevRadius, inout float stepLength, inout float prevT,
                  inout float bestError, inout float bestT, inout uint bestObject) {
    keepBestCandidate(raw / max(t, 1e-6), t, nearest, bestError, bestT, bestObject);
    omega = 1.0;
    prevRadius = 0.0;
    stepLength = 0.0;
    prevT = t;
    t += max(min(max(raw, past - t), second), 0.5 * eps);
}

// An object's raw distance at world point p (an interpolated field without its safety bound: the
// hit decision's value: marchLocalDistance with safety 0 and no rootBound).
float objectRawDistance(uint obj, vec3 p) {
    ++g_evaluations;
    float u, r;
    return sdfObjects[obj].boundsMin.w * marchLocalDistance(obj, sdfToLocal(obj, p), 0.0, false, u, r);
}

// The march along the ray ro + t rd (rd unit) from t (the first box entry, at least tMin) to tMax
// with at most stepLimit object steps, over the candidates set up by the caller (g_list / g_count /
// g_overflow / the tile list, or every traced object without CULL). Returns whether it hit; then t
// is the hit's ray parameter and hitObject its object. steps counts the steps that evaluated
// objects (sdf_trace.comp, steps 3-5).
//
// Rounds of two loops: the march steps until its point is a hit candidate (or the ray ends), then
// the hit decision runs its searches to their end (a hit, or a near miss and the next round
// marches on). On a CPU device a SIMD group runs each loop until its last lane leaves it, so the
// lanes that reach a candidate wait for the others and decide together, and each loop's body
// holds only its own code: the decision evaluates one object (objectRawDistance) or walks a
// field's cells, never the march's candidate loop. The decision's two answers that need no
// evaluation are taken in the march loop itself (a field whose raw value is not below eps: no
// candidate, the near-miss step; a raw value within the root tolerance: the hit there), so those
// rays go on or end without a round: on the 80-object benchmark most field hits first pass a
// "no candidate" point (0.24 per pixel). One loop whose iterations either marched or
// took one search step (Aila and Laine's "if-if" form) let the lanes' marches and searches
// overlap, but every iteration ran both bodies: the two loops are 6-18 % faster with culling
// (docs/BENCHMARKS.md), where a march step is cheap; without culling, where every march step
// evaluates every object and the rounds add march iterations, a few per cent slower. Both give
// the same decisions and steps, so the same picture.
bool sdfMarch(vec3 ro, vec3 rd, float tMin, float tMax, uint stepLimit, inout float t, out uint hitObject,
              inout uint steps) {
    float safety = trace.epsilons.w;
    float footprint = trace.clip.z;
    uint cacheSteps = 0u;
    bool hit = false;
    hitObject = 0xffffffffu;
    float omega = trace.epsilons.z;
    float prevRadius = 0.0, stepLength = 0.0, prevT = t;
    float enteredBy = 3.0e38;
    // The voxel of the last cache lookup that gave neither a cache step nor an id-field object (0:
    // none, or the last one gave something). While the march's last evaluated distance stays below
    // two of those voxels the point is as near a surface as it was there, and the lookup is
    // skipped: a cache step needs more than two voxels of clearance, and the cells that near a
    // surface are the uncertain ones. Skipping only moves the march's samples (the objects are
    // evaluated instead), never the picture.
    float cacheQuiet = 0.0;
    float bestError = 3.0e38, bestT = t;
    uint bestObject = 0xffffffffu;
    for (;;) {
        // (a) The march, to a hit candidate: where the safe distance d of object `nearest` falls
        // below eps (second: the others' lower bound).
        bool candidate = false;
        bool listNext = false;  // evaluate the candidates here, no cache (the id field's object was near)
        float d = 0.0, second = 0.0, eps = 0.0;
        uint nearest = 0xffffffffu;
        for (;;) {
            if (!(steps < stepLimit && t <= tMax)) break;
            vec3 q = ro + rd * t;
            float tFrom = min(prevT, t);
            vec3 pa = abs(q);
            // At least a few float ulps of the point's coordinates (scenes far from the origin)
            // and of the distance travelled.
            eps = max(trace.epsilons.x * footprint * t, max(1e-6 * t, 4.8e-7 * max(max(pa.x, pa.y), pa.z)));
            uint only = 0xffffffffu;  // the id field's object
            float cached = 0.0;
            bool cacheStep = false;
#ifndef SDF_MARCH_NO_CACHE
            // The world cache for the point. Far from every surface a plain step of its distance
            // with no object evaluated; near one, with the id field, only the object it names.
            float cacheVoxel;
            uint cacheObject;
            bool lookup = !listNext && !(prevRadius < 2.0 * cacheQuiet);
            if (lookup && sdfCacheLookup(q, cached, cacheVoxel, cacheObject)) {
                // Beyond two voxels the cached lower bound (the exact distance less at most about
                // one voxel of margin and cell extent) is at least about half the exact step;
                // beyond two hit epsilons the point is no hit candidate, so every candidate and
                // near miss is decided on the objects' distances, as without the cache. World
                // cache steps do not count against the step limit (the object steps then end
                // where the unaccelerated trace's do); they have their own limit.
                cacheStep = (trace.accel.x & kCacheFlag) != 0u && cached > 2.0 * max(cacheVoxel, eps) &&
                            cacheSteps < stepLimit;
                if (!cacheStep && (trace.accel.x & kIdFlag) != 0u && cacheObject < trace.counts.x)
                    only = cacheObject;  // NONE, UNCERTAIN and occluder-only objects: the list
                cacheQuiet = cacheStep || only != 0xffffffffu ? 0.0 : cacheVoxel;
            }
#endif
            listNext = false;
            // The march's evaluation: its candidates at q (the id field's object alone).
            nearest = 0xffffffffu;
            second = cached;
            d = cached;
            g_marchT = t;
            g_marchEps = eps;
            g_ahead = 3.0e38;
            g_enteredBy = enteredBy;
            if (!cacheStep) d = sceneDistance(q, tFrom, safety, only, nearest, second);
            if (only != 0xffffffffu && d < eps) {
                // The id field's object is a hit candidate: the hit decision starts from every
                // candidate's distance here, as without the id field (its near-miss step stays
                // within the others' safe distance, which the one evaluation does not give). The
                // next iteration evaluates them at the same point.
                listNext = true;
                continue;
            }
            float radius = abs(d);
            if (omega > 1.0 && (cacheStep ? radius : abs(g_enteredMin)) + prevRadius < stepLength) {
                // The spheres do not overlap: the over-relaxed step may have skipped a surface.
                // Back to the previous point, plain step from there, no more over-relaxation.
                t = prevT + prevRadius;
                stepLength = prevRadius;
                omega = 1.0;
                prevT = t;
                ++steps;
                continue;
            }
            if (cacheStep) {
                // A plain safe step (the cached value bounds every object's distance from below;
                // as the previous radius it keeps the next over-relaxation check conservative).
                ++cacheSteps;
                prevRadius = d;
                prevT = t;
                enteredBy = 3.0e38;
                stepLength = d;
                t += d;
                continue;
            }
            if (d < eps) {
                // Within eps of a surface by the safe distance: the hit decision. This step counts
                // here, with the decision's evaluations after it, each within the step limit.
                ++steps;
                // The decision's first checks of the candidate's raw value (rootNext's gate and
                // tolerance), taken here so that the ray goes on or ends without a round.
                if (g_nearestRaw >= eps) {
                    // No candidate: a field whose safe distance lies below eps by its
                    // interpolation bound while its raw value does not.
                    nearMissStep(nearest, g_nearestRaw, t, second, eps, t, omega, prevRadius, stepLength,
                                 prevT, bestError, bestT, bestObject);
                    continue;
                }
                if (g_nearestRaw <= max(kRootTolerance * eps, 1e-6 * t)) {
                    // On the surface, or inside the solid (a ray that starts inside, e.g. a camera
                    // in an object or behind the near plane's cut): a hit where it is (no other
                    // candidate can be crossed before it).
                    hit = true;
                    hitObject = nearest;
                    break;
                }
                candidate = true;
                break;
            }
            if (nearest != 0xffffffffu)
                keepBestCandidate(g_nearestUncapped / max(t, 1e-6), t, nearest, bestError, bestT, bestObject);
            // Forward along the ray the point is safe up to its sphere and the nearest box entered
            // only ahead (sceneDistance), whichever is nearer; the next point's sphere must reach
            // back to that (the over-relaxation check above, over the objects entered by now). An
            // over-relaxed step ends at that box's entry at the latest: past it, the object there
            // (a floor whose box begins at its surface) would fail the check. A field whose safe
            // distance is its root bound (sdfFieldRootDistance, up to 1.75 times below the
            // distance) takes a plain step: approaching it, an over-relaxed step fails the check.
            float forward = min(radius, g_ahead);
            prevRadius = forward;
            prevT = t;
            // Boxes entered from here on are left out of the next check only when this step was
            // bounded by their entries (g_aheadRule: a culled list's evaluation).
            enteredBy = g_aheadRule ? t + eps : 3.0e38;
            stepLength = min((d < g_nearestUncapped ? 1.0 : omega) * forward, g_ahead);
            t += stepLength;
            ++steps;
            if (t > tMax && stepLength > forward) {
                // An over-relaxed step past the ray's end (the far plane, or a mesh's depth just
                // behind a surface) is never checked by the spheres' overlap: the plain step
                // instead, and no more over-relaxation.
                t = prevT + forward;
                stepLength = forward;
                omega = 1.0;
            }
        }
        if (!candidate) break;

        // (b) The hit decision at the march point t: the first root along the ray of the
        // candidate's object `nearest`, then of every candidate (index decision) whose distance
        // here is below the gap to the best root so far (below eps while there is none): the
        // earliest root is the hit, on its object; none is a near miss and the march goes on. A
        // search made against a root found already goes on past its object's near misses up to
        // that root; when the first root comes from a later candidate more than eps on, the scan
        // starts over against its gap, the candidate's own object included (a grazing ray's far
        // root must not hide a nearer surface; docs/ACCURACY.md). A field's safe distance lies up
        // to its interpolation bound below the interpolated one, so the raw value decides; the
        // candidate's raw value here is known from the step's evaluation (the same value the
        // search's own first evaluation would take). The scan skips every other candidate when
        // the march's lower bound of their distances here (`second`: safe distances, box
        // distances, the boxes ahead along the ray) is not below the gap: each one's raw distance
        // here is then at least the gap, so its search would end at its first evaluation (the
        // gate) without a root. The bound differs with culling and without, the step count does
        // not: the gate does not count against the step limit, and the scan searches no object
        // whose box the ray enters only past the gap (candidateCrossed).
        int decision = -1;
        int decisionCount = int(candidateCount());
        float dRaw = g_nearestRaw, dNearPast = t, dBest = 3.0e38;
        float dSecond = second;  // the other candidates' lower bound here
        float dTol = max(kRootTolerance * eps, 1e-6 * t);
        uint dRoot = 0xffffffffu;
        bool nearestDone = true;  // the candidate's own search needs no second one
        RootSearch search;
        // The next search's object and parameters: first the candidate's own (its raw value here
        // known), then each one the scan starts. One rootStart and one objectRawDistance in the
        // loop: a CPU device runs every copy of that code in each round, needed or not.
        uint sObj = nearest;
        float sFirst = g_nearestRaw, sGate = eps, sEnd = tMax;
        bool sKnown = true, sScanned = false, sUntilEnd = false;
        for (;;) {
            rootStart(search, sObj, ro, rd, t, sFirst, sKnown, sGate, sEnd, dTol, eps, sScanned);
            search.untilEnd = sUntilEnd;
            // One candidate's search, to its end: evaluations (a field's only for its first value,
            // when not known), then a field walks its cells (stored values, no filter).
            while ((!search.cells || search.r < 0) && rootNext(search, steps, stepLimit))
                rootTake(search, objectRawDistance(search.obj, ro + rd * search.tr), steps);
#ifdef SDF_FIELDS
            while (search.cells && rootNext(search, steps, stepLimit)) cellStep(search, ro, rd, steps);
            // A walk that found its root's cell: the root there (one solve per search).
            if (search.rootCell)
                search.result = search.ta + cellPieceRoot(search.cubic, search.piece) * (search.tb - search.ta);
#endif
            // The search of `decision` is over.
            float tj = search.result;
            if (search.cells)  // the walk's nearest point, for the step-limit rule
                keepBestCandidate(search.sb, search.tp, search.obj, bestError, bestT, bestObject);
            // The candidate's object: where it certainly has no root before (its raw value here,
            // between the root tolerance and eps, was checked in the march loop).
            if (decision < 0) dNearPast = search.tPast;
            if (tj >= 0.0 && tj < dBest) {
                // The first root, found by a later candidate farther than eps on: the candidates
                // before it were passed over against eps only, so the scan starts over against the
                // gap to this root (a grazing ray's far root must not hide a nearer surface).
                // The candidate's own search, ended at its near miss, is one of them: its object
                // may come nearer again before this root.
                if (dRoot == 0xffffffffu && decision >= 0 && tj - t > eps) {
                    decision = -1;
                    nearestDone = false;
                }
                dBest = tj;
                dRoot = search.obj;
            }
            // The next candidate that could be crossed before the best root so far.
            bool started = false;
            float gap = dRoot != 0xffffffffu ? dBest - t : eps;
            if (dSecond >= gap && nearestDone) decision = decisionCount;  // none can be crossed
            for (++decision; decision < decisionCount; ++decision) {
                if (trace.counts.w == 0u || steps >= stepLimit) break;
                uint obj = candidateObject(uint(decision), t);
                if ((obj == nearest && nearestDone) || obj == dRoot || obj == 0xffffffffu) continue;
                if (obj != nearest && dSecond >= gap) continue;
                if (sdfBoxDistance(obj, sdfToLocal(obj, ro + rd * t)) >= gap) continue;
                if (!candidateCrossed(uint(decision), obj, ro, rd, t, gap)) continue;
                sObj = obj;
                sFirst = d;
                sKnown = false;
                sGate = gap;
                sEnd = min(dBest, tMax);
                sScanned = true;
                sUntilEnd = dRoot != 0xffffffffu;
                started = true;
                break;
            }
            if (!started) break;
        }
        if (dRoot != 0xffffffffu) {
            hit = true;
            hitObject = dRoot;
            t = max(dBest, tMin);
            break;
        }
        // Not on the surface (yet).
        nearMissStep(nearest, dRaw, dNearPast, second, eps, t, omega, prevRadius, stepLength, prevT,
                     bestError, bestT, bestObject);
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
