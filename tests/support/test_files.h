// Files the GPU tests generate into the build tree (scenes written from code). ctest runs the
// Vulkan and OpenGL instances of a test as separate processes at the same time, and both write the
// same file: written in place, one process could read it while the other truncates it. So each
// writer writes its own temporary file and renames it over the target (atomic on POSIX): a reader
// sees a complete file, the old one or the new one, which have the same content.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include <unistd.h>

namespace penumbra::test {

// Writes `text` to `path` atomically (creating its folder); false if it could not.
inline bool writeTestFile(const std::string& path, const std::string& text) {
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
    const std::string tmp = path + ".tmp" + std::to_string(::getpid());
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!(out << text) || !out.flush()) return false;
    }
    std::filesystem::rename(tmp, path, ec);
    return !ec;
}

}  // namespace penumbra::test
