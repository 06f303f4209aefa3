#include "engine/app/app_loop.h"

#include <cmath>

#include <fmt/format.h>

namespace penumbra::app {

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
    m_desc = desc;
    m_stepNs = toNanoseconds(desc.fixedDt);
    return true;
}

void AppLoop::reset() {
    m_accumNs = m_simNs = 0;
    m_frames = m_steps = m_dropped = 0;
}

FrameTime AppLoop::advance(double frameSeconds, const Step& step) {
    if (!std::isfinite(frameSeconds) || frameSeconds < 0.0) frameSeconds = 0.0;
    if (frameSeconds > 60.0) frameSeconds = 60.0;
    m_accumNs += toNanoseconds(frameSeconds);

    FrameTime t;
    t.frameIndex = m_frames++;
    t.frameDt = frameSeconds;
    const double dt = double(m_stepNs) * 1e-9;
    while (m_accumNs >= m_stepNs) {
        if (t.steps == m_desc.maxStepsPerFrame) {
            const int64_t left = m_accumNs / m_stepNs;
            m_dropped += uint64_t(left);
            m_accumNs -= left * m_stepNs;
            break;
        }
        if (step) step(dt);
        m_accumNs -= m_stepNs;
        m_simNs += m_stepNs;
        ++m_steps;
        ++t.steps;
    }
    t.simTime = simTime();
    t.alpha = double(m_accumNs) / double(m_stepNs);
    return t;
}

}  // namespace penumbra::app
