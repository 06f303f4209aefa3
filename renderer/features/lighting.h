// Feature "lighting": the full-screen raster pass "lighting" — deferred lighting of the G-buffer
// into the output: world position from linear depth along the camera ray, Cook-Torrance or
// Blinn-Phong over every light (directional, point, sphere), ambient * baseColor * AO, emissive,
// exposure, tone mapping and the sRGB encoding (renderer/shaders/brdf.glsl; CPU reference in
// lighting_reference.h). A frame without geometry has no G-buffer: addBackground() then only
// clears the output to the background colour, display-encoded on the CPU with the same functions.
#pragma once

#include <array>

#include "renderer/features/frame_context.h"

namespace penumbra::render {

// Reads SceneBuffers and GBuffer, writes Output (variant ALBEDO when the G-buffer has albedo).
void addLighting(FrameContext& fc);
// Clears Output to `encoded` (already tone mapped and display encoded).
void addBackground(FrameContext& fc, std::array<float, 4> encoded);

}  // namespace penumbra::render
