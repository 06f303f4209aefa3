// sdf_thickness: subsurface thickness through the object under each pixel (renderer/features/
// sdf_thickness.h documents the settings and the cap). One invocation per full-resolution pixel:
//  1. pixels without a surface, or whose material has no subsurface colour, get 0;
//  2. the object: among the SDF objects whose bounds box contains the surface point and whose
//     material is the pixel's, the one with the smallest |distance| there (the surface it lies on);
//     none (a rasterized mesh without a field): 0;
//  3. a ray from the surface point along -n (into the solid; from a point of a sphere it crosses the
//     centre, so its length inside is the distance to the far side, mTec 7.4 / 004_) marches with
//     steps of |d| while the distance is negative (|d| inside a solid is the distance to its nearest
//     surface, so a step never leaves it unnoticed), at least eps per step, until the distance turns
//     non-negative (the far side: thickness = the distance marched, minus the overshoot), the cap
//     (thickness = cap) or the step limit (thickness = the distance marched so far);
//  4. fields step on their distance plus the interpolation bound (the safety factor applied the
//     other way round): inside a solid that is the conservative |d|.
#version 450
#pragma penumbra_variants SDF_FIELDS SHAPE_PRIMITIVES SDF_FIELDS+SHAPE_PRIMITIVES
layout(local_size_x = 8, local_size_y = 8) in;

#include "scene.glsl"
#include "gbuffer.glsl"
#include "effects.glsl"

SCENE_MATERIALS;

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 6
#define SHAPE_RECORDS_BINDING 7
#define SDF_FIELDS_BINDING 8
#define SDF_ATLAS_BINDING 9
#include "sdf_scene.glsl"

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1) uniform sampler2D gbufferNormal;
layout(set = 2, binding = 2) uniform sampler2D gbufferMaterial;
layout(set = 2, binding = 3, r16f) uniform writeonly image2D thicknessImage;

layout(push_constant) uniform SdfThickness {
    uvec4 counts;  // x objects (every object, occluder-only fields included), y step limit
    vec4 params;   // x epsilon in pixel footprints, y pixel footprint per unit distance,
                   // z field safety factor, w cap in subsurface radii
} pc;

// Signed world distance of `obj` whose magnitude inside the solid never exceeds the true one.
float insideDistance(uint obj, vec3 p) { return sdfObjectDistance(obj, p, -pc.params.z); }

// The object the surface point p lies on (0xffffffff: none with material `material`).
uint surfaceObject(vec3 p, uint material, float slack) {
    uint best = 0xffffffffu;
    float bestD = 3.0e38;
    for (uint obj = 0u; obj < pc.counts.x; ++obj) {
        if (sdfObjects[obj].info.z != material) continue;
        vec3 pl = sdfToLocal(obj, p);
        if (sdfBoxDistance(obj, pl) > slack) continue;
        float d = abs(sdfObjectDistance(obj, p, 0.0));
        if (d < bestD) {
            bestD = d;
            best = obj;
        }
    }
    return best;
}

// Distance along `dir` from p through the solid of `obj` to its far side, at most `cap`.
float traceThickness(uint obj, vec3 p, vec3 dir, float eps, float cap) {
    float t = eps;  // the G-buffer point lies within the trace's epsilon of the surface
    float lastStep = eps;
    bool entered = false;
    // A field's conservative inside distance (distance plus the interpolation bound) turns
    // negative only up to about a voxel below the traced surface: the march enters within that
    // (in steps of at most half a voxel) before it gives up.
    float voxel = sdfObjectVoxel(obj);
    float enterWithin = 4.0 * eps + 2.0 * voxel;
    for (uint i = 0u; i < pc.counts.y; ++i) {
        float d = insideDistance(obj, p + dir * t);
        if (d < 0.0) {
            entered = true;
        } else if (entered) {
            return clamp(t - min(d, lastStep), 0.0, cap);  // left the solid within the last step
        } else if (t > enterWithin) {
            return 0.0;  // never got in: a sheet thinner than the epsilon
        }
        lastStep = entered ? max(abs(d), eps) : max(min(abs(d), 0.5 * voxel), eps);
        t += lastStep;
        if (t >= cap) return cap;
    }
    return min(t, cap);
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (pixel.x >= int(view.viewport.x) || pixel.y >= int(view.viewport.y)) return;
    float thickness = 0.0;
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    if (depth > 0.0) {
        uint material = unpackMaterialIndex(texelFetch(gbufferMaterial, pixel, 0));
        vec4 sss = materials[material].subsurface;
        if (sss.r + sss.g + sss.b > 0.0 && sss.w > 0.0) {
            vec3 p = effectsWorldPosition(pixel, depth);
            vec3 n = octDecode(texelFetch(gbufferNormal, pixel, 0).rg);
            // A tenth of the primary trace's hit epsilon (the trace refines its hits to that), at
            // least a few float ulps of the point's coordinates.
            float dist = depth * length(effectsPixelRay(pixel));
            vec3 pa = abs(p);
            float eps = max(0.1 * pc.params.x * pc.params.y * dist, 4.8e-7 * max(max(pa.x, pa.y), pa.z));
            uint obj = surfaceObject(p, material, 4.0 * eps + 10.0 * pc.params.x * pc.params.y * dist);
            if (obj != 0xffffffffu) thickness = traceThickness(obj, p, -n, eps, pc.params.w * sss.w);
        }
    }
    imageStore(thicknessImage, pixel, vec4(thickness));
}
