#include "renderer/features/sdf_reflection.h"

namespace penumbra::render {

// Placeholder until the module lands (adds no pass).
void addSdfReflection(FrameContext&, const EffectsDesc&) {}

}  // namespace penumbra::render
