// Feature "debug_view": the full-screen pass "debug_view" that shows one G-buffer channel in the
// output instead of the lit image (`penumbra render --debug-view normals|depth|albedo`):
//   normals  world normal * 0.5 + 0.5
//   depth    white at the camera, black at depthRange (the scene renderer passes the far side of the
//            farthest drawn mesh's bounding sphere) and where nothing is hit
//   albedo   base colour (the albedo target when the frame has one, else the material's colour)
// It is the worked example of docs/ARCHITECTURE.md, "How to add a pass".
#pragma once

#include <string_view>

#include "renderer/features/frame_context.h"

namespace penumbra::render {

enum class DebugView : uint32_t { None, Normals, Depth, Albedo };
const char* toString(DebugView view);
// "none", "normals", "depth", "albedo"; false for anything else.
bool parseDebugView(std::string_view text, DebugView& out);

// Reads SceneBuffers and GBuffer, writes Output. `view` must not be None.
void addDebugView(FrameContext& fc, DebugView view, float depthRange);

}  // namespace penumbra::render
