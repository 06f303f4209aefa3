// Terminal progress bar with ETA for long-running work (bakes). It draws only when its output is a
// terminal, only once the work has run longer than a threshold (1 s by default: short work prints
// nothing), and never when disabled (--quiet). Output goes through ProgressOutput so tests can
// capture it; the clock is injectable for deterministic tests.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

namespace penumbra {

class ProgressOutput {
public:
    virtual ~ProgressOutput() = default;
    virtual bool isTerminal() const = 0;
    virtual void write(std::string_view text) = 0;
};

// Writes to the process's stderr; isTerminal() is isatty(stderr).
class StderrProgressOutput final : public ProgressOutput {
public:
    bool isTerminal() const override;
    void write(std::string_view text) override;
};

struct ProgressSettings {
    bool enabled = true;                 // false: --quiet
    double showAfterSeconds = 1.0;       // nothing is drawn before this much time has passed
    double redrawIntervalSeconds = 0.1;  // at most this often
    unsigned barWidth = 30;              // characters between the brackets
    std::function<double()> clock;       // seconds, monotonic; empty = steady_clock
};

class ProgressBar {
public:
    ProgressBar(ProgressOutput& output, ProgressSettings settings = {});
    ~ProgressBar();
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;

    // fraction in [0,1] of the named phase; a new phase name restarts the ETA estimate.
    // Thread-safe.
    void update(double fraction, std::string_view phase);
    // Clears the bar line if one was drawn (also done by the destructor).
    void finish();

    // True once anything has been written.
    bool drawn() const { return m_drawn; }

    // The line update() would draw (without the leading carriage return), for tests.
    static std::string formatLine(std::string_view phase, double fraction, double etaSeconds,
                                  unsigned barWidth);

private:
    double now() const;

    ProgressOutput& m_output;
    ProgressSettings m_settings;
    bool m_active = false;  // enabled and a terminal
    std::mutex m_mutex;
    double m_start = 0, m_phaseStart = 0, m_lastDraw = -1e300;
    std::string m_phase;
    size_t m_lastWidth = 0;
    bool m_drawn = false;
    bool m_finished = false;
};

}  // namespace penumbra
