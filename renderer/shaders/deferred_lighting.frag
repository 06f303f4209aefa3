// deferred_lighting, fragment stage: reads the G-buffer, reconstructs the world position from
// linear depth along the camera ray, sums every light with the selected BRDF, adds ambient and
// emissive, applies exposure, tone mapping and the sRGB encoding. Variant ALBEDO takes the base
// colour from the albedo target, the default variant from the material.
#version 450
#pragma penumbra_variants ALBEDO
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

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    vec3 radiance;
    if (depth <= 0.0) {
        radiance = scene.background.rgb;
    } else {
        vec2 ndc = (vec2(pixel) + 0.5) * view.viewport.zw * 2.0 - 1.0;
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
        float shadow = packed.b;
        float ao = packed.a;
        radiance = scene.ambient.rgb * baseColor * ao + m.emissiveMetal.rgb;
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
            radiance += shadow * shadeLight(scene.params.y, n, v, l, incoming, baseColor, metallic, roughness);
        }
    }
    vec3 mapped = toneMap(scene.params.z, radiance * scene.ambient.w);
    outColor = vec4(scene.params.w != 0u ? mapped : srgbEncode(mapped), 1.0);
}
