// Feature "sdf_ao": ambient occlusion (renderer/features/effects.h orders the effects). NOT YET IMPLEMENTED.
#pragma once

#include "renderer/features/effects.h"

namespace penumbra::render {

void addSdfAo(FrameContext& fc, const EffectsDesc& desc);

}  // namespace penumbra::render
