// C++ emission of a compiled program, the depfile, and write-if-changed output.
#include "internal.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
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

void emitSpirv(std::ostringstream& os, const StageOutput& stage) {
    os << "constexpr uint32_t " << stagePrefix(stage.stage) << "Spirv[] = {";
    for (size_t i = 0; i < stage.spirv.size(); ++i) {
        if (i % 8 == 0) os << "\n   ";
        char buf[16];
        std::snprintf(buf, sizeof(buf), " 0x%08xu,", stage.spirv[i]);
        os << buf;
    }
    os << "\n};\n\n";
}

// The GLSL text as a NUL-terminated char array, each source line shown as a comment above its bytes.
void emitGlsl(std::ostringstream& os, const StageOutput& stage) {
    os << "// GLSL 4.50 core for OpenGL: descriptor sets removed, bindings flattened.\n";
    os << "constexpr char " << stagePrefix(stage.stage) << "Glsl[] = {\n";
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

void emitBindings(std::ostringstream& os, const StageOutput& stage) {
    if (stage.bindings.empty()) return;
    os << "constexpr rhi::ShaderBinding " << stagePrefix(stage.stage) << "Bindings[] = {\n";
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

void emitVertexInputs(std::ostringstream& os, const StageOutput& stage) {
    if (stage.vertexInputs.empty()) return;
    os << "constexpr rhi::VertexInputReflection " << stagePrefix(stage.stage) << "Inputs[] = {\n";
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

}  // namespace

std::string generateHeader(const ProgramOutput& program) {
    std::ostringstream os;
    os << "// Generated by penumbra-shaderc from";
    for (const StageOutput& s : program.stages) os << ' ' << fileName(s.path);
    os << ". Do not edit.\n"
       << "#pragma once\n\n"
       << "#include <rhi/types.h>\n\n"
       << "namespace penumbra::shaders::" << program.name << " {\n\n";
    for (const StageOutput& s : program.stages) {
        os << "// " << fileName(s.path) << ": SPIR-V, OpenGL GLSL and reflection.\n"
           << "const rhi::ShaderDesc& " << stageFunction(s.stage) << "();\n";
    }
    os << "\n}  // namespace penumbra::shaders::" << program.name << "\n";
    return os.str();
}

std::string generateSource(const ProgramOutput& program) {
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
    for (const StageOutput& s : program.stages) {
        emitSpirv(os, s);
        emitGlsl(os, s);
        emitBindings(os, s);
        emitVertexInputs(os, s);
    }
    os << "}  // namespace\n";
    for (const StageOutput& s : program.stages) {
        const std::string prefix = stagePrefix(s.stage);
        os << "\nconst rhi::ShaderDesc& " << stageFunction(s.stage) << "() {\n"
           << "    static const rhi::ShaderDesc desc{\n"
           << "        .stage = " << stageEnum(s.stage) << ",\n"
           << "        .spirv = std::span<const uint32_t>(" << prefix << "Spirv),\n"
           << "        .glsl = std::string_view(" << prefix << "Glsl, sizeof(" << prefix << "Glsl) - 1),\n";
        if (s.bindings.empty()) {
            os << "        .bindings = {},\n";
        } else {
            os << "        .bindings = std::span<const rhi::ShaderBinding>(" << prefix << "Bindings),\n";
        }
        if (s.vertexInputs.empty()) {
            os << "        .vertexInputs = {},\n";
        } else {
            os << "        .vertexInputs = std::span<const rhi::VertexInputReflection>(" << prefix
               << "Inputs),\n";
        }
        os << "        .pushConstantSize = " << s.pushConstantSize << ",\n"
           << "        .workgroupSize = {" << s.workgroupSize[0] << ", " << s.workgroupSize[1] << ", "
           << s.workgroupSize[2] << "},\n"
           << "        .debugName = \"" << escapeLiteral(program.name + "." + detail::stageFileKind(s.stage))
           << "\",\n"
           << "    };\n"
           << "    return desc;\n"
           << "}\n";
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
