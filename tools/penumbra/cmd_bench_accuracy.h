// `penumbra bench accuracy`: speed against error (issue 11 item 3; docs/ACCURACY.md, "Speed against
// error: the SDF trace"). A benchmark, never a timed test.
//
//   penumbra bench accuracy [--scenes a.json,b.json,...] [--backend vulkan|gl|both]
//                           [--passes trace,shadow,ao] [--width 320 --height 180]
//                           [--effect-width 160 --effect-height 90 --effect-error 0.05]
//                           [--frames 5 --warmup 1] [--sweep default|quick] -o DIR
//
// The sdf_shadow and sdf_ao rows are bench_accuracy_effects.h's (their own frame size, reference
// and sweep); what follows describes the sdf_trace rows.
//
// Per scene: the CPU reference AOVs (depth, normal, ids; reference::buildFromWorld + render, as
// `penumbra reference`) once, at simulated time 0; then, for each setting of the sweep (each trace
// setting varied alone around the medium preset, the scene's own render.trace overrides dropped:
// quality preset, maxSteps, hitEpsilon, overRelaxation, fieldSafety, refineSteps and, for scenes
// with mesh bakes, the bake resolution) and each backend: W warm-up frames per setting, then N
// rounds of one timed frame per setting in alternating order (load changes on a shared machine hit
// every setting alike; median GPU ms of the sdf_trace pass and of the whole frame, the sum of its
// passes), then per setting one untimed frame with gbuffer.aux whose AOVs are compared with the
// reference (tools/reference/metrics.h):
//   depth   relative error |t - r| / r over the pixels hit in both: mean, p99, max, RMSE, the PSNR
//           of the relative error (peak 1) and the SSIM of depth / max reference depth; the
//           silhouette mismatch rate; the fraction of pixels hit in both whose entity id differs
//   normal  angle between the unit normals in degrees over the pixels hit in both: mean, p99, max
// Outputs (all or nothing, engine/core/output_file.h):
//   DIR/accuracy.csv        one row per (scene, pass, backend, setting[, light]): scene, pass,
//                           backend, setting, value, gpu_ms_median, frame_ms_median, the metrics
//                           (the trace's, then effect_*: empty where they do not apply), extras
//   DIR/accuracy.md         per scene and backend the Pareto-front settings (Markdown tables)
//   DIR/<pass>_<metric>.png time against error, the Pareto front marked, drawn by
//                           tools/bench/plot_accuracy.py with python3-matplotlib; when no Python
//                           with matplotlib is found the plots are skipped and the command says how
//                           to install it (--no-plots skips them on purpose)
// Progress goes to stderr. Exit codes: 0 ok, 1 runtime error, 2 usage.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace penumbra::cli {

struct BenchAccuracyOptions {
    std::vector<std::string> scenes{"scenes/default.json", "scenes/shapes.json", "scenes/meshes.json",
                                    "scenes/lights.json"};
    std::vector<std::string> passes{"trace", "shadow", "ao"};  // which rows (bench_accuracy_effects.h)
    std::string backend = "both";                              // vulkan | vk | gl | opengl | both
    uint32_t width = 320;
    uint32_t height = 180;
    uint32_t frames = 5;  // timed frames per setting
    uint32_t warmup = 1;  // untimed frames before them
    std::string sweep = "default";
    std::string outputDir;
    std::string cacheDir;  // empty: $PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra or ~/.cache/penumbra
    bool noCache = false;
    bool noPlots = false;
    std::string
        python;  // empty: $PENUMBRA_PYTHON, else python3 or /usr/bin/python3 (the first with matplotlib)
    std::string
        plotScript;        // empty: tools/bench/plot_accuracy.py from the working folder or above the binary
    uint32_t threads = 0;  // reference renderer threads (0: one per CPU)
    // The shadow and AO rows (bench_accuracy_effects.h): their frame size (the Monte Carlo
    // reference is slow on the CPU) and the error size their reference must resolve.
    uint32_t effectWidth = 160;
    uint32_t effectHeight = 90;
    double effectError = 0.05;  // reference samples: reference::samplesForError (0.05 -> 900)

    bool wantPass(const char* p) const {
        for (const std::string& s : passes)
            if (s == p) return true;
        return false;
    }
    bool wantTrace() const { return wantPass("trace"); }
    bool wantShadow() const { return wantPass("shadow"); }
    bool wantAo() const { return wantPass("ao"); }
};

// Adds `accuracy` to the `bench` group.
CLI::App* addBenchAccuracyCommand(CLI::App& group, BenchAccuracyOptions& opt);
int runBenchAccuracy(const BenchAccuracyOptions& opt);

// The metric columns of accuracy.csv, in order (after frame_ms_median), and whether larger is
// better for each (PSNR, SSIM); exposed for tests and the plot script's checks.
struct AccuracyMetricInfo {
    const char* name;
    bool higherIsBetter;
};
const std::vector<AccuracyMetricInfo>& accuracyMetrics();

}  // namespace penumbra::cli
