// Captures the engine log's warnings (engine/core/log.h) while alive, for tests that check a
// warning was given (and how often). Restores the previous sink on destruction.
#pragma once

#include <algorithm>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "engine/core/log.h"

namespace penumbra::test {

struct WarningCapture {
    std::mutex mutex;
    std::vector<std::string> warnings;
    log::Sink previous;
    WarningCapture() {
        previous = log::setSink([this](log::Severity s, std::string_view m) {
            if (s != log::Severity::Warning) return;
            std::lock_guard lock(mutex);
            warnings.emplace_back(m);
        });
    }
    ~WarningCapture() { log::setSink(previous); }
    WarningCapture(const WarningCapture&) = delete;
    WarningCapture& operator=(const WarningCapture&) = delete;
    // Warnings containing `needle`.
    size_t count(const std::string& needle) {
        std::lock_guard lock(mutex);
        return size_t(std::count_if(warnings.begin(), warnings.end(), [&](const std::string& w) {
            return w.find(needle) != std::string::npos;
        }));
    }
};

}  // namespace penumbra::test
