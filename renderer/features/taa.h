// Feature "taa": temporal anti-aliasing (mTec 8.2.11, after PlayDead's TAA and Karis 2014). With
// render.taa the frame is rendered with a sub-pixel jitter (taaJitter: Halton(2, 3), 16 phases, the
// phase being the SceneRenderer's frame index, not time: a sequence is reproducible), lighting
// writes the linear tone-mapped colour, and the "taa" pass (renderer/shaders/taa.comp) resolves it
// with the persistent history, kept at 2x2 texels per pixel (kTaaHistoryScale):
//   - reprojection by gbuffer.velocity (per-object and camera motion, jitter removed) of the nearest
//     surface in the 3x3 neighbourhood (background: camera rotation) or, where the history holds a
//     nearer surface there (one thinner than a pixel that this frame's samples missed), of that
//     surface as a static point; bilinear history resampling per texel;
//   - this frame's sample updates each of its pixel's texels by its bilinear share (where the jitter
//     put it); post_output shows each pixel as the mean of its texels;
//   - the history clipped to a YCoCg box around this frame's 3x3 neighbourhood and the previous
//     frame's raw samples at the reprojected point (a sub-pixel surface this frame's samples missed
//     but the previous frame's hit keeps its history);
//   - history rejection on disocclusion (depth kept in the history's alpha), and Wright 2015's
//     unstable pixels: a rejected pixel takes its blurred surroundings, not its aliased sample;
//   - the history restarts (the frame shows its own jittered sample) on a size change, a camera
//     change, FrameDesc::resetHistory and after any frame that did not run TAA.
// The SDF trace, the G-buffer's position reconstruction and the half- / quarter-resolution shadows
// and AO all follow the jittered rays, so the history also averages their under-sampling.
#pragma once

#include <string>

#include <glm/vec2.hpp>

#include "renderer/features/frame_context.h"

namespace penumbra::render {

inline constexpr uint32_t kTaaJitterPhases = 16;
inline constexpr float kTaaCurrentWeight = 0.1f;  // exponential blend weight of each new frame
// The weight of each new frame where the surface moves >= 0.25 pixels per frame (taa.comp
// kTaaFullMotion; linear in between): on the TAA test's camera path the error ratio went from 0.81
// (0.1 everywhere) to 0.66 (0.35), and with the raw samples in the clipping box from 0.626 (0.35)
// to 0.608 (0.5); with the 2x history and the missed thin surfaces' motion 0.470 (0.3; 0.2: 0.483,
// 0.5: 0.486; tuned on the first, full-screen fragment form of the 2x resolve), 0.449 with the
// per-pixel compute resolve; a still camera's frames keep 0.1.
inline constexpr float kTaaMovingWeight = 0.3f;
inline constexpr float kTaaDepthTolerance = 0.05f;  // relative depth change still the same surface

// The jitter of frame `index`, in pixels within (-0.5, 0.5):
// the Halton(2, 3) point (index % 16) + 1 minus 0.5.
glm::vec2 taaJitter(uint32_t index);

// The history's resolution, per axis, relative to the frame's: each pixel keeps 2x2 texels, so
// resampling it at a new sub-pixel offset every frame blurs a quarter as much (the camera-path
// error ratio went from 0.608 to 0.514 with it, docs/ACCURACY.md "TAA"). taa.comp (its four texels
// per pixel) and post_output.frag (one bilinear fetch per pixel) are written for 2.
inline constexpr uint32_t kTaaHistoryScale = 2;

// The history: two pairs of RGBA16F targets (this frame writes one of each pair and reads the
// other): the resolved colour (rgb) with the linear depth of the pixel (a, 0: background) at
// kTaaHistoryScale times the frame's size, and the frame's raw jittered samples (1x), which widen
// the next frame's clipping box. Owned by the SceneRenderer.
class TaaHistory {
public:
    explicit TaaHistory(rhi::Device& device) : m_device(device) {}
    TaaHistory(const TaaHistory&) = delete;
    TaaHistory& operator=(const TaaHistory&) = delete;

    // Starts a TAA frame of width x height: allocates the targets on first use or a size change
    // (the history restarts) and restarts it when `reset`. False with `error` if allocation fails.
    bool begin(fg::FrameGraph& graph, uint32_t width, uint32_t height, bool reset, std::string& error);
    // Frames in the history before this one (0: the frame starts it).
    uint32_t sampleIndex() const { return m_samples; }
    // Adds "taa" (compute, one invocation per pixel: renderer/shaders/taa.comp): resolves `color`
    // (this frame's linear colour) with the history and keeps its raw samples; returns the resolved
    // colour (the history target this frame writes, kTaaHistoryScale times the frame's size).
    fg::TextureRef add(FrameContext& fc, fg::TextureRef color);
    // After the frame ran: the written target becomes the history.
    void endFrame();
    // Frees the targets (a frame without TAA, the renderer's end).
    void release(fg::FrameGraph& graph);
    uint64_t bytes() const { return m_bytes; }

private:
    rhi::Device& m_device;
    rhi::TextureHandle m_targets[4];  // [0..1] resolved + depth, [2..3] raw samples
    uint32_t m_width = 0, m_height = 0;
    uint32_t m_write = 0;    // the target this frame writes; the other holds the history
    uint32_t m_samples = 0;  // frames accumulated in the history
    uint64_t m_bytes = 0;
};

}  // namespace penumbra::render
