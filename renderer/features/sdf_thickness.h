// Feature "sdf_thickness": the compute pass "sdf_thickness" (renderer/features/effects.h orders the
// effects; renderer/shaders/sdf_thickness.comp describes the algorithm). Full resolution: for each
// pixel whose material has a subsurface colour (GpuMaterial::subsurface.rgb > 0, radius > 0) it
// marches from the surface point along -n through the solid of the SDF object the point lies on to
// the far side (mTec thesis 7.4 and 8.2.3; the 004_ blog traces through the object the same way) and
// writes the distance, in scene units, to Effects::thickness (R16_FLOAT); every other pixel gets 0.
//
// - The object is the one whose surface the point lies on, among every SDF object of the frame
//   (occluder-only mesh fields too, so a rasterized mesh with an occlusion field gets a thickness;
//   a mesh without one gets 0).
// - Only the first exit counts: a concave object seen where the ray leaves and re-enters it (mTec's
//   "hollow objects" extension) measures the first solid part.
// - Cap: kThicknessCapRadii (8) subsurface radii (scene::Material::subsurfaceRadius): beyond it the
//   lighting's transmission exp(-thickness / radius) is below exp(-8) = 3.4e-4, i.e. opaque (the
//   per-object "maximum thickness" of mTec 8.2.3). Step limit kThicknessSteps (64).
// - Precision: the march ends within eps = hitEpsilon / 10 pixel footprints at the surface point
//   (the primary trace refines its hits to that), plus R16F rounding (2^-11 relative).
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

inline constexpr float kThicknessCapRadii = 8.0f;
inline constexpr uint32_t kThicknessSteps = 64;

// Adds the pass. Reads SceneBuffers (view, materials), SdfSceneBuffers and the GBuffer (depth,
// normal, material); writes Effects::thickness.
void addSdfThickness(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
