// Feature "sdf_shadow": cone-traced soft shadows (renderer/features/effects.h orders the effects). NOT YET
// IMPLEMENTED.
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

void addSdfShadow(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
