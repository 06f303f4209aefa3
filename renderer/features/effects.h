// The SDF effects of a frame, after the G-buffer is complete and before lighting (mTec thesis 8.2.5
// - 8.2.10, Wright's DFAO and distance-field shadows): each effect is its own feature module, and
// addEffects() only orders them:
//
//   sdf_shadow       (compute)  cone-traced soft shadows, one layer per shadowed light, at
//                               ShadowSettings::resolutionScale of the frame   -> EffectsLowRes::shadow
//   sdf_ao           (compute)  ambient occlusion (five-tap | multi-ray | cones with bent normal) at
//                               AoSettings::resolutionScale                    -> EffectsLowRes::ao
//   sdf_thickness    (compute)  subsurface thickness, traced through the object, full resolution,
//                               pixels whose material has subsurface > 0       -> Effects::thickness
//   sdf_reflection   (compute)  one traced, shaded reflection bounce, full resolution, pixels whose
//                               material asks for reflections                  -> Effects::reflection
//   effects_upsample (compute)  depth- and normal-aware bilateral upsampling of the low-resolution
//                               shadow and AO layers                           -> Effects::shadow, ::ao
//
// Only what the frame needs runs: no shadowed light (or shadows off) -> no sdf_shadow pass and no
// shadow targets; AO off -> no AO targets; no subsurface / reflective material -> no thickness /
// reflection pass. The lighting pass reads Effects (renderer/shaders/deferred_lighting.frag).
//
// A module whose resolution scale is 1 writes its Effects target directly (nothing to upsample);
// below 1 it writes its EffectsLowRes target and effects_upsample fills the Effects one.
//
// Low- to full-resolution convention (renderer/shaders/effects.glsl, effectsFullPixel): a
// low-resolution pixel (x, y) of a w x h target computes the full-resolution pixel that contains its
// centre, floor((x + 0.5) * W / w), and reads that pixel's G-buffer depth and normal; the
// upsampling weighs the low-resolution neighbours by comparing those with its own.
#pragma once

#include <cstdint>

#include "engine/scene/scene.h"
#include "renderer/features/frame_context.h"

namespace penumbra::render {

// The full-resolution effect targets (persistent: AOVs and tests read them back), published on the
// blackboard by the frame function before addEffects(); an invalid ref = the effect is off.
struct Effects {
    fg::TextureRef shadow;  // R8_UNORM, (width * shadowLayers) x height: layer k at x + k * width,
                            // the visible fraction of shadowed light k (GpuLight::shadow.x = k)
    uint32_t shadowLayers = 0;
    fg::TextureRef ao;          // RGBA8_UNORM: r ambient occlusion (1 = unoccluded), gba bent normal
                                // * 0.5 + 0.5 (the shading normal when the variant has none)
    fg::TextureRef thickness;   // R16_FLOAT: thickness through the object in scene units (0: none)
    fg::TextureRef reflection;  // RGBA16_FLOAT: rgb reflected radiance already weighted by the
                                // material's Fresnel term, a weight (0: none)
};

// The low-resolution results (transients) for effects_upsample: addEffects() publishes an empty one,
// sdf_shadow and sdf_ao fill their part when they run below full resolution (invalid ref: none).
struct EffectsLowRes {
    fg::TextureRef shadow;  // R8_UNORM, (shadowWidth * layers) x shadowHeight, layered as Effects::shadow
    uint32_t shadowWidth = 0, shadowHeight = 0;
    fg::TextureRef ao;  // RGBA8_UNORM as Effects::ao
    uint32_t aoWidth = 0, aoHeight = 0;
};

struct EffectsDesc {
    scene::ShadowSettings shadows;          // maxSteps resolved (never 0)
    scene::AoSettings ao;                   // rays resolved (never 0)
    scene::ReflectionSettings reflections;  // maxSteps resolved
    scene::TraceSettings trace;             // the frame's trace settings (epsilons, field safety)
    scene::TraceQuality quality = scene::TraceQuality::Medium;
    uint32_t shadowLayers = 0;  // shadowed lights this frame (0: no shadow pass)
    bool thickness = false;     // some material of the frame has subsurface > 0
    bool reflection = false;    // some material asks for reflections
    float nearPlane = 0.1f;
    float farPlane = 1000.0f;
    float footprint = 0.0f;  // pixel size per unit distance: 2 / (height * proj[1][1])
    // Culling (shadow / AO tile lists, renderer/features/sdf_effects_cull.h) and the world cache in
    // the cone and AO marches; off: every casting object at every step.
    scene::AccelerationSettings acceleration;
    bool any() const {
        return shadowLayers > 0 || ao.variant != scene::AoVariant::Off || thickness || reflection;
    }
};

// Effect step limits and ray counts by trace quality where the scene leaves them 0
// (docs/FORMATS.md lists them).
EffectsDesc resolveEffects(const scene::RenderSettings& settings);

// Adds the effect passes the desc asks for. Reads SceneBuffers, SdfSceneBuffers, GBuffer and Effects
// (whose targets it writes).
void addEffects(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
