// penumbra — command-line front end.
//   penumbra info [--backend vulkan|gl]      device, driver and limits
//   penumbra render <scene> -o out.png [...] a scene through the embedding API (cmd_render.cpp)
//   penumbra demo -o out.png [--backend] [--width --height] [--aov]   the built-in demo scene + timings
//   penumbra bake <mesh> -o out.psdf [...]   mesh -> signed distance field (cmd_bake.cpp)
//   penumbra sdf info|sample <file.psdf>     inspect / sample a .psdf file (cmd_sdf.cpp)
//   penumbra reference <scene> -o DIR --aov ...  CPU reference AOVs as PFM (cmd_reference.cpp)
//   penumbra bench trace [scene] [...]        benchmarks for docs/BENCHMARKS.md (cmd_bench.cpp)
//   penumbra bench accuracy -o DIR [...]      speed against error (cmd_bench_accuracy.cpp)
//   penumbra bench objects [...]              cost against object count (bench_objects.cpp)
//   penumbra bench trace-modes [...]          full-screen vs box tracing (bench_trace_modes.cpp)
// Global flags (-v, --version, --help) are accepted before or after the subcommand. Every command
// checks its inputs, outputs, backend and image size before the work and writes its outputs all or
// nothing (cli_common.h, engine/core/output_file.h).
// Exit codes: 0 ok, 1 runtime error, 2 usage error.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "aov_output.h"
#include "cli_common.h"
#include "cmd_bench.h"
#include "cmd_reference.h"
#include "cmd_render.h"
#include "cmd_sdf.h"
#include "engine/core/log.h"
#include "engine/core/output_file.h"
#include "engine/engine.h"
#include "engine/image/image.h"
#include "engine/scene/demo_scene.h"
#include "engine/scene/mesh_sdf.h"
#include "renderer/renderer.h"
#include "rhi/device.h"

