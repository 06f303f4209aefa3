// C++ emission of a compiled program, the depfile, and write-if-changed output.
#include "internal.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

namespace fs = std::filesystem;

namespace penumbra::shaderc {
namespace {

const char* stageFunction(rhi::ShaderStage stage) {
    switch (stage) {
        case rhi::ShaderStage::Vertex:
            return "vertex";
        case rhi::ShaderStage::Fragment:
            return "fragment";
        case rhi::ShaderStage::Compute:
            return "compute";
    }
    return "compute";
}

const char* stagePrefix(rhi::ShaderStage stage) {
    switch (stage) {
        case rhi::ShaderStage::Vertex:
            return "kVertex";
        case rhi::ShaderStage::Fragment:
            return "kFragment";
        case rhi::ShaderStage::Compute:
            return "kCompute";
    }
    return "kCompute";
}

const char* stageEnum(rhi::ShaderStage stage) {
    switch (stage) {
        case rhi::ShaderStage::Vertex:
            return "rhi::ShaderStage::Vertex";
        case rhi::ShaderStage::Fragment:
            return "rhi::ShaderStage::Fragment";
        case rhi::ShaderStage::Compute:
            return "rhi::ShaderStage::Compute";
    }
    return "rhi::ShaderStage::Compute";
}

const char* bindingTypeEnum(rhi::BindingType type) {
    switch (type) {
        case rhi::BindingType::UniformBuffer:
            return "rhi::BindingType::UniformBuffer";
        case rhi::BindingType::StorageBuffer:
            return "rhi::BindingType::StorageBuffer";
        case rhi::BindingType::ReadOnlyStorageBuffer:
            return "rhi::BindingType::ReadOnlyStorageBuffer";
        case rhi::BindingType::SampledTexture:
            return "rhi::BindingType::SampledTexture";
        case rhi::BindingType::StorageTexture:
            return "rhi::BindingType::StorageTexture";
    }
    return "rhi::BindingType::UniformBuffer";
}

const char* dimensionEnum(rhi::TextureDimension d) {
    switch (d) {
        case rhi::TextureDimension::Tex2D:
            return "rhi::TextureDimension::Tex2D";
        case rhi::TextureDimension::Tex2DArray:
            return "rhi::TextureDimension::Tex2DArray";
        case rhi::TextureDimension::Tex3D:
            return "rhi::TextureDimension::Tex3D";
    }
    return "rhi::TextureDimension::Tex2D";
}

const char* formatEnum(rhi::Format f) {
    switch (f) {
        case rhi::Format::Undefined:
            return "rhi::Format::Undefined";
        case rhi::Format::R8_UNORM:
            return "rhi::Format::R8_UNORM";
        case rhi::Format::R8_UINT:
            return "rhi::Format::R8_UINT";
        case rhi::Format::R16_FLOAT:
            return "rhi::Format::R16_FLOAT";
        case rhi::Format::R32_FLOAT:
            return "rhi::Format::R32_FLOAT";
        case rhi::Format::R32_UINT:
            return "rhi::Format::R32_UINT";
        case rhi::Format::RG16_FLOAT:
            return "rhi::Format::RG16_FLOAT";
        case rhi::Format::RG32_FLOAT:
            return "rhi::Format::RG32_FLOAT";
        case rhi::Format::RGBA8_UNORM:
            return "rhi::Format::RGBA8_UNORM";
        case rhi::Format::RGBA8_SRGB:
            return "rhi::Format::RGBA8_SRGB";
        case rhi::Format::RGBA16_FLOAT:
            return "rhi::Format::RGBA16_FLOAT";
        case rhi::Format::RGBA32_FLOAT:
            return "rhi::Format::RGBA32_FLOAT";
        case rhi::Format::D32_FLOAT:
            return "rhi::Format::D32_FLOAT";
        case rhi::Format::RGB32_FLOAT:
            return "rhi::Format::RGB32_FLOAT";
        case rhi::Format::Count:
            break;
    }
    return "rhi::Format::Undefined";
}

// A C++ string literal body for `text` (resource names are identifiers, but stay safe).
std::string escapeLiteral(const std::string& text) {
    std::string out;
    for (char c : text) {
        const auto u = static_cast<unsigned char>(c);
        if (c == '"' || c == '\\') {
            out += '\\';
            out += c;
        } else if (u < 0x20 || u >= 0x7f) {
            char buf[8];
            std::snprintf(buf, sizeof(buf), "\\%03o", u);
            out += buf;
        } else {
            out += c;
        }
    }
    return out;
}

// A GLSL line as a `//` comment: printable ASCII only and no trailing backslash (which would
// splice the next line of generated code into the comment).
std::string commentSafe(const std::string& line) {
    std::string out;
    for (char c : line) {
        const auto u = static_cast<unsigned char>(c);
        out += (u >= 0x20 && u < 0x7f) ? c : '?';
    }
    while (!out.empty() && (out.back() == '\\' || out.back() == ' ')) out.pop_back();
    return out;
}

std::string fileName(const std::string& path) { return fs::path(path).filename().string(); }

void emitSpirv(std::ostringstream& os, const StageOutput& stage, const std::string& prefix) {
    os << "constexpr uint32_t " << prefix << "Spirv[] = {";
    for (size_t i = 0; i < stage.spirv.size(); ++i) {
        if (i % 8 == 0) os << "\n   ";
        char buf[16];
        std::snprintf(buf, sizeof(buf), " 0x%08xu,", stage.spirv[i]);
        os << buf;
    }
    os << "\n};\n\n";
}

// The GLSL text as a NUL-terminated char array, each source line shown as a comment above its bytes.
void emitGlsl(std::ostringstream& os, const StageOutput& stage, const std::string& prefix) {
    os << "// GLSL 4.50 core for OpenGL: descriptor sets removed, bindings flattened.\n";
    os << "constexpr char " << prefix << "Glsl[] = {\n";
    size_t start = 0;
    while (start < stage.glsl.size()) {
        size_t end = stage.glsl.find('\n', start);
        end = end == std::string::npos ? stage.glsl.size() : end + 1;
        const std::string line = stage.glsl.substr(start, end - start);
        std::string shown = line;
        if (!shown.empty() && shown.back() == '\n') shown.pop_back();
        os << "    // " << commentSafe(shown) << "\n";
        for (size_t i = 0; i < line.size(); ++i) {
            if (i % 24 == 0) os << (i == 0 ? "   " : "\n   ");
            os << ' ' << static_cast<int>(static_cast<signed char>(line[i])) << ',';
        }
        os << "\n";
        start = end;
    }
    os << "    0};\n\n";
}

void emitBindings(std::ostringstream& os, const StageOutput& stage, const std::string& prefix) {
    if (stage.bindings.empty()) return;
    os << "constexpr rhi::ShaderBinding " << prefix << "Bindings[] = {\n";
    for (const Binding& b : stage.bindings) {
        os << "    {.name = \"" << escapeLiteral(b.name) << "\",\n"
           << "     .set = " << b.set << ",\n"
           << "     .binding = " << b.binding << ",\n"
           << "     .type = " << bindingTypeEnum(b.type) << ",\n"
           << "     .count = " << b.count << ",\n"
           << "     .glBinding = " << b.glBinding << ",\n"
           << "     .textureDimension = " << dimensionEnum(b.textureDimension) << ",\n"
           << "     .storageFormat = " << formatEnum(b.storageFormat) << ",\n"
           << "     .writes = " << (b.writes ? "true" : "false") << "},\n";
    }
    os << "};\n\n";
}

void emitVertexInputs(std::ostringstream& os, const StageOutput& stage, const std::string& prefix) {
    if (stage.vertexInputs.empty()) return;
    os << "constexpr rhi::VertexInputReflection " << prefix << "Inputs[] = {\n";
    for (const rhi::VertexInputReflection& v : stage.vertexInputs) {
        os << "    {.location = " << v.location << ", .format = " << formatEnum(v.format) << "},\n";
    }
    os << "};\n\n";
}

std::string escapeDepfilePath(const std::string& path) {
    std::string out;
    for (char c : path) {
        if (c == ' ' || c == '#') out += '\\';
        if (c == '$') out += '$';
        out += c;
    }
    return out;
}

// "path:line" -> "file:line" (generated code does not depend on where the tree is).
std::string shortOrigin(const std::string& origin) {
    const size_t colon = origin.rfind(':');
    if (colon != std::string::npos && colon + 1 < origin.size() &&
        origin.find_first_not_of("0123456789", colon + 1) == std::string::npos) {
        return fileName(origin.substr(0, colon)) + origin.substr(colon);
    }
    return fileName(origin);
}

std::string kindText(const StructLayout& layout) {
    switch (layout.kind) {
        case BlockKind::UniformBlock:
            return "uniform block (set " + std::to_string(layout.set) + ", binding " +
                   std::to_string(layout.binding) + ", std140 unless declared otherwise)";
        case BlockKind::PushConstant:
            return "push-constant block (std430; on OpenGL a std140 uniform block at the same offsets)";
        case BlockKind::StorageBlock:
            return "storage block (set " + std::to_string(layout.set) + ", binding " +
                   std::to_string(layout.binding) + ")";
        case BlockKind::Struct:
            return "struct";
    }
    return "struct";
}

// glm headers for the C++ types used by `structs`.
std::set<std::string> glmHeaders(const std::vector<const StructLayout*>& structs) {
    std::set<std::string> headers;
    for (const StructLayout* layout : structs) {
        for (const StructMember& m : layout->members) {
            if (m.isStruct || m.cppType.rfind("::glm::", 0) != 0) continue;
            const std::string type = m.cppType.substr(7);  // vec4, ivec2, mat3x4
            const size_t vec = type.find("vec");
            if (vec != std::string::npos) {
                headers.insert("glm/vec" + type.substr(vec + 3) + ".hpp");
            } else if (type.find('x') != std::string::npos) {
                headers.insert("glm/" + type + ".hpp");  // mat3x4
            } else {
                headers.insert("glm/" + type + "x" + type.substr(3) + ".hpp");  // mat4 -> mat4x4
            }
        }
    }
    return headers;
}

// One parameter struct with explicit padding, then a static_assert for its size and for the
// offset of every member: a C++ layout that differs from the GLSL one does not compile.
void emitStruct(std::ostringstream& os, const StructLayout& layout, const std::string& qualifier) {
    std::set<std::string> names;
    for (const StructMember& m : layout.members) names.insert(m.name);
    uint32_t padIndex = 0;
    auto padName = [&] {
        std::string name = "_pad" + std::to_string(padIndex++);
        while (names.count(name)) name += '_';
        names.insert(name);
        return name;
    };

    os << "// " << layout.name << ": " << kindText(layout) << ", declared at " << shortOrigin(layout.origin)
       << ".\n"
       << "struct " << layout.name << " {\n";
    uint32_t at = 0;
    for (const StructMember& m : layout.members) {
        if (m.offset > at) {
            os << "    unsigned char " << padName() << "[" << (m.offset - at) << "]{};  // padding\n";
        }
        const std::string type = m.isStruct ? qualifier + m.cppType : m.cppType;
        os << "    " << type << ' ' << m.name;
        if (m.arraySize > 0) os << '[' << m.arraySize << ']';
        os << "{};  // " << m.glslType;
        if (m.arraySize > 0) os << '[' << m.arraySize << ']';
        os << ", offset " << m.offset << "\n";
        at = m.offset + m.size;
    }
    if (layout.size > at) {
        os << "    unsigned char " << padName() << "[" << (layout.size - at) << "]{};  // padding\n";
    }
    os << "};\n";
    os << "static_assert(sizeof(" << layout.name << ") == " << layout.size << ", \"" << layout.name
       << ": the C++ size differs from the GLSL layout\");\n";
    os << "static_assert(std::is_standard_layout_v<" << layout.name << "> && std::is_trivially_copyable_v<"
       << layout.name << ">);\n";
    for (const StructMember& m : layout.members) {
        os << "static_assert(offsetof(" << layout.name << ", " << m.name << ") == " << m.offset << ", \""
           << layout.name << "::" << m.name << ": the C++ offset differs from the GLSL layout\");\n";
    }
    os << "\n";
}

std::string slotLiteral(const Binding& b) {
    return std::string("{\"") + escapeLiteral(b.name) + "\", " + std::to_string(b.set) + ", " +
           std::to_string(b.binding) + ", " + bindingTypeEnum(b.type) + ", " + std::to_string(b.count) + "}";
}

// Stages of variant `v` (0 = Default).
const std::vector<StageOutput>& variantStages(const ProgramOutput& program, size_t v) {
    return v == 0 ? program.stages : program.variants[v - 1].stages;
}

std::string variantName(const ProgramOutput& program, size_t v) {
    return v == 0 ? "Default" : program.variants[v - 1].name;
}

}  // namespace

std::string generateHeader(const ProgramOutput& program) {
    std::vector<const StructLayout*> structs;
    for (const StructLayout& layout : program.structs) structs.push_back(&layout);

    std::ostringstream os;
    os << "// Generated by penumbra-shaderc from";
    for (const StageOutput& s : program.stages) os << ' ' << fileName(s.path);
    os << ". Do not edit.\n"
       << "#pragma once\n\n"
       << "#include <penumbra/shader_interface.h>\n";
    if (program.usesView) os << "#include <shaders/view.h>\n";
    os << "\n";
    for (const std::string& header : glmHeaders(structs)) os << "#include <" << header << ">\n";
    os << "#include <cstddef>\n"
       << "#include <cstdint>\n"
       << "#include <type_traits>\n\n"
       << "namespace penumbra::shaders::" << program.name << " {\n\n";

    const size_t variantCount = program.variants.size() + 1;
    os << "// Variants (#pragma penumbra_variants); Default is compiled without defines.\n"
       << "enum class Variant : uint32_t {\n"
       << "    Default = 0,\n";
    for (size_t v = 1; v < variantCount; ++v) {
        const VariantOutput& variant = program.variants[v - 1];
        os << "    " << variant.name << " = " << v << ",  //";
        for (const std::string& d : variant.defines) os << ' ' << d;
        os << " (" << shortOrigin(variant.origin) << ")\n";
    }
    os << "};\n"
       << "inline constexpr uint32_t kVariantCount = " << variantCount << ";\n"
       << "inline constexpr const char* kVariantNames[kVariantCount] = {";
    for (size_t v = 0; v < variantCount; ++v) os << (v ? ", " : "") << '"' << variantName(program, v) << '"';
    os << "};\n\n";

    for (const StageOutput& s : program.stages) {
        os << "// " << fileName(s.path)
           << ": SPIR-V, OpenGL GLSL and reflection (without an argument: Default).\n"
           << "const rhi::ShaderDesc& " << stageFunction(s.stage) << "();\n"
           << "const rhi::ShaderDesc& " << stageFunction(s.stage) << "(Variant variant);\n";
    }
    os << "\n";

    if (program.usesView) {
        os << "// The shared per-view block (set 0, binding 0): declared once in <shaders/view.h>.\n"
           << "using ::penumbra::shaders::View;\n\n";
    }
    const std::string qualifier = "::penumbra::shaders::" + program.name + "::";
    for (const StructLayout& layout : program.structs) emitStruct(os, layout, qualifier);
    if (!program.pushConstantStruct.empty()) {
        os << "// The program's push constants (rhi::ShaderDesc::pushConstantSize bytes are pushed).\n"
           << "using PushConstants = " << program.pushConstantStruct << ";\n\n";
    }

    os << "// Named slots: the (set, binding) of every resource of any stage or variant, by its reflected\n"
       << "// name (block type name for buffers, variable name for textures and images).\n"
       << "namespace slot {\n";
    for (const Binding& b : program.slots) {
        os << "inline constexpr ::penumbra::shaders::SlotRef " << b.name << slotLiteral(b) << ";\n";
    }
    os << "}  // namespace slot\n";
    os << "\n}  // namespace penumbra::shaders::" << program.name << "\n";
    return os.str();
}

std::string generateViewHeader(const StructLayout& view, const std::string& viewGlsl) {
    std::ostringstream os;
    os << "// Generated by penumbra-shaderc from " << fileName(viewGlsl) << ". Do not edit.\n"
       << "#pragma once\n\n"
       << "#include <penumbra/shader_interface.h>\n\n";
    for (const std::string& header : glmHeaders({&view})) os << "#include <" << header << ">\n";
    os << "#include <cstddef>\n"
       << "#include <cstdint>\n"
       << "#include <type_traits>\n\n"
       << "namespace penumbra::shaders {\n\n"
       << "// The shared per-view/per-frame block: every program that includes " << fileName(viewGlsl)
       << " has exactly this\n// layout at set " << kViewSet << ", binding " << kViewBinding
       << " (penumbra-shaderc checks it).\n";
    emitStruct(os, view, "::penumbra::shaders::");
    Binding slot;
    slot.name = kViewBlockName;
    slot.set = kViewSet;
    slot.binding = kViewBinding;
    slot.type = rhi::BindingType::UniformBuffer;
    os << "inline constexpr ::penumbra::shaders::SlotRef kViewSlot" << slotLiteral(slot) << ";\n\n"
       << "}  // namespace penumbra::shaders\n";
    return os.str();
}

std::string generateSource(const ProgramOutput& program) {
    const size_t variantCount = program.variants.size() + 1;
    // Array names: kVertexSpirv for the Default variant, kVertex1Spirv for variant 1, ...
    auto prefixOf = [](rhi::ShaderStage stage, size_t v) {
        return std::string(stagePrefix(stage)) + (v == 0 ? "" : std::to_string(v));
    };

    std::ostringstream os;
    os << "// Generated by penumbra-shaderc from";
    for (const StageOutput& s : program.stages) os << ' ' << fileName(s.path);
    os << ". Do not edit.\n"
       << "#include \"" << program.name << ".h\"\n\n"
       << "#include <cstdint>\n"
       << "#include <span>\n"
       << "#include <string_view>\n\n"
       << "namespace penumbra::shaders::" << program.name << " {\n"
       << "namespace {\n\n";
    // A stage whose code equals an earlier variant's (a define the stage does not use) shares
    // that variant's arrays: source[v][i] is the variant whose arrays stage i of variant v uses.
    std::vector<std::vector<size_t>> source(variantCount, std::vector<size_t>(program.stages.size()));
    for (size_t v = 0; v < variantCount; ++v) {
        for (size_t i = 0; i < program.stages.size(); ++i) {
            source[v][i] = v;
            const StageOutput& s = variantStages(program, v)[i];
            for (size_t w = 0; w < v; ++w) {
                const StageOutput& earlier = variantStages(program, w)[i];
                if (earlier.spirv == s.spirv && earlier.glsl == s.glsl) {
                    source[v][i] = w;
                    break;
                }
            }
        }
    }
    for (size_t v = 0; v < variantCount; ++v) {
        if (v > 0) os << "// ---- variant " << variantName(program, v) << " ----\n\n";
        for (size_t i = 0; i < program.stages.size(); ++i) {
            const StageOutput& s = variantStages(program, v)[i];
            const std::string prefix = prefixOf(s.stage, v);
            if (source[v][i] != v) {
                os << "// " << fileName(s.path) << ": the same code as variant "
                   << variantName(program, source[v][i]) << ".\n\n";
                continue;
            }
            emitSpirv(os, s, prefix);
            emitGlsl(os, s, prefix);
            emitBindings(os, s, prefix);
            emitVertexInputs(os, s, prefix);
        }
    }
    os << "}  // namespace\n";
    for (size_t i = 0; i < program.stages.size(); ++i) {
        const rhi::ShaderStage stage = program.stages[i].stage;
        os << "\nconst rhi::ShaderDesc& " << stageFunction(stage) << "(Variant variant) {\n"
           << "    static const rhi::ShaderDesc descs[kVariantCount] = {\n";
        for (size_t v = 0; v < variantCount; ++v) {
            const StageOutput& s = variantStages(program, v)[i];
            const std::string prefix = prefixOf(stage, source[v][i]);
            std::string debugName = program.name + "." + detail::stageFileKind(stage);
            if (v > 0) debugName += "[" + variantName(program, v) + "]";
            os << "        rhi::ShaderDesc{\n"
               << "            .stage = " << stageEnum(stage) << ",\n"
               << "            .spirv = std::span<const uint32_t>(" << prefix << "Spirv),\n"
               << "            .glsl = std::string_view(" << prefix << "Glsl, sizeof(" << prefix
               << "Glsl) - 1),\n";
            if (s.bindings.empty()) {
                os << "            .bindings = {},\n";
            } else {
                os << "            .bindings = std::span<const rhi::ShaderBinding>(" << prefix
                   << "Bindings),\n";
            }
            if (s.vertexInputs.empty()) {
                os << "            .vertexInputs = {},\n";
            } else {
                os << "            .vertexInputs = std::span<const rhi::VertexInputReflection>(" << prefix
                   << "Inputs),\n";
            }
            os << "            .pushConstantSize = " << s.pushConstantSize << ",\n"
               << "            .workgroupSize = {" << s.workgroupSize[0] << ", " << s.workgroupSize[1] << ", "
               << s.workgroupSize[2] << "},\n"
               << "            .debugName = \"" << escapeLiteral(debugName) << "\",\n"
               << "        },\n";
        }
        os << "    };\n"
           << "    // An out-of-range value (only possible through a cast) selects Default.\n"
           << "    const auto index = static_cast<uint32_t>(variant);\n"
           << "    return descs[index < kVariantCount ? index : 0u];\n"
           << "}\n\n"
           << "const rhi::ShaderDesc& " << stageFunction(stage) << "() { return " << stageFunction(stage)
           << "(Variant::Default); }\n";
    }
    os << "\n}  // namespace penumbra::shaders::" << program.name << "\n";
    return os.str();
}

std::string generateDepfile(const std::vector<std::string>& targets,
                            const std::set<std::string>& dependencies) {
    std::string out;
    for (size_t i = 0; i < targets.size(); ++i) {
        if (i) out += ' ';
        out += escapeDepfilePath(targets[i]);
    }
    out += ':';
    for (const std::string& dep : dependencies) out += " \\\n  " + escapeDepfilePath(dep);
    out += '\n';
    return out;
}

bool writeFileIfChanged(const std::string& path, const std::string& content, std::string& error) {
    {
        std::ifstream in(path, std::ios::binary);
        if (in) {
            std::string existing((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
            if (existing == content) return true;
        }
    }
    std::error_code ec;
    const fs::path target(path);
    if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
    if (ec) {
        error = "cannot create folder " + target.parent_path().string() + ": " + ec.message();
        return false;
    }
    const fs::path temp = target.string() + ".tmp";
    {
        std::ofstream outFile(temp, std::ios::binary | std::ios::trunc);
        if (!outFile) {
            error = "cannot write " + temp.string();
            return false;
        }
        outFile << content;
        outFile.close();
        if (!outFile) {
            error = "cannot write " + temp.string();
            return false;
        }
    }
    fs::rename(temp, target, ec);
    if (ec) {
        error = "cannot rename " + temp.string() + " to " + path + ": " + ec.message();
        fs::remove(temp, ec);
        return false;
    }
    return true;
}

}  // namespace penumbra::shaderc
