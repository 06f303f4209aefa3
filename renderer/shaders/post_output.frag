// post_output, fragment stage: the frame's linear (tone-mapped) colour into the output, sRGB-encoded
// as lighting encodes it (linear for a hardware-sRGB target). Variant MOTION_BLUR first gathers
// along the largest motion of the pixel's 3x3 velocity tiles (motion_blur_tiles.comp): McGuire et
// al. 2012's reconstruction filter, simplified: a tap in front of the pixel counts where its own
// motion covers the distance, a tap behind where the pixel's does (renderer/features/post_output.h).
#version 450
#pragma penumbra_variants MOTION_BLUR
#include "scene.glsl"
#include "brdf.glsl"  // srgbEncode

layout(set = 2, binding = 0) uniform sampler2D sceneColor;
#ifdef MOTION_BLUR
layout(set = 2, binding = 1) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 2) uniform sampler2D gbufferVelocity;
layout(set = 2, binding = 3) uniform sampler2D velocityTiles;  // RG: the tile's largest motion (pixels)
#endif

layout(push_constant) uniform PostOutput {
    // x 1 = write linear (hardware sRGB target), y motion blur taps, z tile size, w 1 = sceneColor is
    // at twice the resolution (TAA's history; a bilinear sampler: a pixel is its 2x2 texels' mean)
    uvec4 params;
    vec4 blur;     // x strength (fraction of the frame's motion)
} post;

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

vec3 sceneAt(ivec2 q) {
    return post.params.w != 0u ? texture(sceneColor, (vec2(q) + 0.5) * view.viewport.zw).rgb
                               : texelFetch(sceneColor, q, 0).rgb;
}

#ifdef MOTION_BLUR
vec2 motionAt(ivec2 q) { return texelFetch(gbufferVelocity, q, 0).rg + view.jitter.xy - view.jitter.zw; }
float depthAt(ivec2 q) {
    float d = texelFetch(gbufferDepth, q, 0).r;
    return d > 0.0 ? d : 3.0e38;
}
float cone(float distance, float speed) { return clamp(1.0 - distance / max(speed, 1e-3), 0.0, 1.0); }

vec3 motionBlur(ivec2 pixel) {
    ivec2 size = ivec2(view.viewport.xy);
    ivec2 tile = pixel / int(post.params.z);
    ivec2 tiles = textureSize(velocityTiles, 0);
    vec2 vmax = vec2(0.0);
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            vec2 v = texelFetch(velocityTiles, clamp(tile + ivec2(dx, dy), ivec2(0), tiles - 1), 0).rg;
            if (dot(v, v) > dot(vmax, vmax)) vmax = v;
        }
    vec3 centre = sceneAt(pixel);
    vmax *= post.blur.x;
    if (dot(vmax, vmax) < 0.25) return centre;
    float speedP = length(motionAt(pixel)) * post.blur.x, depthP = depthAt(pixel);
    float total = 1.0 / max(speedP, 1.0);
    vec3 sum = centre * total;
    uint n = post.params.y;
    for (uint i = 0u; i < n; ++i) {
        float t = (float(i) + 0.5) / float(n) - 0.5;  // -0.5..0.5 of the motion
        ivec2 q = clamp(ivec2(vec2(pixel) + 0.5 + t * vmax), ivec2(0), size - 1);
        if (q == pixel) continue;
        float dist = length(t * vmax);
        float speedQ = length(motionAt(q)) * post.blur.x, depthQ = depthAt(q);
        float w = depthQ < depthP ? cone(dist, speedQ) : cone(dist, speedP);
        sum += sceneAt(q) * w;
        total += w;
    }
    return sum / total;
}
#endif

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
#ifdef MOTION_BLUR
    vec3 c = motionBlur(pixel);
#else
    vec3 c = sceneAt(pixel);
#endif
    c = clamp(c, 0.0, 1.0);
    outColor = vec4(post.params.x != 0u ? c : srgbEncode(c), 1.0);
}
