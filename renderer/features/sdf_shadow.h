// Feature "sdf_shadow": the compute pass "sdf_shadow", cone-traced soft shadows through the frame's
// SDF objects (renderer/features/effects.h orders the effects; renderer/shaders/sdf_shadow.comp is
// the pass, renderer/shaders/sdf_cone.glsl the visibility estimate shared with sdf_reflection).
//
// One layer per shadowed light (GpuLight::shadow.x; lights with castShadows false get none and cost
// nothing), dispatched over (lowW, lowH, layers) with lowW = max(1, round(W * resolutionScale)):
//   - directional lights: the cone's half-angle is the light's angular radius;
//   - sphere lights: asin(radius / distance), the sphere's angular radius, up to the sphere;
//   - point lights and ShadowSettings::hard: binary visibility;
// over every SDF object that casts shadows (kSdfObjectCastsShadows: occluder-only mesh fields
// included), with the step limit ShadowSettings::maxSteps (by quality when 0) and the trace's field
// safety. The penumbra comes only from the light's size: the visible fraction of the light's disc
// cut by the nearest occluder edge along the cone (sdf_cone.glsl documents the estimate and its
// bias).
//
// Acceleration (EffectsDesc::acceleration): culling starts each ray's cull from the pixel's tile
// list of its layer (SdfCullLists::shadow, renderer/features/sdf_effects_cull.h); off, every casting
// object is evaluated at every step. worldCache / idField (when SdfWorldCacheView is published): hard
// rays step by the cached world distance where it is at least 4 epsilons (soft cones do not: it
// moves their penumbra samples beyond the parity rule), and the id field's object is evaluated alone
// where it is certain (renderer/shaders/sdf_cone.glsl).
//
// Output: resolutionScale 1 writes Effects::shadow directly; below 1 a transient R8_UNORM strip
// (lowW * layers) x lowH published as EffectsLowRes::shadow for effects_upsample.
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

// Adds the pass for desc.shadowLayers > 0. Reads SceneBuffers (view, scene constants, lights),
// SdfSceneBuffers, GBuffer depth and normal; writes Effects::shadow or a low-resolution transient.
void addSdfShadow(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
