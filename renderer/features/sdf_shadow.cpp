#include "renderer/features/sdf_shadow.h"

namespace penumbra::render {

// Placeholder until the module lands (adds no pass).
void addSdfShadow(FrameContext&, const EffectsDesc&) {}

}  // namespace penumbra::render
