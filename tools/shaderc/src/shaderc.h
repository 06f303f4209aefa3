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
    // The shared per-view block's source (renderer/shaders/view.glsl). When set, every uniform
    // block named kViewBlockName must be at set 0, binding 0 with exactly its layout, and the
    // generated header uses the struct of the shared view header instead of its own.
    std::string viewGlsl;
};

// The shared per-view/per-frame uniform block: its type name and its (set, binding).
inline constexpr const char* kViewBlockName = "View";
inline constexpr uint32_t kViewSet = 0;
inline constexpr uint32_t kViewBinding = 0;

// One member of a generated parameter struct (offsets and sizes in bytes).
struct StructMember {
    std::string name;
    std::string glslType;      // as written in GLSL: "vec4", "mat3", "uint", or a struct name
    std::string cppType;       // element type: "::glm::vec4", "float", "uint32_t", or a struct name
    bool isStruct = false;     // cppType is another generated struct
    uint32_t arraySize = 0;    // 0: not an array
    uint32_t arrayStride = 0;  // arrays only
    uint32_t offset = 0;
    uint32_t elementSize = 0;  // C++ size of one element (structs: resolved by the program)
    uint32_t size = 0;         // C++ size of the member (elementSize * max(arraySize, 1))
    std::string origin;        // "path:line" of its declaration (diagnostics)
};

enum class BlockKind { UniformBlock, PushConstant, StorageBlock, Struct };

// A uniform block, push-constant block, storage block (without a runtime-sized array) or a struct
// used inside one, as a C++ struct whose layout equals the GLSL one.
struct StructLayout {
    std::string name;  // the GLSL type name
    BlockKind kind = BlockKind::Struct;
    uint32_t set = 0;  // blocks with a descriptor (uniform/storage)
    uint32_t binding = 0;
    std::vector<StructMember> members;  // in offset order
    uint32_t declaredSize = 0;          // SPIR-V declared size
    uint32_t size = 0;                  // sizeof of the C++ struct (declared size + tail padding)
    uint32_t runtimeArrayStride = 0;    // stride of a runtime-sized array of this struct (0: none)
    std::string origin;                 // "path:line" (or "path") where the GLSL type is declared
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
    std::vector<std::string> files;     // the source, then every file it included (diagnostics)
    std::vector<StructLayout> layouts;  // blocks of this stage and the structs inside them
    std::string pushConstantBlock;      // type name of the push-constant block ("" if none)
};

// A variant declared with `#pragma penumbra_variants`: the program compiled with `defines`.
struct VariantOutput {
    std::string name;                  // C++ enumerator, e.g. "AlbedoOnly" for ALBEDO_ONLY
    std::vector<std::string> defines;  // each #defined to 1
    std::string origin;                // "path:line" of the declaring pragma
    std::vector<StageOutput> stages;
};

struct ProgramOutput {
    std::string name;
    std::vector<StageOutput> stages;      // the Default variant (no defines)
    std::vector<VariantOutput> variants;  // the declared variants, in declaration order
    std::set<std::string> dependencies;   // every source and included file that was read
    // Parameter structs of all stages and variants, each struct after the structs it contains.
    // The shared View block is not among them when the program uses it (usesView).
    std::vector<StructLayout> structs;
    std::string pushConstantStruct;  // "" if no stage has push constants
    bool usesView = false;
    // One named slot per binding name over all stages and variants, sorted by (set, binding, name).
    std::vector<Binding> slots;
};

// Diagnostics are collected as lines in the `path:line: error: message` form (or `path: error:
// message` where no line applies). Returns false if the program could not be compiled.
bool compileProgram(const ProgramRequest& request, ProgramOutput& out, std::vector<std::string>& diagnostics);

// Compiles the shared per-view block's source on its own and returns its layout.
bool reflectViewBlock(const std::string& viewGlsl, StructLayout& view, std::set<std::string>& dependencies,
                      std::vector<std::string>& diagnostics);

// Generated files (see tools/shaderc/README.md for their exact shape).
std::string generateHeader(const ProgramOutput& program);
std::string generateViewHeader(const StructLayout& view, const std::string& viewGlsl);
std::string generateSource(const ProgramOutput& program);
// Makefile-syntax depfile: "<targets>: <dependencies>" with spaces escaped.
std::string generateDepfile(const std::vector<std::string>& targets,
                            const std::set<std::string>& dependencies);

// Writes `content` to `path` unless the file already holds exactly that. Creates parent folders.
bool writeFileIfChanged(const std::string& path, const std::string& content, std::string& error);

bool isValidProgramName(const std::string& name);

}  // namespace penumbra::shaderc
