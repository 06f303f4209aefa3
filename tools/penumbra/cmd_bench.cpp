#include "cmd_bench.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <optional>
#include <thread>
#include <unordered_set>
#include <vector>

#include <fmt/format.h>

#include "cli_common.h"
#include "engine/core/log.h"
#include "engine/core/output_file.h"
#include "engine/ecs/components.h"
#include "engine/engine.h"
#include "engine/scene/mesh_sdf.h"
#include "renderer/renderer.h"

namespace penumbra::cli {
namespace {

// Offline time between frames, as `penumbra render`'s default --fixed-dt.
constexpr double kFrameDt = 1.0 / 60.0;
constexpr int kSettings = 2;  // 0: the scene's / preset's over-relaxation, 1: overRelaxation = 1

std::vector<double> finite(std::vector<double> v) {
    v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
    return v;
}
double minimum(std::vector<double> v) {
    v = finite(std::move(v));
    return v.empty() ? std::nan("") : *std::min_element(v.begin(), v.end());
}
std::string ms(double v) { return std::isfinite(v) ? fmt::format("{:.3f}", v) : std::string("n/a"); }
std::string ratioText(double a, double b) {
    return std::isfinite(a) && std::isfinite(b) && b > 0 ? fmt::format("{:.3f}", a / b) : std::string("n/a");
}

struct PassSeries {
    std::string name;
    std::vector<double> gpu, cpu;
};

// Sphere-trace steps of one frame, from gbuffer.aux (x entity index, y steps).
struct StepStats {
    uint64_t sdfPixels = 0;  // an SdfRenderer entity is visible there (the trace hit it)
    uint64_t meshPixels = 0;
    uint64_t backgroundPixels = 0;
    double sdfSteps = 0, allSteps = 0;
    double sdfMean() const { return sdfPixels ? sdfSteps / double(sdfPixels) : std::nan(""); }
    uint64_t allPixels() const { return sdfPixels + meshPixels + backgroundPixels; }
    double allMean() const { return allPixels() ? allSteps / double(allPixels()) : std::nan(""); }
};

struct BackendRun {
    rhi::Backend backend = rhi::Backend::Auto;
    std::string device, driver, platform;
    std::string loadBefore, loadAfter;
    float omega[kSettings] = {1.0f, 1.0f};
    std::vector<PassSeries> passes[kSettings];
    std::vector<double> totalGpu[kSettings], totalCpu[kSettings];  // per frame: sum over passes
    StepStats steps[kSettings];
    uint32_t sdfObjects = 0, drawCalls = 0;
    std::string quality;
};

const PassSeries* findPass(const std::vector<PassSeries>& v, const std::string& name) {
    for (const PassSeries& s : v)
        if (s.name == name) return &s;
    return nullptr;
}

std::string backendTitle(rhi::Backend b) {
    return b == rhi::Backend::Vulkan ? "Vulkan" : b == rhi::Backend::OpenGL ? "OpenGL" : rhi::toString(b);
}

// Timings of the renders of one backend run, matched to the renders in order (one FrameTimings per
// executed frame, frame numbers consecutive).
class TimingSink {
public:
    explicit TimingSink(BackendRun& run) : m_run(run) {}
    // The setting of the next render: -1 untimed (warm-up, the aux frames), else 0 or 1.
    void rendered(int setting) { m_tags.push_back(setting); }
    bool add(std::vector<fg::FrameTimings> frames, std::string& error) {
        for (const fg::FrameTimings& f : frames) {
            if (m_received > 0 && f.frame != m_lastFrame + 1) {
                error = fmt::format("frame timings out of step (frame {} after {})", f.frame, m_lastFrame);
                return false;
            }
            if (m_received >= m_tags.size()) {
                error = "more frame timings than rendered frames";
                return false;
            }
            m_lastFrame = f.frame;
            const int setting = m_tags[m_received++];
            if (setting < 0) continue;
            double gpu = 0, cpu = 0;
            bool gpuValid = false;
            for (const fg::PassTiming& t : f.passes) {
                std::vector<PassSeries>& series = m_run.passes[setting];
                auto it = std::find_if(series.begin(), series.end(),
                                       [&](const PassSeries& s) { return s.name == t.name; });
                if (it == series.end()) it = series.insert(series.end(), PassSeries{t.name, {}, {}});
                it->gpu.push_back(t.gpuMs);
                it->cpu.push_back(t.cpuMs);
                if (std::isfinite(t.gpuMs)) {
                    gpu += t.gpuMs;
                    gpuValid = true;
                }
                cpu += t.cpuMs;
            }
            m_run.totalGpu[setting].push_back(gpuValid ? gpu : std::nan(""));
            m_run.totalCpu[setting].push_back(cpu);
        }
        return true;
    }
    bool complete() const { return m_received == m_tags.size(); }

private:
    BackendRun& m_run;
    std::vector<int> m_tags;
    size_t m_received = 0;
    uint64_t m_lastFrame = 0;
};

bool countSteps(const std::vector<uint8_t>& texels, rhi::Format format, uint32_t width, uint32_t height,
                const std::unordered_set<uint32_t>& sdfEntities, StepStats& out, std::string& error) {
    const size_t pixels = size_t(width) * height;
    if (format != rhi::Format::RG32_FLOAT || texels.size() < pixels * 8) {
        error = fmt::format("gbuffer.aux: expected {}x{} RG32_FLOAT texels, got {} bytes of {}", width,
                            height, texels.size(), rhi::formatInfo(format).name);
        return false;
    }
    out = {};
    for (size_t i = 0; i < pixels; ++i) {
        float v[2];
        std::memcpy(v, texels.data() + i * 8, 8);
        const double steps = std::isfinite(v[1]) ? double(v[1]) : 0.0;
        out.allSteps += steps;
        if (v[0] < 0.0f || !std::isfinite(v[0])) {
            ++out.backgroundPixels;
        } else if (sdfEntities.count(uint32_t(std::lround(v[0])))) {
            ++out.sdfPixels;
            out.sdfSteps += steps;
        } else {
            ++out.meshPixels;
        }
    }
    return true;
}

// One backend: engine + renderer, W + N frames per setting (interleaved), then one aux frame per
// setting for the step counts. Returns the exit code (0 ok).
int runBackend(const BenchTraceOptions& opt, rhi::Backend backend, const std::string& cacheDir,
               BackendRun& run) {
    std::string error;
    run.backend = backend;
    run.loadBefore = loadAverage();
    const char* name = rhi::toString(backend);
    fmt::print(stderr, "[{}] loading {}\n", name, opt.scene);

    EngineDesc engineDesc;
    engineDesc.cacheDir = cacheDir;
    std::unique_ptr<Engine> engine = Engine::create(engineDesc, error);
    if (!engine || !engine->loadScene(opt.scene, error)) {
        log::error("bench trace: {}", error);
        return 1;
    }
    scene::RenderSettings& settings = engine->settings();
    if (!opt.quality.empty()) scene::parseTraceQuality(opt.quality, settings.quality);
    applyAccelOption(opt.accel, settings.acceleration, error);  // checked in runBenchTrace
    run.quality = scene::toString(settings.quality);
    if (engine->world().count<ecs::SdfRenderer>() == 0) {
        log::error("bench trace: {}: the scene has no SDF objects (sdf components): nothing to trace",
                   opt.scene);
        return 1;
    }
    // As penumbra render runs it: the scene's render.meshSdf (auto: occlusion fields for its meshes
    // when shadows or AO are on).
    if (!scene::applyMeshSdf(engine->scene(), engine->assets(), settings.meshSdf, error)) {
        log::error("bench trace: {}: {}", opt.scene, error);
        return 1;
    }
    if (scene::findCamera(engine->world(), settings.camera) == ecs::kNullEntity) {
        log::error("bench trace: {}: {}", opt.scene,
                   settings.camera.empty()
                       ? std::string("the scene has no camera")
                       : fmt::format("the scene has no camera named '{}'", settings.camera));
        return 1;
    }
    const std::optional<float> sceneOmega = settings.trace.overRelaxation;
    run.omega[0] = settings.resolvedTrace().overRelaxation;
    run.omega[1] = 1.0f;
    auto useSetting = [&](int s) {
        settings.trace.overRelaxation = s == 0 ? sceneOmega : std::optional(1.0f);
    };

    RendererDesc rendererDesc;
    rendererDesc.backend = backend;
    rendererDesc.width = opt.width;
    rendererDesc.height = opt.height;
    std::unique_ptr<Renderer> renderer = Renderer::create(*engine, rendererDesc, error);
    if (!renderer) {
        log::error("bench trace: {}: {}", name, error);
        return 1;
    }
    if (!refuseNullDevice(renderer->device(), "bench trace", error) ||
        !checkImageSize(opt.width, opt.height, renderer->device(), "bench trace: --width/--height", error)) {
        log::error("{}", error);
        return 2;
    }
    const rhi::DeviceInfo& info = renderer->device().info();
    run.device = info.deviceName;
    run.driver = fmt::format("{} {}", info.driverName, info.driverVersion);
    run.platform = info.platform;
    fmt::print(
        stderr, "[{}] {} ({}), {}x{}: {} warm-up + {} timed frames, each with over-relaxation {} and 1\n",
        name, info.deviceName, info.platform, opt.width, opt.height, opt.warmup, opt.frames, run.omega[0]);

    TimingSink sink(run);
    app::FrameTime time;
    const uint32_t total = opt.warmup + opt.frames;
    for (uint32_t frame = 0; frame < total; ++frame) {
        if (!engine->updateOffline(frame == 0 ? 0.0 : kFrameDt, time, error)) {
            log::error("bench trace: {}: frame {}: {}", opt.scene, frame, error);
            return 1;
        }
        // Both settings at the same simulated time, one after the other, in alternating order: load
        // changes on a shared machine and the order itself hit both alike.
        for (int i = 0; i < kSettings; ++i) {
            const int s = frame % 2 ? kSettings - 1 - i : i;
            useSetting(s);
            if (!renderer->renderFrame(*engine, error)) {
                log::error("bench trace: {}: {}: frame {}: {}", name, opt.scene, frame, error);
                return 1;
            }
            sink.rendered(frame < opt.warmup ? -1 : s);
            if (!sink.add(renderer->takeTimings(false), error)) {
                log::error("bench trace: {}: {}", name, error);
                return 1;
            }
        }
        fmt::print(stderr, "[{}] frame {}/{}{}\n", name, frame + 1, total,
                   frame < opt.warmup ? " (warm-up)" : "");
    }
    if (!sink.add(renderer->takeTimings(true), error)) {
        log::error("bench trace: {}: {}", name, error);
        return 1;
    }
    const render::FrameStats& stats = renderer->stats();
    run.sdfObjects = stats.sdfObjects;
    run.drawCalls = stats.drawCalls;

    // Step counts: one more frame per setting at the last frame's time, with gbuffer.aux (not timed:
    // the aux target adds writes the timed frames do not have).
    std::unordered_set<uint32_t> sdfEntities;
    for (auto [entity, sdf] : engine->world().view<const ecs::SdfRenderer>()) {
        (void)sdf;
        sdfEntities.insert(entity.index);
    }
    for (int s = 0; s < kSettings; ++s) {
        useSetting(s);
        render::FrameDesc frame;
        frame.camera = scene::findCamera(engine->world(), settings.camera);
        frame.settings = settings;
        frame.width = opt.width;
        frame.height = opt.height;
        frame.aux = true;
        std::vector<uint8_t> texels;
        rhi::Format format = rhi::Format::Undefined;
        if (!renderer->sceneRenderer().render(engine->world(), engine->assets(), frame, error) ||
            !renderer->sceneRenderer().readTarget("gbuffer.aux", texels, format, error) ||
            !countSteps(texels, format, opt.width, opt.height, sdfEntities, run.steps[s], error)) {
            log::error("bench trace: {}: step counts (over-relaxation {}): {}", name, run.omega[s], error);
            return 1;
        }
        sink.rendered(-1);
    }
    if (!sink.add(renderer->takeTimings(true), error) || !sink.complete()) {
        log::error("bench trace: {}: {}", name, error.empty() ? "frame timings missing" : error);
        return 1;
    }
    useSetting(0);
    run.loadAfter = loadAverage();
    return 0;
}

void printRun(const BenchTraceOptions& opt, const BackendRun& run) {
    fmt::print("\n{} — {} ({}, {})\n", backendTitle(run.backend), run.device, run.driver, run.platform);
    fmt::print("{}x{}, quality {}, {} SDF objects, {} draw calls; load average before {}, after {}\n",
               opt.width, opt.height, run.quality, run.sdfObjects, run.drawCalls, run.loadBefore,
               run.loadAfter);
    fmt::print("per pass, over-relaxation {}, over {} frames (ms):\n", run.omega[0], opt.frames);
    fmt::print("{:<28} {:>10} {:>10} {:>10} {:>10}\n", "pass", "GPU med", "GPU min", "CPU med", "CPU min");
    for (const PassSeries& s : run.passes[0])
        fmt::print("{:<28} {:>10} {:>10} {:>10} {:>10}\n", s.name, ms(median(s.gpu)), ms(minimum(s.gpu)),
                   ms(median(s.cpu)), ms(minimum(s.cpu)));
    fmt::print("{:<28} {:>10} {:>10} {:>10} {:>10}\n", "total (per frame)", ms(median(run.totalGpu[0])),
               ms(minimum(run.totalGpu[0])), ms(median(run.totalCpu[0])), ms(minimum(run.totalCpu[0])));

    const PassSeries* traceA = findPass(run.passes[0], "sdf_trace");
    const PassSeries* traceB = findPass(run.passes[1], "sdf_trace");
    const double gA = traceA ? median(traceA->gpu) : std::nan(""),
                 gB = traceB ? median(traceB->gpu) : std::nan("");
    fmt::print("{:<52} {:>12} {:>12} {:>10}\n", "", fmt::format("omega {}", run.omega[0]), "omega 1",
               "ratio");
    fmt::print("{:<52} {:>12} {:>12} {:>10}\n", "sdf_trace GPU ms (median)", ms(gA), ms(gB),
               ratioText(gA, gB));
    const double mA = traceA ? minimum(traceA->gpu) : std::nan(""),
                 mB = traceB ? minimum(traceB->gpu) : std::nan("");
    fmt::print("{:<52} {:>12} {:>12} {:>10}\n", "sdf_trace GPU ms (min)", ms(mA), ms(mB), ratioText(mA, mB));
    const StepStats &a = run.steps[0], &b = run.steps[1];
    fmt::print("{:<52} {:>12.2f} {:>12.2f} {:>10}\n",
               fmt::format("mean steps/pixel, SDF-hit pixels ({} / {})", a.sdfPixels, b.sdfPixels),
               a.sdfMean(), b.sdfMean(), ratioText(a.sdfMean(), b.sdfMean()));
    fmt::print("{:<52} {:>12.2f} {:>12.2f} {:>10}\n",
               fmt::format("mean steps/pixel, all pixels ({})", a.allPixels()), a.allMean(), b.allMean(),
               ratioText(a.allMean(), b.allMean()));
    fmt::print(
        "(steps: gbuffer.aux y of one extra frame per setting; SDF-hit = an SDF object is the visible "
        "surface; all = every pixel, mesh and background pixels included; ratio = with / without "
        "over-relaxation)\n");
}

std::string commandLine(const BenchTraceOptions& opt) {
    std::string c =
        fmt::format("penumbra bench trace {} --backend {} --width {} --height {} --frames {} --warmup {}",
                    opt.scene, opt.backend, opt.width, opt.height, opt.frames, opt.warmup);
    if (!opt.quality.empty()) c += " --quality " + opt.quality;
    if (!opt.accel.empty()) c += " --accel " + opt.accel;
    return c;
}

std::string markdownReport(const BenchTraceOptions& opt, const std::vector<BackendRun>& runs,
                           const std::string& date, const std::string& loadBefore,
                           const std::string& loadAfter) {
    std::string md;
    md += fmt::format("`{}`, {}. Machine: {}, {} hardware threads. Load average before: {}; after: {}.\n\n",
                      commandLine(opt), date, cpuModel(), std::thread::hardware_concurrency(), loadBefore,
                      loadAfter);
    for (const BackendRun& r : runs)
        md += fmt::format("- {}: {} ({}), quality {}, {} SDF objects, {} draw calls\n",
                          backendTitle(r.backend), r.device, r.driver, r.quality, r.sdfObjects, r.drawCalls);
    md += fmt::format(
        "\nPer pass, ms over {} frames (median, min in brackets), over-relaxation as the scene sets it:\n\n",
        opt.frames);
    std::string header = "| pass |", rule = "|---|";
    for (const BackendRun& r : runs) {
        header += fmt::format(" {} GPU ms | {} CPU ms |", backendTitle(r.backend), backendTitle(r.backend));
        rule += "---:|---:|";
    }
    md += header + "\n" + rule + "\n";
    std::vector<std::string> names;
    for (const BackendRun& r : runs)
        for (const PassSeries& s : r.passes[0])
            if (std::find(names.begin(), names.end(), s.name) == names.end()) names.push_back(s.name);
    for (const std::string& n : names) {
        std::string row = "| " + n + " |";
        for (const BackendRun& r : runs) {
            const PassSeries* s = findPass(r.passes[0], n);
            if (!s) {
                row += " – | – |";
                continue;
            }
            row += fmt::format(" {} ({}) | {} ({}) |", ms(median(s->gpu)), ms(minimum(s->gpu)),
                               ms(median(s->cpu)), ms(minimum(s->cpu)));
        }
        md += row + "\n";
    }
    std::string totalRow = "| total (per frame) |";
    for (const BackendRun& r : runs)
        totalRow += fmt::format(" {} ({}) | {} ({}) |", ms(median(r.totalGpu[0])), ms(minimum(r.totalGpu[0])),
                                ms(median(r.totalCpu[0])), ms(minimum(r.totalCpu[0])));
    md += totalRow + "\n\n";
    md +=
        "Over-relaxation: mean sphere-trace steps per pixel (gbuffer.aux y) and the sdf_trace GPU median, "
        "with "
        "the scene's over-relaxation and with overRelaxation = 1:\n\n";
    md += "| backend | measure | with | without (1) | ratio with / without |\n|---|---|---:|---:|---:|\n";
    for (const BackendRun& r : runs) {
        const StepStats &a = r.steps[0], &b = r.steps[1];
        const std::string t = backendTitle(r.backend);
        md += fmt::format(
            "| {} | mean steps, SDF-hit pixels ({} / {} px), omega {} vs 1 | {:.2f} | {:.2f} | {} |\n", t,
            a.sdfPixels, b.sdfPixels, r.omega[0], a.sdfMean(), b.sdfMean(),
            ratioText(a.sdfMean(), b.sdfMean()));
        md += fmt::format("| {} | mean steps, all {} pixels | {:.2f} | {:.2f} | {} |\n", t, a.allPixels(),
                          a.allMean(), b.allMean(), ratioText(a.allMean(), b.allMean()));
        const PassSeries* ta = findPass(r.passes[0], "sdf_trace");
        const PassSeries* tb = findPass(r.passes[1], "sdf_trace");
        const double ga = ta ? median(ta->gpu) : std::nan(""), gb = tb ? median(tb->gpu) : std::nan("");
        md += fmt::format("| {} | sdf_trace GPU ms (median) | {} | {} | {} |\n", t, ms(ga), ms(gb),
                          ratioText(ga, gb));
        const double na = ta ? minimum(ta->gpu) : std::nan(""), nb = tb ? minimum(tb->gpu) : std::nan("");
        md += fmt::format("| {} | sdf_trace GPU ms (min) | {} | {} | {} |\n", t, ms(na), ms(nb),
                          ratioText(na, nb));
    }
    return md;
}

std::string csvReport(const BenchTraceOptions& opt, const std::vector<BackendRun>& runs) {
    auto quote = [](const std::string& s) {
        std::string q = "\"";
        for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
        return q + "\"";
    };
    auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string(); };
    std::string csv =
        "backend,device,width,height,frames,quality,over_relaxation,kind,name,gpu_ms_median,gpu_ms_min,"
        "cpu_ms_median,cpu_ms_min,pixels,mean_steps\n";
    for (const BackendRun& r : runs)
        for (int s = 0; s < kSettings; ++s) {
            const std::string prefix =
                fmt::format("{},{},{},{},{},{},{}", rhi::toString(r.backend), quote(r.device), opt.width,
                            opt.height, opt.frames, r.quality, r.omega[s]);
            for (const PassSeries& p : r.passes[s])
                csv += fmt::format("{},pass,{},{},{},{},{},,\n", prefix, p.name, num(median(p.gpu)),
                                   num(minimum(p.gpu)), num(median(p.cpu)), num(minimum(p.cpu)));
            csv += fmt::format("{},pass,total,{},{},{},{},,\n", prefix, num(median(r.totalGpu[s])),
                               num(minimum(r.totalGpu[s])), num(median(r.totalCpu[s])),
                               num(minimum(r.totalCpu[s])));
            const StepStats& st = r.steps[s];
            csv +=
                fmt::format("{},steps,sdf_hit_pixels,,,,,{},{}\n", prefix, st.sdfPixels, num(st.sdfMean()));
            csv += fmt::format("{},steps,all_pixels,,,,,{},{}\n", prefix, st.allPixels(), num(st.allMean()));
        }
    return csv;
}

}  // namespace

