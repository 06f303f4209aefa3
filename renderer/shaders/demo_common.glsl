// Shared declarations of the RHI demo frame: camera block, scene primitives, the analytic SDF.
// The scene itself is data (a storage buffer of primitives and materials), never shader code.

struct Primitive {
    vec4 centerType;  // xyz centre, w type: 0 sphere, 1 box, 2 plane, 3 sampled volume
    vec4 params;      // sphere: x radius; box/volume: xyz half extents; plane: xyz normal, w offset
    vec4 material;    // x material id
};

struct Material {
    vec4 albedo;  // rgb linear albedo, a unused
};

#include "demo_camera.glsl"

layout(set = 0, binding = 1, std430) readonly buffer Primitives { Primitive prims[]; };
layout(set = 0, binding = 2, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 3) uniform sampler3D volumeSdf;  // distance in world units, texture space = box

float sdSphere(vec3 p, float r) { return length(p) - r; }

float sdBox(vec3 p, vec3 h) {
    vec3 q = abs(p) - h;
    return length(max(q, 0.0)) + min(max(q.x, max(q.y, q.z)), 0.0);
}

// Sampled distance volume: outside its box the box distance is a lower bound of the true distance
// (the surface lies inside the box), inside it the trilinearly filtered texture.
float sdVolume(vec3 p, vec3 h) {
    float dBox = sdBox(p, h);
    if (dBox > 0.02) return dBox;
    vec3 uvw = clamp(p / (2.0 * h) + 0.5, vec3(0.0), vec3(1.0));
    return textureLod(volumeSdf, uvw, 0.0).r;
}

float sdPrimitive(Primitive pr, vec3 p) {
    vec3 q = p - pr.centerType.xyz;
    int type = int(pr.centerType.w);
    if (type == 0) return sdSphere(q, pr.params.x);
    if (type == 1) return sdBox(q, pr.params.xyz);
    if (type == 2) return dot(p, pr.params.xyz) - pr.params.w;
    return sdVolume(q, pr.params.xyz);
}

// Distance to the scene and the material id of the closest primitive.
float sceneSdf(vec3 p, out int materialId) {
    float best = 1e30;
    materialId = -1;
    for (int i = 0; i < cam.counts.x; ++i) {
        float d = sdPrimitive(prims[i], p);
        if (d < best) {
            best = d;
            materialId = int(prims[i].material.x);
        }
    }
    return best;
}

float sceneSdf(vec3 p) {
    int unused;
    return sceneSdf(p, unused);
}

vec3 sceneNormal(vec3 p, float eps) {
    vec2 e = vec2(eps, 0.0);
    return normalize(vec3(sceneSdf(p + e.xyy) - sceneSdf(p - e.xyy), sceneSdf(p + e.yxy) - sceneSdf(p - e.yxy),
                          sceneSdf(p + e.yyx) - sceneSdf(p - e.yyx)));
}

// World-space ray direction through pixel centre `pixel` of a width x height image.
vec3 cameraRay(vec2 pixel) {
    vec2 ndc = (pixel + 0.5) / vec2(cam.counts.yz) * 2.0 - 1.0;
    vec4 farPoint = cam.invViewProj * vec4(ndc, 1.0, 1.0);
    return normalize(farPoint.xyz / farPoint.w - cam.position.xyz);
}
