// Fragment stage of the deferred lighting programs (deferred_lighting, deferred_lighting_albedo):
// reads the G-buffer, reconstructs the world position from linear depth along the camera ray,
// sums every light with the selected BRDF, adds ambient and emissive, applies exposure, tone
// mapping and the sRGB encoding. With GBUFFER_ALBEDO defined the base colour comes from the albedo
// target, otherwise from the material.
#include "scene.glsl"
#include "gbuffer.glsl"
#include "brdf.glsl"

layout(set = 0, binding = 1, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 2, std430) readonly buffer Lights { Light lights[]; };

layout(set = 1, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 1, binding = 1) uniform sampler2D gbufferNormal;
layout(set = 1, binding = 2) uniform sampler2D gbufferMaterial;
#ifdef GBUFFER_ALBEDO
layout(set = 1, binding = 3) uniform sampler2D gbufferAlbedo;
#endif

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    vec3 radiance;
    if (depth <= 0.0) {
        radiance = frame.background.rgb;
    } else {
        vec2 ndc = (vec2(pixel) + 0.5) * frame.viewport.zw * 2.0 - 1.0;
        vec3 ray = frame.forward.xyz + ndc.x * frame.rayRight.xyz + ndc.y * frame.rayUp.xyz;
        vec3 p = frame.position.xyz + depth * ray;
        vec3 v = -normalize(ray);
        vec3 n = octDecode(texelFetch(gbufferNormal, pixel, 0).rg);
        vec4 packed = texelFetch(gbufferMaterial, pixel, 0);
        Material m = materials[unpackMaterialIndex(packed)];
#ifdef GBUFFER_ALBEDO
        vec3 baseColor = texelFetch(gbufferAlbedo, pixel, 0).rgb;
#else
        vec3 baseColor = m.baseColor.rgb;
#endif
        float metallic = m.emissiveMetal.w;
        float roughness = m.params.x;
        float shadow = packed.b;
        float ao = packed.a;
        radiance = frame.ambient.rgb * baseColor * ao + m.emissiveMetal.rgb;
        for (uint i = 0u; i < frame.params.x; ++i) {
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
            radiance += shadow * shadeLight(frame.params.y, n, v, l, incoming, baseColor, metallic, roughness);
        }
    }
    vec3 mapped = toneMap(frame.params.z, radiance * frame.ambient.w);
    outColor = vec4(frame.params.w != 0u ? mapped : srgbEncode(mapped), 1.0);
}
