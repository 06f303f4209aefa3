// Feature "sdf_ao": the compute pass "sdf_ao" — ambient occlusion and a bent normal from the frame's
// SDF objects (renderer/features/effects.h orders the effects; renderer/shaders/sdf_ao.comp holds
// the algorithms). Three variants (scene::AoVariant, chosen per scene):
//   five-tap   5 distance taps along the normal at maxDistance * k / 5 (Evans, Quilez), weights
//              2^-(k-1), occlusion = sum w_k clamp(t_k - d_k, 0, t_k) / sum w_k t_k; no bent normal
//              (writes the shading normal)
//   multi-ray  the five-tap along each of AoSettings::rays spherical-Fibonacci directions over the
//              cosine-weighted hemisphere (mTec's hybrid), taps compared with the distance an open
//              tangent plane would give; at trace quality "reference" each direction is instead
//              sphere-traced to a binary hit / miss within maxDistance (the ray-traced AO, 1024 rays);
//              bent normal = the mean unoccluded direction
//   cones      9 cones of half-angle 25 deg, each 1/9 of the cosine weight, visibility = min of
//              d / (t tan 25 deg) along the axis (Wright); bent normal = visibility-weighted axes
// Occluders: every object with kSdfObjectCastsShadows (occluder-only mesh fields included) whose
// bounds box is within maxDistance of the point (the influence radius); the candidates come from the
// pixel's AO tile list (SdfCullLists::ao) with acceleration.culling, every object otherwise (culling
// off: every casting object evaluated at every step, those beyond the radius then ignored). With the
// world cache a cached distance >= maxDistance is used without evaluating objects, with the id field
// the cell's certain object alone. AO = 1 - strength * occlusion.
//
// Resolution: (max(1, round(W * s)), max(1, round(H * s))), s = AoSettings::resolutionScale. At
// s = 1 the pass writes Effects::ao; below, a transient RGBA8 target published in EffectsLowRes for
// effects_upsample. Background pixels get AO 1 and the zero normal.
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

// Adds the pass. Reads SceneBuffers (view), SdfSceneBuffers and the GBuffer's depth and normal;
// writes Effects::ao or (resolution scale < 1) a new EffectsLowRes::ao.
void addSdfAo(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
