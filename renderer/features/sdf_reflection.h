// Feature "sdf_reflection": traced reflections (renderer/features/effects.h orders the effects). NOT YET
// IMPLEMENTED.
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

void addSdfReflection(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
