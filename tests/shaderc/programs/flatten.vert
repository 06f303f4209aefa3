#version 450
// Vertex + fragment using different and shared (set, binding) pairs: shaderc_tests checks that the
// OpenGL bindings are flattened per program without collisions.
layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec2 inUv;
layout(location = 2) in float inWeight;
layout(location = 3) in vec4 inColor;

layout(location = 0) out vec2 vUv;
layout(location = 1) out vec4 vColor;

layout(set = 0, binding = 0) uniform Camera {
    mat4 viewProj;
} camera;

layout(set = 1, binding = 0) uniform Object {
    mat4 model;
} object;

layout(set = 0, binding = 1) uniform sampler2D heightMap;

layout(push_constant) uniform Push {
    vec4 tint;
} pc;

void main() {
    float h = textureLod(heightMap, inUv, 0.0).r * inWeight;
    vUv = inUv;
    vColor = inColor * pc.tint;
    gl_Position = camera.viewProj * object.model * vec4(inPosition + vec3(0.0, h, 0.0), 1.0);
}
