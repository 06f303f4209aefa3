#include "renderer/features/sdf_ao.h"

namespace penumbra::render {

// Placeholder until the module lands (adds no pass).
void addSdfAo(FrameContext&, const EffectsDesc&) {}

}  // namespace penumbra::render
