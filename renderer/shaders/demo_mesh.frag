#version 450
#include "demo_camera.glsl"
layout(push_constant) uniform Push {
    mat4 model;
    vec4 material;
} pc;
layout(location = 0) in vec3 vNormal;
layout(location = 1) in vec3 vWorld;
layout(location = 0) out vec4 outNormal;  // xyz normal, w material id
layout(location = 1) out float outDepth;  // view-space depth

void main() {
    outNormal = vec4(normalize(vNormal), pc.material.x);
    outDepth = dot(vWorld - cam.position.xyz, cam.forward.xyz);
}
