// The shadow and ambient-occlusion rows of `penumbra bench accuracy` (docs/ACCURACY.md, "Speed
// against error: shadows" and "...: ambient occlusion"), and the row type every pass of the bench
// shares (cmd_bench_accuracy.cpp writes the CSV, the tables and the plots).
//
// Per scene, at the effect size (--effect-width x --effect-height, smaller than the trace's: the
// Monte Carlo reference is slow on the CPU):
//   reference  depth, ids, ao (RenderDesc::aoMaxDistance = the scene's render.ao.maxDistance) and
//              shadowN of every shadowed light, samples = reference::samplesForError(--effect-error)
//   sdf_shadow (scenes with shadowed lights) each setting changes one value of the default shadow
//              settings at the medium preset (resolutionScale, maxSteps, hard, quality); AO off
//   sdf_ao     (every scene: the bench turns AO on) each variant x resolutionScale, multi-ray rays,
//              quality presets; strength 1, shadows off
// GPU ms = the pass + effects_upsample when it runs (the other effect is off, so the upsampling is
// the measured effect's alone). Metrics over the pixels hit in both whose entity ids agree: the
// effect value (shadow visibility of each light, or AO) against the reference's.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rhi/types.h"

namespace penumbra {
class Engine;
}

namespace penumbra::cli {

struct BenchAccuracyOptions;

namespace accuracy {

inline constexpr const char* kTracePass = "sdf_trace";
inline constexpr const char* kShadowPass = "sdf_shadow";
inline constexpr const char* kAoPass = "sdf_ao";
inline constexpr const char* kUpsamplePass = "effects_upsample";

// Column indices into Row::metrics (the order of accuracyMetrics()).
enum Metric : size_t {
    kDepthRelMean,
    kDepthRelP99,
    kDepthRelMax,
    kDepthRelRmse,
    kDepthPsnr,
    kDepthSsim,
    kSilhouette,
    kIdMismatch,
    kNormalMean,
    kNormalP99,
    kNormalMax,
    kEffectMean,  // the effect rows: |test - reference| of the visibility or AO value in [0, 1]
    kEffectP99,
    kEffectMax,
    kEffectRmse,
    kEffectPsnr,
    kEffectSsim,
    kMetricCount
};
// The metrics of the effect rows (the trace's are the others).
inline bool isEffectMetric(size_t m) { return m >= kEffectMean && m < kMetricCount; }

// One row of accuracy.csv: one (scene, pass, backend, setting[, light]).
struct Row {
    std::string scene, pass, backend, device, setting, value;
    std::string light;      // sdf_shadow: "all" or "N:type" (shadowed light N); empty otherwise
    bool baseline = false;  // the setting is the medium preset itself (AO: per variant)
    double gpuMedian = std::nan(""), frameMedian = std::nan(""), gpuMin = std::nan(""),
           frameMin = std::nan("");
    double metrics[kMetricCount];
    double meanSteps = std::nan("");
    size_t pixelsReference = 0, pixelsTest = 0, pixelsBoth = 0;  // effect rows: both = compared
    uint32_t frames = 0;
    uint32_t refSamples = 0;  // effect rows: the reference's samples per pixel (0: exact)
    double refStdMean = std::nan(""), refStdMax = std::nan("");  // its standard-error bounds
    Row() {
        for (double& m : metrics) m = std::nan("");
    }
};

// What the effect rows of one scene used (the Markdown states it).
struct EffectSceneInfo {
    std::string path;
    uint32_t width = 0, height = 0;
    uint32_t samples = 0;      // reference samples per pixel
    double targetError = 0.0;  // --effect-error
    double aoMaxDistance = 0.0;
    double referenceSeconds = 0.0;
    uint64_t unconverged = 0;
    std::vector<std::string> lights;  // "N:type (size)" of the shadowed lights
    bool shadowRows = false, aoRows = false;
};

// The effect rows of one loaded scene (updated to t = 0) on each backend, appended to `rows`.
// Returns the exit code (0 ok; errors are logged).
int runEffectRows(const BenchAccuracyOptions& opt, Engine& engine, const std::vector<rhi::Backend>& backends,
                  const std::string& scenePath, std::vector<Row>& rows, EffectSceneInfo& info);

// The Markdown of the effect rows: per scene and backend the Pareto-front settings of sdf_shadow
// and sdf_ao, and the default-preset tables (AO error per variant, shadow error per light type).
std::string effectsMarkdown(const BenchAccuracyOptions& opt, const std::vector<Row>& rows,
                            const std::vector<EffectSceneInfo>& scenes);

// Shared with cmd_bench_accuracy.cpp.
std::string num(double v);
std::string sig(double v);
std::string msText(double v);
std::vector<bool> paretoFront(const std::vector<const Row*>& rows, size_t metric);

}  // namespace accuracy
}  // namespace penumbra::cli
