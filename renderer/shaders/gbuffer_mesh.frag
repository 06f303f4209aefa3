// gbuffer_mesh, fragment stage. Variant ALBEDO also writes the albedo target: the material's base
// colour times its base-colour texture (a 1x1 white texture is bound for materials without one).
// Variant AUX also writes the aux target: the entity index and 0 trace steps.
#version 450
#pragma penumbra_variants ALBEDO AUX ALBEDO+AUX
#include "scene.glsl"
#include "gbuffer.glsl"

#ifdef ALBEDO
SCENE_MATERIALS;
layout(set = 3, binding = 0) uniform sampler2D baseColorTexture;
#endif

layout(location = 0) in vec3 vNormal;
layout(location = 1) in float vViewDepth;
layout(location = 2) in vec4 vClip;
layout(location = 3) in vec4 vPrevClip;
layout(location = 4) in vec2 vUv;
layout(location = 5) flat in uint vMaterial;
layout(location = 6) flat in uint vEntity;

layout(location = 0) out float outDepth;
layout(location = 1) out vec2 outNormal;
layout(location = 2) out vec4 outMaterial;
layout(location = 3) out vec2 outVelocity;
#ifdef ALBEDO
layout(location = 4) out vec4 outAlbedo;
#endif
#if defined(AUX) && defined(ALBEDO)
layout(location = 5) out vec2 outAux;
#elif defined(AUX)
layout(location = 4) out vec2 outAux;
#endif

// Clip position -> pixel coordinates (x right, y down from the top row, pixel centres at +0.5).
vec2 clipToPixel(vec4 clip) { return (clip.xy / clip.w * 0.5 + 0.5) * view.viewport.xy; }

void main() {
    outDepth = vViewDepth;
    outNormal = octEncode(normalize(vNormal));
    // b,a: no SDF object (0).
    outMaterial = packMaterial(vMaterial, 0u);
    // A point behind the previous camera has no previous pixel: no motion.
    outVelocity = vPrevClip.w > 1e-6 ? clipToPixel(vClip) - clipToPixel(vPrevClip) : vec2(0.0);
#ifdef ALBEDO
    Material m = materials[vMaterial];
    outAlbedo = packAlbedo(m.baseColor.rgb * texture(baseColorTexture, vUv).rgb);
#endif
#ifdef AUX
    outAux = vec2(float(vEntity), 0.0);
#endif
}
