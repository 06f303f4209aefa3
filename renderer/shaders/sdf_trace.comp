// sdf_trace: full-screen sphere tracing of the frame's SDF objects into the G-buffer
// (renderer/features/sdf_trace.h documents the settings, renderer/scene_renderer.h the G-buffer).
// The march and hit decision (steps 2-5's code: candidate lists, sceneDistance, RootSearch,
// sdfMarch) live in sdf_march.glsl, shared with the box trace (sdf_box_trace.frag).
// One invocation per pixel:
//  1. the camera ray through the pixel centre; its interval ends at the rasterized depth when a mesh
//     pass ran (RASTER flag: the trace is bounded by the raster depth, so meshes and SDFs occlude
//     each other correctly), else at the far plane;
//  2. culling (acceleration flag CULL, scene::AccelerationSettings::culling): the candidate objects
//     are the pixel's 8x8 tile list (sdf_tiles.glsl, built by sdf_cull; every traced object when
//     the frame has no lists); each one's local bounds box is intersected with the ray, objects it
//     misses are never evaluated, the march starts at the first box entry, and an object is
//     dropped once a step starts past its box or when its box is farther than the best distance
//     so far; a box the ray enters only ahead is not evaluated, and the step may reach its entry.
//     Up to kListSize objects are kept in a per-pixel list; a ray crossing more boxes
//     evaluates the whole tile list (correct, slower). Without CULL every object [0, tracedCount)
//     is evaluated at every step (mTec's "no optimization" baseline); the march interval (first
//     box entry on, none when the ray crosses no box) is the same either way;
//  3. sphere tracing with over-relaxation (Keinert et al. 2014): steps of omega * d while the
//     unbounding spheres of consecutive points overlap; when they do not, the step returns to the
//     previous point plus its plain (safe) step and omega becomes 1 for the rest of the ray (so
//     does an over-relaxed step that ends past the ray's end, which no next point would check);
//  4. a hit candidate is d < hitEpsilon pixel footprints at the current distance (at least a few
//     float ulps of the point's coordinates), d the safe distance and, for a field, then also its
//     raw (interpolated) value — when only the safe one is below, the ray goes on with plain steps
//     on the raw value; a ray inside a solid (d <= 0, e.g. a camera inside an object) hits where it
//     is; if the step limit runs out, the point with the smallest d / t (screen-space error) is kept
//     when that error is within 4x the hit threshold (Keinert's hit selection), else the pixel is a
//     miss;
//  5. the hit decision (RootSearch; refineSteps 0: every candidate is a hit where it is): the
//     first root along the ray of the candidate's object on its own raw distance (no interpolation
//     safety), and of every other candidate object whose distance here is below the gap to the best
//     root so far (below hitEpsilon while there is none) — secant steps while the distance falls,
//     regula falsi once a point below zero brackets the root, at most refineSteps evaluations per
//     object, converged within 1e-3 hit epsilons of the surface. The earliest root is the hit, on
//     its object (the first surface at a contact line, e.g. a box standing on the floor, where the
//     union's distance is near zero all along the contact plane); when no object has a root (the
//     distance grows again: the ray passes within hitEpsilon of a silhouette; concluded only from
//     steps that cannot have passed a root: a secant step that does is replaced by plain steps) the
//     march goes on past the candidate object's closest approach. The decision depends only on the
//     ray and the objects, not on where the march's samples landed, so culling, the world cache and
//     over-relaxation leave the picture as it is (tests/renderer/sdf_accel_parity_test.cpp). steps
//     counts every evaluation but a scanned candidate's first (its gate) and never exceeds the step
//     limit;
//  6. the normal is the gradient of the hit object's world distance by central differences over
//     a tetrahedron (4 evaluations) with h = normalEpsilon pixel footprints (at least 1e-5 of the
//     distance from the origin, for float precision, and for fields at least half a voxel);
//     velocity from the object's previous model.
// World cache (flags CACHE, ID; sdf_world_cache.glsl, built by sdf_world_cache): at each step
// whose point lies in a clipmap level, a cached distance above two voxels and two hit epsilons is
// taken as a plain safe step with no object evaluated (such steps have their own limit and do not
// count against the step limit); nearer, when the id field names a traced object for the point's
// cell, that object alone is evaluated (it is the nearest everywhere in the cell; once it is within
// the hit epsilon the list is evaluated at the same point, so the hit decision starts from every
// candidate's distance); otherwise the list (or every object). With ID but not CACHE only the id
// part is used. While the march's last distance stays below two voxels of the last lookup that
// gave neither a cache step nor an object, the lookup is skipped (sdf_march.glsl).
// Tile dispatch (flag TILE_DISPATCH, with the frame's tile lists): one workgroup per tile of a class,
// from the indirect dispatches the culling wrote: the tiles whose list holds a baked field run the
// frame's variant, those whose list holds shape objects only the variant without SDF_FIELDS and
// without WORLD_CACHE, and the tiles with an empty list cross no box, so their pixels are misses
// with no step (sdf_trace_empty.comp writes those). The world cache is left out where the list has
// analytic shapes only: with the per-pixel list a cache step is never longer than the step the
// listed objects give (the cache is a lower bound of the distance to every object, less a margin;
// the culled step covers the objects whose boxes the ray is in, and reaches the next box entry),
// so the cache only saves evaluations, and an analytic shape costs about what a lookup costs. On
// the 40 analytic objects of the parity test the cache made the culled trace 1.8x slower (44
// against 25 ms, Vulkan, 320 x 180). The hit decision does not depend on where the samples land,
// so the picture is the same with the cache and without it (tests/renderer/
// sdf_accel_parity_test.cpp); the steps counted differ.
// Cone prepass (flag PREPASS; sdf_cone_prepass.comp ran before): every ray of an 8x8 tile starts no
// nearer than where the tile's cone touched a surface; the hit decision does not depend on where
// the march starts, so the picture stays.
// gbuffer.aux y counts the steps that evaluated objects (at most the step limit; cache steps are
// not counted), or (flag COUNT_EVALUATIONS, tests and benchmarks) the object distance evaluations
// of the pixel: the work the acceleration saves.
#version 450
#pragma penumbra_variants ALBEDO AUX SDF_FIELDS ALBEDO+AUX ALBEDO+SDF_FIELDS AUX+SDF_FIELDS ALBEDO+AUX+SDF_FIELDS WORLD_CACHE ALBEDO+WORLD_CACHE AUX+WORLD_CACHE ALBEDO+AUX+WORLD_CACHE SDF_FIELDS+WORLD_CACHE ALBEDO+SDF_FIELDS+WORLD_CACHE AUX+SDF_FIELDS+WORLD_CACHE ALBEDO+AUX+SDF_FIELDS+WORLD_CACHE SHAPE_PRIMITIVES ALBEDO+SHAPE_PRIMITIVES AUX+SHAPE_PRIMITIVES ALBEDO+AUX+SHAPE_PRIMITIVES SDF_FIELDS+SHAPE_PRIMITIVES ALBEDO+SDF_FIELDS+SHAPE_PRIMITIVES AUX+SDF_FIELDS+SHAPE_PRIMITIVES ALBEDO+AUX+SDF_FIELDS+SHAPE_PRIMITIVES WORLD_CACHE+SHAPE_PRIMITIVES ALBEDO+WORLD_CACHE+SHAPE_PRIMITIVES AUX+WORLD_CACHE+SHAPE_PRIMITIVES ALBEDO+AUX+WORLD_CACHE+SHAPE_PRIMITIVES SDF_FIELDS+WORLD_CACHE+SHAPE_PRIMITIVES ALBEDO+SDF_FIELDS+WORLD_CACHE+SHAPE_PRIMITIVES AUX+SDF_FIELDS+WORLD_CACHE+SHAPE_PRIMITIVES ALBEDO+AUX+SDF_FIELDS+WORLD_CACHE+SHAPE_PRIMITIVES ALBEDO+SDF_OBJECTS_UBO AUX+SDF_OBJECTS_UBO SDF_FIELDS+SDF_OBJECTS_UBO ALBEDO+AUX+SDF_OBJECTS_UBO ALBEDO+SDF_FIELDS+SDF_OBJECTS_UBO AUX+SDF_FIELDS+SDF_OBJECTS_UBO ALBEDO+AUX+SDF_FIELDS+SDF_OBJECTS_UBO WORLD_CACHE+SDF_OBJECTS_UBO ALBEDO+WORLD_CACHE+SDF_OBJECTS_UBO AUX+WORLD_CACHE+SDF_OBJECTS_UBO ALBEDO+AUX+WORLD_CACHE+SDF_OBJECTS_UBO SDF_FIELDS+WORLD_CACHE+SDF_OBJECTS_UBO ALBEDO+SDF_FIELDS+WORLD_CACHE+SDF_OBJECTS_UBO AUX+SDF_FIELDS+WORLD_CACHE+SDF_OBJECTS_UBO ALBEDO+AUX+SDF_FIELDS+WORLD_CACHE+SDF_OBJECTS_UBO SHAPE_PRIMITIVES+SDF_OBJECTS_UBO ALBEDO+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO AUX+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO ALBEDO+AUX+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO SDF_FIELDS+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO ALBEDO+SDF_FIELDS+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO AUX+SDF_FIELDS+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO ALBEDO+AUX+SDF_FIELDS+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO WORLD_CACHE+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO ALBEDO+WORLD_CACHE+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO AUX+WORLD_CACHE+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO ALBEDO+AUX+WORLD_CACHE+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO SDF_FIELDS+WORLD_CACHE+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO ALBEDO+SDF_FIELDS+WORLD_CACHE+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO AUX+SDF_FIELDS+WORLD_CACHE+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO ALBEDO+AUX+SDF_FIELDS+WORLD_CACHE+SHAPE_PRIMITIVES+SDF_OBJECTS_UBO SDF_OBJECTS_UBO
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

