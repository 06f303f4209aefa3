// `penumbra bench trace-modes` (bench_trace_modes.h): full-screen vs box tracing over N.
#include "bench_trace_modes.h"

#include "bench_objects.h"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "cli_common.h"
#include "engine/core/log.h"
#include "engine/core/output_file.h"
#include "engine/engine.h"
#include "engine/scene/objects_scene.h"
#include "renderer/renderer.h"

namespace penumbra::cli {
namespace {

namespace fs = std::filesystem;
constexpr double kFrameDt = 1.0 / 60.0;
const scene::TraceMode kModes[2] = {scene::TraceMode::Fullscreen, scene::TraceMode::Box};

bool tracePass(const std::string& name) {
    return name == "sdf_trace" || name == "sdf_box_trace" || name.rfind("sdf_tile_cull", 0) == 0;
}

struct Series {
    std::vector<double> trace, frame;
};

struct Row {
    uint32_t count = 0, sdfObjects = 0, boxDraws = 0, nearDraws = 0;
    double coverage = 0.0;  // the boxes' summed screen fractions (FrameStats::boxCoverage)
    Series modes[2];
};

struct Table {
    rhi::Backend backend = rhi::Backend::Auto;
    std::string device;
    std::vector<Row> rows;
};

// Frame timings arrive late: every rendered frame is tagged (mode, or -1 untimed) in order.
struct Sink {
    std::vector<int> tags;
    size_t next = 0;
    bool add(Row& row, const std::vector<fg::FrameTimings>& frames, std::string& error) {
        for (const fg::FrameTimings& f : frames) {
            if (next >= tags.size()) {
                error = "more frame timings than rendered frames";
                return false;
            }
            const int mode = tags[next++];
            if (mode < 0) continue;
            double trace = 0, total = 0;
            for (const fg::PassTiming& t : f.passes) {
                if (!std::isfinite(t.gpuMs)) continue;
                total += t.gpuMs;
                if (tracePass(t.name)) trace += t.gpuMs;
            }
            row.modes[mode].trace.push_back(trace);
            row.modes[mode].frame.push_back(total);
        }
        return true;
    }
};

int runCount(const BenchTraceModesOptions& opt, rhi::Backend backend, uint32_t count,
             const std::string& tmpDir, const std::string& cacheDir, Table& table) {
    std::string error;
    scene::ObjectsSceneDesc desc;
    desc.count = count;
    desc.instanced = opt.instancing == "on";
    desc.resolution = opt.resolution;
    desc.aspect = float(opt.width) / float(opt.height);
    desc.meshDir = fs::absolute(opt.meshDir).string();
    scene::ObjectsScene generated;
    const std::string path = fmt::format("{}/objects_{}.json", tmpDir, count);
    OutputFiles files;
    if (!scene::generateObjectsScene(desc, generated, error) || !files.add(path, error) ||
        !files.writeText(path, generated.json, error) || !files.commit(error)) {
        log::error("bench trace-modes: {}", error);
        return 1;
    }
    std::unique_ptr<Engine> engine;
    std::unique_ptr<Renderer> renderer;
    const int rc = openObjectsBench(
        path, cacheDir, backend, opt.width, opt.height, "bench trace-modes",
        [](Engine& e) {
            e.settings().shadows.enabled = false;  // Table 7: the primary trace only
            e.settings().ao.variant = scene::AoVariant::Off;
        },
        engine, renderer);
    if (rc != 0) return rc;
    table.device = renderer->device().info().deviceName;
    fmt::print(stderr, "[{}] {} objects: {} warm-up + {} timed frames per mode\n", rhi::toString(backend),
               count, opt.warmup, opt.frames);
    Row row;
    row.count = count;
    Sink sink;
    app::FrameTime time;
    uint64_t frameNo = 0;
    for (uint32_t f = 0; f < opt.warmup + opt.frames; ++f)
        for (int m = 0; m < 2; ++m, ++frameNo) {
            engine->settings().traceMode = kModes[m];
            if (!engine->updateOffline(frameNo == 0 ? 0.0 : kFrameDt, time, error) ||
                !renderer->renderFrame(*engine, error)) {
                log::error("bench trace-modes: {} objects: {}", count, error);
                return 1;
            }
            if (renderer->stats().traceMode != kModes[m]) {
                log::error("bench trace-modes: {} objects: mode {} did not run", count,
                           scene::toString(kModes[m]));
                return 1;
            }
            if (m == 1) {
                row.boxDraws = renderer->stats().boxDraws;
                row.nearDraws = renderer->stats().nearDraws;
                row.coverage = renderer->stats().boxCoverage;
            }
            row.sdfObjects = renderer->stats().sdfObjects;
            sink.tags.push_back(f < opt.warmup ? -1 : m);
            if (!sink.add(row, renderer->takeTimings(false), error)) {
                log::error("bench trace-modes: {}", error);
                return 1;
            }
        }
    if (!sink.add(row, renderer->takeTimings(true), error) || sink.next != sink.tags.size()) {
        log::error("bench trace-modes: {}", error.empty() ? "frame timings missing" : error);
        return 1;
    }
    table.rows.push_back(std::move(row));
    return 0;
}

double ratio(double a, double b) { return b > 0 ? a / b : std::nan(""); }

// The counts where box tracing was faster (trace time) and those where full-screen was, as text.
std::string faster(const Table& t, bool box) {
    std::string out;
    for (const Row& r : t.rows) {
        const double ft = median(r.modes[0].trace), bt = median(r.modes[1].trace);
        if (box ? bt < ft : ft <= bt) out += (out.empty() ? "" : ", ") + std::to_string(r.count);
    }
    return out.empty() ? "none" : out;
}

std::string markdown(const BenchTraceModesOptions& opt, const std::vector<Table>& tables,
                     const std::string& header) {
    std::string md = fmt::format(
        "`penumbra bench trace-modes --counts {} --width {} --height {} --frames {} --warmup {} --instancing "
        "{}`; "
        "{}\n\n",
        opt.counts, opt.width, opt.height, opt.frames, opt.warmup, opt.instancing, header);
    for (const Table& t : tables) {
        md += fmt::format("**{}** ({}); median GPU ms, shadows and AO off:\n\n", rhi::toString(t.backend),
                          t.device);
        md +=
            "| N | SDF objects | boxes / near-plane draws | coverage (screens) | fullscreen trace | box "
            "trace | "
            "box / fullscreen | fullscreen frame | box frame |\n|---|---|---|---|---|---|---|---|---|\n";
        for (const Row& r : t.rows) {
            const double ft = median(r.modes[0].trace), bt = median(r.modes[1].trace);
            md += fmt::format("| {} | {} | {} / {} | {:.2f} | {:.2f} | {:.2f} | {:.2f} | {:.2f} | {:.2f} |\n",
                              r.count, r.sdfObjects, r.boxDraws, r.nearDraws, r.coverage, ft, bt,
                              ratio(bt, ft), median(r.modes[0].frame), median(r.modes[1].frame));
        }
        md += fmt::format("\nBox trace faster at N = {}; full-screen faster at N = {}.\n\n", faster(t, true),
                          faster(t, false));
    }
    return md;
}

std::string csv(const std::vector<Table>& tables) {
    std::string out = "backend,count,mode,trace_ms,frame_ms\n";
    for (const Table& t : tables)
        for (const Row& r : t.rows)
            for (int m = 0; m < 2; ++m)
                out += fmt::format("{},{},{},{:.4f},{:.4f}\n", rhi::toString(t.backend), r.count,
                                   scene::toString(kModes[m]), median(r.modes[m].trace),
                                   median(r.modes[m].frame));
    return out;
}

}  // namespace

CLI::App* addBenchTraceModesCommand(CLI::App& group, BenchTraceModesOptions& opt) {
    CLI::App* cmd = group.add_subcommand(
        "trace-modes",
        "Full-screen against box tracing (mTec Table 7) on the generated objects scene: median GPU ms of the "
        "trace (fullscreen: sdf_trace + sdf_tile_cull*; box: sdf_box_trace) and of the frame per object "
        "count, shadows and AO off, the ratio and the crossover");
    cmd->add_option("--counts", opt.counts, "Object counts, comma-separated (each 1 .. 100000)")
        ->capture_default_str();
    addBenchBackendOption(cmd, opt.backend);
    addSizeOption(cmd, "--width", opt.width, "Image width in pixels")->capture_default_str();
    addSizeOption(cmd, "--height", opt.height, "Image height in pixels")->capture_default_str();
    cmd->add_option("--frames", opt.frames, "Timed frames per mode (medians)")
        ->check(CLI::Range(1u, 100000u))
        ->capture_default_str();
    cmd->add_option("--warmup", opt.warmup, "Untimed frames per mode before the timed ones")
        ->check(CLI::Range(0u, 100000u))
        ->capture_default_str();
    cmd->add_option("--instancing", opt.instancing,
                    "on: objects of a kind share one field; off: each object its own field")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    cmd->add_option("--resolution", opt.resolution, "Bake resolution of the meshes (voxels, longest axis)")
        ->check(CLI::Range(8u, 1024u))
        ->capture_default_str();
    cmd->add_option("--mesh-dir", opt.meshDir,
                    "Folder of bunny.ply, teapot.ply, dragon_vrip_res3.ply (tools/fetch_meshes.sh)")
        ->capture_default_str();
    cmd->add_option("--csv", opt.csv, "Also write the results as CSV");
    cmd->add_option("--markdown", opt.markdown, "Also write the tables as Markdown (docs/BENCHMARKS.md)");
    cmd->add_option("--cache-dir", opt.cacheDir, "Processed-asset cache folder (baked fields)");
    cmd->add_flag("--no-cache", opt.noCache, "Do not read or write the processed-asset cache");
    return cmd;
}

int runBenchTraceModes(const BenchTraceModesOptions& opt) {
    std::string error;
    std::vector<uint32_t> counts;
    if (!parseObjectCounts(opt.counts, counts, error)) {
        log::error("bench trace-modes: {}", error);
        return 2;
    }
    std::vector<rhi::Backend> backends;
    if (!benchBackends(opt.backend, backends)) {
        log::error("bench trace-modes: --backend '{}': use vulkan, gl or both", opt.backend);
        return 2;
    }
    if (!checkObjectsMeshes(opt.meshDir, error)) {
        log::error("bench trace-modes: {}", error);
        return 1;
    }
    OutputFiles outputs;
    if (!prepareOutputs(outputs, {opt.csv, opt.markdown}, "bench trace-modes")) return 1;
    const std::string cacheDir =
        opt.noCache ? std::string() : (opt.cacheDir.empty() ? defaultCacheDir() : opt.cacheDir);
    const fs::path tmpDir =
        fs::temp_directory_path() / fmt::format("penumbra-bench-trace-modes-{}", ::getpid());
    fs::create_directories(tmpDir);
    const std::string date = utcNow(), loadBefore = loadAverage();
    std::vector<Table> tables;
    int rc = 0;
    for (rhi::Backend b : backends) {
        Table t;
        t.backend = b;
        for (uint32_t n : counts)
            if (rc == 0) rc = runCount(opt, b, n, tmpDir.string(), cacheDir, t);
        tables.push_back(std::move(t));
    }
    std::error_code ec;
    fs::remove_all(tmpDir, ec);
    if (rc != 0) return rc;
    const std::string header =
        fmt::format("{}. Machine: {}, {} hardware threads. Load average before: {}; after: {}.", date,
                    cpuModel(), std::thread::hardware_concurrency(), loadBefore, loadAverage());
    const std::string md = markdown(opt, tables, header);
    fmt::print("\n{}", md);
    if ((!opt.markdown.empty() && !outputs.writeText(opt.markdown, md, error)) ||
        (!opt.csv.empty() && !outputs.writeText(opt.csv, csv(tables), error)) || !outputs.commit(error)) {
        log::error("bench trace-modes: {}", error);
        return 1;
    }
    return 0;
}

}  // namespace penumbra::cli
