// One logging sink for the whole module. Library code logs through here (never printf); the
// application decides where messages go (stderr by default, a file, the editor console, a test).
#pragma once

#include <functional>
#include <string_view>

#include <fmt/format.h>

namespace penumbra::log {

enum class Severity { Debug, Info, Warning, Error };

using Sink = std::function<void(Severity, std::string_view)>;

// Replaces the sink (null restores the default stderr sink). Returns the previous one.
Sink setSink(Sink sink);
// Messages below this severity are dropped (default Info).
void setMinSeverity(Severity s);
void write(Severity s, std::string_view message);
const char* toString(Severity s);

template <typename... Args>
void debug(fmt::format_string<Args...> f, Args&&... args) {
    write(Severity::Debug, fmt::format(f, std::forward<Args>(args)...));
}
template <typename... Args>
void info(fmt::format_string<Args...> f, Args&&... args) {
    write(Severity::Info, fmt::format(f, std::forward<Args>(args)...));
}
template <typename... Args>
void warn(fmt::format_string<Args...> f, Args&&... args) {
    write(Severity::Warning, fmt::format(f, std::forward<Args>(args)...));
}
template <typename... Args>
void error(fmt::format_string<Args...> f, Args&&... args) {
    write(Severity::Error, fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace penumbra::log
