// Feature "post_output": the end of a frame that has a linear colour target (render.taa or
// render.motionBlur; otherwise lighting writes the output directly and none of this runs).
//   motion_blur_tiles (compute)  per 16x16 tile the largest motion of gbuffer.velocity (jitter
//                                removed), a transient RG16F target (motion blur only)
//   post_output       (raster)   the colour into Output, sRGB-encoded as lighting encodes it (linear
//                                for a hardware-sRGB target); with motion blur first a gather of
//                                `samples` taps along the largest motion of the pixel's 3x3 tiles,
//                                times `strength` (McGuire et al. 2012's reconstruction, simplified:
//                                renderer/shaders/post_output.frag)
#pragma once

#include "engine/scene/scene.h"
#include "renderer/features/frame_context.h"

namespace penumbra::render {

inline constexpr uint32_t kMotionBlurTile = 16;  // pixels per velocity tile side

// Reads `color` (linear, tone-mapped RGBA16F), with motion blur GBuffer depth and velocity;
// writes Output.
// `color` is at twice the frame's resolution when `supersampled` (TAA's history: each pixel the
// average of its 2x2 texels).
void addPostOutput(FrameContext& fc, fg::TextureRef color, const scene::MotionBlurSettings& blur,
                   bool supersampled = false);

}  // namespace penumbra::render
