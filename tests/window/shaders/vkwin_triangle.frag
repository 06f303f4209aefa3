// Vulkan window test: flat colour from the push constants.
#version 450
layout(push_constant) uniform Params {
    vec4 color;
} pc;

layout(location = 0) out vec4 outColor;

void main() { outColor = pc.color; }
