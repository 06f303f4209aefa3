#include "cmd_reference.h"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli_common.h"
#include "engine/core/log.h"
#include "engine/core/output_file.h"
#include "engine/core/progress.h"
#include "engine/engine.h"
#include "reference/pfm.h"
#include "reference/reference.h"

namespace penumbra::cli {
namespace {

// "inf" / "infinity" or a positive number of scene units.
bool parseDistance(const std::string& text, double& out) {
    if (text == "inf" || text == "infinity") {
        out = std::numeric_limits<double>::infinity();
        return true;
    }
    char* end = nullptr;
    out = std::strtod(text.c_str(), &end);
    return !text.empty() && end && *end == '\0' && std::isfinite(out) && out > 0.0;
}

nlohmann::json jsonNumber(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

CLI::App* addReferenceCommand(CLI::App& app, ReferenceOptions& opt) {
    auto* cmd = app.add_subcommand(
        "reference",
        "Render float AOVs of a scene on the CPU from its original geometry (the accuracy reference, "
        "docs/ACCURACY.md) to PFM files");
    cmd->add_option("scene", opt.scene, "Scene file: .json (docs/FORMATS.md), .gltf or .glb")->required();
    cmd->add_option("-o,--output", opt.outputDir, "Output folder: one <aov>.pfm per AOV")
        ->capture_default_str();
    cmd->add_option(
           "--aov", opt.aovs,
           "Comma-separated AOVs: depth, normal, ids, ao, shadow (the first shadowed light), shadowN "
           "(shadowed light N)")
        ->capture_default_str();
    cmd->add_option("--samples", opt.samples,
                    "AO and area-light rays per pixel, rounded up to k*k (stratified); the report gives each "
                    "image's standard error")
        ->check(CLI::Range(1u, 1u << 20))
        ->capture_default_str();
    cmd->add_option("--error", opt.targetError,
                    "Instead of --samples: the size of the errors to measure; picks the smallest k*k whose "
                    "standard-error bound is at most a third of it (0.02 -> 5625)")
        ->check(CLI::Range(0.001, 10.0))
        ->excludes(cmd->get_option("--samples"));
    cmd->add_option("--width", opt.width, "Image width in pixels (default: the scene's render.width)")
        ->check(CLI::Range(1u, 16384u));
    cmd->add_option("--height", opt.height, "Image height in pixels (default: the scene's render.height)")
        ->check(CLI::Range(1u, 16384u));
    cmd->add_option("--camera", opt.camera,
                    "Camera name (default: the scene's render.camera, else the first)");
    cmd->add_option("--ao-distance", opt.aoDistance,
                    "Max occlusion distance of AO rays in scene units, or inf (unbounded)")
        ->capture_default_str();
    cmd->add_option("--seed", opt.seed, "Seed of the per-pixel sample streams")->capture_default_str();
    cmd->add_option("--threads", opt.threads, "Worker threads (0: one per CPU)")->capture_default_str();
    cmd->add_option(
        "--report", opt.report,
        "JSON report: settings and each image's standard error (default: <output>/reference.json)");
    cmd->add_flag("-q,--quiet", opt.quiet, "No progress bar");
    return cmd;
}

int runReference(const ReferenceOptions& opt) {
    // Everything that can be checked before the work is checked first: options, input, outputs.
    std::string error;
    std::vector<reference::AovRequest> aovs;
    if (!reference::parseAovList(opt.aovs, aovs, error)) {
        log::error("reference: --aov: {}", error);
        return 2;
    }
    double aoDistance = 0.0;
    if (!parseDistance(opt.aoDistance, aoDistance)) {
        log::error("reference: --ao-distance: '{}' is not a positive number of scene units or 'inf'",
                   opt.aoDistance);
        return 2;
    }
    if (!checkInputFile(opt.scene, "scene file (.json, .gltf or .glb)", error)) {
        log::error("reference: {}", error);
        return 1;
    }
    const std::string dir = opt.outputDir.empty() ? std::string(".") : opt.outputDir;
    std::vector<std::string> paths;
    for (const reference::AovRequest& a : aovs) paths.push_back(dir + "/" + a.name() + ".pfm");
    const std::string reportPath = opt.report.empty() ? dir + "/reference.json" : opt.report;
    std::vector<std::string> allPaths = paths;
    allPaths.push_back(reportPath);
    OutputFiles outputs;
    if (!prepareOutputs(outputs, allPaths, "reference")) return 1;

    std::unique_ptr<Engine> engine = Engine::create({}, error);
    if (!engine || !engine->loadScene(opt.scene, error)) {
        log::error("{}", error);
        return 1;
    }
    app::FrameTime time;
    if (!engine->updateOffline(0.0, time, error)) {  // world transforms at t = 0
        log::error("{}: {}", opt.scene, error);
        return 1;
    }
    const scene::RenderSettings& settings = engine->settings();
    const std::string cameraName = opt.camera.empty() ? settings.camera : opt.camera;
    const ecs::Entity cameraEntity = scene::findCamera(engine->world(), cameraName);
    if (cameraEntity == ecs::kNullEntity) {
        log::error(
            "{}: the scene has {}", opt.scene,
            cameraName.empty() ? std::string("no camera") : fmt::format("no camera named '{}'", cameraName));
        return 1;
    }
    const uint32_t width = opt.width ? opt.width : settings.width;
    const uint32_t height = opt.height ? opt.height : settings.height;
    reference::ReferenceCamera camera;
    if (!reference::makeCamera(engine->world(), cameraEntity, width, height, camera, error)) {
        log::error("{}: {}", opt.scene, error);
        return 1;
    }
    std::unique_ptr<reference::ReferenceScene> refScene = reference::ReferenceScene::create(error);
    if (!refScene || !reference::buildFromWorld(engine->world(), engine->assets(), *refScene, error) ||
        !refScene->commit(error)) {
        log::error("{}: {}", opt.scene, error);
        return 1;
    }
    for (const reference::AovRequest& a : aovs)
        if (a.kind == reference::AovKind::Shadow && a.light >= refScene->lights().size()) {
            log::error(
                "{}: --aov {}: the scene has {} shadowed light(s) (shadow = the first, shadowN = light N)",
                opt.scene, a.name(), refScene->lights().size());
            return 1;
        }

    reference::RenderDesc desc;
    desc.aovs = aovs;
    desc.samples = opt.targetError > 0.0 ? reference::samplesForError(opt.targetError) : opt.samples;
    desc.aoMaxDistance = aoDistance;
    desc.seed = opt.seed;
    desc.threads = opt.threads;
    StderrProgressOutput progressOutput;
    ProgressSettings progressSettings;
    progressSettings.enabled = !opt.quiet;
    ProgressBar progress(progressOutput, progressSettings);
    desc.progress = [&](double f) { progress.update(f, "render"); };
    fmt::print("penumbra reference: {}, {}x{}, {} sample(s) per pixel, AOVs {}\n", opt.scene, width, height,
               reference::stratifiedCount(desc.samples), opt.aovs);
    const auto start = std::chrono::steady_clock::now();
    std::vector<reference::AovImage> images;
    if (!reference::render(*refScene, camera, desc, images, error)) {
        log::error("{}: {}", opt.scene, error);
        return 1;
    }
    progress.finish();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    nlohmann::json report;
    report["scene"] = opt.scene;
    report["camera"] = cameraName;
    report["width"] = width;
    report["height"] = height;
    report["samples"] = reference::stratifiedCount(desc.samples);
    report["targetError"] = opt.targetError > 0.0 ? nlohmann::json(opt.targetError) : nlohmann::json(nullptr);
    report["aoMaxDistance"] = jsonNumber(aoDistance);  // null: unbounded
    report["seed"] = opt.seed;
    report["seconds"] = seconds;
    const reference::ReferenceScene::SdfStats sdfStats = refScene->sdfStats();
    report["sdf"] = {
        {"rays", sdfStats.rays}, {"iterations", sdfStats.iterations}, {"unconverged", sdfStats.unconverged}};
    report["images"] = nlohmann::json::array();
    for (size_t i = 0; i < images.size(); ++i) {
        const reference::AovImage& img = images[i];
        if (!outputs.write(
                paths[i],
                [&](const std::string& tmp, std::string& e) {
                    return reference::writePfm(tmp, img.width, img.height, img.channels, img.data.data(), e);
                },
                error)) {
            log::error("reference: {}", error);
            return 1;
        }
        report["images"].push_back({{"name", img.name},
                                    {"file", paths[i]},
                                    {"channels", img.channels},
                                    {"samples", img.samples},
                                    {"meanStdError", img.meanStdError},
                                    {"maxStdError", img.maxStdError}});
        fmt::print("{:<10} {:>7} samples  mean standard error {:.6f}  max {:.6f}\n", img.name, img.samples,
                   img.meanStdError, img.maxStdError);
    }
    if (!outputs.writeText(reportPath, report.dump(2) + "\n", error) || !outputs.commit(error)) {
        log::error("reference: {}", error);
        return 1;
    }
    fmt::print("rendered in {:.2f} s; wrote {} PFM file(s) to {} and {}\n", seconds, images.size(), dir,
               reportPath);
    return 0;
}

}  // namespace penumbra::cli
