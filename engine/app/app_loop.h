// The application loop: fixed-step update, variable-rate render, in two modes.
//
// Real time (`advance`, the editor and windowed callers): each rendered frame adds its measured
// frame time to an accumulator and runs as many whole steps of `fixedDt` as fit, at most
// maxStepsPerFrame. The rest of a long stall is dropped so a hitch never turns into a spiral of
// catch-up steps; dropped time is counted (droppedSteps, droppedTime, FrameTime::dropped) and
// logged as a warning. Render gets `alpha`, the fraction of a step left in the accumulator, for
// interpolation. Accumulator and step are integer nanoseconds (fixedDt rounded to the nearest ns),
// so the same frame times give the same step sequence on every run.
//
// Offline (`advanceOffline`, `penumbra render --frames N --fixed-dt S`): every call advances by
// exactly `frameSeconds` and nothing is dropped. The frame is split into n equal update steps of
// frameSeconds / n, n being the smallest whole number of steps no longer than fixedDt that fill
// it (a ratio frameSeconds / fixedDt within 1e-9 relative of a whole number counts as that
// number, since decimal inputs such as 0.1 or 1/60 are not exact in binary): with fixedDt = 1/60,
// a frame of 1 s runs 60 steps of 1/60 s and a frame of 0.025 s runs 2 steps of 0.0125 s.
// Simulated time is kept per run of equal frame times as start + k * frameSeconds, so after k
// offline frames of S seconds (from time 0) simTime is exactly k * S (one rounding of the
// product, no accumulated drift); the catch-up cap does not apply. Nothing here reads a clock.
//
// Switching between the modes, or changing the offline frame time or fixedDt, starts a new run at
// the current simulated time; the real-time accumulator's leftover (less than one step) is
// discarded when an offline frame follows a real-time one.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace penumbra::app {

struct LoopDesc {
    double fixedDt = 1.0 / 60.0;     // update step in seconds, in [1e-6, 10] (offline: the upper bound)
    uint32_t maxStepsPerFrame = 16;  // real-time cap on catch-up steps per frame (>= 1)
};

struct FrameTime {
    uint64_t frameIndex = 0;  // 0 for the first frame
    uint32_t steps = 0;       // fixed steps run during this frame
    double simTime = 0.0;     // simulated seconds after this frame's steps
    double frameDt = 0.0;     // the frame time this frame was advanced by (seconds)
    double stepDt = 0.0;      // the update step of this frame's steps (seconds)
    double alpha = 0.0;       // leftover accumulator / fixedDt, in [0, 1) (offline: 0)
    double dropped = 0.0;     // simulated seconds this frame dropped (real time only)
};

class AppLoop {
public:
    using Step = std::function<void(double dt)>;

    // The longest offline frame, seconds.
    static constexpr double kMaxOfflineFrameSeconds = 10.0;

    AppLoop() = default;
    // False (with `error`) for an out-of-range desc; the loop keeps its previous settings.
    bool configure(const LoopDesc& desc, std::string& error);
    const LoopDesc& desc() const { return m_desc; }

    // Real time: advances by `frameSeconds` (negative, NaN and infinite values count as 0; values
    // above one minute are clamped, the excess counted as dropped) and calls `step(fixedDt)` for
    // every whole step that fits, at most maxStepsPerFrame.
    FrameTime advance(double frameSeconds, const Step& step);

    // Offline: advances by exactly `frameSeconds` (0 keeps the time; otherwise finite and at most
    // kMaxOfflineFrameSeconds), calling `step(frameSeconds / n)` n times (see the file comment).
    // False with `error` for an invalid frame time; then nothing changes.
    bool advanceOffline(double frameSeconds, const Step& step, FrameTime& out, std::string& error);

    // Update steps per offline frame of `frameSeconds` with a step of at most `fixedDt` (both > 0).
    static uint64_t offlineStepsPerFrame(double frameSeconds, double fixedDt);

    uint64_t frameCount() const { return m_frames; }
    uint64_t stepCount() const { return m_steps; }
    uint64_t droppedSteps() const { return m_dropped; }
    double droppedTime() const { return m_droppedSeconds; }  // seconds, real time only
    double simTime() const;
    int64_t fixedDtNs() const { return m_stepNs; }
    void reset();

    // Seconds -> whole nanoseconds (round to nearest), the real-time loop's unit of time.
    static int64_t toNanoseconds(double seconds);

private:
    enum class Run { None, RealTime, Offline };
    // Ends the current run: its time is folded into m_runStart.
    void endRun();

    LoopDesc m_desc;
    int64_t m_stepNs = toNanoseconds(1.0 / 60.0);
    int64_t m_accumNs = 0;
    Run m_run = Run::None;
    double m_runStart = 0.0;          // simulated seconds when the current run began
    int64_t m_runNs = 0;              // real-time run: simulated nanoseconds since it began
    double m_runFrameSeconds = 0.0;   // offline run: its frame time
    uint64_t m_runFrames = 0;         // offline run: frames since it began
    uint64_t m_runStepsPerFrame = 0;  // offline run: update steps per frame
    uint64_t m_frames = 0;
    uint64_t m_steps = 0;
    uint64_t m_dropped = 0;
    double m_droppedSeconds = 0.0;
};

}  // namespace penumbra::app
