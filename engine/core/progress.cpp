#include "engine/core/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <fmt/format.h>

namespace penumbra {

bool StderrProgressOutput::isTerminal() const { return ::isatty(STDERR_FILENO) == 1; }

void StderrProgressOutput::write(std::string_view text) {
    std::fwrite(text.data(), 1, text.size(), stderr);
    std::fflush(stderr);
}

ProgressBar::ProgressBar(ProgressOutput& output, ProgressSettings settings)
    : m_output(output), m_settings(std::move(settings)) {
    m_active = m_settings.enabled && m_output.isTerminal();
    m_start = m_phaseStart = now();
}

ProgressBar::~ProgressBar() { finish(); }

double ProgressBar::now() const {
    if (m_settings.clock) return m_settings.clock();
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string ProgressBar::formatLine(std::string_view phase, double fraction, double etaSeconds,
                                    unsigned barWidth) {
    if (!(fraction >= 0)) fraction = 0;  // also NaN
    fraction = std::min(fraction, 1.0);
    const unsigned filled = unsigned(std::floor(fraction * barWidth));
    std::string bar(filled, '#');
    bar.append(barWidth - filled, '-');
    std::string eta = "ETA --";
    if (etaSeconds >= 0 && std::isfinite(etaSeconds)) {
        const long s = std::lround(etaSeconds);
        eta = s < 60 ? fmt::format("ETA {}s", s) : fmt::format("ETA {}:{:02}", s / 60, s % 60);
    }
    return fmt::format("{:<9} [{}] {:3}% {}", phase, bar, int(std::floor(fraction * 100.0)), eta);
}

void ProgressBar::update(double fraction, std::string_view phase) {
    if (!m_active) return;
    std::lock_guard lock(m_mutex);
    if (m_finished) return;
    const double t = now();
    if (phase != m_phase) {
        m_phase = std::string(phase);
        m_phaseStart = t;
        m_lastDraw = -1e300;  // draw a new phase at once (once visible)
    }
    if (t - m_start < m_settings.showAfterSeconds) return;
    if (t - m_lastDraw < m_settings.redrawIntervalSeconds && fraction < 1.0) return;
    m_lastDraw = t;
    double eta = -1;
    const double elapsed = t - m_phaseStart;
    if (fraction >= 0.01 && elapsed > 0) eta = elapsed * (1.0 - std::min(fraction, 1.0)) / fraction;
    std::string line = formatLine(m_phase, fraction, eta, m_settings.barWidth);
    const size_t width = line.size();
    if (width < m_lastWidth) line.append(m_lastWidth - width, ' ');
    m_lastWidth = width;
    m_output.write("\r" + line);
    m_drawn = true;
}

void ProgressBar::finish() {
    std::lock_guard lock(m_mutex);
    if (m_finished) return;
    m_finished = true;
    if (m_drawn) m_output.write("\r" + std::string(m_lastWidth, ' ') + "\r");
}

}  // namespace penumbra
