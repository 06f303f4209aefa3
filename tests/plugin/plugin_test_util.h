// Helpers shared by the plugin-host tests: log capture, temporary folders, plugin paths.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/core/log.h"

#ifndef PENUMBRA_PLUGIN_DIR
#define PENUMBRA_PLUGIN_DIR PENUMBRA_BINARY_DIR "/plugins"
#endif
#ifndef PENUMBRA_PLUGIN_FIXTURE_DIR
#define PENUMBRA_PLUGIN_FIXTURE_DIR PENUMBRA_BINARY_DIR "/tests/plugin/fixtures"
#endif

namespace penumbra::test {

inline std::string pluginPath(const std::string& name) {
    return std::string(PENUMBRA_PLUGIN_DIR "/") + name + ".so";
}
inline std::string fixturePath(const std::string& name) {
    return std::string(PENUMBRA_PLUGIN_FIXTURE_DIR "/") + name + ".so";
}

// Collects every log message (all severities) while alive.
class LogCapture {
public:
    LogCapture() {
        log::setMinSeverity(log::Severity::Debug);
        m_previous = log::setSink([this](log::Severity s, std::string_view m) {
            if (s == log::Severity::Error) m_errors.emplace_back(m);
            m_all.emplace_back(m);
        });
    }
    ~LogCapture() {
        log::setSink(m_previous);
        log::setMinSeverity(log::Severity::Info);
    }
    LogCapture(const LogCapture&) = delete;
    LogCapture& operator=(const LogCapture&) = delete;

    const std::vector<std::string>& errors() const { return m_errors; }
    const std::vector<std::string>& all() const { return m_all; }
    std::string lastError() const { return m_errors.empty() ? std::string() : m_errors.back(); }
    void clear() {
        m_errors.clear();
        m_all.clear();
    }

private:
    log::Sink m_previous;
    std::vector<std::string> m_errors;
    std::vector<std::string> m_all;
};

// A fresh folder under the system temp dir, removed at the end of the test.
class PluginTempDir {
public:
    PluginTempDir() {
        const auto* info = testing::UnitTest::GetInstance()->current_test_info();
        std::string name = "penumbra_plugin_" + std::to_string(::getpid());
        if (info) name.append("_").append(info->test_suite_name()).append("_").append(info->name());
        for (char& c : name) {
            if (c == '/') c = '_';
        }
        m_path = std::filesystem::temp_directory_path() / name;
        std::filesystem::remove_all(m_path);
        std::filesystem::create_directories(m_path);
    }
    ~PluginTempDir() {
        std::error_code ec;
        std::filesystem::remove_all(m_path, ec);
    }
    PluginTempDir(const PluginTempDir&) = delete;
    PluginTempDir& operator=(const PluginTempDir&) = delete;

    std::string file(const std::string& name) const { return (m_path / name).string(); }
    std::string path() const { return m_path.string(); }

    std::string write(const std::string& name, const std::string& bytes) const {
        const std::string p = file(name);
        std::ofstream out(p, std::ios::binary);
        out.write(bytes.data(), std::streamsize(bytes.size()));
        return p;
    }

private:
    std::filesystem::path m_path;
};

}  // namespace penumbra::test
