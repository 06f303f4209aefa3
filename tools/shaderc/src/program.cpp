// compileProgram: the whole pipeline for one program (all stages together, because OpenGL binding
// flattening and the desktop-GLSL link check are per program).
#include "internal.h"

#include <array>
#include <cctype>
#include <string_view>

namespace penumbra::shaderc {

bool isValidProgramName(const std::string& name) {
    if (name.empty() || std::isdigit(static_cast<unsigned char>(name.front()))) return false;
    for (char c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
    }
    // Names become C++ namespaces: reject the keywords a shader file is plausibly named after.
    static constexpr std::array<std::string_view, 24> kKeywords = {
        "default", "delete", "new",    "class", "struct", "union", "namespace", "template",
        "this",    "switch", "case",   "for",   "while",  "do",    "if",        "else",
        "return",  "const",  "static", "auto",  "int",    "float", "void",      "operator"};
    for (std::string_view k : kKeywords) {
        if (name == k) return false;
    }
    return true;
}

bool compileProgram(const ProgramRequest& request, ProgramOutput& out,
                    std::vector<std::string>& diagnostics) {
    out = ProgramOutput{};
    out.name = request.name;
    if (!isValidProgramName(request.name)) {
        diagnostics.push_back("error: program name '" + request.name + "' is not a usable C++ identifier");
        return false;
    }
    const bool isCompute = request.stages.size() == 1 && request.stages[0].stage == rhi::ShaderStage::Compute;
    const bool isGraphics = request.stages.size() == 2 &&
                            request.stages[0].stage == rhi::ShaderStage::Vertex &&
                            request.stages[1].stage == rhi::ShaderStage::Fragment;
    if (!isCompute && !isGraphics) {
        diagnostics.push_back("error: program '" + request.name +
                              "' must be one compute shader or one vertex + one fragment shader");
        return false;
    }

    bool ok = true;
    for (const StageInput& input : request.stages) {
        StageOutput stage;
        stage.stage = input.stage;
        stage.path = input.path;
        if (!detail::compileToSpirv(input, request.includeDirs, stage.spirv, out.dependencies, diagnostics)) {
            ok = false;
            continue;
        }
        if (!detail::reflectStage(stage, diagnostics)) ok = false;
        out.stages.push_back(std::move(stage));
    }
    if (!ok) return false;

    if (!detail::assignGlBindings(out.stages, diagnostics)) return false;
    for (StageOutput& stage : out.stages) {
        if (!detail::emitDesktopGlsl(stage, diagnostics)) ok = false;
    }
    if (!ok) return false;
    return detail::checkDesktopGlsl(out.stages, diagnostics);
}

}  // namespace penumbra::shaderc
