// sdf_reflection: one traced, shaded reflection bounce per pixel of a reflective material
// (renderer/features/sdf_reflection.h documents the settings; mTec thesis 7.5). One invocation per
// full-resolution pixel:
//  1. pixels without a surface, or whose material lacks MATERIAL_REFLECTIONS (set only for
//     materials below the roughness cut-off), get 0;
//  2. the view ray is mirrored about the G-buffer normal, r = i - 2 (n.i) n, and starts on it two
//     hit epsilons above the surface (so it does not hit the surface it leaves);
//  3. culling: every object's bounds box (all objects, occluder-only mesh fields included) is
//     intersected with the ray; up to kListSize crossing objects are kept, more -> all objects;
//  4. plain sphere tracing (no over-relaxation) with the hit test of the primary trace: d below
//     hitEpsilon pixel footprints at the reflected ray's total length from the camera (the
//     reflection of a surface is as coarse as the surface seen that far away), then up to
//     kRefineSteps steps on the raw distance (a plain step, then secant steps along the ray) onto
//     the surface; a candidate that does not converge below eps / 10 is a near miss and the march
//     goes on (silhouettes are not widened by eps, as in the primary trace);
//  5. at a hit: the gradient normal and the hit object's material (baseColor, no textures), shaded
//     with the scene's lights by the lighting pass's BRDF (brdf.glsl) plus the sky/ground ambient
//     and emissive; each light the frame shadows is shadowed at the hit by the shadow pass's cone
//     trace (sdf_cone.glsl, the same light sizes, hard setting and step limit); a miss sees the
//     background radiance;
//  6. rgb = radiance * Fresnel (Schlick, F0 = mix(0.04, baseColor, metallic), at n.v) * fade,
//     a = fade, where fade = 1 - smoothstep(0, cut-off, roughness) reaches 0 at the cut-off.
#version 450
#pragma penumbra_variants SDF_FIELDS SHAPE_PRIMITIVES SDF_FIELDS+SHAPE_PRIMITIVES
layout(local_size_x = 8, local_size_y = 8) in;

#include "scene.glsl"
#include "gbuffer.glsl"
#include "brdf.glsl"
#include "effects.glsl"

SCENE_CONSTANTS;
SCENE_MATERIALS;
SCENE_LIGHTS;

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 6
#define SHAPE_RECORDS_BINDING 7
#define SDF_FIELDS_BINDING 8
#define SDF_ATLAS_BINDING 9
#include "sdf_scene.glsl"
#include "sdf_cone.glsl"

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1) uniform sampler2D gbufferNormal;
layout(set = 2, binding = 2) uniform sampler2D gbufferMaterial;
layout(set = 2, binding = 3, rgba16f) uniform writeonly image2D reflectionImage;

layout(push_constant) uniform SdfReflection {
    uvec4 counts;    // x objects (all, occluder-only fields included), y step limit, z 1 = hard
                     // shadows, w shadow step limit
    vec4 epsilons;   // x hit epsilon, y normal epsilon (pixel footprints), z field safety,
                     // w pixel footprint per unit distance
    vec4 params;     // x longest reflected ray (the far plane), y roughness cut-off
} pc;

const int kListSize = 16;
const int kRefineSteps = 4;  // secant steps onto the surface at a hit
uint g_list[kListSize];
int g_count;
bool g_overflow;

// Ambient radiance arriving around direction n (the lighting pass's ambientRadiance).
vec3 ambientRadiance(vec3 n) { return mix(scene.ambient.rgb, scene.ambientSky.rgb, 0.5 + 0.5 * n.y); }

// The objects whose box the ray o + t d, t in [0, tMax], crosses.
void cullObjects(vec3 o, vec3 d, float tMax) {
    g_count = 0;
    g_overflow = false;
    for (uint obj = 0u; obj < pc.counts.x; ++obj) {
        vec2 iv = sdfRayInterval(obj, o, d);
        if (iv.x > iv.y || iv.y < 0.0 || iv.x > tMax) continue;
        if (g_count == kListSize) {
            g_overflow = true;
            return;
        }
        g_list[g_count++] = obj;
    }
}

