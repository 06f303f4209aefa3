// Feature "effects_upsample": the compute pass "effects_upsample" that brings the low-resolution
// shadow layers and AO (EffectsLowRes, written by sdf_shadow / sdf_ao below full resolution) to the
// frame's resolution (Effects::shadow, Effects::ao) with a depth- and normal-aware bilateral filter
// (renderer/shaders/effects_upsample.comp). renderer/features/effects.h orders it after the modules.
//
// For a full-resolution pixel p (linear depth d, normal n) each of the 3x3 low-resolution pixels
// around p's position on the low-resolution grid stands for its source pixel's G-buffer (d_i, n_i;
// the convention of effectsFullPixel, renderer/shaders/effects.glsl). Its weight is
//   bilinear(p, i) * exp(-(r / 0.02)^2) * max(dot(n, n_i), 0)^8
// with r the relative depth difference min(|d_i - d|, |d_i - d_plane|) / d, d_plane the depth where
// the source pixel's camera ray meets p's tangent plane (slanted surfaces keep their neighbours).
// The bilinear tent makes only the 2x2 around p count; when their weights sum below 1e-3 (p is at
// a depth or normal edge, none of the four lies on its surface) the result fades linearly (by
// sum / 1e-3) into the edge value: that of the 3x3 nearest in depth among those facing within 60
// degrees of n (any if none), a soft minimum (weights exp(-((g_i - min g) / (0.002 d))^2) of the
// depth gaps g_i = |d_i - d|) so that candidates tied in depth to the trace's last digits share the
// value rather than one winning by the last bit (box against full-screen tracing,
// docs/ACCURACY.md). So a value never crosses a depth discontinuity unless no low-resolution pixel
// of the surface lies within 1.5 low-resolution pixels, and no pixel jumps between the two rules.
// Background pixels get shadow 1 and AO 1 with a zero bent normal. The AO texel's bent normal (gba)
// is averaged and renormalized.
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

// Reads SceneBuffers (view), GBuffer (depth, normal), EffectsLowRes; writes Effects::shadow (every
// layer) when EffectsLowRes::shadow is valid and Effects::ao when EffectsLowRes::ao is.
void addEffectsUpsample(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
