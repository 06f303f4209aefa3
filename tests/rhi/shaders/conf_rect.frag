#version 450
// Conformance: solid colour from push constants.
#include "conf_rect_push.glsl"

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

void main() { outColor = pc.color; }
