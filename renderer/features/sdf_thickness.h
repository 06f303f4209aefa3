// Feature "sdf_thickness": subsurface thickness (renderer/features/effects.h orders the effects). NOT YET
// IMPLEMENTED.
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

void addSdfThickness(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