namespace {

struct DeviceOptions {
    std::string backend;  // empty: PENUMBRA_BACKEND or auto
    bool validation = false;
};

void addDeviceOptions(CLI::App* cmd, DeviceOptions& opt) {
    penumbra::cli::addBackendOption(cmd, opt.backend);
    cmd->add_flag("--validation", opt.validation,
                  "Enable RHI validation and the Vulkan validation layer / GL debug output");
}

// `backend` comes from --backend / $PENUMBRA_BACKEND (penumbra::cli::chooseBackend for commands
// that produce images, which refuses the null backend).
std::unique_ptr<rhi::Device> openDevice(const DeviceOptions& opt, rhi::Backend backend) {
    rhi::DeviceDesc desc;
    desc.headless = true;
    desc.validation = opt.validation;
    desc.backend = backend;
    desc.log = penumbra::engineLogCallback();
    auto device = rhi::createDevice(desc);
    if (!device)
        penumbra::log::error("no usable graphics device (backend '{}')",
                             opt.backend.empty() ? "auto" : opt.backend);
    return device;
}

int runInfo(const DeviceOptions& opt) {
    rhi::Backend backend = rhi::Backend::Auto;
    if (!opt.backend.empty() && !rhi::parseBackend(opt.backend, backend)) {
        penumbra::log::error("unknown backend '{}'", opt.backend);
        return 2;
    }
    auto device = openDevice(opt, backend);
    if (!device) return 1;
    const rhi::DeviceInfo& info = device->info();
    const rhi::DeviceLimits& l = info.limits;
    fmt::print("backend            {}\n", rhi::toString(info.backend));
    fmt::print("api                {}\n", info.apiVersion);
    fmt::print("device             {}\n", info.deviceName);
    fmt::print("driver             {} {}\n", info.driverName, info.driverVersion);
    fmt::print("platform           {}\n", info.platform);
    fmt::print("limits\n");
    fmt::print("  texture 2D/3D    {} / {} (array layers {})\n", l.maxTextureSize2D, l.maxTextureSize3D,
               l.maxTextureArrayLayers);
    fmt::print("  workgroup size   {} x {} x {} (invocations {})\n", l.maxComputeWorkgroupSize[0],
               l.maxComputeWorkgroupSize[1], l.maxComputeWorkgroupSize[2], l.maxComputeWorkgroupInvocations);
    fmt::print("  workgroup count  {} x {} x {}\n", l.maxComputeWorkgroupCount[0],
               l.maxComputeWorkgroupCount[1], l.maxComputeWorkgroupCount[2]);
    fmt::print("  storage buffer   {} bytes\n", l.maxStorageBufferRange);
    fmt::print("  uniform buffer   {} bytes\n", l.maxUniformBufferRange);
    fmt::print("  push constants   {} bytes, bind groups {}, colour targets {}\n", l.maxPushConstantSize,
               l.maxBindGroups, l.maxColorTargets);
    fmt::print("  timestamps       {} (period {} ns)\n", l.timestamps ? "yes" : "no", l.timestampPeriodNs);
    fmt::print("  conservative depth {}\n", l.conservativeDepth ? "yes" : "no");
    fmt::print("  subgroups        size {}, ops {}\n", l.subgroupSize, rhi::toString(l.subgroupOps));
    fmt::print("enabled features   {}\n", info.enabledFeatures.empty()
                                              ? "none"
                                              : fmt::format("{}", fmt::join(info.enabledFeatures, " ")));
    fmt::print("formats\n");
    for (uint32_t f = 1; f < uint32_t(rhi::Format::Count); ++f)
        fmt::print("  {:<16} {}\n", rhi::formatInfo(rhi::Format(f)).name,
                   rhi::toString(device->formatSupport(rhi::Format(f))));
    return 0;
}

void printTimings(const std::vector<penumbra::fg::PassTiming>& timings) {
    double gpuTotal = 0, cpuTotal = 0;
    fmt::print("{:<28} {:>10} {:>10}\n", "pass", "GPU ms", "CPU ms");
    for (const auto& t : timings) {
        fmt::print("{:<28} {:>10.3f} {:>10.3f}\n", t.name, t.gpuMs, t.cpuMs);
        if (std::isfinite(t.gpuMs)) gpuTotal += t.gpuMs;
        cpuTotal += t.cpuMs;
    }
    fmt::print("{:<28} {:>10.3f} {:>10.3f}\n", "total", gpuTotal, cpuTotal);
}

int runDemo(const DeviceOptions& opt, const std::string& output, uint32_t width, uint32_t height,
            const std::string& graphvizPath, const std::string& aovSpec) {
    // Everything that can be checked is checked before the frame is rendered.
    std::string err;
    penumbra::RendererDesc rendererDesc;
    rendererDesc.validation = opt.validation;
    rendererDesc.width = width;
    rendererDesc.height = height;
    if (!penumbra::cli::chooseBackend(opt.backend, "demo", rendererDesc.backend, err)) {
        penumbra::log::error("{}", err);
        return 2;
    }
    if (!penumbra::cli::checkPngPath(output, "-o", err)) {
        penumbra::log::error("demo: {}", err);
        return 2;
    }
    std::vector<penumbra::cli::AovOutput> aovs;
    if (!penumbra::cli::parseAovOutputs(aovSpec, aovs, err) ||
        !penumbra::cli::requestAuxTarget(rendererDesc, aovs, err)) {
        penumbra::log::error("demo: {}", err);
        return 2;
    }
    std::vector<std::string> outputPaths = penumbra::cli::aovPaths(aovs);
    outputPaths.insert(outputPaths.begin(), {output, graphvizPath});
    penumbra::OutputFiles outputs;
    if (!penumbra::cli::prepareOutputs(outputs, outputPaths, "demo")) return 1;
    // The built-in demo scene (engine/scene/demo_scene.h) through the scene renderer: the same
    // frame path as `penumbra render`.
    std::unique_ptr<penumbra::Engine> engine = penumbra::Engine::create({}, err);
    // Its meshes cast shadows and AO through baked occlusion fields, as any scene's do by default
    // (render.meshSdf auto: docs/FORMATS.md).
    if (!engine || !penumbra::scene::buildDemoScene(engine->assets(), engine->scene(), err) ||
        !penumbra::scene::applyMeshSdf(engine->scene(), engine->assets(), engine->settings().meshSdf, err)) {
        penumbra::log::error("demo: {}", err);
        return 1;
    }
    std::unique_ptr<penumbra::Renderer> renderer = penumbra::Renderer::create(*engine, rendererDesc, err);
    if (!renderer) {
        penumbra::log::error("{}", err);
        return 1;
    }
    if (!penumbra::cli::refuseNullDevice(renderer->device(), "demo", err) ||
        !penumbra::cli::checkImageSize(width, height, renderer->device(), "demo: --width/--height", err)) {
        penumbra::log::error("{}", err);
        return 2;
    }
    const rhi::DeviceInfo& info = renderer->device().info();
    fmt::print("penumbra demo: {} on {} ({}), {}x{}\n", rhi::toString(info.backend), info.deviceName,
               info.platform, width, height);
    penumbra::ImageRGBA8 image;
    if (!renderer->renderFrame(*engine, err) || !renderer->readPixels(image, err)) {
        penumbra::log::error("demo frame failed: {}", err);
        return 1;
    }
    if (!penumbra::cli::writePngOutput(outputs, output, image, err) ||
        (!graphvizPath.empty() && !outputs.writeText(graphvizPath, renderer->frameGraphviz(), err)) ||
        !penumbra::cli::writeAovOutputs(outputs, renderer->sceneRenderer(), width, height, aovs, err)) {
        penumbra::log::error("demo: {}", err);
        return 1;
    }
    const penumbra::render::FrameStats& stats = renderer->stats();  // waits for the frame's timings
    printTimings(stats.passes);
    fmt::print("entities {}, draw calls {}, triangles {}, lights {}\n", engine->world().aliveCount(),
               stats.drawCalls, stats.triangles, stats.lights);
    // A run with validation errors failed: its outputs are not kept.
    if (opt.validation && renderer->validationErrors() != 0) {
        penumbra::log::error("{} validation error(s) reported; no output written",
                             renderer->validationErrors());
        return 1;
    }
    if (!outputs.commit(err)) {
        penumbra::log::error("demo: {}", err);
        return 1;
    }
    fmt::print("wrote {}\n", output);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"penumbra — signed-distance-field rendering module: command-line front end"};
    app.require_subcommand(1);
    // Subcommands created below inherit this: options they do not know (the global -v) are handed
    // to the parent, so `penumbra render scene.json -v` works like `penumbra -v render scene.json`.
    app.fallthrough();
    app.set_version_flag("--version", std::string("penumbra ") + PENUMBRA_VERSION,
                         "Print the version and exit");
    bool verbose = false;
    app.add_flag("-v,--verbose", verbose, "Also print informational and debug messages from the device");

