// taa, fragment stage: temporal anti-aliasing (renderer/features/taa.h). Per pixel: the 3x3
// neighbourhood of this frame's linear colour in YCoCg, widened by the previous frame's raw samples
// at the reprojected point (the box clips the history, Karis 2014; the PlayDead TAA mTec 8.2.11
// ports), the motion of the nearest surface in that neighbourhood
// (gbuffer.velocity is current - previous in jittered pixels: adding this frame's jitter and
// removing the previous one's gives the surface's motion; background: the camera's rotation), the
// history resampled there (bilinear: on the TAA test path it gave a lower error than Catmull-Rom,
// whose ringing the high-contrast edges keep), history rejection on disocclusion (the surface's
// expected previous depth outside the range of the history depths around the reprojected point),
// and Wright 2015's unstable pixels: a rejected pixel is filled with its blurred surroundings (a 3x3
// tent of this frame) instead of its aliased sample. Outputs: rgb the resolved colour, a this
// pixel's linear depth (0 = background) for the next frame's rejection test; this frame's raw sample.
#version 450
#include "view.glsl"

layout(set = 2, binding = 0) uniform sampler2D sceneColor;
layout(set = 2, binding = 1) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 2) uniform sampler2D gbufferVelocity;
layout(set = 2, binding = 3) uniform sampler2D history;  // bilinear, clamped
layout(set = 2, binding = 4) uniform sampler2D rawHistory;  // the previous frame's raw samples (rgb)

layout(push_constant) uniform Taa {
    // x 1 = the history is valid, y weight of this frame (still surface), z relative depth tolerance,
    // w weight of this frame for a surface moving kTaaFullMotion pixels per frame or more
    vec4 params;
} taa;

// From this motion (pixels per frame) on, this frame gets weight params.w: the history, resampled
// bilinearly at a fractional offset each frame, blurs and trails where thin surfaces move against
// what lies behind them (their mixed pixels have no single motion); a still surface keeps params.y.
const float kTaaFullMotion = 0.25;

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;
layout(location = 1) out vec4 outRaw;  // rgb this frame's raw sample, the next frame's rawHistory

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

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    ivec2 size = ivec2(view.viewport.xy);
    vec3 current = texelFetch(sceneColor, pixel, 0).rgb;
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    outRaw = vec4(current, 0.0);

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

    vec2 motion = texelFetch(gbufferVelocity, nearestPixel, 0).rg;
    if (nearest > 1.0e38) {
        // Only background around: gbuffer.velocity holds 0 there; the background is at infinity,
        // it moves with the camera's rotation only (a direction through the previous camera).
        vec2 ndc = (vec2(pixel) + 0.5 + view.jitter.xy) * view.viewport.zw * 2.0 - 1.0;
        vec4 prevClip = view.prevViewProj * vec4(view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz, 0.0);
        motion = prevClip.w > 1e-6 ? vec2(pixel) + 0.5 - (prevClip.xy / prevClip.w * 0.5 + 0.5) * view.viewport.xy : vec2(0.0);
    }
    motion += view.jitter.xy - view.jitter.zw;
    vec2 prev = vec2(pixel) + 0.5 - motion;
    bool valid = taa.params.x > 0.5 && all(greaterThanEqual(prev, vec2(0.0))) && all(lessThan(prev, view.viewport.xy));
    if (!valid) {
        outColor = vec4(taa.params.x > 0.5 ? blurred : current, depth);
        return;
    }
    // Disocclusion: the depth this surface had in the previous frame (its point reprojected with the
    // previous camera; object motion is lateral enough within one frame) against the history's.
    float expected = 0.0;
    if (depth > 0.0) {
        vec2 ndc = (vec2(pixel) + 0.5 + view.jitter.xy) * view.viewport.zw * 2.0 - 1.0;
        vec3 p = view.position.xyz + depth * (view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz);
        expected = (view.prevViewProj * vec4(p, 1.0)).w;
    }
    // The history's depths around the reprojected point: a surface point (a plane seen at a grazing
    // angle changes depth fast from texel to texel) lies within their range, or the background
    // finds background there; otherwise the surface was hidden (or elsewhere) in the previous frame.
    float hmin = 3.0e38, hmax = 0.0;
    bool background = false;
    ivec2 hp = ivec2(floor(prev));
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            float h = texelFetch(history, clamp(hp + ivec2(dx, dy), ivec2(0), size - 1), 0).a;
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
        outColor = vec4(blurred, depth);  // unstable: the blurred surroundings (Wright 2015)
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
    vec3 h = fromYCoCg(clipToBox(lo, hi, toYCoCg(texture(history, prev / view.viewport.xy).rgb)));
    float weight = mix(taa.params.y, taa.params.w, clamp(length(motion) / kTaaFullMotion, 0.0, 1.0));
    outColor = vec4(mix(h, current, weight), depth);
}
