// Internal interfaces between the shaderc core's translation units.
#pragma once

#include "shaderc.h"

#include <string>
#include <vector>

namespace penumbra::shaderc::detail {

// Process-wide glslang initialisation (idempotent, thread-safe).
void ensureGlslangInitialized();

// GLSL 450 (Vulkan semantics) -> validated SPIR-V. Appends `path:line: error: ...` diagnostics.
// Every file read (the source and its includes) is added to `dependencies`.
bool compileToSpirv(const StageInput& input, const std::vector<std::string>& includeDirs,
                    std::vector<uint32_t>& spirv, std::set<std::string>& dependencies,
                    std::vector<std::string>& diagnostics);

// Compiles the generated desktop GLSL of all stages of a program with glslang (no Vulkan rules)
// and links them together. Diagnostics name `stages[i].path`.
bool checkDesktopGlsl(const std::vector<StageOutput>& stages, std::vector<std::string>& diagnostics);

// SPIR-V reflection of one stage: bindings (glBinding unset), push constants, workgroup size,
// vertex inputs.
bool reflectStage(StageOutput& stage, std::vector<std::string>& diagnostics);

// Assigns glBinding per resource class across the program's stages; errors on conflicting
// declarations of one (set, binding).
bool assignGlBindings(std::vector<StageOutput>& stages, std::vector<std::string>& diagnostics);

// SPIR-V -> GLSL 4.50 core with the stage's glBindings applied and descriptor sets removed.
bool emitDesktopGlsl(StageOutput& stage, std::vector<std::string>& diagnostics);

const char* stageFileKind(rhi::ShaderStage stage);  // "comp", "vert", "frag"

}  // namespace penumbra::shaderc::detail
