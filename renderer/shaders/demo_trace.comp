#version 450
// RHI demo, pass 1: compute sphere tracing of the analytic scene into the G-buffer
// (normal + material id, and view-space depth; depth 0 marks sky).
#include "demo_common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 1, binding = 0, rgba16f) uniform writeonly image2D gbufNormal;
layout(set = 1, binding = 1, r32f) uniform writeonly image2D gbufDepth;

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (pixel.x >= cam.counts.y || pixel.y >= cam.counts.z) return;
    vec3 ro = cam.position.xyz;
    vec3 rd = cameraRay(vec2(pixel));
    float t = cam.projParams.z;
    int materialId = -1;
    bool hit = false;
    for (int i = 0; i < 160 && t < cam.projParams.w; ++i) {
        float d = sceneSdf(ro + rd * t, materialId);
        if (d < 1e-4 * t + 1e-4) {
            hit = true;
            break;
        }
        t += d;
    }
    if (!hit) {
        imageStore(gbufNormal, pixel, vec4(0.0, 0.0, 0.0, -1.0));
        imageStore(gbufDepth, pixel, vec4(0.0));
        return;
    }
    vec3 p = ro + rd * t;
    imageStore(gbufNormal, pixel, vec4(sceneNormal(p, 1e-3 * max(t, 1.0)), float(materialId)));
    imageStore(gbufDepth, pixel, vec4(t * dot(rd, cam.forward.xyz)));
}
