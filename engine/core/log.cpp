#include "engine/core/log.h"

#include <atomic>
#include <cstdio>
#include <mutex>

namespace penumbra::log {
namespace {
std::mutex g_mutex;
Sink g_sink;
std::atomic<int> g_min{int(Severity::Info)};
}  // namespace

const char* toString(Severity s) {
    switch (s) {
        case Severity::Debug:
            return "debug";
        case Severity::Info:
            return "info";
        case Severity::Warning:
            return "warning";
        case Severity::Error:
            return "error";
    }
    return "?";
}

Sink setSink(Sink sink) {
    std::lock_guard lock(g_mutex);
    Sink old = std::move(g_sink);
    g_sink = std::move(sink);
    return old;
}

void setMinSeverity(Severity s) { g_min = int(s); }

void write(Severity s, std::string_view message) {
    if (int(s) < g_min) return;
    std::lock_guard lock(g_mutex);
    if (g_sink) {
        g_sink(s, message);
        return;
    }
    std::fprintf(stderr, "[%s] %.*s\n", toString(s), int(message.size()), message.data());
}

}  // namespace penumbra::log
