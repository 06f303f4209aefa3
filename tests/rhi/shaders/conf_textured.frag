#version 450
// Conformance: a fragment shader sampling a texture and reading a uniform buffer.
layout(set = 0, binding = 0) uniform sampler2D image;
layout(set = 0, binding = 1) uniform Tint { vec4 color; } tint;

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

void main() { outColor = texture(image, vUv) * tint.color; }