// Conservative distance to the nearest culled object at p.
float sceneDistance(vec3 p, out uint nearest) {
    float d = 3.0e38;
    nearest = 0xffffffffu;
    int count = g_overflow ? int(pc.counts.x) : g_count;
    for (int i = 0; i < count; ++i) {
        uint obj = g_overflow ? uint(i) : g_list[i];
        vec3 pl = sdfToLocal(obj, p);
        if (sdfBoxDistance(obj, pl) >= d) continue;
        float di = sdfObjects[obj].boundsMin.w * sdfLocalDistance(obj, pl, pc.epsilons.z);
        if (di < d) {
            d = di;
            nearest = obj;
        }
    }
    return d;
}

// Refines a hit candidate at t (raw distance dr of `obj`) onto the surface along the ray: a plain
// step, then secant steps once the sign changes, each at most twice the first distance (or a voxel).
// Returns true when |d| falls below eps / 10 (a hit, t on the surface); false: the ray passes the
// surface within eps (a near miss, as the primary trace treats it).
bool refineHit(uint obj, vec3 o, vec3 d, inout float t, float dr, float eps) {
    float voxel = sdfObjectVoxel(obj);
    float limit = voxel > 0.0 ? voxel : 2.0 * max(abs(dr), eps);
    float tr = t, prevT = t, prevD = dr;
    for (int r = 0; r < kRefineSteps && abs(dr) > 0.1 * eps; ++r) {
        float step = dr;
        if (r > 0 && (dr - prevD) * (tr - prevT) < 0.0) step = -dr * (tr - prevT) / (dr - prevD);
        prevT = tr;
        prevD = dr;
        tr += clamp(step, -limit, limit);
        dr = sdfObjectDistance(obj, o + d * tr, 0.0);
    }
    if (abs(dr) > 0.1 * eps) return false;
    t = tr;
    return true;
}

// Sphere traces o + t d from t = 0; `start` is the camera's distance to o (the hit epsilon grows
// with the total path length). Returns the hit object (0xffffffff: none) and its t.
uint traceRay(vec3 o, vec3 d, float start, out float t) {
    float tMax = pc.params.x;
    cullObjects(o, d, tMax);
    t = 0.0;
    if (g_count == 0 && !g_overflow) return 0xffffffffu;
    for (uint steps = 0u; steps < pc.counts.y && t <= tMax; ++steps) {
        vec3 p = o + d * t;
        uint nearest;
        float dist = sceneDistance(p, nearest);
        float eps = max(pc.epsilons.x * pc.epsilons.w * (start + t), 1e-6 * max(length(p), 1.0));
        if (dist < eps) {
            // The raw (interpolated, for fields) distance decides; inside a solid: a hit here.
            float raw = sdfObjectDistance(nearest, p, 0.0);
            if (raw <= 0.0) return nearest;
            if (raw < eps && refineHit(nearest, o, d, t, raw, eps)) return nearest;
            dist = raw;  // not on the surface: plain steps on the raw value
        }
        t += max(dist, 0.5 * eps);
    }
    return 0xffffffffu;
}

// Visibility of a light from the reflected hit p (normal n, direction to the light l), as the
// shadow pass computes it for a pixel (sdf_shadow.comp): only lights the frame shadows (shadow.x >=
// 0), the cone half-angle from the light's size (hard rays with the hard setting), the ray lifted
// off the surface by sdfSurfaceBias; `pixelSize` is the world size of a pixel at the reflected
// hit's total path length.
float reflectionShadow(Light light, vec3 p, vec3 n, vec3 l, float pixelSize) {
    if (light.shadow.x < 0.0) return 1.0;
    float tMax, sinHalf;
    if (light.positionType.w < 0.5) {
        tMax = pc.params.x;
        sinHalf = sin(light.shadow.y);
    } else {
        float dist = length(light.positionType.xyz - p);
        float radius = light.positionType.w > 1.5 ? min(light.radianceRadius.w, dist) : 0.0;
        tMax = dist - radius;
        sinHalf = dist > 0.0 ? radius / dist : 0.0;
    }
    if (pc.counts.z != 0u) sinHalf = 0.0;
    float bias = sdfSurfaceBias(p, pixelSize, pc.counts.x);
    float epsilon = max(0.5 * pixelSize, 1e-6 * max(length(p), 1.0));
    return sdfConeVisibility(p + n * bias, l, 2.0 * pixelSize + bias, tMax, sinHalf, pc.counts.x, pc.counts.w,
                             pc.epsilons.z, epsilon);
}

