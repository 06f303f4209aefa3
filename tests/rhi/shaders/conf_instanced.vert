#version 450
// Conformance: per-vertex position (buffer slot 0) and per-instance offset + normalised RGBA8 colour
// (buffer slot 1).
layout(location = 0) in vec2 inPosition;
layout(location = 1) in vec2 inOffset;
layout(location = 2) in vec4 inColor;

layout(location = 0) out vec4 vColor;

void main() {
    vColor = inColor;
    gl_Position = vec4(inPosition + inOffset, 0.5, 1.0);
}
