// effects_upsample: depth- and normal-aware (joint bilateral, Kopf et al. 2007) upsampling of the
// low-resolution shadow layers and AO (renderer/features/effects_upsample.h documents the weights).
// One invocation per full-resolution pixel p with linear depth d and normal n:
//  1. q = the pixel centre in low-resolution pixel coordinates; the 3x3 low-resolution pixels
//     around the nearest one are the candidates; each low-resolution pixel i stands for the
//     G-buffer of its full-resolution source pixel (effects.glsl effectsFullPixel): depth d_i,
//     normal n_i;
//  2. weight w_i = bilinear(q, i) * depthWeight * normalWeight, where bilinear is the usual tent
//     (non-zero for the 2x2 pixels around q only), normalWeight = max(dot(n, n_i), 0)^kNormalPower
//     and depthWeight = exp(-(r / kDepthSigma)^2) with r the relative depth difference: the smaller
//     of |d_i - d| / d and |d_i - d_plane| / d, d_plane being the depth where the source pixel's
//     camera ray meets the tangent plane of p (so slanted surfaces, whose depth changes fast from
//     pixel to pixel, keep their neighbours);
//  3. the edge value: among the 3x3 candidates whose normal faces the same way as n (dot > 0.5;
//     all of them when none does) the ones nearest in depth, by a soft minimum of the depth gaps
//     g_i = |d_i - d|: weights exp(-((g_i - min g) / (kTieSigma d))^2), so candidates whose gaps tie
//     within the trace's last digits (two floor pixels of one row) share the value instead of one
//     winning by the last bit of its depth. When the step-2 weights sum to less than kMinWeight (no
//     similar pixel among the bilinear four: an edge) the result moves linearly from the bilateral
//     average (at kMinWeight) to the edge value (at 0), so no pixel switches between them abruptly;
//  4. background pixels (d = 0): shadow 1, AO 1 with a zero bent normal (0.5, 0.5, 0.5).
// The same weights serve every shadow layer (the geometry is the same). Variants SHADOW and AO
// say which low-resolution parts exist.
#version 450
#pragma penumbra_variants SHADOW AO SHADOW+AO
layout(local_size_x = 8, local_size_y = 8) in;

#include "scene.glsl"
#include "gbuffer.glsl"
#include "effects.glsl"

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1) uniform sampler2D gbufferNormal;
#ifdef SHADOW
layout(set = 2, binding = 2, r8) uniform readonly image2D lowShadowImage;
layout(set = 2, binding = 3, r8) uniform writeonly image2D shadowImage;
#endif
#ifdef AO
layout(set = 2, binding = 4, rgba8) uniform readonly image2D lowAoImage;
layout(set = 2, binding = 5, rgba8) uniform writeonly image2D aoImage;
#endif

layout(push_constant) uniform EffectsUpsample {
    uvec4 sizes;  // x, y the low-resolution shadow size (one layer), z, w the low-resolution AO size
    uvec4 frame;  // x, y the full-resolution size, z shadow layers
} upsample;

const float kDepthSigma = 0.02;  // relative depth difference with weight exp(-1)
const float kNormalPower = 8.0;  // 30 degrees apart: 0.32, 60 degrees: 0.004
const float kMinWeight = 1e-3;   // below this sum no bilinear neighbour is similar: an edge
const float kTieSigma = 2e-3;    // step 3: relative depth gap (beyond the nearest) with weight exp(-1)

struct Taps {
    ivec2 origin;     // the low-resolution pixel of candidate 0 (the 3x3's top-left)
    float weight[9];  // normalized weights of the 3x3 (step 2 blended with step 3's)
};

// The relative depth difference of a source pixel to this pixel's surface (step 2 above).
float depthDifference(ivec2 src, float srcDepth, float depth, vec3 normal, vec3 position) {
    float plain = abs(srcDepth - depth) / depth;
    vec3 ray = effectsPixelRay(src);
    float facing = dot(normal, ray);
    if (abs(facing) < 1e-4) return plain;
    float planeDepth = dot(normal, position - view.position.xyz) / facing;
    return planeDepth > 0.0 ? min(plain, abs(srcDepth - planeDepth) / depth) : plain;
}

