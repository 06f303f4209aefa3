// penumbra-shaderc: command-line front end of the shader compiler (see tools/shaderc/README.md).
#include "shaderc.h"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <iostream>

namespace fs = std::filesystem;

int main(int argc, char** argv) {
    CLI::App app{
        "penumbra-shaderc: compiles one shader program (GLSL 450, Vulkan semantics) into SPIR-V, OpenGL "
        "GLSL 4.50 with flattened bindings and reflection, emitted as <out-dir>/<name>.h and <name>.cpp "
        "declaring penumbra::shaders::<name>::compute() or vertex() + fragment(), one per variant, with "
        "C++ structs for the parameter blocks and named slots. With --view-header: writes <out-dir>/view.h "
        "with the struct of the shared per-view block of --view-glsl.",
        "penumbra-shaderc"};
    std::string name;
    std::string outDir;
    std::string comp;
    std::string vert;
    std::string frag;
    std::string depfile;
    std::string viewGlsl;
    bool viewHeader = false;
    std::vector<std::string> includeDirs;
    auto* nameOpt = app.add_option("--name", name, "Program name (a C++ identifier; becomes the namespace)");
    app.add_option("--out-dir", outDir, "Folder for <name>.h and <name>.cpp (or view.h)")->required();
    auto* compOpt = app.add_option("--comp", comp, "Compute shader source");
    auto* vertOpt = app.add_option("--vert", vert, "Vertex shader source (needs --frag)");
    auto* fragOpt = app.add_option("--frag", frag, "Fragment shader source (needs --vert)");
    app.add_option("-I,--include-dir", includeDirs, "Folder searched for #include files (repeatable)");
    app.add_option("--depfile", depfile, "Write a Makefile-syntax depfile listing every file read");
    app.add_option("--view-glsl", viewGlsl,
                   "The shared per-view block's source (view.glsl): uniform blocks named View must have its "
                   "layout, and the program's header uses <shaders/view.h> for it");
    auto* viewHeaderOpt = app.add_flag(
        "--view-header", viewHeader, "Only write <out-dir>/view.h: the C++ struct of the --view-glsl block");
    viewHeaderOpt->excludes(nameOpt)->excludes(compOpt)->excludes(vertOpt)->excludes(fragOpt);
    compOpt->excludes(vertOpt)->excludes(fragOpt);
    vertOpt->needs(fragOpt);
    fragOpt->needs(vertOpt);
    CLI11_PARSE(app, argc, argv);

    std::string error;
    if (viewHeader) {
        if (viewGlsl.empty()) {
            std::cerr << "penumbra-shaderc: error: --view-header needs --view-glsl <file>\n";
            return 2;
        }
        penumbra::shaderc::StructLayout view;
        std::set<std::string> dependencies;
        std::vector<std::string> diagnostics;
        const bool ok = penumbra::shaderc::reflectViewBlock(viewGlsl, view, dependencies, diagnostics);
        for (const std::string& line : diagnostics) std::cerr << line << '\n';
        if (!ok) {
            std::cerr << "penumbra-shaderc: the per-view block of " << viewGlsl << " failed to compile\n";
            return 1;
        }
        const std::string header = (fs::path(outDir) / "view.h").string();
        if (!penumbra::shaderc::writeFileIfChanged(
                header, penumbra::shaderc::generateViewHeader(view, viewGlsl), error) ||
            (!depfile.empty() &&
             !penumbra::shaderc::writeFileIfChanged(
                 depfile, penumbra::shaderc::generateDepfile({header}, dependencies), error))) {
            std::cerr << "penumbra-shaderc: error: " << error << '\n';
            return 1;
        }
        return 0;
    }
    if (name.empty()) {
        std::cerr << "penumbra-shaderc: error: --name is required\nRun with --help for more information.\n";
        return 2;
    }

    penumbra::shaderc::ProgramRequest request;
    request.name = name;
    request.includeDirs = includeDirs;
    request.viewGlsl = viewGlsl;
    if (!comp.empty()) {
        request.stages.push_back({rhi::ShaderStage::Compute, comp});
    } else if (!vert.empty() && !frag.empty()) {
        request.stages.push_back({rhi::ShaderStage::Vertex, vert});
        request.stages.push_back({rhi::ShaderStage::Fragment, frag});
    } else {
        std::cerr << "penumbra-shaderc: error: give --comp <file>, or --vert <file> and --frag <file>\n"
                  << "Run with --help for more information.\n";
        return 2;
    }

    penumbra::shaderc::ProgramOutput program;
    std::vector<std::string> diagnostics;
    const bool ok = penumbra::shaderc::compileProgram(request, program, diagnostics);
    for (const std::string& line : diagnostics) std::cerr << line << '\n';
    if (!ok) {
        std::cerr << "penumbra-shaderc: shader program '" << name << "' failed to compile\n";
        return 1;
    }

    const std::string header = (fs::path(outDir) / (name + ".h")).string();
    const std::string source = (fs::path(outDir) / (name + ".cpp")).string();
    if (!penumbra::shaderc::writeFileIfChanged(header, penumbra::shaderc::generateHeader(program), error) ||
        !penumbra::shaderc::writeFileIfChanged(source, penumbra::shaderc::generateSource(program), error)) {
        std::cerr << "penumbra-shaderc: error: " << error << '\n';
        return 1;
    }
    if (!depfile.empty()) {
        const std::string text = penumbra::shaderc::generateDepfile({header, source}, program.dependencies);
        if (!penumbra::shaderc::writeFileIfChanged(depfile, text, error)) {
            std::cerr << "penumbra-shaderc: error: " << error << '\n';
            return 1;
        }
    }
    return 0;
}
