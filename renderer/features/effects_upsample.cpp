#include "renderer/features/effects_upsample.h"

namespace penumbra::render {

// Placeholder until the module lands (adds no pass).
void addEffectsUpsample(FrameContext&, const EffectsDesc&) {}

}  // namespace penumbra::render