// SHAPE_PRIMITIVES: every shape object is one shape (sdf_scene.glsl, no program interpreter).
// SDF_OBJECTS_UBO: the objects are read from a uniform block (sdf_scene.glsl; at most
// kSdfObjectsUniformCapacity of them).
// WORLD_CACHE: the frame has the world cache (worldCache or idField on); without it the march
// loop has no lookup code (a CPU device runs every branch of a SIMD group: 8-10 % of the trace).
#ifdef WORLD_CACHE
#define SDF_CACHE_SET 2
#define SDF_CACHE_DISTANCE_BINDING 12
#define SDF_CACHE_IDS_BINDING 13
#define SDF_CACHE_LEVELS_BINDING 14
#include "sdf_world_cache.glsl"
#else
#define SDF_MARCH_NO_CACHE
#endif

// Per 8x8 tile: x the ray distance its rays are empty up to (a float's bits), y the evaluations
// the tile's cone took (sdf_cone_prepass.comp; flag PREPASS; tile index with trace.accel.z per row).
layout(set = 2, binding = 15, std430) readonly buffer SdfTileStarts { uvec2 sdfTileStarts[]; };
// The tile dispatch (flag TILE_DISPATCH; renderer/features/sdf_cull.h, SdfTileLists::dispatch): the
// indices of one class of tiles from trace.accel.w on, one workgroup each.
layout(set = 2, binding = 16, std430) readonly buffer SdfTileDispatch { uint sdfTileDispatch[]; };

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
    uvec4 accel;     // x acceleration flags (k*Flag below), y tiles per row of the tile lists and of
                     // the tile dispatch, z tiles per row of sdfTileStarts, w the dispatched class's
                     // first tile in sdfTileDispatch
} trace;

