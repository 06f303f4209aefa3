#include "renderer/features/effects.h"

#include "renderer/features/effects_upsample.h"
#include "renderer/features/sdf_ao.h"
#include "renderer/features/sdf_effects_cull.h"
#include "renderer/features/sdf_reflection.h"
#include "renderer/features/sdf_shadow.h"
#include "renderer/features/sdf_thickness.h"

namespace penumbra::render {

EffectsDesc resolveEffects(const scene::RenderSettings& settings) {
    using Q = scene::TraceQuality;
    EffectsDesc d;
    d.shadows = settings.shadows;
    d.ao = settings.ao;
    d.reflections = settings.reflections;
    d.trace = settings.resolvedTrace();
    d.quality = settings.quality;
    d.acceleration = settings.acceleration;
    const uint32_t q = uint32_t(settings.quality);  // low, medium, high, reference
    static constexpr uint32_t kShadowSteps[] = {32, 64, 128, 1024};
    // Reference multi-ray AO traces every direction to a binary hit (up to 256 steps each). With
    // 1024 directions llvmpipe and lavapipe returned wrong AO (0.5 on an open plane), consistent
    // with a limit on an invocation's total loop iterations (Mesa's loop limiter, 65535); 128
    // directions (at most 128 x 256 iterations) stay under it and measure a mean error of 0.004
    // against the closed form (tests/renderer/sdf_ao_test.cpp).
    static constexpr uint32_t kAoRays[] = {4, 8, 16, 128};
    static constexpr uint32_t kReflectionSteps[] = {32, 64, 128, 1024};
    static_assert(uint32_t(Q::Reference) == 3);
    if (d.shadows.maxSteps == 0) d.shadows.maxSteps = kShadowSteps[q];
    if (d.ao.rays == 0) d.ao.rays = kAoRays[q];
    if (d.reflections.maxSteps == 0) d.reflections.maxSteps = kReflectionSteps[q];
    return d;
}

void addEffects(FrameContext& fc, const EffectsDesc& desc) {
    fc.board.add<EffectsLowRes>();  // modules replace it with their part filled in
    // Shadow and AO tile lists first (they read the finished G-buffer depth).
    if (desc.acceleration.culling && (desc.shadowLayers > 0 || desc.ao.variant != scene::AoVariant::Off))
        addSdfEffectsCull(fc, desc);
    if (desc.shadowLayers > 0) addSdfShadow(fc, desc);
    if (desc.ao.variant != scene::AoVariant::Off) addSdfAo(fc, desc);
    if (desc.thickness) addSdfThickness(fc, desc);
    if (desc.reflection) addSdfReflection(fc, desc);
    const EffectsLowRes& low = *fc.board.find<EffectsLowRes>();
    if (low.shadow.isValid() || low.ao.isValid()) addEffectsUpsample(fc, desc);
}

}  // namespace penumbra::render
