#version 450
layout(location = 0) in vec2 vUv;
layout(location = 1) in vec4 vColor;
layout(location = 0) out vec4 outColor;

// Conservative depth must survive into the OpenGL GLSL.
layout(depth_greater) out float gl_FragDepth;

// Same (set, binding) as the vertex shader's Camera, with more members (legal in Vulkan).
layout(set = 0, binding = 0) uniform Camera {
    mat4 viewProj;
    vec4 fogColor;
} camera;

layout(set = 2, binding = 0) uniform Material {
    vec4 baseColor;
} material;

layout(set = 2, binding = 1) uniform sampler2D albedo;

layout(set = 3, binding = 0) readonly buffer Lights {
    vec4 lights[];
} lightData;

layout(push_constant) uniform Push {
    vec4 tint;
    float depthBias;
} pc;

void main() {
    outColor = texture(albedo, vUv) * material.baseColor * vColor + camera.fogColor + lightData.lights[0];
    gl_FragDepth = gl_FragCoord.z + pc.depthBias;
}
