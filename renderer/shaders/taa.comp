// taa (compute, one invocation per pixel): temporal anti-aliasing (renderer/features/taa.h) into a
// history of twice the frame's resolution (2x2 texels per pixel). Per pixel: the 3x3 neighbourhood
// of this frame's linear colour in YCoCg, widened by the previous frame's raw samples at the
// reprojected point (the box clips the history, Karis 2014; the PlayDead TAA mTec 8.2.11 ports),
// the motion of the nearest surface in that neighbourhood or, nearer still, of a surface the
// history had there that this frame's samples missed (gbuffer.velocity is current - previous in
// jittered pixels: adding this frame's jitter and removing the previous one's gives the surface's
// motion; background: the camera's rotation), history rejection on disocclusion (the surface's
// expected previous depth outside the range of the history depths around the reprojected point),
// and Wright 2015's unstable pixels: a rejected pixel is filled with its blurred surroundings (a 3x3
// tent of this frame) instead of its aliased sample. Per texel: the history resampled bilinearly
// at the texel's reprojected centre (a half-pixel texel blurs a line moving by a fraction of a
// pixel a quarter as much as a pixel-sized one), clipped, and updated by this frame's sample with
// the texel's bilinear share of it (where the jitter put it), so a still camera's texels average
// the samples that fell near them and a pixel (the mean of its texels, post_output.frag) their box
// filter. Writes rgb the resolved colour and a the pixel's linear depth (0 = background: the next
// frame's rejection test and motion), and the raw sample (the next frame's rawHistory).
#version 450
layout(local_size_x = 8, local_size_y = 8) in;
#include "view.glsl"

layout(set = 2, binding = 0) uniform sampler2D sceneColor;
layout(set = 2, binding = 1) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 2) uniform sampler2D gbufferVelocity;
layout(set = 2, binding = 3) uniform sampler2D history;     // 2x the frame's size; bilinear, clamped
layout(set = 2, binding = 4) uniform sampler2D rawHistory;  // the previous frame's raw samples (rgb)
layout(set = 2, binding = 5, rgba16f) uniform writeonly image2D historyOut;  // 2x
layout(set = 2, binding = 6, rgba16f) uniform writeonly image2D rawOut;      // 1x

layout(push_constant) uniform Taa {
    // x 1 = the history is valid, y weight of this frame (still surface), z relative depth tolerance,
    // w weight of this frame for a surface moving kTaaFullMotion pixels per frame or more
    vec4 params;
} taa;

// From this motion (pixels per frame) on, this frame gets weight params.w: the history, resampled
// bilinearly at a fractional offset each frame, blurs and trails where thin surfaces move against
// what lies behind them (their mixed pixels have no single motion); a still surface keeps params.y.
const float kTaaFullMotion = 0.25;
// This frame's weight in a texel is min(1, kTaaShareScale x weight x its share of the sample): the
// four shares sum to 1, so a pixel's texels take on average the pixel's weight.
const float kTaaShareScale = 4.0;

vec3 toYCoCg(vec3 c) {
    return vec3(0.25 * c.r + 0.5 * c.g + 0.25 * c.b, 0.5 * c.r - 0.5 * c.b, -0.25 * c.r + 0.5 * c.g - 0.25 * c.b);
}
vec3 fromYCoCg(vec3 c) {
    float t = c.x - c.z;
    return vec3(t + c.y, c.x + c.z, t - c.y);
}

// Clips h toward the centre of the box [lo, hi] onto its surface (inside: unchanged).
vec3 clipToBox(vec3 lo, vec3 hi, vec3 h) {
    vec3 c = 0.5 * (lo + hi), e = 0.5 * (hi - lo) + 1e-6;
    vec3 d = h - c;
    vec3 a = abs(d) / e;
    float m = max(a.x, max(a.y, a.z));
    return m > 1.0 ? c + d / m : h;
}

// The motion (pixels, current - previous) of what pixel's ray sees, given its previous clip position.
vec2 motionFrom(ivec2 pixel, vec4 prevClip) {
    return prevClip.w > 1e-6 ? vec2(pixel) + 0.5 - (prevClip.xy / prevClip.w * 0.5 + 0.5) * view.viewport.xy : vec2(0.0);
}

