// Feature "effects_upsample": bilateral upsampling (renderer/features/effects.h orders the effects). NOT YET
// IMPLEMENTED.
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

void addEffectsUpsample(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