Taps computeTaps(ivec2 pixel, ivec2 lowSize, ivec2 fullSize, float depth, vec3 normal) {
    vec2 q = (vec2(pixel) + 0.5) * vec2(lowSize) / vec2(fullSize) - 0.5;
    ivec2 nearest = ivec2(floor(q + 0.5));
    Taps taps;
    taps.origin = nearest - 1;
    vec3 position = effectsWorldPosition(pixel, depth);
    float total = 0.0;
    float gap[9];  // |d_i - d| for step 3; negative: a background source (never similar)
    bool facingSame[9];
    bool anyFacing = false;
    for (int k = 0; k < 9; ++k) {
        ivec2 low = clamp(taps.origin + ivec2(k % 3, k / 3), ivec2(0), lowSize - 1);
        ivec2 src = effectsFullPixel(low, lowSize, fullSize);
        float d = texelFetch(gbufferDepth, src, 0).r;
        vec2 t = max(1.0 - abs(q - vec2(taps.origin + ivec2(k % 3, k / 3))), 0.0);
        taps.weight[k] = 0.0;
        gap[k] = -1.0;
        facingSame[k] = false;
        if (d <= 0.0) continue;  // a background source: never similar
        float facing = dot(normal, octDecode(texelFetch(gbufferNormal, src, 0).rg));
        float r = depthDifference(src, d, depth, normal, position);
        float w = t.x * t.y * exp(-(r * r) / (kDepthSigma * kDepthSigma)) * pow(max(facing, 0.0), kNormalPower);
        taps.weight[k] = w;
        total += w;
        gap[k] = abs(d - depth);
        facingSame[k] = facing > 0.5;
        anyFacing = anyFacing || facingSame[k];
    }
    // Step 3, the edge value: the candidates of the class (facing the same way, or all when none
    // does) nearest in depth, by a soft minimum over the depth gaps (kTieSigma): candidates whose
    // gaps tie within the root search's last digits (e.g. two floor pixels of one row) share the
    // value instead of one winning by the last bit of its depth.
    float gapMin = 3.0e38;
    for (int k = 0; k < 9; ++k)
        if (gap[k] >= 0.0 && facingSame[k] == anyFacing) gapMin = min(gapMin, gap[k]);
    float edge[9];
    float edgeTotal = 0.0;
    for (int k = 0; k < 9; ++k) {
        float x = (gap[k] - gapMin) / (kTieSigma * depth);
        edge[k] = gap[k] >= 0.0 && facingSame[k] == anyFacing ? exp(-x * x) : 0.0;
        edgeTotal += edge[k];
    }
    if (edgeTotal <= 0.0) {  // every source is background: the centre candidate
        edge[4] = 1.0;
        edgeTotal = 1.0;
    }
    // Below kMinWeight the bilateral average hands over to the edge value linearly, so a pixel
    // whose similar neighbours fade out does not jump from one to the other.
    float blend = min(total / kMinWeight, 1.0);
    for (int k = 0; k < 9; ++k)
        taps.weight[k] = (total > 0.0 ? blend * (taps.weight[k] / total) : 0.0) + (1.0 - blend) * (edge[k] / edgeTotal);
    return taps;
}

// The low-resolution pixel of candidate k, clamped to the target (layer offset added by the caller).
ivec2 tapPixel(Taps taps, int k, ivec2 lowSize) {
    return clamp(taps.origin + ivec2(k % 3, k / 3), ivec2(0), lowSize - 1);
}

#ifdef SHADOW
void upsampleShadow(ivec2 pixel, ivec2 fullSize, float depth, vec3 normal) {
    ivec2 lowSize = ivec2(upsample.sizes.xy);
    uint layers = upsample.frame.z;
    if (depth <= 0.0) {
        for (uint l = 0u; l < layers; ++l) imageStore(shadowImage, pixel + ivec2(int(l) * fullSize.x, 0), vec4(1.0));
        return;
    }
    Taps taps = computeTaps(pixel, lowSize, fullSize, depth, normal);
    for (uint l = 0u; l < layers; ++l) {
        ivec2 layer = ivec2(int(l) * lowSize.x, 0);
        float value = 0.0;
        for (int k = 0; k < 9; ++k)
            if (taps.weight[k] > 0.0)
                value += taps.weight[k] * imageLoad(lowShadowImage, tapPixel(taps, k, lowSize) + layer).r;
        imageStore(shadowImage, pixel + ivec2(int(l) * fullSize.x, 0), vec4(value));
    }
}
#endif

#ifdef AO
// AO and the bent normal are averaged as stored (the bent normal encoded * 0.5 + 0.5) and the bent
// normal is renormalized: the lighting pass normalizes it anyway, and a unit vector keeps the AOV's
// convention.
void upsampleAo(ivec2 pixel, ivec2 fullSize, float depth, vec3 normal) {
    if (depth <= 0.0) {
        imageStore(aoImage, pixel, vec4(1.0, 0.5, 0.5, 0.5));
        return;
    }
    ivec2 lowSize = ivec2(upsample.sizes.zw);
    Taps taps = computeTaps(pixel, lowSize, fullSize, depth, normal);
    vec4 value = vec4(0.0);
    for (int k = 0; k < 9; ++k)
        if (taps.weight[k] > 0.0) value += taps.weight[k] * imageLoad(lowAoImage, tapPixel(taps, k, lowSize));
    vec3 bent = value.gba * 2.0 - 1.0;
    bent = dot(bent, bent) > 1e-8 ? normalize(bent) : normal;
    imageStore(aoImage, pixel, vec4(value.r, bent * 0.5 + 0.5));
}
#endif

void main() {
    ivec2 fullSize = ivec2(upsample.frame.xy);
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, fullSize))) return;
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    vec3 normal = depth > 0.0 ? octDecode(texelFetch(gbufferNormal, pixel, 0).rg) : vec3(0.0, 0.0, 1.0);
#ifdef SHADOW
    upsampleShadow(pixel, fullSize, depth, normal);
#endif
#ifdef AO
    upsampleAo(pixel, fullSize, depth, normal);
#endif
}
