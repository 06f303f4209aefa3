#version 450
// Conformance: conservative depth output. The shader promises to only move depth away from the
// viewer (depth_greater) and writes gl_FragCoord.z + offset, offset >= 0.
#include "conf_rect_push.glsl"

layout(depth_greater) out float gl_FragDepth;

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

void main() {
    outColor = pc.color;
    gl_FragDepth = gl_FragCoord.z + pc.depth.y;
}
