// deferred_lighting, fragment stage: reads the G-buffer, reconstructs the world position from
// linear depth along the camera ray, sums every light with the selected BRDF, adds ambient and
// emissive, applies exposure, tone mapping and the sRGB encoding. Variant ALBEDO takes the base
// colour from the albedo target, the default variant from the material. Variant EFFECTS reads the
// SDF effects (renderer/features/effects.h; scene.effects says which are real, the others are
// bound to the depth target and never read): each shadowed light's visibility from its layer of effects.shadow, AO and the
// bent normal (ambient: the sky/ground ambient in the bent normal's direction times AO),
// the subsurface translucency term from effects.thickness, the reflection from effects.reflection.
#version 450
#pragma penumbra_variants ALBEDO EFFECTS ALBEDO+EFFECTS
#include "scene.glsl"
#include "gbuffer.glsl"
#include "brdf.glsl"

SCENE_CONSTANTS;
SCENE_MATERIALS;
SCENE_LIGHTS;

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1) uniform sampler2D gbufferNormal;
layout(set = 2, binding = 2) uniform sampler2D gbufferMaterial;
#ifdef ALBEDO
layout(set = 2, binding = 3) uniform sampler2D gbufferAlbedo;
#endif
#ifdef EFFECTS
layout(set = 2, binding = 4) uniform sampler2D effectsShadow;
layout(set = 2, binding = 5) uniform sampler2D effectsAo;
layout(set = 2, binding = 6) uniform sampler2D effectsThickness;
layout(set = 2, binding = 7) uniform sampler2D effectsReflection;
#endif

// Ambient radiance arriving around direction n: the ground ambient below, the sky's above.
vec3 ambientRadiance(vec3 n) { return mix(scene.ambient.rgb, scene.ambientSky.rgb, 0.5 + 0.5 * n.y); }

// Subsurface translucency (Barre-Brisebois and Bouchard 2011, as mTec ch. 7 uses it): light that
// entered the far side and crossed `thickness` of the object, seen when looking toward the light.
vec3 translucency(Material m, vec3 n, vec3 v, vec3 l, vec3 incoming, float thickness) {
    const float kDistortion = 0.2, kPower = 4.0;
    vec3 back = l + n * kDistortion;
    float facing = pow(clamp(dot(v, -back), 0.0, 1.0), kPower);
    float transmitted = exp(-thickness / max(m.subsurface.w, 1e-6));
    return m.subsurface.rgb * transmitted * facing * incoming;
}

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    vec3 radiance;
    if (depth <= 0.0) {
        radiance = scene.background.rgb;
    } else {
        vec2 ndc = (vec2(pixel) + 0.5 + view.jitter.xy) * view.viewport.zw * 2.0 - 1.0;  // the trace's ray
        vec3 ray = view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz;
        vec3 p = view.position.xyz + depth * ray;
        vec3 v = -normalize(ray);
        vec3 n = octDecode(texelFetch(gbufferNormal, pixel, 0).rg);
        vec4 packed = texelFetch(gbufferMaterial, pixel, 0);
        Material m = materials[unpackMaterialIndex(packed)];
#ifdef ALBEDO
        vec3 baseColor = unpackAlbedo(texelFetch(gbufferAlbedo, pixel, 0));
#else
        vec3 baseColor = m.baseColor.rgb;
#endif
        float metallic = m.emissiveMetal.w;
        float roughness = m.params.x;
        float shadow = 1.0;  // the effects targets (EFFECTS variant) supply shadow and AO
        float ao = 1.0;
        vec3 ambientNormal = n;
        float thickness = -1.0;  // < 0: no subsurface term
#ifdef EFFECTS
        if (scene.effects.y != 0u) {
            vec4 aoBent = texelFetch(effectsAo, pixel, 0);
            ao *= aoBent.r;
            vec3 bent = aoBent.gba * 2.0 - 1.0;
            if (dot(bent, bent) > 1e-6) ambientNormal = normalize(bent);
        }
        if (scene.effects.z != 0u && m.subsurface.r + m.subsurface.g + m.subsurface.b > 0.0)
            thickness = texelFetch(effectsThickness, pixel, 0).r;
#endif
        radiance = ambientRadiance(ambientNormal) * baseColor * ao + m.emissiveMetal.rgb;
#ifdef EFFECTS
        if (scene.effects.w != 0u) radiance += texelFetch(effectsReflection, pixel, 0).rgb;
#endif
        for (uint i = 0u; i < scene.params.x; ++i) {
            Light light = lights[i];
            vec3 l;
            vec3 incoming = light.radianceRadius.rgb;
            if (light.positionType.w < 0.5) {
                l = -light.directionRange.xyz;
            } else {
                vec3 toLight = light.positionType.xyz - p;
                float d = length(toLight);
                l = d > 0.0 ? toLight / d : n;
                incoming *= distanceFalloff(d, light.directionRange.w, light.radianceRadius.w);
            }
            float visibility = shadow;
#ifdef EFFECTS
            int layer = int(light.shadow.x);
            if (layer >= 0 && uint(layer) < scene.effects.x)
                visibility *= texelFetch(effectsShadow, ivec2(pixel.x + layer * int(view.viewport.x), pixel.y), 0).r;
            // Translucency is not shadowed: the light reaches the far side.
            if (thickness >= 0.0) radiance += translucency(m, n, v, l, incoming, thickness);
#endif
            radiance += visibility * shadeLight(scene.params.y, n, v, l, incoming, baseColor, metallic, roughness);
        }
    }
    vec3 mapped = toneMap(scene.params.z, radiance * scene.ambient.w);
    // params.w: write linear (a hardware-sRGB output, or the linear scene colour TAA and motion blur read)
    outColor = vec4(scene.params.w != 0u ? mapped : srgbEncode(mapped), 1.0);
}
