// sdf_world_cache_update: recomputes or splats boxes of the world SDF cache (renderer/features/
// world_cache_clipmap.h documents the values and margins, sdf_world_cache.h the passes). One
// invocation per voxel of a job (a box of at most 8^3 voxels of one level). Recompute jobs: one
// workgroup per job. Splat jobs (their boxes are the parts of bricks near a changed object, often
// smaller than a brick): packed, the dispatch's invocations run over the concatenated voxels of
// all the splat jobs (each job's first index in list.z, found by a binary search), so no
// workgroup runs idle lanes for the voxels of a brick outside the box (a CPU device runs all of a
// SIMD group's code even when every lane of it has returned).
//   recompute: D = min(T, d_1) - margin over the job's objects (every object within T + slack of
//              the box), id = the nearest when d_2 - U >= sqrt(3) h + 2 slack, U an upper bound at c
//              of its true distance and of the distance the trace steps on it (upperDistance: exact
//              programs under any scale, fields where c lies in their box of voxel centres; none for
//              inexact programs), UNCERTAIN otherwise, NONE when d_1 >= T;
//   splat:     D = min(D, d_1 - margin) over the job's (changed) objects, id = UNCERTAIN unless it
//              was NONE and stays so (no listed object within T).
// Distances are lower bounds at the voxel centre c of the distance to the object's solid and to
// the surface the trace finds on it (objectLowerBound): sdfObjectDistance(o, c, 1) (sdf_scene.glsl),
// for a field also its sdfFieldRootDistance (the trace's surface of a field is the zero set of its
// trilinear interpolant, which may lie up to about a voxel nearer than the mesh), raised outside
// the object's bounds box to the distance to that box (the solid and that zero set lie in it).
#version 450
#pragma penumbra_variants SDF_FIELDS SHAPE_PRIMITIVES SDF_FIELDS+SHAPE_PRIMITIVES SDF_FIELDS+SDF_OBJECTS_UBO SHAPE_PRIMITIVES+SDF_OBJECTS_UBO SDF_FIELDS+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO SDF_OBJECTS_UBO
layout(local_size_x = 8, local_size_y = 8, local_size_z = 8) in;

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 0
#define SHAPE_RECORDS_BINDING 1
#define SDF_FIELDS_BINDING 2
#define SDF_ATLAS_BINDING 3
#include "sdf_scene.glsl"
#include "sdf_world_cache.glsl"

struct CacheJob {
    ivec4 origin;  // xyz first voxel, w level
    uvec4 size;    // xyz voxels per axis, w mode (0 recompute, 1 splat)
    uvec4 list;    // x first index into cacheObjectList, y count, z (splat jobs) first packed voxel
};
layout(set = 2, binding = 4, std430) readonly buffer CacheJobs { CacheJob cacheJobs[]; };
layout(set = 2, binding = 5, std430) readonly buffer CacheObjectList { uint cacheObjectList[]; };
layout(set = 2, binding = 6, std430) readonly buffer CacheLevels {
    uvec4 cacheInfo;  // x level count, y resolution R
    SdfCacheLevel cacheLevels[];
};
layout(set = 2, binding = 7, r32f) uniform image3D cacheDistanceImage;
layout(set = 2, binding = 8, r32ui) uniform uimage3D cacheIdImage;
layout(set = 2, binding = 9, std430) readonly buffer CacheObjectFlags { uint cacheObjectFlags[]; };

layout(push_constant) uniform SdfWorldCacheUpdate {
    uvec4 jobs;    // x first job of this dispatch, y object count of the frame, z packed jobs (0: one
                   // workgroup per job), w their voxels
    uvec4 packed;  // x (packed) the first workgroup of this dispatch
} pc;

const uint kModeSplat = 1u;

const uint kExactProgram = 1u;  // CacheObjectFlags: the shape program's value is exact