const uint kRasterFlag = 1u;
const uint kPrepassFlag = 64u;  // sdfTileStarts holds this frame's cone prepass
// The dispatch runs over one class of tiles (sdfTileDispatch); every tile otherwise.
const uint kTileDispatchFlag = 128u;

#include "sdf_march.glsl"

vec2 clipToPixel(vec4 clip) { return (clip.xy / clip.w * 0.5 + 0.5) * view.viewport.xy; }

void main() {
    // Each run of 8 consecutive invocations (a SIMD group on CPU devices, which run a group at the
    // pace of its slowest ray) traces a 2x4 block of the 8x8 tile instead of a row of 8: nearby
    // rays take similar step counts, and compact blocks are more alike than rows (objects scene:
    // 8.6 instead of 9.7 steps for the slowest ray of a group, at 3.8 on average). The tile stays
    // the workgroup, and every 32 consecutive invocations still cover 8x4 pixels.
    uint block = gl_LocalInvocationIndex / 8u, lane = gl_LocalInvocationIndex % 8u;
    // With tile lists the workgroups run over one class of tiles: a CPU device runs all of the
    // march's code for a group of lanes even when none of them crosses a box (the empty tiles get the
    // "nothing hit" values from sdf_trace_empty.comp instead) or none needs it (the tiles whose list
    // has no baked field run the variant without field code and world cache).
    uvec2 tile = gl_WorkGroupID.xy;
    if ((trace.accel.x & kTileDispatchFlag) != 0u) {
        uint index = sdfTileDispatch[trace.accel.w + gl_WorkGroupID.x];
        tile = uvec2(index % trace.accel.y, index / trace.accel.y);
    }
    ivec2 pixel = ivec2(tile * 8u + uvec2(block % 4u * 2u + lane % 2u, block / 4u * 4u + lane / 2u));
    if (pixel.x >= int(view.viewport.x) || pixel.y >= int(view.viewport.y)) return;
    // The cone prepass (sdf_cone_prepass.comp): every ray of the tile is empty up to its start.
    bool prepass = (trace.accel.x & kPrepassFlag) != 0u;
    uvec2 cone = prepass ? sdfTileStarts[sdfTileIndex(pixel, trace.accel.z)] : uvec2(0u);
    float tileStart = uintBitsToFloat(cone.x);
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

    float footprint = trace.clip.z;
    uint steps = 0u;
    bool hit = false;
    uint hitObject = 0xffffffffu;
    // The tile's cone is empty up to tileStart along every ray of the tile (the prepass).
    float t = max(tStart, tileStart);
    if (crossed && t <= tMax) hit = sdfMarch(ro, rd, tMin, tMax, stepLimit, t, hitObject, steps);

    vec3 p = ro + rd * t;
    if (hit) g_evaluations += 4u;  // the normal's tetrahedron
    if (all(equal(pixel % 8, ivec2(0)))) g_evaluations += cone.y;  // the tile's cone, on its first pixel
    float work = float((trace.accel.x & kCountEvalsFlag) != 0u ? g_evaluations : steps);
    // One set of stores for a hit and for "nothing hit" (a CPU device runs every store of the
    // shader for each group of invocations, whichever branch its lanes take).
    vec4 depth = vec4(0.0), normal = vec4(0.0), material = vec4(0.0), velocity = vec4(0.0);
#ifdef ALBEDO
    vec4 albedo = vec4(0.0);
#endif
    float id = -1.0;
    if (hit) {
        // Fields: at least half a voxel, so the gradient spans the trilinear cells around the
        // point instead of one cell's piecewise-linear facet.
        float h = max(max(trace.epsilons.y * footprint * t, 1e-5 * max(length(p), 1.0)), 0.5 * sdfObjectVoxel(hitObject));
        vec3 n = sdfObjectNormal(hitObject, p, h);
        if (any(isnan(n))) n = -rd;
        uvec4 info = sdfObjects[hitObject].info;
        depth = vec4(t / dirLength);
        normal = vec4(octEncode(n), 0.0, 0.0);
        // b,a: the object + 1 for sdf_surface (0 past the 16-bit range: such objects keep the factor).
        material = packMaterial(info.z, hitObject < 65535u ? hitObject + 1u : 0u);
        vec3 local = sdfToLocal(hitObject, p);
        vec4 prevClip = view.prevViewProj * (sdfObjects[hitObject].prevModel * vec4(local, 1.0));
        vec4 clip = view.viewProj * vec4(p, 1.0);
        velocity = vec4(prevClip.w > 1e-6 ? clipToPixel(clip) - clipToPixel(prevClip) : vec2(0.0), 0.0, 0.0);
#ifdef ALBEDO
        albedo = packAlbedo(materials[info.z].baseColor.rgb);
#endif
        id = float(info.w);
    }
    if (hit || !raster) {
        // A hit, or nothing else wrote this pixel this frame: the G-buffer's "nothing hit" values.
        imageStore(gbufferDepthImage, pixel, depth);
        imageStore(gbufferNormalImage, pixel, normal);
        imageStore(gbufferMaterialImage, pixel, material);  // material 0, no SDF object when nothing hit
        imageStore(gbufferVelocityImage, pixel, velocity);
#ifdef ALBEDO
        imageStore(gbufferAlbedoImage, pixel, albedo);
#endif
    }
#ifdef AUX
    // A mesh pixel or the background behind a mesh pass keeps the id the mesh pass wrote; every
    // pixel gets the steps its ray took.
    if (!hit && raster) id = imageLoad(gbufferAuxImage, pixel).x;
    imageStore(gbufferAuxImage, pixel, vec4(id, work, 0.0, 0.0));
#endif
}
