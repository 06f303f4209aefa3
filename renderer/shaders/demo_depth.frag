#version 450
// RHI demo, pass 2: turns the traced view-space depth into hardware depth so the mesh pass can
// depth-test against the traced surfaces. Sky (depth 0) goes to the far plane.
#include "demo_camera.glsl"
layout(set = 1, binding = 0) uniform sampler2D tracedDepth;
layout(location = 0) in vec2 vUv;

void main() {
    float viewDepth = texelFetch(tracedDepth, ivec2(gl_FragCoord.xy), 0).r;
    // Right-handed view space looks down -z: z_view = -viewDepth, NDC z = (A z + B) / -z.
    gl_FragDepth = viewDepth > 0.0 ? clamp(-cam.projParams.x + cam.projParams.y / viewDepth, 0.0, 1.0) : 1.0;
}