// An upper bound of the object's true signed world distance at c (local position pl), given its
// value d there (the lower bound objectLowerBound) and, for a field, its raw value and
// interpolation bound there; 3e38 when none is known. Exact programs (flag): the local value
// d / sigma_min is the true local distance. World from local: outside (> 0) at most sigma_max
// times, inside at most sigma_min times (a negative value), sigma_max^2 <= the largest Gershgorin
// row sum of M^T M.
float upperDistance(uint o, vec3 c, vec3 pl, float d, vec2 rawBound) {
    const mat3 m = mat3(sdfObjects[o].model);
    const mat3 g = transpose(m) * m;
    float rowMax = 0.0;
    for (int i = 0; i < 3; ++i) rowMax = max(rowMax, abs(g[i][0]) + abs(g[i][1]) + abs(g[i][2]));
    const float sigmaMin = sdfObjects[o].boundsMin.w, sigmaMax = sqrt(rowMax) * 1.000001;
    if (!(sigmaMin > 0.0)) return 3.0e38;
    float local;
    if (sdfObjects[o].info.x == SDF_KIND_SHAPES) {
        if ((cacheObjectFlags[o] & kExactProgram) == 0u) return 3.0e38;
        local = d / sigmaMin;
    } else {
#ifdef SDF_FIELDS
        // Fields, where c lies in the box of voxel centres B (outside it the field's value is only
        // a lower bound): the mesh distance f <= raw + bound + the storage rounding (< 2^-10 of the
        // value, the atlas's halfs) at c (sdf_field.glsl), and what the trace steps on the field
        // at a point p of the cell (marchLocalDistance: at most the filtered value raw(p)) is at
        // most f(p) + margin (|interpolant - f| <= the interpolation bound <= sqrt(3)/2 voxel +
        // the hardware term), f being 1-Lipschitz: local = raw + bound + margin bounds both at c,
        // and the cell's extent is added by the caller (sqrt(3)/2 h per side, in world units,
        // which sigma_min converts: the step is sigma_min times the local value, and a local point
        // moves at most 1 / sigma_min times the world offset).
        const SdfField f = sdfFields[sdfObjects[o].info.y];
        const vec3 x = sdfFieldVoxelCoord(f, pl);
        if (any(lessThan(x, vec3(0.0))) || any(greaterThan(x, f.dims.xyz - 1.0))) return 3.0e38;
        const float raw = rawBound.x, bound = rawBound.y;  // objectLowerBound's
        const float margin = (0.8660254 + sdfFieldHardwareTerm(f)) * f.origin.w;
        local = raw + bound + margin + abs(raw) * 0.0009765625;
#else
        return 3.0e38;
#endif
    }
    const float world = local > 0.0 ? local * sigmaMax : local * sigmaMin;
    return world + 1.0e-5 * max(1.0, length(c)) + 1.0e-6 * abs(world);  // float evaluation
}

// A lower bound at c (local position pl) of the object's world distance to its solid and to the
// surface the trace finds on it (fields: the zero set of the interpolant, sdfFieldRootDistance),
// raised outside the object's bounds box to the distance to that box; box is that distance.
// rawBound: a field's local value and interpolation bound at c (for upperDistance).
float objectLowerBound(uint o, vec3 pl, float box, out vec2 rawBound) {
    rawBound = vec2(0.0);
    const uvec4 info = sdfObjects[o].info;
    float d;
#ifdef SDF_FIELDS
    if (info.x == SDF_KIND_FIELD) {
        const SdfField f = sdfFields[info.y];
        const float raw = sdfFieldDistanceOf(f, pl);
        const float bound = sdfFieldInterpolationBoundOf(f, pl);
        d = sdfObjects[o].boundsMin.w * min(raw - bound, sdfFieldRootDistance(f, pl, raw, bound));
        rawBound = vec2(raw, bound);
    } else
#endif
        d = sdfObjects[o].boundsMin.w * sdfShapeDistance(info, pl);
    return box > 0.0 ? max(d, box) : d;
}

