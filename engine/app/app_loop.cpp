#include "engine/app/app_loop.h"

#include <cmath>

#include <fmt/format.h>

#include "engine/core/log.h"

namespace penumbra::app {

namespace {

constexpr double kMaxRealTimeFrameSeconds = 60.0;
// A ratio frameSeconds / fixedDt this close (relative) to a whole number counts as that number.
constexpr double kWholeRatioTolerance = 1e-9;

}  // namespace

int64_t AppLoop::toNanoseconds(double seconds) { return int64_t(std::llround(seconds * 1e9)); }

bool AppLoop::configure(const LoopDesc& desc, std::string& error) {
    if (!std::isfinite(desc.fixedDt) || desc.fixedDt < 1e-6 || desc.fixedDt > 10.0) {
        error = fmt::format("fixed update step {} s is outside [1e-6, 10] seconds", desc.fixedDt);
        return false;
    }
    if (desc.maxStepsPerFrame == 0) {
        error = "maxStepsPerFrame must be at least 1";
        return false;
    }
    if (desc.fixedDt != m_desc.fixedDt) endRun();
    m_desc = desc;
    m_stepNs = toNanoseconds(desc.fixedDt);
    return true;
}

double AppLoop::simTime() const {
    switch (m_run) {
        case Run::RealTime:
            return m_runStart + double(m_runNs) * 1e-9;
        case Run::Offline:
            return m_runStart + double(m_runFrames) * m_runFrameSeconds;
        case Run::None:
            break;
    }
    return m_runStart;
}

void AppLoop::endRun() {
    m_runStart = simTime();
    m_run = Run::None;
    m_runNs = 0;
    m_runFrameSeconds = 0.0;
    m_runFrames = 0;
    m_runStepsPerFrame = 0;
}

void AppLoop::reset() {
    m_accumNs = m_runNs = 0;
    m_run = Run::None;
    m_runStart = m_runFrameSeconds = 0.0;
    m_runFrames = m_runStepsPerFrame = 0;
    m_frames = m_steps = m_dropped = 0;
    m_droppedSeconds = 0.0;
}

FrameTime AppLoop::advance(double frameSeconds, const Step& step) {
    if (m_run != Run::RealTime) {
        endRun();
        m_run = Run::RealTime;
    }
    if (!std::isfinite(frameSeconds) || frameSeconds < 0.0) frameSeconds = 0.0;
    const double requested = frameSeconds;
    FrameTime t;
    if (frameSeconds > kMaxRealTimeFrameSeconds) {
        t.dropped = frameSeconds - kMaxRealTimeFrameSeconds;
        frameSeconds = kMaxRealTimeFrameSeconds;
    }
    m_accumNs += toNanoseconds(frameSeconds);

    t.frameIndex = m_frames++;
    t.frameDt = frameSeconds;
    const double dt = double(m_stepNs) * 1e-9;
    t.stepDt = dt;
    while (m_accumNs >= m_stepNs) {
        if (t.steps == m_desc.maxStepsPerFrame) {
            const int64_t left = m_accumNs / m_stepNs;
            m_dropped += uint64_t(left);
            m_accumNs -= left * m_stepNs;
            t.dropped += double(left * m_stepNs) * 1e-9;
            break;
        }
        if (step) step(dt);
        m_accumNs -= m_stepNs;
        m_runNs += m_stepNs;
        ++m_steps;
        ++t.steps;
    }
    if (t.dropped > 0.0) {
        m_droppedSeconds += t.dropped;
        log::warn(
            "app loop: frame {} of {:.6g} s ran {} update steps of {:.6g} s and dropped {:.6g} s of "
            "simulated time (real-time limits: at most {} steps and {} s per frame)",
            t.frameIndex, requested, t.steps, dt, t.dropped, m_desc.maxStepsPerFrame,
            kMaxRealTimeFrameSeconds);
    }
    t.simTime = simTime();
    t.alpha = double(m_accumNs) / double(m_stepNs);
    return t;
}

uint64_t AppLoop::offlineStepsPerFrame(double frameSeconds, double fixedDt) {
    const double ratio = frameSeconds / fixedDt;
    const double whole = std::round(ratio);
    if (whole >= 1.0 && std::abs(ratio - whole) <= kWholeRatioTolerance * whole) return uint64_t(whole);
    return uint64_t(std::ceil(ratio));
}

bool AppLoop::advanceOffline(double frameSeconds, const Step& step, FrameTime& out, std::string& error) {
    if (!std::isfinite(frameSeconds) || frameSeconds < 0.0 || frameSeconds > kMaxOfflineFrameSeconds) {
        error = fmt::format("offline frame time {} s is outside [0, {}] seconds", frameSeconds,
                            kMaxOfflineFrameSeconds);
        return false;
    }
    if (m_run != Run::Offline || m_runFrameSeconds != frameSeconds) {
        endRun();
        m_run = Run::Offline;
        m_runFrameSeconds = frameSeconds;
        m_runStepsPerFrame = frameSeconds > 0.0 ? offlineStepsPerFrame(frameSeconds, m_desc.fixedDt) : 0;
        m_accumNs = 0;
    }
    FrameTime t;
    t.frameIndex = m_frames++;
    t.frameDt = frameSeconds;
    t.stepDt = m_runStepsPerFrame > 0 ? frameSeconds / double(m_runStepsPerFrame) : 0.0;
    for (uint64_t i = 0; i < m_runStepsPerFrame; ++i) {
        if (step) step(t.stepDt);
        ++m_steps;
        ++t.steps;
    }
    ++m_runFrames;
    t.simTime = simTime();
    out = t;
    return true;
}

}  // namespace penumbra::app
