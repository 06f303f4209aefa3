// What the SDF effect passes share (renderer/features/effects.h): the low- to full-resolution pixel
// convention and the surface of a G-buffer pixel. Include after view.glsl (scene.glsl) and
// gbuffer.glsl.
#ifndef PENUMBRA_EFFECTS_GLSL
#define PENUMBRA_EFFECTS_GLSL

// The full-resolution pixel whose G-buffer a low-resolution pixel `low` of a `lowSize` target reads:
// the one containing the low-resolution pixel's centre.
ivec2 effectsFullPixel(ivec2 low, ivec2 lowSize, ivec2 fullSize) {
    vec2 centre = (vec2(low) + 0.5) * vec2(fullSize) / vec2(lowSize);
    return min(ivec2(centre), fullSize - 1);
}

// The camera ray through a full-resolution pixel centre (moved by the TAA jitter, the trace's ray);
// its parameter is the linear view depth.
vec3 effectsPixelRay(ivec2 pixel) {
    vec2 ndc = (vec2(pixel) + 0.5 + view.jitter.xy) * view.viewport.zw * 2.0 - 1.0;
    return view.forward.xyz + ndc.x * view.rayRight.xyz + ndc.y * view.rayUp.xyz;
}

// World position of a full-resolution pixel at linear depth `depth`.
vec3 effectsWorldPosition(ivec2 pixel, float depth) { return view.position.xyz + depth * effectsPixelRay(pixel); }

#endif