BenchCommands addBenchCommand(CLI::App& app, BenchTraceOptions& opt) {
    BenchCommands out;
    out.group = app.add_subcommand("bench",
                                   "Benchmarks (results for docs/BENCHMARKS.md); see `penumbra bench "
                                   "SUBCOMMAND --help`");
    out.group->require_subcommand(1);
    CLI::App* cmd = out.trace =
        out.group->add_subcommand("trace",
                                  "SDF trace benchmark: per-pass GPU/CPU ms (median and min over the timed "
                                  "frames) on each backend, and the "
                                  "mean sphere-trace steps per pixel with the scene's over-relaxation and "
                                  "with none (overRelaxation = 1)");
    cmd->add_option("scene", opt.scene,
                    "Scene file: .json (docs/FORMATS.md), .gltf or .glb; needs sdf objects")
        ->capture_default_str();
    addBenchBackendOption(cmd, opt.backend);
    addSizeOption(cmd, "--width", opt.width, "Image width in pixels (1 .. device max)")
        ->capture_default_str();
    addSizeOption(cmd, "--height", opt.height, "Image height in pixels (1 .. device max)")
        ->capture_default_str();
    cmd->add_option(
           "--frames", opt.frames,
           "Timed frames per setting (offline time, 1/60 s apart); the tables give medians and minima")
        ->check(CLI::Range(1u, 100000u))
        ->capture_default_str();
    cmd->add_option("--warmup", opt.warmup, "Untimed frames first (pipeline compilation, uploads)")
        ->check(CLI::Range(0u, 100000u))
        ->capture_default_str();
    cmd->add_option("--quality", opt.quality,
                    "SDF trace quality preset: low | medium | high | reference (replaces the scene's "
                    "render.quality; the scene's render.trace overrides still apply)")
        ->check(CLI::IsMember({"low", "medium", "high", "reference"}));
    addAccelOption(cmd, opt.accel);
    cmd->add_option("--csv", opt.csv, "Also write the results as CSV (one row per pass / step measure)");
    cmd->add_option("--markdown", opt.markdown,
                    "Also write the results as Markdown tables (docs/BENCHMARKS.md)");
    cmd->add_option("--cache-dir", opt.cacheDir,
                    "Processed-asset cache folder, for fields baked at load (default: $PENUMBRA_CACHE_DIR, "
                    "$XDG_CACHE_HOME/penumbra or ~/.cache/penumbra)");
    cmd->add_flag("--no-cache", opt.noCache, "Do not read or write the processed-asset cache");
    out.accuracyOptions = std::make_shared<BenchAccuracyOptions>();
    out.accuracy = addBenchAccuracyCommand(*out.group, *out.accuracyOptions);
    out.objectsOptions = std::make_shared<BenchObjectsOptions>();
    out.objects = addBenchObjectsCommand(*out.group, *out.objectsOptions);
    out.traceModesOptions = std::make_shared<BenchTraceModesOptions>();
    out.traceModes = addBenchTraceModesCommand(*out.group, *out.traceModesOptions);
    return out;
}

