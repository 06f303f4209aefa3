// The world SDF cache as the shaders see it (renderer/features/sdf_world_cache.h is the C++ side,
// renderer/features/world_cache_clipmap.h documents the layout, the values and their margins):
// camera-centred clipmap levels of R^3 voxels, level i with voxel h_i = h_0 2^i, stored toroidally
// (world voxel v of level i at texel (v mod R) + (0, 0, i R)) in an R32F distance texture and an
// R32UI object-id texture.
//
// Use: define SDF_CACHE_SET, SDF_CACHE_DISTANCE_BINDING, SDF_CACHE_IDS_BINDING and
// SDF_CACHE_LEVELS_BINDING, then include; sdfCacheLookup reads the voxel containing p (nearest, no
// filtering) of the finest level whose window contains it. Without SDF_CACHE_SET only the level
// table's struct and the id constants are declared (the update pass).
#ifndef PENUMBRA_SDF_WORLD_CACHE_GLSL
#define PENUMBRA_SDF_WORLD_CACHE_GLSL

const uint SDF_CACHE_NONE = 0xffffffffu;       // no object within the level's truncation distance
const uint SDF_CACHE_UNCERTAIN = 0xfffffffeu;  // the nearest object is not certain in this cell

struct SdfCacheLevel {
    ivec4 origin;  // xyz window origin in voxels (world voxel coordinates), w first z texel (level * R)
    ivec4 wrap;    // xyz origin mod R: the texel of the origin voxel
    vec4 params;   // x voxel size h, y truncation T = 8 h, z margin sqrt(3)/2 h + slack, w slack
};

#ifdef SDF_CACHE_SET
// A uniform block (at most 16 levels, 784 bytes, bound over the frame's levels): the lookup's level
// index is the same in every lane, so a CPU device reads it with scalar loads (a storage buffer it
// loads lane by lane in a loop at every lookup).
layout(set = SDF_CACHE_SET, binding = SDF_CACHE_LEVELS_BINDING, std140) uniform SdfCacheLevels {
    uvec4 sdfCacheInfo;  // x level count, y resolution R
    SdfCacheLevel sdfCacheLevels[16];
};
layout(set = SDF_CACHE_SET, binding = SDF_CACHE_DISTANCE_BINDING) uniform sampler3D sdfCacheDistance;
layout(set = SDF_CACHE_SET, binding = SDF_CACHE_IDS_BINDING) uniform usampler3D sdfCacheIds;

// False when p lies outside every level. Otherwise `distance` is a conservative lower bound of the
// scene distance at p (all objects of the frame, traced and occluder-only, min over them; already
// minus every margin), `voxel` the voxel size of the level used (finest containing p), and `object`
// the object index (into sdfObjects) that is the nearest object everywhere in p's cell, or
// SDF_CACHE_NONE / SDF_CACHE_UNCERTAIN.
bool sdfCacheLookup(vec3 p, out float distance, out float voxel, out uint object) {
    distance = 0.0;
    voxel = 0.0;
    object = SDF_CACHE_UNCERTAIN;
    const uint count = min(sdfCacheInfo.x, 16u);
    const int r = int(sdfCacheInfo.y);
    for (uint i = 0u; i < count; ++i) {
        const float h = sdfCacheLevels[i].params.x;
        const vec3 rel = floor(p / h) - vec3(sdfCacheLevels[i].origin.xyz);
        if (any(lessThan(rel, vec3(0.0))) || any(greaterThanEqual(rel, vec3(float(r))))) continue;
        ivec3 t = ivec3(rel) + sdfCacheLevels[i].wrap.xyz;
        t -= ivec3(greaterThanEqual(t, ivec3(r))) * r;
        t.z += sdfCacheLevels[i].origin.w;
        distance = texelFetch(sdfCacheDistance, t, 0).x;
        object = texelFetch(sdfCacheIds, t, 0).x;
        voxel = h;
        return true;
    }
    return false;
}
#endif

#endif
