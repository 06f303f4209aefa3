#version 450
// RHI demo, pass 4: deferred shading of the G-buffer: Lambert + ambient, sphere-traced soft
// shadows through the analytic scene, sky gradient, Reinhard tone map and sRGB encoding.
#include "demo_common.glsl"

layout(set = 1, binding = 0) uniform sampler2D gbufNormal;
layout(set = 1, binding = 1) uniform sampler2D gbufDepth;
layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

float softShadow(vec3 ro, vec3 rd, float k) {
    float res = 1.0;
    float t = 0.02;
    for (int i = 0; i < 64 && t < 20.0; ++i) {
        float h = sceneSdf(ro + rd * t);
        if (h < 1e-4) return 0.0;
        res = min(res, k * h / t);
        t += clamp(h, 0.01, 0.5);
    }
    return clamp(res, 0.0, 1.0);
}

vec3 linearToSrgb(vec3 c) {
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 gn = texelFetch(gbufNormal, pixel, 0);
    float viewDepth = texelFetch(gbufDepth, pixel, 0).r;
    vec3 rd = cameraRay(vec2(pixel));
    vec3 color;
    if (viewDepth <= 0.0) {
        color = mix(vec3(0.55, 0.62, 0.70), vec3(0.18, 0.30, 0.55), clamp(rd.y * 1.5, 0.0, 1.0));
    } else {
        vec3 n = normalize(gn.xyz);
        int materialId = int(gn.w + 0.5);
        vec3 albedo = materials[materialId].albedo.rgb;
        vec3 p = cam.position.xyz + rd * (viewDepth / dot(rd, cam.forward.xyz));
        vec3 l = cam.lightDir.xyz;
        float ndl = max(dot(n, l), 0.0);
        float shadow = ndl > 0.0 ? softShadow(p + n * 2e-3, l, 10.0) : 0.0;
        float sky = 0.5 + 0.5 * n.y;
        color = albedo * (cam.lightDir.w * ndl * shadow + 0.25 * sky);
    }
    color = color / (1.0 + color);
    outColor = vec4(linearToSrgb(color), 1.0);
}
