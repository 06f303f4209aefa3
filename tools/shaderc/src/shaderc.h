// penumbra-shaderc core: compiles one shader program (a compute shader, or a vertex + fragment pair)
// written in GLSL 450 with Vulkan semantics into SPIR-V, GLSL 4.50 with flattened bindings for
// OpenGL and reflection data, and renders that as C++ source for the rhi::ShaderDesc API.
#pragma once

#include <rhi/types.h>

#include <array>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace penumbra::shaderc {

struct StageInput {
    rhi::ShaderStage stage = rhi::ShaderStage::Compute;
    std::string path;  // source file, as given (used verbatim in diagnostics)
};

struct ProgramRequest {
    std::string name;                      // program name, a C++ identifier
    std::vector<StageInput> stages;        // {Compute} or {Vertex, Fragment}
    std::vector<std::string> includeDirs;  // searched after the including file's own directory
};

// Reflection of one resource, same meaning as rhi::ShaderBinding but owning its name.
struct Binding {
    std::string name;
    uint32_t set = 0;
    uint32_t binding = 0;
    rhi::BindingType type = rhi::BindingType::UniformBuffer;
    uint32_t count = 1;
    uint32_t glBinding = 0;
    rhi::TextureDimension textureDimension = rhi::TextureDimension::Tex2D;
    rhi::Format storageFormat = rhi::Format::Undefined;
    bool writes = false;
};

struct StageOutput {
    rhi::ShaderStage stage = rhi::ShaderStage::Compute;
    std::string path;
    std::vector<uint32_t> spirv;
    std::string glsl;               // GLSL 4.50 core, no descriptor sets, flattened bindings
    std::vector<Binding> bindings;  // sorted by (set, binding)
    std::vector<rhi::VertexInputReflection> vertexInputs;  // vertex stage, sorted by location
    uint32_t pushConstantSize = 0;
    std::array<uint32_t, 3> workgroupSize{1, 1, 1};
};

struct ProgramOutput {
    std::string name;
    std::vector<StageOutput> stages;
    std::set<std::string> dependencies;  // every source and included file that was read
};

// Diagnostics are collected as lines in the `path:line: error: message` form (or `path: error:
// message` where no line applies). Returns false if the program could not be compiled.
bool compileProgram(const ProgramRequest& request, ProgramOutput& out, std::vector<std::string>& diagnostics);

// Generated files (see tools/shaderc/README.md for their exact shape).
std::string generateHeader(const ProgramOutput& program);
std::string generateSource(const ProgramOutput& program);
// Makefile-syntax depfile: "<targets>: <dependencies>" with spaces escaped.
std::string generateDepfile(const std::vector<std::string>& targets,
                            const std::set<std::string>& dependencies);

// Writes `content` to `path` unless the file already holds exactly that. Creates parent folders.
bool writeFileIfChanged(const std::string& path, const std::string& content, std::string& error);

bool isValidProgramName(const std::string& name);

}  // namespace penumbra::shaderc
