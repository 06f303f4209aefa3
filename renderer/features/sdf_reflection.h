// Feature "sdf_reflection": the compute pass "sdf_reflection" (renderer/features/effects.h orders the
// effects; renderer/shaders/sdf_reflection.comp describes the algorithm). Full resolution: for each
// pixel whose material asks for reflections (scene::Material::reflections with roughness at most
// ReflectionSettings::roughnessCutoff: the MATERIAL_REFLECTIONS flag) it mirrors the view ray about
// the G-buffer normal, sphere-traces every SDF object of the frame (mTec thesis 7.5), shades the hit
// with the scene's lights as the lighting pass does, and writes to Effects::reflection (RGBA16_FLOAT)
//   rgb = reflected radiance * Schlick Fresnel (F0 = mix(0.04, baseColor, metallic)) * fade,
//   a   = fade = 1 - smoothstep(0, roughnessCutoff, roughness)   (0 at the cut-off; 0: no reflection)
// which the lighting pass adds to the pixel's radiance.
//
// Settings: ReflectionSettings::maxSteps (resolved by quality: 32/64/128/1024), ShadowSettings (hard,
// maxSteps) for the shadows at the hit, the frame's trace
// hitEpsilon / normalEpsilon / fieldSafety (scene::TraceSettings), rays up to the far plane.
//
// What a reflection shows and what it lacks:
// - SDF objects and occluder-only mesh fields (--mesh-sdf occlusion): meshes are reflected through
//   their baked fields. Rasterized-only meshes (no SDF) are absent from mirror reflections.
// - The hit's material is its constant baseColor / metallic / roughness / emissive: no textures.
// - Reflected hits are shadowed for the lights the frame shadows, by the shadow pass's cone trace
//   (renderer/shaders/sdf_cone.glsl; ShadowSettings hard / maxSteps), per reflected pixel at full
//   resolution; no AO at the hit; a miss sees the background radiance.
// - One sharp ray per pixel even for rough materials (the fade hides the error as roughness grows);
//   the lighting still adds its ambient term, so reflective pixels count the ambient's specular part
//   twice (small with the usual ambient levels).
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

// Adds the pass. Reads SceneBuffers (view, scene constants, materials, lights), SdfSceneBuffers and
// the GBuffer (depth, normal, material); writes Effects::reflection.
void addSdfReflection(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