    DeviceOptions infoOpt;
    auto* info = app.add_subcommand("info", "Print the graphics device, driver and limits");
    addDeviceOptions(info, infoOpt);

    DeviceOptions demoOpt;
    std::string output = "out/default.png", graphviz, demoAov;
    uint32_t width = 640, height = 360;
    auto* demo = app.add_subcommand(
        "demo", "Render the built-in demo scene (no scene file) to a PNG and print per-pass GPU/CPU times");
    addDeviceOptions(demo, demoOpt);
    demo->add_option("-o,--output", output, "Output PNG path (.png)")->capture_default_str();
    penumbra::cli::addSizeOption(demo, "--width", width,
                                 "Image width in pixels (1 .. device max 2D texture size)")
        ->capture_default_str();
    penumbra::cli::addSizeOption(demo, "--height", height,
                                 "Image height in pixels (1 .. device max 2D texture size)")
        ->capture_default_str();
    demo->add_option("--graphviz", graphviz, "Also write the frame graph as Graphviz dot to this file");
    penumbra::cli::addAovOption(demo, demoAov);

    penumbra::cli::RenderOptions renderOpt;
    auto* render = penumbra::cli::addRenderCommand(app, renderOpt);
    penumbra::cli::ReferenceOptions referenceOpt;
    auto* reference = penumbra::cli::addReferenceCommand(app, referenceOpt);

    penumbra::cli::BakeOptions bakeOpt;
    auto* bake = penumbra::cli::addBakeCommand(app, bakeOpt);
    penumbra::cli::SdfInfoOptions sdfInfoOpt;
    penumbra::cli::SdfSampleOptions sdfSampleOpt;
    CLI::App* sdfInfo = nullptr;
    CLI::App* sdfSample = nullptr;
    penumbra::cli::addSdfCommand(app, sdfInfoOpt, sdfSampleOpt, &sdfInfo, &sdfSample);
    penumbra::cli::BenchTraceOptions benchTraceOpt;
    const penumbra::cli::BenchCommands bench = penumbra::cli::addBenchCommand(app, benchTraceOpt);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help / --version exit 0; every usage error exits 2 with CLI11's message.
        return app.exit(e) == 0 ? 0 : 2;
    }
    penumbra::log::setMinSeverity(verbose ? penumbra::log::Severity::Debug
                                          : penumbra::log::Severity::Warning);
    if (info->parsed()) return runInfo(infoOpt);
    if (render->parsed()) return penumbra::cli::runRender(renderOpt);
    if (reference->parsed()) return penumbra::cli::runReference(referenceOpt);
    if (demo->parsed()) return runDemo(demoOpt, output, width, height, graphviz, demoAov);
    if (bake->parsed()) {
        std::string commandLine;
        for (int i = 0; i < argc; ++i) commandLine += (i ? " " : "") + std::string(argv[i]);
        return penumbra::cli::runBake(bakeOpt, commandLine);
    }
    if (sdfInfo->parsed()) return penumbra::cli::runSdfInfo(sdfInfoOpt);
    if (sdfSample->parsed()) return penumbra::cli::runSdfSample(sdfSampleOpt);
    if (bench.trace->parsed()) return penumbra::cli::runBenchTrace(benchTraceOpt);
    if (bench.accuracy->parsed()) return penumbra::cli::runBenchAccuracy(*bench.accuracyOptions);
    if (bench.objects->parsed()) return penumbra::cli::runBenchObjects(*bench.objectsOptions);
    if (bench.traceModes->parsed()) return penumbra::cli::runBenchTraceModes(*bench.traceModesOptions);
    return 2;
}