// Radiance leaving the hit point p (normal n, material m) towards v, as the lighting pass shades it.
vec3 shadeHit(Material m, vec3 p, vec3 n, vec3 v, float pixelSize) {
    vec3 base = m.baseColor.rgb;
    vec3 radiance = ambientRadiance(n) * base + m.emissiveMetal.rgb;
    for (uint i = 0u; i < scene.params.x; ++i) {
        Light light = lights[i];
        vec3 l;
        vec3 incoming = light.radianceRadius.rgb;
        if (light.positionType.w < 0.5) {
            l = -light.directionRange.xyz;
        } else {
            vec3 toLight = light.positionType.xyz - p;
            float dl = length(toLight);
            l = dl > 0.0 ? toLight / dl : n;
            incoming *= distanceFalloff(dl, light.directionRange.w, light.radianceRadius.w);
        }
        if (dot(n, l) <= 0.0) continue;
        radiance += reflectionShadow(light, p, n, l, pixelSize) *
                    shadeLight(scene.params.y, n, v, l, incoming, base, m.emissiveMetal.w, m.params.x);
    }
    return radiance;
}

vec4 reflectPixel(ivec2 pixel, float depth, Material m) {
    vec3 ray = effectsPixelRay(pixel);
    vec3 p = view.position.xyz + depth * ray;
    vec3 i = normalize(ray);
    vec3 n = octDecode(texelFetch(gbufferNormal, pixel, 0).rg);
    if (dot(n, i) > 0.0) n = -n;  // seen from behind (a camera inside a solid): mirror anyway
    vec3 r = reflect(i, n);
    float camDist = depth * length(ray);
    float eps0 = max(pc.epsilons.x * pc.epsilons.w * camDist, 1e-6 * max(length(p), 1.0));
    // Start two epsilons above the surface on the reflected ray itself (an offset along n would
    // shift the whole ray, and with it the mirror image); near grazing, where that point is far,
    // at most 8 epsilons along r and the remaining height along n.
    float along = min(2.0 * eps0 / max(dot(r, n), 1e-6), 8.0 * eps0);
    vec3 o = p + r * along + n * max(2.0 * eps0 - along * dot(r, n), 0.0);
    float t;
    uint hit = traceRay(o, r, camDist, t);
    vec3 radiance = scene.background.rgb;
    if (hit != 0xffffffffu) {
        vec3 q = o + r * t;
        float h = max(max(pc.epsilons.y * pc.epsilons.w * (camDist + t), 1e-5 * max(length(q), 1.0)),
                      0.5 * sdfObjectVoxel(hit));
        vec3 nq = sdfObjectNormal(hit, q, h);
        if (any(isnan(nq))) nq = -r;
        radiance = shadeHit(materials[sdfObjects[hit].info.z], q, nq, -r, pc.epsilons.w * (camDist + t));
    }
    vec3 f0 = mix(vec3(0.04), m.baseColor.rgb, clamp(m.emissiveMetal.w, 0.0, 1.0));
    vec3 fresnel = fresnelSchlick(f0, dot(n, -i));
    float cutoff = pc.params.y;
    float fade = cutoff > 0.0 ? 1.0 - smoothstep(0.0, cutoff, m.params.x) : 1.0;
    return vec4(radiance * fresnel * fade, fade);
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (pixel.x >= int(view.viewport.x) || pixel.y >= int(view.viewport.y)) return;
    vec4 result = vec4(0.0);
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    if (depth > 0.0) {
        Material m = materials[unpackMaterialIndex(texelFetch(gbufferMaterial, pixel, 0))];
        if ((materialFlags(m) & MATERIAL_REFLECTIONS) != 0u) result = reflectPixel(pixel, depth, m);
    }
    imageStore(reflectionImage, pixel, result);
}