// Writes the pixel's four texels with `c` (and its depth), and its raw sample.
void store(ivec2 pixel, vec3 c, float depth, vec3 raw) {
    for (int j = 0; j <= 1; ++j)
        for (int i = 0; i <= 1; ++i) imageStore(historyOut, 2 * pixel + ivec2(i, j), vec4(c, depth));
    imageStore(rawOut, pixel, vec4(raw, 0.0));
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(view.viewport.xy);
    if (pixel.x >= size.x || pixel.y >= size.y) return;
    vec3 current = texelFetch(sceneColor, pixel, 0).rgb;
    float depth = texelFetch(gbufferDepth, pixel, 0).r;

    vec3 lo = vec3(3.0e38), hi = vec3(-3.0e38), blurred = vec3(0.0);
    float nearest = 3.0e38;
    ivec2 nearestPixel = pixel;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = clamp(pixel + ivec2(dx, dy), ivec2(0), size - 1);
            vec3 c = texelFetch(sceneColor, q, 0).rgb;
            vec3 y = toYCoCg(c);
            lo = min(lo, y);
            hi = max(hi, y);
            blurred += c * float((dx == 0 ? 2 : 1) * (dy == 0 ? 2 : 1));
            float d = texelFetch(gbufferDepth, q, 0).r;
            if (d > 0.0 && d < nearest) {
                nearest = d;
                nearestPixel = q;
            }
        }
    }
    blurred *= 1.0 / 16.0;
    if (taa.params.x < 0.5) {  // no history: this frame's sample
        store(pixel, current, depth, current);
        return;
    }

    vec2 ndc = (vec2(pixel) + 0.5 + view.jitter.xy) * view.viewport.zw * 2.0 - 1.0;
    vec3 ray = view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz;
    vec2 motion = texelFetch(gbufferVelocity, nearestPixel, 0).rg;
    if (nearest > 1.0e38) {
        // Only background around: gbuffer.velocity holds 0 there; the background is at infinity,
        // it moves with the camera's rotation only (a direction through the previous camera).
        vec4 prevClip = view.prevViewProj * vec4(ray, 0.0);
        motion = motionFrom(pixel, prevClip);
    }
    // A surface the history had around this pixel (the four texels of a pixel hold its depth)
    // nearer than any this frame's samples hit: a surface thinner than a pixel that the jitter
    // missed this time. It moves as a static point at its depth would; taking the nearest current
    // surface's motion (or the background's) instead left its history behind.
    float hn = 3.0e38;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            float h = texelFetch(history, 2 * clamp(pixel + ivec2(dx, dy), ivec2(0), size - 1), 0).a;
            if (h > 0.0) hn = min(hn, h);
        }
    }
    if (hn < nearest * (1.0 - taa.params.z)) {
        vec4 prevClip = view.prevViewProj * vec4(view.position.xyz + hn * ray, 1.0);
        motion = motionFrom(pixel, prevClip);
    }
    motion += view.jitter.xy - view.jitter.zw;
    vec2 prev = vec2(pixel) + 0.5 - motion;
    if (any(lessThan(prev, vec2(0.0))) || any(greaterThanEqual(prev, view.viewport.xy))) {
        store(pixel, blurred, depth, current);  // came from outside the frame
        return;
    }
    // Disocclusion: the depth this surface had in the previous frame (its point reprojected with the
    // previous camera; object motion is lateral enough within one frame) against the history's.
    float expected = depth > 0.0 ? (view.prevViewProj * vec4(view.position.xyz + depth * ray, 1.0)).w : 0.0;
    // The history's depths around the reprojected point (one texel per pixel): a surface point (a
    // plane seen at a grazing angle changes depth fast from pixel to pixel) lies within their
    // range, or the background finds background there; otherwise the surface was hidden (or
    // elsewhere) in the previous frame.
    float hmin = 3.0e38, hmax = 0.0;
    bool background = false;
    ivec2 hp = ivec2(floor(prev));
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            float h = texelFetch(history, 2 * clamp(hp + ivec2(dx, dy), ivec2(0), size - 1), 0).a;
            background = background || h <= 0.0;
            if (h > 0.0) {
                hmin = min(hmin, h);
                hmax = max(hmax, h);
            }
        }
    }
    bool match = depth <= 0.0 ? background
                              : expected >= hmin * (1.0 - taa.params.z) && expected <= hmax * (1.0 + taa.params.z);
    if (!match) {
        store(pixel, blurred, depth, current);  // unstable: the blurred surroundings (Wright 2015)
        return;
    }
    // The previous frame's raw samples around the reprojected point (its bilinear footprint) widen
    // the box: a surface thinner than a pixel that this frame's jittered samples all missed, but the
    // previous frame's hit, keeps its history instead of being clipped to what lies behind it.
    ivec2 r0 = ivec2(floor(prev - 0.5));
    for (int dy = 0; dy <= 1; ++dy) {
        for (int dx = 0; dx <= 1; ++dx) {
            vec3 y = toYCoCg(texelFetch(rawHistory, clamp(r0 + ivec2(dx, dy), ivec2(0), size - 1), 0).rgb);
            lo = min(lo, y);
            hi = max(hi, y);
        }
    }
    float weight = mix(taa.params.y, taa.params.w, clamp(length(motion) / kTaaFullMotion, 0.0, 1.0));
    // This frame's sample lies at pixel + 0.5 + jitter: its share of a texel is the bilinear weight
    // between the pixel's four texel centres (a partition of unity over the four).
    vec2 s = clamp(view.jitter.xy, -0.25, 0.25);
    for (int j = 0; j <= 1; ++j) {
        for (int i = 0; i <= 1; ++i) {
            vec2 t = vec2(i, j) * 0.5 - 0.25;  // the texel's centre from the pixel's
            vec2 w2 = clamp(1.0 - abs(s - t) * 2.0, 0.0, 1.0);
            vec2 at = vec2(pixel) + 0.5 + t - motion;
            vec3 h = fromYCoCg(clipToBox(lo, hi, toYCoCg(textureLod(history, at / view.viewport.xy, 0.0).rgb)));
            vec3 c = mix(h, current, min(1.0, kTaaShareScale * weight * w2.x * w2.y));
            imageStore(historyOut, 2 * pixel + ivec2(i, j), vec4(c, depth));
        }
    }
    imageStore(rawOut, pixel, vec4(current, 0.0));
}
