// sdf_box_trace, fragment stage (renderer/features/sdf_box_trace.h): traces the pixel-centre camera
// ray through this draw's object alone, with the march and hit decision of the full-screen trace
// (sdf_march.glsl: the same code, a per-pixel candidate list holding just this object), from its
// bounds-box entry (at least the near plane) with the object's own step limit. A hit writes the
// G-buffer like the compute trace and the hardware depth of the hit point; a miss is discarded.
// Overlapping boxes and meshes resolve by the depth test (LESS, writes): the nearest object's
// first root, as the full-screen trace's union picks it.
//
// Conservative depth: the hit lies at or behind the rasterized surface (the box's front face, or
// the near plane for near-plane triangles), so gl_FragDepth is declared depth_greater and early
// depth testing can still reject fragments behind nearer geometry. The written depth is at least
// gl_FragCoord.z (float rounding of a hit on the box face itself must not break the promise).
#version 450
#pragma penumbra_variants ALBEDO AUX SDF_FIELDS ALBEDO+AUX ALBEDO+SDF_FIELDS AUX+SDF_FIELDS ALBEDO+AUX+SDF_FIELDS SHAPE_PRIMITIVES ALBEDO+SHAPE_PRIMITIVES AUX+SHAPE_PRIMITIVES ALBEDO+AUX+SHAPE_PRIMITIVES SDF_FIELDS+SHAPE_PRIMITIVES ALBEDO+SDF_FIELDS+SHAPE_PRIMITIVES AUX+SDF_FIELDS+SHAPE_PRIMITIVES ALBEDO+AUX+SDF_FIELDS+SHAPE_PRIMITIVES
#include "scene.glsl"
#include "gbuffer.glsl"

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 0
#define SHAPE_RECORDS_BINDING 1
#define SDF_FIELDS_BINDING 2
#define SDF_ATLAS_BINDING 3
#include "sdf_scene.glsl"

#ifdef ALBEDO
SCENE_MATERIALS;
#endif

layout(push_constant) uniform SdfBoxTrace {
    uvec4 counts;   // as sdf_trace.comp's (x objects, z step limit, w refine steps)
    vec4 epsilons;  // as sdf_trace.comp's
    vec4 clip;      // as sdf_trace.comp's
    uvec4 accel;    // as sdf_trace.comp's (culling: the per-pixel list is this draw's object)
    uvec4 draw;     // x object, y 1 = a near-plane triangle instead of the box
} trace;

#define SDF_MARCH_NO_TILES
#define SDF_MARCH_NO_CACHE
#define SDF_MARCH_LIST_SIZE 1
#include "sdf_march.glsl"

layout(location = 0) out float outDepth;
layout(location = 1) out vec2 outNormal;
layout(location = 2) out vec4 outMaterial;
layout(location = 3) out vec2 outVelocity;
#ifdef ALBEDO
layout(location = 4) out vec4 outAlbedo;
#endif
#if defined(AUX) && defined(ALBEDO)
layout(location = 5) out vec2 outAux;
#elif defined(AUX)
layout(location = 4) out vec2 outAux;
#endif
layout(depth_greater) out float gl_FragDepth;

vec2 clipToPixel(vec4 clip) { return (clip.xy / clip.w * 0.5 + 0.5) * view.viewport.xy; }

void main() {
    uint obj = trace.draw.x;
    // The ray through the pixel centre moved by the TAA jitter (0 without TAA), computed as
    // sdf_trace.comp does (gl_FragCoord.xy is the pixel plus 0.5 on both backends; the jittered
    // projection moves the rasterized box by -jitter, so the box covers the pixels this ray needs).
    vec2 ndc = (gl_FragCoord.xy + view.jitter.xy) * view.viewport.zw * 2.0 - 1.0;
    vec3 dir = view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz;
    float dirLength = length(dir);
    vec3 rd = dir / dirLength;
    vec3 ro = view.position.xyz;
    float tMin = trace.clip.x * dirLength;
    float tMax = trace.clip.y * dirLength;

    vec2 iv = sdfRayInterval(obj, ro, rd);
    if (iv.x > iv.y || iv.y < tMin || iv.x > tMax) discard;  // a near-plane triangle off the box
    g_list[0] = obj;
    g_interval[0] = iv;
    g_count = 1;
    g_overflow = false;
    g_tileAll = true;
    g_tileFirst = 0u;
    g_tileCount = 1u;
    g_evaluations = 0u;
    uint stepLimit = max(trace.counts.z, sdfObjects[obj].params.x);
    float t = max(iv.x, tMin);
    uint steps = 0u, hitObject;
    if (!sdfMarch(ro, rd, tMin, tMax, stepLimit, t, hitObject, steps)) discard;

    vec3 p = ro + rd * t;
    g_evaluations += 4u;  // the normal's tetrahedron
    float footprint = trace.clip.z;
    float h = max(max(trace.epsilons.y * footprint * t, 1e-5 * max(length(p), 1.0)), 0.5 * sdfObjectVoxel(hitObject));
    vec3 n = sdfObjectNormal(hitObject, p, h);
    if (any(isnan(n))) n = -rd;
    uvec4 info = sdfObjects[hitObject].info;
    outDepth = t / dirLength;
    outNormal = octEncode(n);
    outMaterial = packMaterial(info.z, hitObject < 65535u ? hitObject + 1u : 0u);
    vec3 local = sdfToLocal(hitObject, p);
    vec4 prevClip = view.prevViewProj * (sdfObjects[hitObject].prevModel * vec4(local, 1.0));
    vec4 clip = view.viewProj * vec4(p, 1.0);
    outVelocity = prevClip.w > 1e-6 ? clipToPixel(clip) - clipToPixel(prevClip) : vec2(0.0);
#ifdef ALBEDO
    outAlbedo = packAlbedo(materials[info.z].baseColor.rgb);
#endif
#ifdef AUX
    outAux = vec2(float(info.w), float((trace.accel.x & kCountEvalsFlag) != 0u ? g_evaluations : steps));
#endif
    gl_FragDepth = clamp(max(clip.z / clip.w, gl_FragCoord.z), 0.0, 1.0);
}
