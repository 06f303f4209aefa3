// debug_view, fragment stage: shows one G-buffer channel instead of the lit image
// (renderer/features/debug_view.h). Background pixels (depth 0) are black.
//   mode 0 normals  world normal * 0.5 + 0.5
//   mode 1 depth    linear depth / depthRange, white = near, black = far or nothing hit
//   mode 2 albedo   base colour (variant ALBEDO: the albedo target, else the material's colour)
#version 450
#pragma penumbra_variants ALBEDO
#include "scene.glsl"
#include "gbuffer.glsl"
#include "brdf.glsl"

SCENE_CONSTANTS;
SCENE_MATERIALS;

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1) uniform sampler2D gbufferNormal;
layout(set = 2, binding = 2) uniform sampler2D gbufferMaterial;
#ifdef ALBEDO
layout(set = 2, binding = 3) uniform sampler2D gbufferAlbedo;
#endif

layout(push_constant) uniform DebugView {
    uvec4 mode;        // x mode (see above)
    vec4 depthRange;   // x linear depth shown as black
} debugView;

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    vec3 value = vec3(0.0);
    if (depth > 0.0) {
        if (debugView.mode.x == 0u) {
            value = octDecode(texelFetch(gbufferNormal, pixel, 0).rg) * 0.5 + 0.5;
        } else if (debugView.mode.x == 1u) {
            value = vec3(1.0 - clamp(depth / debugView.depthRange.x, 0.0, 1.0));
        } else {
#ifdef ALBEDO
            value = unpackAlbedo(texelFetch(gbufferAlbedo, pixel, 0));
#else
            value = materials[unpackMaterialIndex(texelFetch(gbufferMaterial, pixel, 0))].baseColor.rgb;
#endif
        }
    }
    // Normals and depth are display values already; albedo is linear colour.
    vec3 encoded = debugView.mode.x == 2u ? srgbEncode(value) : value;
    outColor = vec4(scene.params.w != 0u && debugView.mode.x == 2u ? value : encoded, 1.0);
}
