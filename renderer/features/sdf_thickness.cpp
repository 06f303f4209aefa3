#include "renderer/features/sdf_thickness.h"

namespace penumbra::render {

// Placeholder until the module lands (adds no pass).
void addSdfThickness(FrameContext&, const EffectsDesc&) {}

}  // namespace penumbra::render
