// `penumbra bench <subcommand>` — benchmarks as commands of the CLI (programs, never timed tests;
// results go into docs/BENCHMARKS.md). A command group; its subcommands:
//   bench trace [scene] [--backend vk|gl|both] [--width W --height H] [--frames N] [--warmup W]
//               [--quality low|medium|high|reference] [--csv out.csv] [--markdown out.md]
//     Renders the scene (default scenes/default.json) through the embedding API (penumbra::Engine +
//     penumbra::Renderer, offline time like `penumbra render --frames`) on each backend: W warm-up
//     frames then N timed frames, each frame twice — with the scene's / preset's over-relaxation
//     and with overRelaxation = 1 (interleaved, so both see the same machine load). Prints per pass
//     the median and min GPU / CPU ms over the N frames of the first setting, the sdf_trace GPU
//     median of both, and the mean sphere-trace steps per pixel of both (gbuffer.aux y of one extra
//     frame each: over the pixels where an SDF was hit, and over all pixels) with their ratio.
//     Progress goes to stderr; --csv / --markdown are written all or nothing.
//   bench accuracy [--scenes a.json,...] [...] -o DIR   speed against error (cmd_bench_accuracy.h)
//   bench objects [--counts 20,40,60,80] [...]          mTec Table 2: cost against object count and
//                                                       acceleration toggles (bench_objects.h)
//   bench trace-modes [--counts 20,...,1000] [...]     mTec Table 7: full-screen vs box tracing
//                                                       against object count (bench_trace_modes.h)
// Exit codes: 0 ok, 1 runtime error (bad scene, device failure, unwritable output), 2 usage.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "bench_objects.h"
#include "bench_trace_modes.h"
#include "cmd_bench_accuracy.h"

namespace penumbra::cli {

struct BenchTraceOptions {
    std::string scene = "scenes/default.json";
    std::string backend = "both";  // vulkan | vk | gl | opengl | both
    uint32_t width = 640;
    uint32_t height = 360;
    uint32_t frames = 7;  // timed frames per setting
    uint32_t warmup = 2;  // untimed frames before them
    std::string quality;  // empty: the scene's render.quality
    std::string accel;    // --accel (cli_common.h); empty: the scene's render.acceleration
    std::string csv;
    std::string markdown;
    std::string cacheDir;  // empty: $PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra or ~/.cache/penumbra
    bool noCache = false;
};

struct BenchCommands {
    CLI::App* group = nullptr;     // `bench`
    CLI::App* trace = nullptr;     // `bench trace`
    CLI::App* accuracy = nullptr;  // `bench accuracy` (cmd_bench_accuracy.h)
    CLI::App* objects = nullptr;   // `bench objects` (bench_objects.h)
    // `bench trace-modes` (bench_trace_modes.h)
    CLI::App* traceModes = nullptr;
    std::shared_ptr<BenchTraceModesOptions> traceModesOptions;
    std::shared_ptr<BenchAccuracyOptions> accuracyOptions;
    std::shared_ptr<BenchObjectsOptions> objectsOptions;
};

BenchCommands addBenchCommand(CLI::App& app, BenchTraceOptions& traceOpt);
int runBenchTrace(const BenchTraceOptions& opt);

}  // namespace penumbra::cli
