#version 450
// Conformance: two colour targets, an RGBA8 colour and an R32F value.
#include "conf_rect_push.glsl"

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;
layout(location = 1) out float outValue;

void main() {
    outColor = pc.color;
    outValue = pc.depth.z;
}
