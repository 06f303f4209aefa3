// The application loop: fixed-step update, variable-rate render.
//
// Simulation time advances in fixed steps of `fixedDt`; each rendered frame adds its frame time to
// an accumulator and runs as many whole steps as fit (at most maxStepsPerFrame; the rest of a long
// stall is dropped and counted, so a hitch never turns into a spiral of catch-up steps). Render
// gets `alpha`, the fraction of a step left in the accumulator, for interpolation.
//
// Time is kept in integer nanoseconds, so offline rendering is exactly reproducible: the CLI's
// `--frames N --fixed-dt S` advances every frame by S (not by wall-clock time) and the same scene
// gives the same step count, the same simulated time and therefore the same images on every run.
// Real-time callers (the editor) pass measured frame times instead; nothing here reads a clock.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace penumbra::app {

struct LoopDesc {
    double fixedDt = 1.0 / 60.0;     // update step in seconds, in [1e-6, 10]
    uint32_t maxStepsPerFrame = 16;  // cap on catch-up steps per frame (>= 1)
};

struct FrameTime {
    uint64_t frameIndex = 0;  // 0 for the first frame
    uint32_t steps = 0;       // fixed steps run during this frame
    double simTime = 0.0;     // simulated seconds after this frame's steps
    double frameDt = 0.0;     // the frame time this frame was advanced by (seconds)
    double alpha = 0.0;       // leftover accumulator / fixedDt, in [0, 1)
};

class AppLoop {
public:
    using Step = std::function<void(double dt)>;

    AppLoop() = default;
    // False (with `error`) for an out-of-range desc; the loop keeps its previous settings.
    bool configure(const LoopDesc& desc, std::string& error);
    const LoopDesc& desc() const { return m_desc; }

    // Advances by `frameSeconds` (negative, NaN and infinite values count as 0; values above one
    // minute are clamped) and calls `step(fixedDt)` for every whole step that fits.
    FrameTime advance(double frameSeconds, const Step& step);

    uint64_t frameCount() const { return m_frames; }
    uint64_t stepCount() const { return m_steps; }
    uint64_t droppedSteps() const { return m_dropped; }
    double simTime() const { return double(m_simNs) * 1e-9; }
    int64_t fixedDtNs() const { return m_stepNs; }
    void reset();

    // Seconds -> whole nanoseconds (round to nearest), the loop's unit of time.
    static int64_t toNanoseconds(double seconds);

private:
    LoopDesc m_desc;
    int64_t m_stepNs = toNanoseconds(1.0 / 60.0);
    int64_t m_accumNs = 0;
    int64_t m_simNs = 0;
    uint64_t m_frames = 0;
    uint64_t m_steps = 0;
    uint64_t m_dropped = 0;
};

}  // namespace penumbra::app