void main() {
    CacheJob job;
    uvec3 local;
    if (pc.jobs.z > 0u) {
        // Packed: voxel g of the concatenated boxes (x fastest within a box); its job is the last
        // one whose first packed voxel is at most g.
        const uint g = (pc.packed.x + gl_WorkGroupID.x) * 512u + gl_LocalInvocationIndex;
        if (g >= pc.jobs.w) return;
        uint lo = 0u, hi = pc.jobs.z - 1u;
        while (lo < hi) {
            const uint mid = (lo + hi + 1u) / 2u;
            if (cacheJobs[pc.jobs.x + mid].list.z <= g) lo = mid;
            else hi = mid - 1u;
        }
        job = cacheJobs[pc.jobs.x + lo];
        const uint i = g - job.list.z;
        local = uvec3(i % job.size.x, i / job.size.x % job.size.y, i / (job.size.x * job.size.y));
    } else {
        job = cacheJobs[pc.jobs.x + gl_WorkGroupID.x];
        local = gl_LocalInvocationID;
        if (any(greaterThanEqual(local, job.size.xyz))) return;
    }
    const uint level = uint(job.origin.w);
    const int r = int(cacheInfo.y);
    const SdfCacheLevel lv = cacheLevels[level];
    const float h = lv.params.x, truncation = lv.params.y, margin = lv.params.z, slack = lv.params.w;
    const ivec3 v = job.origin.xyz + ivec3(local);
    ivec3 t = v - lv.origin.xyz + lv.wrap.xyz;
    t -= ivec3(greaterThanEqual(t, ivec3(r))) * r;
    t.z += lv.origin.w;
    const vec3 c = (vec3(v) + 0.5) * h;

    float d1 = truncation, d2 = truncation;
    uint nearest = SDF_CACHE_NONE;
    vec2 nearestRawBound = vec2(0.0);
    vec3 nearestLocal = vec3(0.0);
    for (uint k = 0u; k < job.list.y; ++k) {
        const uint o = cacheObjectList[job.list.x + k];
        if (o >= pc.jobs.y) continue;
        // The solid lies in its bounds box, so outside the box (box > 0) the box distance is a lower
        // bound as well: an object whose box is at least d_2 away changes neither d_1 nor d_2 and is
        // not evaluated, and every evaluated distance is raised to its box distance (so the result
        // does not depend on the order of the list). Inside the box (box = 0) the signed distance
        // is kept as it is.
        const vec3 pl = sdfToLocal(o, c);
        const float box = sdfBoxDistance(o, pl);
        if (box >= d2) continue;
        vec2 rawBound;
        const float d = objectLowerBound(o, pl, box, rawBound);
        if (d < d1) {
            d2 = d1;
            d1 = d;
            nearest = o;
            nearestRawBound = rawBound;
            nearestLocal = pl;
        } else {
            d2 = min(d2, d);
        }
    }
    if (job.size.w == kModeSplat) {
        const float old = imageLoad(cacheDistanceImage, t).x;
        const uint oldId = imageLoad(cacheIdImage, t).x;
        imageStore(cacheDistanceImage, t, vec4(min(old, d1 - margin)));
        const bool none = oldId == SDF_CACHE_NONE && nearest == SDF_CACHE_NONE;
        imageStore(cacheIdImage, t, uvec4(none ? SDF_CACHE_NONE : SDF_CACHE_UNCERTAIN));
        return;
    }
    // Certain: for every p in the cell the nearest's true distance <= U + sqrt(3)/2 h + slack <=
    // d_2 - sqrt(3)/2 h - slack <= every other object's true distance. U >= d_1 (an upper and a
    // lower bound of one distance), so a gap below d_1 needs no U.
    uint id = nearest;
    const float gap = d2 - 1.7320509 * h - 2.0 * slack;
    if (nearest != SDF_CACHE_NONE &&
        !(gap >= d1 && gap >= upperDistance(nearest, c, nearestLocal, d1, nearestRawBound)))
        id = SDF_CACHE_UNCERTAIN;
    imageStore(cacheDistanceImage, t, vec4(d1 - margin));
    imageStore(cacheIdImage, t, uvec4(id));
}
