#version 450
#pragma penumbra_variants ALBEDO_ONLY ALBEDO_ONLY+FLIP_Y  // the combination is one more variant
#include "view.glsl"

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

layout(set = 1, binding = 0) uniform sampler2D gbufferDepth;
#ifdef ALBEDO_ONLY
layout(set = 1, binding = 1) uniform sampler2D gbufferAlbedo;
#endif

layout(push_constant) uniform Push {
    vec4 tint;
} pc;

void main() {
    vec4 color = texture(gbufferDepth, vUv) * pc.tint * view.viewport.z;
#ifdef ALBEDO_ONLY
    color *= texture(gbufferAlbedo, vUv);
#endif
    outColor = color;
}
