#include "shaderc_test_util.h"

#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <spirv-tools/libspirv.hpp>

#include <sys/wait.h>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>

namespace fs = std::filesystem;

namespace shaderc_test {
namespace {

std::string shellQuote(const std::string& s) {
    std::string out = "'";
    for (char c : s) {
        if (c == '\'') {
            out += "'\\''";
        } else {
            out += c;
        }
    }
    return out + "'";
}

EShLanguage languageOf(rhi::ShaderStage stage) {
    switch (stage) {
        case rhi::ShaderStage::Vertex:
            return EShLangVertex;
        case rhi::ShaderStage::Fragment:
            return EShLangFragment;
        case rhi::ShaderStage::Compute:
            return EShLangCompute;
    }
    return EShLangCompute;
}

}  // namespace

RunResult runShaderc(const std::vector<std::string>& args) {
    std::string command = shellQuote(SHADERC_EXECUTABLE);
    for (const std::string& a : args) command += " " + shellQuote(a);
    return runCommand(command);
}

void writeFile(const std::string& path, const std::string& text) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
}

RunResult runCommand(const std::string& shellCommand) {
    const std::string command = shellCommand + " 2>&1";
    RunResult result;
    FILE* pipe = popen(command.c_str(), "r");
    if (!pipe) return result;
    std::array<char, 4096> buffer{};
    size_t n = 0;
    while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
    const int status = pclose(pipe);
    result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return result;
}

std::string fixture(const std::string& relative) { return (fs::path(SHADERC_FIXTURES) / relative).string(); }

std::string scratchDir(const std::string& name) {
    const fs::path dir = fs::path(SHADERC_SCRATCH) / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir.string();
}

std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

std::string compileDesktopGlsl(const std::vector<const rhi::ShaderDesc*>& stages) {
    static std::once_flag once;
    std::call_once(once, [] { glslang::InitializeProcess(); });
    std::vector<std::unique_ptr<glslang::TShader>> shaders;
    glslang::TProgram program;
    for (const rhi::ShaderDesc* desc : stages) {
        auto shader = std::make_unique<glslang::TShader>(languageOf(desc->stage));
        const std::string text(desc->glsl);
        const char* ptr = text.c_str();
        shader->setStrings(&ptr, 1);
        if (!shader->parse(GetDefaultResources(), 450, ECoreProfile, false, false, EShMsgDefault)) {
            return std::string(desc->debugName) + ": " + shader->getInfoLog();
        }
        program.addShader(shader.get());
        shaders.push_back(std::move(shader));
    }
    if (!program.link(EShMsgDefault)) return std::string("link: ") + program.getInfoLog();
    return "";
}

std::string validateSpirv(const rhi::ShaderDesc& desc) {
    spvtools::SpirvTools tools(SPV_ENV_VULKAN_1_3);
    std::string messages;
    tools.SetMessageConsumer([&](spv_message_level_t, const char*, const spv_position_t&, const char* m) {
        messages += m;
        messages += '\n';
    });
    if (!tools.Validate(desc.spirv.data(), desc.spirv.size(), spvtools::ValidatorOptions())) {
        return messages.empty() ? "invalid" : messages;
    }
    return "";
}

}  // namespace shaderc_test
