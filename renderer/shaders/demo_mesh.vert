#version 450
// RHI demo, pass 3: an indexed triangle mesh rasterised into the same G-buffer.
#include "demo_camera.glsl"
layout(push_constant) uniform Push {
    mat4 model;
    vec4 material;  // x material id
} pc;
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 0) out vec3 vNormal;
layout(location = 1) out vec3 vWorld;

void main() {
    vec4 world = pc.model * vec4(inPosition, 1.0);
    vWorld = world.xyz;
    vNormal = mat3(pc.model) * inNormal;  // the demo's model matrix has no non-uniform scale
    gl_Position = cam.viewProj * world;
}