int runBenchTrace(const BenchTraceOptions& opt) {
    std::string error;
    std::vector<rhi::Backend> backends;
    if (!benchBackends(opt.backend, backends)) {
        log::error("bench trace: --backend '{}': use vulkan, gl or both", opt.backend);
        return 2;
    }
    if (scene::AccelerationSettings accel; !applyAccelOption(opt.accel, accel, error)) {
        log::error("bench trace: {}", error);
        return 2;
    }
    if (!checkInputFile(opt.scene, "scene file (.json, .gltf or .glb)", error)) {
        log::error(
            "bench trace: {}{}", error,
            opt.scene == BenchTraceOptions{}.scene
                ? " (the default scene path is relative: run from the repository root or name the scene)"
                : "");
        return 1;
    }
    OutputFiles outputs;
    if (!prepareOutputs(outputs, {opt.csv, opt.markdown}, "bench trace")) return 1;
    const std::string cacheDir =
        opt.noCache ? std::string() : (opt.cacheDir.empty() ? defaultCacheDir() : opt.cacheDir);

    const std::string date = utcNow(), loadBefore = loadAverage();
    fmt::print("penumbra bench trace: {}, {}x{}, {} warm-up + {} timed frames per setting, {}\n", opt.scene,
               opt.width, opt.height, opt.warmup, opt.frames, date);
    fmt::print("machine: {}, {} hardware threads; load average before: {}\n", cpuModel(),
               std::thread::hardware_concurrency(), loadBefore);
    std::vector<BackendRun> runs;
    for (rhi::Backend b : backends) {
        BackendRun run;
        if (const int rc = runBackend(opt, b, cacheDir, run); rc != 0) return rc;
        printRun(opt, run);
        runs.push_back(std::move(run));
    }
    const std::string loadAfter = loadAverage();
    fmt::print("\nload average after: {}\n", loadAfter);
    if (!opt.markdown.empty() &&
        !outputs.writeText(opt.markdown, markdownReport(opt, runs, date, loadBefore, loadAfter), error)) {
        log::error("bench trace: {}", error);
        return 1;
    }
    if (!opt.csv.empty() && !outputs.writeText(opt.csv, csvReport(opt, runs), error)) {
        log::error("bench trace: {}", error);
        return 1;
    }
    if (!outputs.commit(error)) {
        log::error("bench trace: {}", error);
        return 1;
    }
    if (!opt.markdown.empty()) fmt::print("wrote {}\n", opt.markdown);
    if (!opt.csv.empty()) fmt::print("wrote {}\n", opt.csv);
    return 0;
}

}  // namespace penumbra::cli
