// compileProgram: the whole pipeline for one program (all stages together, because OpenGL binding
// flattening and the desktop-GLSL link check are per program).
#include "internal.h"

#include <array>
#include <cctype>
#include <filesystem>
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

namespace {

// One variant of the program: every stage compiled with `defines`, reflected, flattened for
// OpenGL and checked as desktop GLSL.
bool compileVariant(const ProgramRequest& request, const std::vector<std::string>& defines,
                    std::vector<StageOutput>& stages, std::set<std::string>& dependencies,
                    std::vector<std::string>& diagnostics) {
    bool ok = true;
    for (const StageInput& input : request.stages) {
        StageOutput stage;
        stage.stage = input.stage;
        stage.path = input.path;
        const bool compiled = detail::compileToSpirv(input, request.includeDirs, defines, nullptr,
                                                     stage.spirv, stage.files, diagnostics);
        dependencies.insert(stage.files.begin(), stage.files.end());
        if (!compiled) {
            ok = false;
            continue;
        }
        if (!detail::reflectStage(stage, diagnostics)) ok = false;
        if (!detail::reflectLayouts(stage, diagnostics)) ok = false;
        stages.push_back(std::move(stage));
    }
    if (!ok) return false;

    if (!detail::assignGlBindings(stages, diagnostics)) return false;
    for (StageOutput& stage : stages) {
        if (!detail::emitDesktopGlsl(stage, diagnostics)) ok = false;
    }
    if (!ok) return false;
    return detail::checkDesktopGlsl(stages, diagnostics);
}

std::string joined(const std::vector<std::string>& items, const char* separator) {
    std::string out;
    for (const std::string& item : items) out += (out.empty() ? "" : separator) + item;
    return out;
}

}  // namespace

bool reflectViewBlock(const std::string& viewGlsl, StructLayout& view, std::set<std::string>& dependencies,
                      std::vector<std::string>& diagnostics) {
    // The include file compiled alone, inside a minimal compute shader.
    std::error_code ec;
    const std::string absolute = std::filesystem::absolute(viewGlsl, ec).lexically_normal().string();
    const std::string wrapper =
        "#version 450\n#include \"" + absolute + "\"\nlayout(local_size_x = 1) in;\nvoid main() {}\n";
    StageOutput stage;
    stage.stage = rhi::ShaderStage::Compute;
    stage.path = viewGlsl + " (compiled alone)";
    const StageInput input{rhi::ShaderStage::Compute, stage.path};
    const bool compiled =
        detail::compileToSpirv(input, {}, {}, &wrapper, stage.spirv, stage.files, diagnostics);
    dependencies.insert(stage.files.begin(), stage.files.end());
    if (!compiled || !detail::reflectLayouts(stage, diagnostics)) return false;
    for (const StructLayout& layout : stage.layouts) {
        if (layout.name != kViewBlockName) continue;
        if (layout.kind != BlockKind::UniformBlock || layout.set != kViewSet ||
            layout.binding != kViewBinding) {
            diagnostics.push_back(layout.origin + ": error: '" + kViewBlockName +
                                  "' must be a uniform block at set 0, binding 0");
            return false;
        }
        for (const StructMember& m : layout.members) {
            if (m.isStruct) {
                diagnostics.push_back(m.origin +
                                      ": error: the shared per-view block has no struct members (member '" +
                                      m.name + "'); keep it flat");
                return false;
            }
        }
        view = layout;
        view.size = (view.declaredSize + 3u) & ~3u;
        return true;
    }
    diagnostics.push_back(viewGlsl + ": error: declares no uniform block named " + kViewBlockName);
    return false;
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
    if (!request.viewGlsl.empty() && request.name == "view") {
        diagnostics.push_back(
            "error: the program name 'view' is reserved for the shared per-view header view.h");
        return false;
    }

    std::vector<VariantOutput> variants;
    const bool pragmasOk = detail::parseVariantPragmas(request.stages, variants, diagnostics);
    if (!compileVariant(request, {}, out.stages, out.dependencies, diagnostics) || !pragmasOk) return false;

    bool ok = true;
    for (VariantOutput& variant : variants) {
        if (!compileVariant(request, variant.defines, variant.stages, out.dependencies, diagnostics)) {
            diagnostics.push_back(variant.origin + ": note: while compiling variant " + variant.name + " (" +
                                  joined(variant.defines, " + ") + ")");
            ok = false;
            continue;
        }
        // A variant that compiles to the default's code means its defines are never used.
        bool differs = false;
        for (size_t i = 0; i < variant.stages.size(); ++i) {
            differs |= variant.stages[i].spirv != out.stages[i].spirv;
        }
        if (!differs) {
            diagnostics.push_back(
                variant.origin + ": error: variant " + variant.name + " (" + joined(variant.defines, " + ") +
                ") compiles to the same code as the Default variant: no stage of program '" + request.name +
                "' uses " + joined(variant.defines, " or "));
            ok = false;
        }
    }
    if (!ok) return false;
    out.variants = std::move(variants);

    StructLayout view;
    if (!request.viewGlsl.empty() &&
        !reflectViewBlock(request.viewGlsl, view, out.dependencies, diagnostics)) {
        return false;
    }
    return detail::resolveProgramInterface(out, request.viewGlsl.empty() ? nullptr : &view, diagnostics);
}

}  // namespace penumbra::shaderc
