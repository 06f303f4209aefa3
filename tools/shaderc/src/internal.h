// Internal interfaces between the shaderc core's translation units.
#pragma once

#include "shaderc.h"

#include <string>
#include <vector>

namespace penumbra::shaderc::detail {

// Process-wide glslang initialisation (idempotent, thread-safe).
void ensureGlslangInitialized();

// GLSL 450 (Vulkan semantics) -> validated SPIR-V. Appends `path:line: error: ...` diagnostics.
// `defines` are each #defined to 1 before the source. With `sourceText` the source is that text
// (named input.path in diagnostics) instead of the file's content. Every file read (the source
// file, then its includes in the order they were opened) is appended to `files`.
bool compileToSpirv(const StageInput& input, const std::vector<std::string>& includeDirs,
                    const std::vector<std::string>& defines, const std::string* sourceText,
                    std::vector<uint32_t>& spirv, std::vector<std::string>& files,
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

// The parameter-block layouts of one stage (stage.layouts, stage.pushConstantBlock); a member
// without a C++ equivalent is an error at its declaration (located in stage.files).
bool reflectLayouts(StageOutput& stage, std::vector<std::string>& diagnostics);

// Over all stages of all variants: merges the layouts into program.structs (one struct per name),
// checks blocks named View against `view` (null: View is an ordinary block), resolves struct
// sizes and padding, and collects the named slots.
bool resolveProgramInterface(ProgramOutput& program, const StructLayout* view,
                             std::vector<std::string>& diagnostics);

// `#pragma penumbra_variants A B+C ...` lines of the stage sources -> variants (stages empty).
bool parseVariantPragmas(const std::vector<StageInput>& stages, std::vector<VariantOutput>& variants,
                         std::vector<std::string>& diagnostics);

// "path:line" of the declaration of GLSL type `typeName` (a block or struct), or of its member
// `member` when given, searched in `files` in order; "path" of files[0] when not found.
std::string locateDeclaration(const std::vector<std::string>& files, const std::string& typeName,
                              const std::string& member);

// SPIR-V -> GLSL 4.50 core with the stage's glBindings applied and descriptor sets removed.
bool emitDesktopGlsl(StageOutput& stage, std::vector<std::string>& diagnostics);

const char* stageFileKind(rhi::ShaderStage stage);  // "comp", "vert", "frag"

}  // namespace penumbra::shaderc::detail
