// Helpers shared by the shaderc tests: running penumbra-shaderc, reading files, and an independent
// desktop-GLSL / SPIR-V check that does not go through the shaderc core.
#pragma once

#include <rhi/types.h>

#include <string>
#include <vector>

namespace shaderc_test {

struct RunResult {
    int exitCode = -1;
    std::string output;  // stdout and stderr together
};

// Runs penumbra-shaderc with `args` (each argument quoted for the shell).
RunResult runShaderc(const std::vector<std::string>& args);
// Runs `command` through the shell (stderr joined to stdout).
RunResult runCommand(const std::string& command);
void writeFile(const std::string& path, const std::string& text);

std::string fixture(const std::string& relative);  // absolute path under tests/shaderc/fixtures
std::string scratchDir(const std::string& name);   // fresh empty folder under the build tree
std::string readFile(const std::string& path);

// Compiles `glsl` as desktop GLSL 4.50 (no Vulkan rules) with glslang; returns the info log on
// failure, "" on success. With two sources (vertex, fragment) they are also linked together.
std::string compileDesktopGlsl(const std::vector<const rhi::ShaderDesc*>& stages);

// Validates SPIR-V for Vulkan 1.3 with the SPIRV-Tools library; returns "" or the messages.
std::string validateSpirv(const rhi::ShaderDesc& desc);

}  // namespace shaderc_test
