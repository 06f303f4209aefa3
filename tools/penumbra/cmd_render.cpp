#include "cmd_render.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "aov_output.h"
#include "cli_common.h"
#include "engine/core/log.h"
#include "engine/core/output_file.h"
#include "engine/ecs/components.h"
#include "engine/engine.h"
#include "engine/image/image.h"
#include "engine/scene/mesh_sdf.h"
#include "renderer/renderer.h"

namespace penumbra::cli {
namespace {

struct PassSeries {
    std::string name;
    std::vector<double> gpu, cpu;
};

// Appends every frame's pass timings to the per-pass series (first appearance order).
void addTimings(std::vector<PassSeries>& series, const std::vector<fg::FrameTimings>& frames) {
    for (const fg::FrameTimings& f : frames)
        for (const fg::PassTiming& t : f.passes) {
            auto it = std::find_if(series.begin(), series.end(),
                                   [&](const PassSeries& s) { return s.name == t.name; });
            if (it == series.end()) it = series.insert(series.end(), PassSeries{t.name, {}, {}});
            it->gpu.push_back(t.gpuMs);
            it->cpu.push_back(t.cpuMs);
        }
}

nlohmann::json jsonNumber(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

// The table: medians over all frames (the first frame also uploads meshes and textures).
void printPassTable(const std::vector<PassSeries>& series, uint32_t frames) {
    double gpuTotal = 0, cpuTotal = 0;
    fmt::print("{:<28} {:>10} {:>10}\n", "pass", "GPU ms", "CPU ms");
    for (const PassSeries& s : series) {
        const double g = median(s.gpu), c = median(s.cpu);
        fmt::print("{:<28} {:>10.3f} {:>10.3f}\n", s.name, g, c);
        if (std::isfinite(g)) gpuTotal += g;
        if (std::isfinite(c)) cpuTotal += c;
    }
    fmt::print("{:<28} {:>10.3f} {:>10.3f}\n", "total", gpuTotal, cpuTotal);
    if (frames > 1) fmt::print("(medians over {} frames)\n", frames);
}

// What a run was, for the --stats file (README: "--stats JSON").
struct StatsRun {
    const std::string& scene;
    const rhi::DeviceInfo& info;
    uint32_t width, height, frames;
    double fixedDt, simTime;
    const std::string& cacheDir;
};

nlohmann::json statsJson(const StatsRun& run, Engine& engine, const render::FrameStats& stats,
                         const std::vector<PassSeries>& series) {
    const ecs::World& world = engine.world();
    const assets::AssetManager& assets = engine.assets();
    nlohmann::json j;
    j["scene"] = run.scene;
    j["backend"] = rhi::toString(run.info.backend);
    j["device"] = run.info.deviceName;
    j["width"] = run.width;
    j["height"] = run.height;
    j["frames"] = run.frames;
    j["fixedDt"] = run.fixedDt;
    j["simTime"] = run.simTime;
    j["updateSteps"] = engine.loop().stepCount();
    nlohmann::json passes = nlohmann::json::array();
    for (const PassSeries& s : series) {
        passes.push_back({{"name", s.name},
                          {"gpuMs", jsonNumber(median(s.gpu))},
                          {"cpuMs", jsonNumber(median(s.cpu))},
                          {"gpuMsLast", jsonNumber(s.gpu.back())},
                          {"cpuMsLast", jsonNumber(s.cpu.back())},
                          {"samples", s.gpu.size()}});
    }
    j["passes"] = passes;
    j["memory"] = {{"meshBuffers", stats.memory.meshBuffers},
                   {"sceneBuffers", stats.memory.sceneBuffers},
                   {"textures", stats.memory.textures},
                   {"renderTargets", stats.memory.renderTargets},
                   {"sdfAtlas", stats.memory.sdfAtlas},
                   {"worldCache", stats.memory.worldCache},
                   {"total", stats.memory.total()}};
    j["sdfAtlas"] = {{"bytes", stats.atlas.bytes},
                     {"fill", jsonNumber(stats.atlas.fill)},
                     {"slots", stats.atlas.slots},
                     {"size", {stats.atlas.width, stats.atlas.height, stats.atlas.depth}},
                     {"format", stats.atlas.format}};
    j["sdfUpload"] = {{"objectsUploaded", stats.sdfUpload.objectsUploaded},
                      {"fullUpload", stats.sdfUpload.fullUpload},
                      {"deltaBytes", stats.sdfUpload.deltaBytes},
                      {"uploadBytes", stats.sdfUpload.uploadBytes},
                      {"objectBufferBytes", stats.sdfUpload.objectBufferBytes}};
    j["effects"] = {{"shadowLayers", stats.effects.shadowLayers}, {"ao", stats.effects.ao},
                    {"thickness", stats.effects.thickness},       {"reflection", stats.effects.reflection},
                    {"targetBytes", stats.effects.targetBytes},   {"lowResBytes", stats.effects.lowResBytes}};
    j["tileListBytes"] = stats.tileListBytes;
    j["tileListScratchBytes"] = stats.tileListScratchBytes;
    // The SDF trace mode that ran (render.traceMode / --trace-mode, `auto` resolved) and the box
    // trace's draws (renderer/features/sdf_box_trace.h).
    j["traceMode"] = {{"ran", scene::toString(stats.traceMode)},
                      {"boxDraws", stats.boxDraws},
                      {"nearPlaneDraws", stats.nearDraws},
                      {"coverage", jsonNumber(stats.boxCoverage)}};
    const render::WorldCacheReport& wc = stats.worldCache;  // renderer/features/sdf_world_cache.h
    j["worldCache"] = {{"active", wc.active},
                       {"levels", wc.levels},
                       {"resolution", wc.resolution},
                       {"voxel", jsonNumber(wc.voxel)},
                       {"distanceBytes", wc.distanceBytes},
                       {"idBytes", wc.idBytes},
                       {"fullVoxels", wc.voxels.fullVoxels},
                       {"scrollVoxels", wc.voxels.scrollVoxels},
                       {"dirtyVoxels", wc.voxels.dirtyVoxels},
                       {"splatVoxels", wc.voxels.splatVoxels},
                       {"queuedVoxels", wc.voxels.queuedVoxels},
                       {"changedObjects", wc.voxels.changedObjects},
                       {"jobs", wc.jobs}};
    j["counts"] = {{"entities", world.aliveCount()},
                   {"meshRenderers", world.count<ecs::MeshRenderer>()},
                   {"cameras", world.count<ecs::Camera>()},
                   {"lights", world.count<ecs::Light>()},
                   {"assets", assets.count()},
                   {"meshAssets", assets.count(assets::AssetKind::Mesh)},
                   {"materialAssets", assets.count(assets::AssetKind::Material)},
                   {"textureAssets", assets.count(assets::AssetKind::Texture)},
                   {"sdfRenderers", world.count<ecs::SdfRenderer>()},
                   {"sdfObjects", stats.sdfObjects},
                   {"sdfOccluders", stats.sdfOccluders},
                   {"drawCalls", stats.drawCalls},
                   {"triangles", stats.triangles}};
    j["assetCache"] = {{"dir", run.cacheDir},
                       {"hits", assets.cacheStats().hits},
                       {"misses", assets.cacheStats().misses},
                       {"writes", assets.cacheStats().writes},
                       {"rejected", assets.cacheStats().rejected}};
    j["sdfBakeCache"] = {{"hits", assets.cacheStats().sdfHits},
                         {"misses", assets.cacheStats().sdfMisses},
                         {"writes", assets.cacheStats().sdfWrites},
                         {"rejected", assets.cacheStats().sdfRejected},
                         {"bakes", assets.cacheStats().sdfBakes}};
    return j;
}

}  // namespace

CLI::App* addRenderCommand(CLI::App& app, RenderOptions& opt) {
    auto* cmd = app.add_subcommand(
        "render",
        "Render a scene (.json scene file, .gltf or .glb) to a PNG and print per-pass GPU/CPU times");
    cmd->add_option("scene", opt.scene, "Scene file: .json (docs/FORMATS.md), .gltf or .glb")->required();
    cmd->add_option("-o,--output", opt.output, "Output PNG path (.png)")->capture_default_str();
    addBackendOption(cmd, opt.backend);
    cmd->add_flag(
        "--validation", opt.validation,
        "Enable RHI validation and the Vulkan validation layer / GL debug output (errors fail the run)");
    addSizeOption(cmd, "--width", opt.width,
                  "Image width in pixels, 1 .. the device's max 2D texture size (default: the scene's "
                  "render.width)");
    addSizeOption(cmd, "--height", opt.height,
                  "Image height in pixels, 1 .. the device's max 2D texture size (default: the scene's "
                  "render.height)");
    cmd->add_option("--frames", opt.frames, "Number of frames to run; the last one is written")
        ->check(CLI::Range(1u, 100000u))
        ->capture_default_str();
    cmd->add_option("--fixed-dt", opt.fixedDt,
                    "Simulated seconds between rendered frames: frame k is rendered at exactly k * dt. Not "
                    "the scene's render.fixedDt (the update step): each frame runs the fewest equal "
                    "update steps no longer than render.fixedDt that fill dt")
        ->check(CLI::Range(0.0, 10.0))
        ->capture_default_str();
    cmd->add_option("--camera", opt.camera,
                    "Camera name (default: the scene's render.camera, else the first)");
    cmd->add_option(
        "--stats", opt.stats,
        "Write JSON statistics: per-pass GPU/CPU ms, memory per resource class, entity/asset counts");
    cmd->add_option("--graphviz", opt.graphviz, "Also write the last frame's frame graph as Graphviz dot");
    cmd->add_option("--cache-dir", opt.cacheDir,
                    "Processed-asset cache folder (default: $PENUMBRA_CACHE_DIR, $XDG_CACHE_HOME/penumbra or "
                    "~/.cache/penumbra)");
    cmd->add_flag("--no-cache", opt.noCache, "Do not read or write the processed-asset cache");
    cmd->add_option("--mesh-sdf", opt.meshSdf,
                    "How meshes take part in the SDF passes (replaces the scene's render.meshSdf, default "
                    "auto): off: rasterized only (they cast no SDF shadows or AO); trace: every visible mesh "
                    "is baked to a signed distance field (automatic medium resolution, cached in "
                    "<cache-dir>/sdf) and sphere-traced instead, for comparisons; occlusion: meshes stay "
                    "rasterized and get a coarse baked field (64 voxels) used only by shadows and AO; "
                    "auto: occlusion when shadows or AO are on and the scene has meshes, else off")
        ->check(CLI::IsMember({"off", "trace", "occlusion", "auto"}));
    cmd->add_option("--plugin-dir", opt.pluginDir, "Load shared-library plugins (*.so) from this folder");
    cmd->add_option("--shading", opt.shading, "Override the scene's shading model")
        ->check(CLI::IsMember({"cook-torrance", "blinn-phong"}));
    cmd->add_option("--tone-mapper", opt.toneMapper, "Override the scene's tone mapper")
        ->check(CLI::IsMember({"clamp", "reinhard", "aces"}));
    cmd->add_option(
           "--debug-view", opt.debugView,
           "Show a debug view instead of the lit image: normals | depth | albedo | steps | ids | "
           "field-slice | ao | shadow (first shadowed light) | bentnormal | thickness | tiles (objects per "
           "8x8 tile after culling) (none: lit; replaces the scene's render.debugView; docs/FORMATS.md)")
        ->check(CLI::IsMember({"none", "normals", "depth", "albedo", "steps", "ids", "field-slice", "ao",
                               "shadow", "bentnormal", "thickness", "tiles"}));
    cmd->add_option("--slice", opt.slice,
                    "The field-slice plane: AXIS=OFFSET (x, y or z; e.g. y=0.5) or NX,NY,NZ,OFFSET "
                    "(dot(N / |N|, p) = OFFSET); replaces the scene's render.slice (default y=0)");
    addAovOption(cmd, opt.aov);
    cmd->add_option("--quality", opt.quality,
                    "SDF trace quality preset: low | medium | high | reference (replaces the scene's "
                    "render.quality; the scene's render.trace overrides still apply; docs/FORMATS.md)")
        ->check(CLI::IsMember({"low", "medium", "high", "reference"}));
    cmd->add_option("--shadows", opt.shadows,
                    "Soft shadows of lights with castShadows: on (cone traced, penumbra from the light's "
                    "size) | hard (binary) | off (replaces the scene's render.shadows.enabled / hard)")
        ->check(CLI::IsMember({"on", "off", "hard"}));
    cmd->add_option("--ao", opt.ao,
                    "Ambient occlusion variant: off | five-tap | multi-ray | cones (bent normal) (replaces "
                    "the scene's render.ao.variant; docs/FORMATS.md)")
        ->check(CLI::IsMember({"off", "five-tap", "multi-ray", "cones"}));
    addAccelOption(cmd, opt.accel);
    cmd->add_option("--trace-mode", opt.traceMode,
                    "How SDF objects are traced: fullscreen (one compute invocation per pixel over its "
                    "tile's objects) | box (each object's bounds box is rasterized and traced in that "
                    "object alone, conservative depth) | auto (box for at most 200 objects whose boxes "
                    "cover at most 3 screens, else fullscreen: the crossover measured here, "
                    "docs/BENCHMARKS.md); replaces the scene's render.traceMode (default fullscreen). "
                    "--stats reports the mode that ran")
        ->check(CLI::IsMember({"fullscreen", "box", "auto"}));
    cmd->add_option("--taa", opt.taa,
                    "Temporal anti-aliasing: on | off (replaces the scene's render.taa; it converges over "
                    "frames: with --frames N --fixed-dt T, frame k is rendered at k * T with jitter phase k, "
                    "so runs are reproducible; docs/FORMATS.md)")
        ->check(CLI::IsMember({"on", "off"}));
    cmd->add_option("--motion-blur", opt.motionBlur,
                    "Motion blur from the velocity buffer: on | off (replaces the scene's "
                    "render.motionBlur.enabled; its strength and samples stay the scene's)")
        ->check(CLI::IsMember({"on", "off"}));
    return cmd;
}

namespace {

// The command line's overrides of the loaded scene's render settings, then the scene's (or the
// flag's) render.meshSdf, which looks at the effect settings; false with `error` for an unknown
// --camera.
bool applySceneOverrides(const RenderOptions& opt, const glm::vec4& slice, Engine& engine,
                         std::string& error) {
    scene::RenderSettings& settings = engine.settings();
    if (!opt.shading.empty()) scene::parseShadingModel(opt.shading, settings.shading);
    if (!opt.toneMapper.empty()) scene::parseToneMapper(opt.toneMapper, settings.toneMapper);
    if (!opt.quality.empty()) scene::parseTraceQuality(opt.quality, settings.quality);
    if (!opt.traceMode.empty()) scene::parseTraceMode(opt.traceMode, settings.traceMode);
    if (!opt.shadows.empty()) {
        settings.shadows.enabled = opt.shadows != "off";
        settings.shadows.hard = opt.shadows == "hard";
    }
    if (!opt.ao.empty()) scene::parseAoVariant(opt.ao, settings.ao.variant);
    applyAccelOption(opt.accel, settings.acceleration, error);  // checked in runRender
    if (!opt.taa.empty()) settings.taa = opt.taa == "on";
    if (!opt.motionBlur.empty()) settings.motionBlur.enabled = opt.motionBlur == "on";
    // After the effect overrides: auto looks at them.
    if (!opt.meshSdf.empty()) scene::parseMeshSdfMode(opt.meshSdf, settings.meshSdf);
    if (!scene::applyMeshSdf(engine.scene(), engine.assets(), settings.meshSdf, error)) return false;
    if (!opt.debugView.empty()) scene::parseDebugView(opt.debugView, settings.debugView);
    if (!opt.slice.empty()) settings.slice = slice;
    if (!opt.camera.empty() && scene::findCamera(engine.world(), opt.camera) == ecs::kNullEntity) {
        error = fmt::format("the scene has no camera named '{}'", opt.camera);
        return false;
    }
    return true;
}

}  // namespace

int runRender(const RenderOptions& opt) {
    // Everything that can be checked before the work is checked first: backend, input, outputs.
    std::string error;
    RendererDesc rendererDesc;
    rendererDesc.validation = opt.validation;
    rendererDesc.width = opt.width;
    rendererDesc.height = opt.height;
    if (!chooseBackend(opt.backend, "render", rendererDesc.backend, error)) {
        log::error("{}", error);
        return 2;
    }
    if (!checkPngPath(opt.output, "-o", error)) {
        log::error("render: {}", error);
        return 2;
    }
    glm::vec4 slice(0.0f);
    if (!opt.slice.empty() && !render::parseSlicePlane(opt.slice, slice, error)) {
        log::error("render: {}", error);
        return 2;
    }
    std::vector<AovOutput> aovs;
    if (scene::AccelerationSettings accel; !applyAccelOption(opt.accel, accel, error)) {
        log::error("render: {}", error);
        return 2;
    }
    if (!parseAovOutputs(opt.aov, aovs, error) || !requestAuxTarget(rendererDesc, aovs, error)) {
        log::error("render: {}", error);
        return 2;
    }
    if (!checkInputFile(opt.scene, "scene file (.json, .gltf or .glb)", error)) {
        log::error("render: {}", error);
        return 1;
    }
    OutputFiles outputs;
    std::vector<std::string> outputPaths = aovPaths(aovs);
    outputPaths.insert(outputPaths.begin(), {opt.output, opt.stats, opt.graphviz});
    if (!prepareOutputs(outputs, outputPaths, "render")) return 1;

    EngineDesc engineDesc;
    engineDesc.cacheDir =
        opt.noCache ? std::string() : (opt.cacheDir.empty() ? defaultCacheDir() : opt.cacheDir);
    engineDesc.pluginDir = opt.pluginDir;
    std::unique_ptr<Engine> engine = Engine::create(engineDesc, error);
    if (!engine) {
        log::error("{}", error);
        return 1;
    }
    if (!engine->loadScene(opt.scene, error)) {
        log::error("{}", error);
        return 1;
    }
    if (!applySceneOverrides(opt, slice, *engine, error)) {
        log::error("{}: {}", opt.scene, error);
        return 1;
    }
    const scene::RenderSettings& settings = engine->settings();

    std::unique_ptr<Renderer> renderer = Renderer::create(*engine, rendererDesc, error);
    if (!renderer) {
        log::error("{}", error);
        return 1;
    }
    const rhi::DeviceInfo& info = renderer->device().info();
    const uint32_t width = opt.width ? opt.width : settings.width;
    const uint32_t height = opt.height ? opt.height : settings.height;
    // One size limit: the device's maximum 2D texture size, whether the size comes from the flags
    // or from the scene (whose format allows up to 16384, docs/FORMATS.md).
    const std::string sizeSource = opt.width && opt.height ? "--width/--height"
                                   : opt.width  ? std::string("--width and the scene's render.height")
                                   : opt.height ? std::string("the scene's render.width and --height")
                                                : fmt::format("{}: render.width/height", opt.scene);
    if (!refuseNullDevice(renderer->device(), "render", error) ||
        !checkImageSize(width, height, renderer->device(), sizeSource, error)) {
        log::error("render: {}", error);
        return opt.width || opt.height ? 2 : 1;
    }
    fmt::print("penumbra render: {} on {} ({}), {}x{}, {} frame(s) of {:.6g} s\n",
               rhi::toString(info.backend), info.deviceName, info.platform, width, height, opt.frames,
               opt.fixedDt);

    std::vector<PassSeries> series;
    app::FrameTime lastTime;
    for (uint32_t frame = 0; frame < opt.frames; ++frame) {
        // Offline time: frame 0 shows the scene at t = 0, frame k at exactly k * --fixed-dt (each
        // frame split into equal update steps no longer than the scene's fixedDt; no catch-up cap).
        if (!engine->updateOffline(frame == 0 ? 0.0 : opt.fixedDt, lastTime, error)) {
            log::error("{}: frame {}: {}", opt.scene, frame, error);
            return 1;
        }
        if (!renderer->renderFrame(*engine, error, opt.camera)) {
            log::error("{}: frame {}: {}", opt.scene, frame, error);
            return 1;
        }
        // GPU timings come back a few frames late; the loop never waits for them.
        addTimings(series, renderer->takeTimings(false));
        if (opt.frames > 1 && (frame + 1) % 10 == 0)
            fmt::print(stderr, "frame {}/{}\n", frame + 1, opt.frames);
    }
    addTimings(series, renderer->takeTimings(true));  // the frames still in flight

    ImageRGBA8 image;
    if (!renderer->readPixels(image, error)) {
        log::error("reading back the frame failed: {}", error);
        return 1;
    }
    if (!writePngOutput(outputs, opt.output, image, error) ||
        !writeAovOutputs(outputs, renderer->sceneRenderer(), width, height, aovs, error)) {
        log::error("render: {}", error);
        return 1;
    }

    printPassTable(series, opt.frames);

    const render::FrameStats& stats = renderer->stats();
    const ecs::World& world = engine->world();
    if (!opt.stats.empty()) {
        const StatsRun run{opt.scene,          info, width, height, opt.frames, opt.fixedDt, lastTime.simTime,
                           engineDesc.cacheDir};
        if (!outputs.writeText(opt.stats, statsJson(run, *engine, stats, series).dump(2) + "\n", error)) {
            log::error("render: {}", error);
            return 1;
        }
    }
    if (!opt.graphviz.empty() && !outputs.writeText(opt.graphviz, renderer->frameGraphviz(), error)) {
        log::error("render: {}", error);
        return 1;
    }
    fmt::print("entities {}, draw calls {}, triangles {}, GPU memory {:.2f} MiB\n", world.aliveCount(),
               stats.drawCalls, stats.triangles, double(stats.memory.total()) / (1024.0 * 1024.0));
    // A run with validation errors failed: its outputs are not kept.
    if (opt.validation && renderer->validationErrors() != 0) {
        log::error("{} validation error(s) reported; no output written", renderer->validationErrors());
        return 1;
    }
    if (!outputs.commit(error)) {
        log::error("render: {}", error);
        return 1;
    }
    fmt::print("wrote {}\n", opt.output);
    return 0;
}

}  // namespace penumbra::cli
