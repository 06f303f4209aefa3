#include "cmd_bench_accuracy.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <glm/vec3.hpp>

#include "aov_output.h"
#include "bench_accuracy_effects.h"
#include "cli_common.h"
#include "engine/core/log.h"
#include "engine/core/output_file.h"
#include "engine/core/progress.h"
#include "engine/ecs/components.h"
#include "engine/engine.h"
#include "reference/metrics.h"
#include "reference/pfm.h"
#include "reference/reference.h"
#include "renderer/renderer.h"

namespace penumbra::cli {
namespace accuracy {

std::string num(double v) {
    if (std::isnan(v)) return {};
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    return fmt::format("{:.6g}", v);
}

// Rows (indices) on the Pareto front of (gpu ms, metric), lower is better for both: no other row
// is at least as good in both and better in one.
std::vector<bool> paretoFront(const std::vector<const Row*>& rows, size_t metric) {
    std::vector<bool> front(rows.size(), false);
    for (size_t i = 0; i < rows.size(); ++i) {
        const double t = rows[i]->gpuMedian, e = rows[i]->metrics[metric];
        if (!std::isfinite(t) || std::isnan(e)) continue;
        bool dominated = false;
        for (size_t j = 0; j < rows.size() && !dominated; ++j) {
            if (j == i) continue;
            const double tj = rows[j]->gpuMedian, ej = rows[j]->metrics[metric];
            if (!std::isfinite(tj) || std::isnan(ej)) continue;
            dominated = tj <= t && ej <= e && (tj < t || ej < e);
        }
        front[i] = !dominated;
    }
    return front;
}

std::string sig(double v) { return std::isfinite(v) ? fmt::format("{:.3g}", v) : std::string("–"); }
std::string msText(double v) {
    if (!std::isfinite(v)) return "–";
    return v >= 100.0  ? fmt::format("{:.0f}", v)
           : v >= 10.0 ? fmt::format("{:.1f}", v)
                       : fmt::format("{:.2f}", v);
}

}  // namespace accuracy

namespace {

namespace fs = std::filesystem;

constexpr const char* kCommand = "bench accuracy";
using namespace accuracy;                        // Row, the metric columns, the pass names
constexpr uint32_t kMediumBakeResolution = 128;  // sdf::automaticResolution at BakeQuality::Medium

// The column of a metric name of accuracyMetrics() (kMetricCount: unknown).
size_t metricIndex(const std::string& name) {
    const std::vector<AccuracyMetricInfo>& all = accuracyMetrics();
    for (size_t i = 0; i < all.size(); ++i)
        if (name == all[i].name) return i;
    return kMetricCount;
}

double minimum(const std::vector<double>& v) {
    double m = std::nan("");
    for (double x : v)
        if (std::isfinite(x) && !(m <= x)) m = x;
    return m;
}

std::string shellQuote(const std::string& s) {
    std::string q = "'";
    for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}

std::string csvField(const std::string& s) {
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}

// ---- the sweep -------------------------------------------------------------------------------

// One setting: one trace parameter (or the bake resolution, or a whole preset) changed from the
// medium preset.
struct Setting {
    std::string
        param;  // quality, maxSteps, hitEpsilon, overRelaxation, fieldSafety, refineSteps, bakeResolution
    std::string value;
    scene::TraceQuality quality = scene::TraceQuality::Medium;
    scene::TraceOverrides trace;  // one override at most
    uint32_t bakeResolution =
        0;  // bakeResolution rows: voxels along the longest axis; 0 = the scene's fields
};

std::string floatText(float v) { return fmt::format("{}", v); }

std::vector<Setting> buildSweep(const std::string& sweep, bool bakes) {
    const bool quick = sweep == "quick";
    std::vector<Setting> out;
    for (scene::TraceQuality q :
         quick
             ? std::vector<scene::TraceQuality>{scene::TraceQuality::Low, scene::TraceQuality::Medium}
             : std::vector<scene::TraceQuality>{scene::TraceQuality::Low, scene::TraceQuality::Medium,
                                                scene::TraceQuality::High, scene::TraceQuality::Reference}) {
        Setting s;
        s.param = "quality";
        s.value = scene::toString(q);
        s.quality = q;
        out.push_back(s);
    }
    for (uint32_t v : quick ? std::vector<uint32_t>{32} : std::vector<uint32_t>{16, 32, 64, 128, 256}) {
        Setting s;
        s.param = "maxSteps";
        s.value = std::to_string(v);
        s.trace.maxSteps = v;
        out.push_back(s);
    }
    for (float v :
         quick ? std::vector<float>{1.0f} : std::vector<float>{2.0f, 1.0f, 0.5f, 0.25f, 0.1f, 0.02f}) {
        Setting s;
        s.param = "hitEpsilon";
        s.value = floatText(v);
        s.trace.hitEpsilon = v;
        out.push_back(s);
    }
    for (float v : quick ? std::vector<float>{1.0f} : std::vector<float>{1.0f, 1.2f, 1.3f, 1.5f}) {
        Setting s;
        s.param = "overRelaxation";
        s.value = floatText(v);
        s.trace.overRelaxation = v;
        out.push_back(s);
    }
    for (float v : quick ? std::vector<float>{0.0f} : std::vector<float>{0.0f, 0.5f, 1.0f}) {
        Setting s;
        s.param = "fieldSafety";
        s.value = floatText(v);
        s.trace.fieldSafety = v;
        out.push_back(s);
    }
    for (uint32_t v : quick ? std::vector<uint32_t>{0} : std::vector<uint32_t>{0, 4, 8, 16, 32}) {
        Setting s;
        s.param = "refineSteps";
        s.value = std::to_string(v);
        s.trace.refineSteps = v;
        out.push_back(s);
    }
    if (bakes)
        for (uint32_t v : quick ? std::vector<uint32_t>{32} : std::vector<uint32_t>{32, 64, 128, 256}) {
            Setting s;
            s.param = "bakeResolution";
            s.value = std::to_string(v);
            s.bakeResolution = v;
            out.push_back(s);
        }
    return out;
}

bool sameTrace(const scene::TraceSettings& a, const scene::TraceSettings& b) {
    return a.maxSteps == b.maxSteps && a.refineSteps == b.refineSteps && a.hitEpsilon == b.hitEpsilon &&
           a.normalEpsilon == b.normalEpsilon && a.overRelaxation == b.overRelaxation &&
           a.fieldSafety == b.fieldSafety;
}

// ---- results ---------------------------------------------------------------------------------

struct SceneInfo {
    std::string path;
    double referenceSeconds = 0;
    uint64_t unconverged = 0;
    size_t referencePixels = 0;
    uint32_t sdfObjects = 0, meshBakes = 0;
};

reference::FloatImage toFloatImage(const reference::AovImage& a) {
    reference::FloatImage f;
    f.width = a.width;
    f.height = a.height;
    f.channels = a.channels;
    f.data = a.data;
    return f;
}

bool hit(float depth) { return std::isfinite(depth) && depth > 0.0f; }

// Every metric of one frame's AOVs against the reference (see the header).
bool computeMetrics(const reference::FloatImage& refDepth, const reference::FloatImage& refNormal,
                    const reference::FloatImage& refIds, const reference::FloatImage& depth,
                    const reference::FloatImage& normal, const reference::FloatImage& ids, Row& row,
                    std::string& error) {
    reference::SilhouetteStats sil;
    if (!reference::silhouetteMismatch(depth, refDepth, sil, error)) return false;
    row.metrics[kSilhouette] = sil.mismatchRate;
    row.pixelsTest = sil.hitA;
    row.pixelsReference = sil.hitB;
    row.pixelsBoth = sil.hitBoth;
    if (sil.hitBoth == 0) return true;  // nothing to compare: the other metrics stay empty
    const std::vector<uint8_t> mask = reference::bothHitMask(depth, refDepth);
    const size_t pixels = size_t(depth.width) * depth.height;

    // Relative depth error: (t / r) against 1 over the pixels hit in both.
    reference::FloatImage rel, one;
    rel.width = one.width = depth.width;
    rel.height = one.height = depth.height;
    rel.data.assign(pixels, 1.0f);
    one.data.assign(pixels, 1.0f);
    double maxRef = 0.0;
    size_t idDiffer = 0;
    for (size_t i = 0; i < pixels; ++i) {
        if (hit(refDepth.data[i])) maxRef = std::max(maxRef, double(refDepth.data[i]));
        if (!mask[i]) continue;
        rel.data[i] = float(double(depth.data[i]) / double(refDepth.data[i]));
        if (std::lround(ids.data[i]) != std::lround(refIds.data[i])) ++idDiffer;
    }
    reference::MetricsDesc desc;
    desc.mask = mask;
    reference::ErrorStats st;
    if (!reference::compareImages(rel, one, desc, st, error)) {
        error = "relative depth: " + error;
        return false;
    }
    row.metrics[kDepthRelMean] = st.meanAbs;
    row.metrics[kDepthRelP99] = st.p99Abs;
    row.metrics[kDepthRelMax] = st.maxAbs;
    row.metrics[kDepthRelRmse] = st.rmse;
    row.metrics[kDepthPsnr] = st.psnr;
    row.metrics[kIdMismatch] = double(idDiffer) / double(sil.hitBoth);

    // SSIM of depth scaled by the largest reference depth (peak 1).
    reference::FloatImage a = depth, b = refDepth;
    const float scale = maxRef > 0.0 ? float(1.0 / maxRef) : 1.0f;
    for (size_t i = 0; i < pixels; ++i) {
        a.data[i] = std::isfinite(a.data[i]) ? a.data[i] * scale : 0.0f;
        b.data[i] = std::isfinite(b.data[i]) ? b.data[i] * scale : 0.0f;
    }
    row.metrics[kDepthSsim] = reference::ssim(a, b, mask, 1.0);

    // Normal angle in degrees (atan2 of |a x b| and a . b: accurate at small angles).
    reference::FloatImage angle, zero;
    angle.width = zero.width = depth.width;
    angle.height = zero.height = depth.height;
    angle.data.assign(pixels, 0.0f);
    zero.data.assign(pixels, 0.0f);
    for (size_t i = 0; i < pixels; ++i) {
        if (!mask[i]) continue;
        const glm::dvec3 n(normal.data[i * 3], normal.data[i * 3 + 1], normal.data[i * 3 + 2]);
        const glm::dvec3 r(refNormal.data[i * 3], refNormal.data[i * 3 + 1], refNormal.data[i * 3 + 2]);
        const double ln = glm::length(n), lr = glm::length(r);
        double deg = 180.0;  // a missing or non-finite normal counts as the worst
        if (std::isfinite(ln) && std::isfinite(lr) && ln > 1e-12 && lr > 1e-12)
            deg = glm::degrees(std::atan2(glm::length(glm::cross(n / ln, r / lr)), glm::dot(n / ln, r / lr)));
        angle.data[i] = float(deg);
    }
    reference::MetricsDesc angleDesc;
    angleDesc.mask = mask;
    angleDesc.peak = 180.0;
    if (!reference::compareImages(angle, zero, angleDesc, st, error)) {
        error = "normal angle: " + error;
        return false;
    }
    row.metrics[kNormalMean] = st.meanAbs;
    row.metrics[kNormalP99] = st.p99Abs;
    row.metrics[kNormalMax] = st.maxAbs;
    return true;
}

// ---- one scene -------------------------------------------------------------------------------

// MeshBake entities whose mesh file is known: their field can be baked again at another resolution.
struct BakeTarget {
    ecs::Entity entity;
    std::string mesh;
    assets::AssetId original = 0;
    uint32_t sceneResolution = 0;
};

class Rebaker {
public:
    explicit Rebaker(Engine& engine) : m_engine(engine) {
        for (auto [e, sr] : engine.world().view<ecs::SdfRenderer>())
            if (sr.visible && sr.source == ecs::SdfSource::MeshBake && !sr.bakeMesh.empty() && sr.sdf != 0)
                m_targets.push_back({e, sr.bakeMesh, sr.sdf, sr.bakeResolution});
    }
    ~Rebaker() {
        restore();
        for (const auto& [key, id] : m_fields) m_engine.assets().release(id);
    }
    bool empty() const { return m_targets.empty(); }
    size_t size() const { return m_targets.size(); }
    // Whether the scene's own fields are baked at `resolution` (automatic medium = 128).
    bool sceneUses(uint32_t resolution) const {
        for (const BakeTarget& t : m_targets)
            if ((t.sceneResolution ? t.sceneResolution : kMediumBakeResolution) != resolution) return false;
        return true;
    }
    // 0: the scene's fields. Each (mesh, resolution) is baked once (AssetManager::bakeSdf, which
    // also reads and writes the processed-asset cache).
    bool apply(uint32_t resolution, const std::string& label, std::string& error) {
        for (const BakeTarget& t : m_targets) {
            assets::AssetId field = t.original;
            if (resolution != 0) {
                const std::string key = fmt::format("{}@{}", t.mesh, resolution);
                auto it = m_fields.find(key);
                if (it == m_fields.end()) {
                    fmt::print(stderr, "[{}] baking {} at resolution {}\n", label, t.mesh, resolution);
                    const assets::AssetId mesh = m_engine.assets().loadMesh(t.mesh, error);
                    if (mesh == 0) return false;
                    sdf::BakeSettings settings;
                    settings.resolution = resolution;
                    const assets::AssetId baked = m_engine.assets().bakeSdf(mesh, settings, error);
                    m_engine.assets().release(mesh);
                    if (baked == 0) {
                        error = fmt::format("baking {} at resolution {}: {}", t.mesh, resolution, error);
                        return false;
                    }
                    it = m_fields.emplace(key, baked).first;
                }
                field = it->second;
            }
            m_engine.world().get<ecs::SdfRenderer>(t.entity)->sdf = field;
        }
        return true;
    }
    void restore() {
        for (const BakeTarget& t : m_targets)
            if (ecs::SdfRenderer* sr = m_engine.world().get<ecs::SdfRenderer>(t.entity)) sr->sdf = t.original;
    }

private:
    Engine& m_engine;
    std::vector<BakeTarget> m_targets;
    std::map<std::string, assets::AssetId> m_fields;  // "<mesh>@<resolution>" -> one reference
};

struct Reference {
    reference::FloatImage depth, normal, ids;
};

bool renderReference(const BenchAccuracyOptions& opt, Engine& engine, ecs::Entity camera, Reference& ref,
                     SceneInfo& info, std::string& error) {
    reference::ReferenceCamera cam;
    if (!reference::makeCamera(engine.world(), camera, opt.width, opt.height, cam, error)) return false;
    std::unique_ptr<reference::ReferenceScene> scene = reference::ReferenceScene::create(error);
    if (!scene || !reference::buildFromWorld(engine.world(), engine.assets(), *scene, error) ||
        !scene->commit(error))
        return false;
    reference::RenderDesc desc;
    if (!reference::parseAovList("depth,normal,ids", desc.aovs, error)) return false;
    desc.samples = 1;  // exact AOVs only: no Monte Carlo
    desc.threads = opt.threads;
    StderrProgressOutput progressOutput;
    ProgressBar progress(progressOutput);
    desc.progress = [&](double f) { progress.update(f, "reference"); };
    const auto start = std::chrono::steady_clock::now();
    std::vector<reference::AovImage> images;
    if (!reference::render(*scene, cam, desc, images, error)) return false;
    progress.finish();
    info.referenceSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    info.unconverged = scene->sdfStats().unconverged;
    for (const reference::AovImage& a : images) {
        if (a.name == "depth") ref.depth = toFloatImage(a);
        if (a.name == "normal") ref.normal = toFloatImage(a);
        if (a.name == "ids") ref.ids = toFloatImage(a);
    }
    if (ref.depth.data.empty() || ref.normal.data.empty() || ref.ids.data.empty()) {
        error = "the reference renderer returned no depth, normal or ids image";
        return false;
    }
    for (float d : ref.depth.data) info.referencePixels += hit(d) ? 1 : 0;
    return true;
}

bool readAovs(render::SceneRenderer& renderer, uint32_t width, uint32_t height, reference::FloatImage& depth,
              reference::FloatImage& normal, reference::FloatImage& ids, reference::FloatImage& steps,
              std::string& error) {
    TargetTexels d, n, a;
    if (!renderer.readTarget("gbuffer.depth", d.texels, d.format, error) ||
        !renderer.readTarget("gbuffer.normal", n.texels, n.format, error) ||
        !renderer.readTarget("gbuffer.aux", a.texels, a.format, error))
        return false;
    return convertAov(RenderAov::Depth, width, height, &d, &n, &a, depth, error) &&
           convertAov(RenderAov::Normal, width, height, &d, &n, &a, normal, error) &&
           convertAov(RenderAov::Ids, width, height, &d, &n, &a, ids, error) &&
           convertAov(RenderAov::Steps, width, height, &d, &n, &a, steps, error);
}

// One untimed frame with gbuffer.aux (ids, steps) for the AOVs: the same settings and time as the
// timed frames.
bool renderAovFrame(Engine& engine, render::SceneRenderer& renderer, const scene::RenderSettings& settings,
                    const BenchAccuracyOptions& opt, reference::FloatImage& depth,
                    reference::FloatImage& normal, reference::FloatImage& ids, reference::FloatImage& steps,
                    std::string& error) {
    render::FrameDesc fd;
    fd.camera = scene::findCamera(engine.world(), settings.camera);
    fd.settings = settings;
    fd.width = opt.width;
    fd.height = opt.height;
    fd.aux = true;
    return renderer.render(engine.world(), engine.assets(), fd, error) &&
           readAovs(renderer, opt.width, opt.height, depth, normal, ids, steps, error);
}

// One backend over every setting of the sweep. Returns the exit code (0 ok).
int runBackend(const BenchAccuracyOptions& opt, Engine& engine, rhi::Backend backend, const Reference& ref,
               const std::vector<Setting>& sweep, Rebaker& rebaker, const std::string& scenePath,
               std::vector<Row>& rows) {
    std::string error;
    const char* name = rhi::toString(backend);
    RendererDesc rendererDesc;
    rendererDesc.backend = backend;
    rendererDesc.width = opt.width;
    rendererDesc.height = opt.height;
    std::unique_ptr<Renderer> renderer = Renderer::create(engine, rendererDesc, error);
    if (!renderer) {
        log::error("{}: {}: {}", kCommand, name, error);
        return 1;
    }
    if (!refuseNullDevice(renderer->device(), kCommand, error) ||
        !checkImageSize(opt.width, opt.height, renderer->device(), "bench accuracy: --width/--height",
                        error)) {
        log::error("{}", error);
        return 2;
    }
    const rhi::DeviceInfo& info = renderer->device().info();
    const std::string device = fmt::format("{}; {} {}", info.deviceName, info.driverName, info.driverVersion);
    scene::RenderSettings& settings = engine.settings();
    const scene::RenderSettings original = settings;
    const std::string label = fmt::format("{} {}", scenePath, name);
    fmt::print(
        stderr,
        "[{}] {}, {}x{}: {} settings; {} warm-up frame(s) each, then {} round(s) of one timed frame per "
        "setting\n",
        label, device, opt.width, opt.height, sweep.size(), opt.warmup, opt.frames);

    auto apply = [&](size_t si) {
        const Setting& s = sweep[si];
        settings.quality = s.quality;
        settings.trace = s.trace;  // the scene's own overrides are dropped: one change from the preset
        if (rebaker.empty() || rebaker.apply(s.bakeResolution, label, error)) return true;
        log::error("{}: {}: {}", kCommand, scenePath, error);
        return false;
    };
    // Timings arrive in the order of the frames (one FrameTimings per rendered frame): tags[k] is the
    // setting of the k-th frame, -1 for untimed frames (warm-up, AOV frames).
    const size_t count = sweep.size();
    std::vector<std::vector<double>> gpu(count), frame(count);
    std::vector<int> tags;
    size_t received = 0;
    auto collect = [&](bool wait) {
        for (const fg::FrameTimings& t : renderer->takeTimings(wait)) {
            if (received >= tags.size()) return false;
            const int si = tags[received++];
            if (si < 0) continue;
            double pass = std::nan(""), sum = 0;
            bool any = false;
            for (const fg::PassTiming& p : t.passes) {
                if (p.name == kTracePass) pass = p.gpuMs;
                if (std::isfinite(p.gpuMs)) {
                    sum += p.gpuMs;
                    any = true;
                }
            }
            gpu[size_t(si)].push_back(pass);
            frame[size_t(si)].push_back(any ? sum : std::nan(""));
        }
        return true;
    };
    auto renderOne = [&](size_t si, bool timed, const char* what) {
        if (!apply(si)) return false;
        if (!renderer->renderFrame(engine, error)) {
            log::error("{}: {}: {}={}: {} frame: {}", kCommand, label, sweep[si].param, sweep[si].value, what,
                       error);
            return false;
        }
        tags.push_back(timed ? int(si) : -1);
        if (collect(false)) return true;
        log::error("{}: {}: more frame timings than frames", kCommand, label);
        return false;
    };
    renderer->takeTimings(true);  // nothing from before
    // Warm-up per setting (uploads, re-baked fields), then N rounds of one frame per setting, in
    // alternating order: load changes on a shared machine hit every setting alike.
    for (size_t si = 0; si < count; ++si)
        for (uint32_t w = 0; w < opt.warmup; ++w)
            if (!renderOne(si, false, "warm-up")) return 1;
    for (uint32_t round = 0; round < opt.frames; ++round) {
        for (size_t i = 0; i < count; ++i)
            if (!renderOne(round % 2 ? count - 1 - i : i, true, "timed")) return 1;
        fmt::print(stderr, "[{}] timed round {}/{} ({} frames)\n", label, round + 1, opt.frames, count);
    }
    if (!collect(true)) {
        log::error("{}: {}: more frame timings than frames", kCommand, label);
        return 1;
    }

    for (size_t si = 0; si < count; ++si) {
        const Setting& s = sweep[si];
        if (!apply(si)) return 1;
        reference::FloatImage depth, normal, ids, steps;
        if (!renderAovFrame(engine, renderer->sceneRenderer(), settings, opt, depth, normal, ids, steps,
                            error)) {
            log::error("{}: {}: {}={}: AOVs: {}", kCommand, label, s.param, s.value, error);
            return 1;
        }
        tags.push_back(-1);
        if (!collect(false)) {
            log::error("{}: {}: more frame timings than frames", kCommand, label);
            return 1;
        }
        Row row;
        row.scene = scenePath;
        row.pass = kTracePass;
        row.backend = name;
        row.device = device;
        row.setting = s.param;
        row.value = s.value;
        row.baseline = s.bakeResolution ? rebaker.sceneUses(s.bakeResolution)
                                        : sameTrace(settings.resolvedTrace(),
                                                    scene::tracePreset(scene::TraceQuality::Medium));
        row.gpuMedian = median(gpu[si]);
        row.frameMedian = median(frame[si]);
        row.gpuMin = minimum(gpu[si]);
        row.frameMin = minimum(frame[si]);
        row.frames = opt.frames;
        double stepSum = 0;
        for (float v : steps.data) stepSum += std::isfinite(v) ? v : 0.0;
        row.meanSteps = steps.data.empty() ? std::nan("") : stepSum / double(steps.data.size());
        if (!computeMetrics(ref.depth, ref.normal, ref.ids, depth, normal, ids, row, error)) {
            log::error("{}: {}: {}={}: metrics: {}", kCommand, label, s.param, s.value, error);
            return 1;
        }
        fmt::print(stderr,
                   "[{}] {}/{} {}={}: {} {} ms (frame {} ms), depth rel. p99 {}, silhouette {:.3f} %, "
                   "normal mean {} deg\n",
                   label, si + 1, sweep.size(), s.param, s.value, kTracePass, num(row.gpuMedian),
                   num(row.frameMedian), num(row.metrics[kDepthRelP99]), 100.0 * row.metrics[kSilhouette],
                   num(row.metrics[kNormalMean]));
        rows.push_back(std::move(row));
    }
    if (!collect(true) || received != tags.size()) {
        log::error("{}: {}: {} frame timings for {} frames", kCommand, label, received, tags.size());
        return 1;
    }
    if (!rebaker.empty()) rebaker.restore();
    settings = original;
    return 0;
}

// ---- reports ---------------------------------------------------------------------------------

std::string csvReport(const std::vector<Row>& rows) {
    std::string csv = "scene,pass,backend,setting,value,gpu_ms_median,frame_ms_median";
    for (const AccuracyMetricInfo& m : accuracyMetrics()) csv += std::string(",") + m.name;
    csv +=
        ",gpu_ms_min,frame_ms_min,mean_steps,pixels_reference,pixels_test,pixels_both,frames,baseline,"
        "device,light,ref_samples,ref_std_error_mean,ref_std_error_max\n";
    for (const Row& r : rows) {
        csv += fmt::format("{},{},{},{},{},{},{}", csvField(r.scene), r.pass, r.backend, r.setting, r.value,
                           num(r.gpuMedian), num(r.frameMedian));
        for (double m : r.metrics) csv += "," + num(m);
        csv += fmt::format(",{},{},{},{},{},{},{},{},{},{},{},{},{}\n", num(r.gpuMin), num(r.frameMin),
                           num(r.meanSteps), r.pixelsReference, r.pixelsTest, r.pixelsBoth, r.frames,
                           r.baseline ? 1 : 0, csvField(r.device), csvField(r.light),
                           r.refSamples ? std::to_string(r.refSamples) : std::string(), num(r.refStdMean),
                           num(r.refStdMax));
    }
    return csv;
}

std::string percent(double v) {
    return std::isfinite(v) ? fmt::format("{:.2f}", 100.0 * v) : std::string("–");
}

std::string markdownReport(const BenchAccuracyOptions& opt, const std::vector<Row>& rows,
                           const std::vector<SceneInfo>& scenes, const std::string& date,
                           const std::string& loadBefore, const std::string& loadAfter) {
    std::string md;
    std::string scenesArg;
    for (const std::string& s : opt.scenes) scenesArg += (scenesArg.empty() ? "" : ",") + s;
    std::string passesArg;
    for (const std::string& p : opt.passes) passesArg += (passesArg.empty() ? "" : ",") + p;
    md += fmt::format(
        "`penumbra bench accuracy --scenes {} --backend {} --passes {} --width {} --height {} --effect-width "
        "{} "
        "--effect-height {} --effect-error {} --frames {} --warmup {} --sweep {}`, {}. Machine: {}, {} "
        "hardware "
        "threads; load average (1 / 5 / 15 min) before {}, after {}.\n\n",
        scenesArg, opt.backend, passesArg, opt.width, opt.height, opt.effectWidth, opt.effectHeight,
        opt.effectError, opt.frames, opt.warmup, opt.sweep, date, cpuModel(),
        std::thread::hardware_concurrency(), loadBefore, loadAfter);
    std::vector<std::string> devices;
    for (const Row& r : rows) {
        const std::string d = fmt::format("{}: {}", r.backend, r.device);
        if (std::find(devices.begin(), devices.end(), d) == devices.end()) devices.push_back(d);
    }
    for (const std::string& d : devices) md += "- " + d + "\n";
    if (!opt.wantTrace()) return md;
    md += fmt::format(
        "\nPareto-front settings of the {} pass (time: median GPU ms over {} frames; front: D = depth "
        "rel. p99, S = silhouette mismatch, N = normal mean angle; ids % = pixels hit in both whose entity "
        "differs; each setting changes one value of the medium preset, \"(medium)\" marks the preset "
        "itself; the spread of the GPU ms of its repeated rows shows the timing noise):\n",
        kTracePass, opt.frames);
    for (const SceneInfo& sc : scenes) {
        md += fmt::format(
            "\n**{}** — {} SDF objects ({} mesh bakes); reference: {} pixels hit, {:.1f} s, {} unconverged "
            "rays\n\n",
            sc.path, sc.sdfObjects, sc.meshBakes, sc.referencePixels, sc.referenceSeconds, sc.unconverged);
        md +=
            "| backend | setting | GPU ms | frame ms | depth rel. mean | depth rel. p99 | silhouette % | ids "
            "% | "
            "normal mean ° | normal p99 ° | front |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
        std::vector<std::string> backends;
        for (const Row& r : rows)
            if (r.scene == sc.path &&
                std::find(backends.begin(), backends.end(), r.backend) == backends.end())
                backends.push_back(r.backend);
        std::string noise;
        for (const std::string& b : backends) {
            std::vector<const Row*> group;
            for (const Row& r : rows)
                if (r.scene == sc.path && r.backend == b && r.pass == kTracePass) group.push_back(&r);
            const std::vector<bool> d = paretoFront(group, kDepthRelP99), s = paretoFront(group, kSilhouette),
                                    n = paretoFront(group, kNormalMean);
            std::vector<size_t> order;
            for (size_t i = 0; i < group.size(); ++i)
                if (d[i] || s[i] || n[i]) order.push_back(i);
            std::sort(order.begin(), order.end(),
                      [&](size_t x, size_t y) { return group[x]->gpuMedian < group[y]->gpuMedian; });
            for (size_t i : order) {
                const Row& r = *group[i];
                std::string flags = std::string(d[i] ? "D" : "") + (s[i] ? "S" : "") + (n[i] ? "N" : "");
                md += fmt::format("| {} | {}={}{} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", b,
                                  r.setting, r.value, r.baseline ? " (medium)" : "", msText(r.gpuMedian),
                                  msText(r.frameMedian), sig(r.metrics[kDepthRelMean]),
                                  sig(r.metrics[kDepthRelP99]), percent(r.metrics[kSilhouette]),
                                  percent(r.metrics[kIdMismatch]), sig(r.metrics[kNormalMean]),
                                  sig(r.metrics[kNormalP99]), flags);
            }
            std::vector<double> medium;
            for (const Row* r : group)
                if (r->baseline && std::isfinite(r->gpuMedian)) medium.push_back(r->gpuMedian);
            if (medium.size() > 1)
                noise += fmt::format("{}{}: {} rows, {}–{} ms", noise.empty() ? "" : "; ", b, medium.size(),
                                     msText(*std::min_element(medium.begin(), medium.end())),
                                     msText(*std::max_element(medium.begin(), medium.end())));
        }
        if (!noise.empty()) md += "\nThe medium preset itself (repeated rows), GPU ms: " + noise + ".\n";
    }
    return md;
}

// ---- plots -----------------------------------------------------------------------------------

std::string executableDir() {
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    return ec ? std::string() : exe.parent_path().string();
}

// tools/bench/plot_accuracy.py: --plot-script, else from the working folder, else from the folders
// above the binary (build/release/tools/penumbra/penumbra -> the source tree).
std::string findPlotScript(const std::string& given) {
    if (!given.empty()) return given;
    const fs::path relative = "tools/bench/plot_accuracy.py";
    std::error_code ec;
    if (fs::is_regular_file(relative, ec)) return relative.string();
    fs::path dir = executableDir();
    for (int up = 0; up < 8 && !dir.empty(); ++up, dir = dir.parent_path()) {
        if (fs::is_regular_file(dir / relative, ec)) return (dir / relative).string();
        if (dir == dir.parent_path()) break;
    }
    return {};
}

bool hasMatplotlib(const std::string& python) {
    const std::string cmd = shellQuote(python) + " -c 'import matplotlib' >/dev/null 2>&1";
    return std::system(cmd.c_str()) == 0;
}

// The Python for the plots: --python, else $PENUMBRA_PYTHON, else the first of python3 on PATH and
// /usr/bin/python3 that has matplotlib
// (Debian's python3-matplotlib is installed for the system Python, which a pyenv or venv python3
// on PATH does not see).
std::string findPython(const std::string& given, std::string& tried) {
    std::vector<std::string> candidates;
    if (!given.empty()) {
        candidates.push_back(given);
    } else {
        if (const char* env = std::getenv("PENUMBRA_PYTHON"); env && *env) {
            candidates.push_back(env);  // a choice: no fallback (without matplotlib the plots are skipped)
        } else {
            candidates.push_back("python3");
            candidates.push_back("/usr/bin/python3");
        }
    }
    for (const std::string& c : candidates) {
        tried += (tried.empty() ? "" : ", ") + c;
        if (hasMatplotlib(c)) return c;
    }
    return {};
}

// The Python with matplotlib and the plot script, found before the work. False (logged) on a bad
// --plot-script / --python; `skipped` says why plots will be skipped (empty: they will be drawn).
bool findPlotter(const BenchAccuracyOptions& opt, std::string& python, std::string& plotScript,
                 std::string& skipped) {
    std::string pythonTried;
    if (opt.noPlots) {
        skipped = "--no-plots";
    } else {
        plotScript = findPlotScript(opt.plotScript);
        if (!opt.plotScript.empty() && !fs::is_regular_file(opt.plotScript)) {
            log::error("{}: --plot-script {}: no such file", kCommand, opt.plotScript);
            return false;
        }
        python = findPython(opt.python, pythonTried);
        if (plotScript.empty()) {
            skipped =
                "tools/bench/plot_accuracy.py was not found (run from the repository root or pass "
                "--plot-script)";
        } else if (python.empty()) {
            if (!opt.python.empty()) {
                log::error("{}: --python {}: it cannot import matplotlib", kCommand, opt.python);
                return false;
            }
            skipped = fmt::format(
                "no Python with matplotlib (tried {}); install it with `sudo apt-get install "
                "python3-matplotlib` (tools/setup.sh does) and plot this CSV later with `/usr/bin/python3 "
                "tools/bench/plot_accuracy.py {}/accuracy.csv -o {}`",
                pythonTried, opt.outputDir, opt.outputDir);
        }
    }
    return true;
}

// Runs the plot script on `csv` in a private folder; the PNGs then go through `outputs` like the
// CSV. False (logged, with where the CSV was kept) when plotting fails.
bool drawPlots(const BenchAccuracyOptions& opt, const std::string& csv, const std::string& python,
               const std::string& plotScript, const std::vector<std::string>& plotMetrics,
               const std::vector<std::string>& plotNames, OutputFiles& outputs, std::string& error) {
    std::string tmpl = (fs::temp_directory_path() / "penumbra-accuracy-XXXXXX").string();
    if (!::mkdtemp(tmpl.data())) {
        log::error("{}: cannot create a temporary folder for the plots: {}", kCommand, std::strerror(errno));
        return false;
    }
    const fs::path staging = tmpl;
    {
        std::ofstream out(staging / "accuracy.csv", std::ios::binary);
        out << csv;
    }
    std::string metricsArg;
    for (const std::string& m : plotMetrics) metricsArg += (metricsArg.empty() ? "" : ",") + m;
    const std::string cmd =
        fmt::format("MPLBACKEND=Agg {} {} {} -o {} --metrics {} >{} 2>&1", shellQuote(python),
                    shellQuote(plotScript), shellQuote((staging / "accuracy.csv").string()),
                    shellQuote(staging.string()), metricsArg, shellQuote((staging / "plot.log").string()));
    fmt::print(stderr, "[{}] plotting with {} {}\n", kCommand, python, plotScript);
    const int rc = std::system(cmd.c_str());
    bool ok = rc == 0;
    for (size_t i = 0; ok && i < plotNames.size(); ++i) {
        const fs::path png = staging / plotNames[i];
        ok = outputs.write(
            opt.outputDir + "/" + plotNames[i],
            [&](const std::string& tmp, std::string& e) {
                std::error_code ec;
                fs::copy_file(png, tmp, fs::copy_options::overwrite_existing, ec);
                if (ec) e = fmt::format("the plot script did not write {}: {}", png.string(), ec.message());
                return !ec;
            },
            error);
    }
    if (!ok) {
        std::ifstream logFile(staging / "plot.log");
        const std::string logText((std::istreambuf_iterator<char>(logFile)),
                                  std::istreambuf_iterator<char>());
        log::error(
            "{}: plotting failed{}{}\n{}\nNothing was written to {}; this run's CSV is kept at {} (plot "
            "it "
            "with `{} {} {} -o DIR`, or rerun with --no-plots)",
            kCommand, error.empty() ? "" : ": ", error, logText, opt.outputDir,
            (staging / "accuracy.csv").string(), python, plotScript, (staging / "accuracy.csv").string());
        return false;
    }
    std::error_code ec;
    fs::remove_all(staging, ec);
    return true;
}

// The sdf_trace rows of one loaded scene: the exact reference, then the sweep on each backend.
// Returns the exit code (0 ok; errors are logged).
int runTraceRows(const BenchAccuracyOptions& opt, Engine& engine, ecs::Entity camera,
                 const std::vector<rhi::Backend>& backends, std::vector<Row>& rows, SceneInfo& info) {
    std::string error;
    const std::string& path = info.path;
    fmt::print(stderr, "[{}] reference {}x{} (depth, normal, ids)\n", path, opt.width, opt.height);
    Reference ref;
    if (!renderReference(opt, engine, camera, ref, info, error)) {
        log::error("{}: {}: reference: {}", kCommand, path, error);
        return 1;
    }
    fmt::print(stderr, "[{}] reference: {} pixels hit, {:.1f} s, {} unconverged rays\n", path,
               info.referencePixels, info.referenceSeconds, info.unconverged);
    if (info.unconverged)
        log::warn("{}: {}: {} reference rays did not converge (counted as misses)", kCommand, path,
                  info.unconverged);

    Rebaker rebaker(engine);
    info.meshBakes = uint32_t(rebaker.size());
    const std::vector<Setting> sweep = buildSweep(opt.sweep, !rebaker.empty());
    for (rhi::Backend b : backends)
        if (const int rc = runBackend(opt, engine, b, ref, sweep, rebaker, path, rows); rc != 0) return rc;
    return 0;
}

// The effect passes' plots, for the passes that have rows (known only after the work; the output
// folder was checked before it with the CSV). False (logged) when a path cannot be written.
bool addEffectPlots(const BenchAccuracyOptions& opt, const std::vector<Row>& rows,
                    const std::vector<std::string>& plotMetrics, std::vector<std::string>& plotNames,
                    OutputFiles& outputs) {
    std::string error;
    for (const char* pass : {kShadowPass, kAoPass}) {
        if (std::none_of(rows.begin(), rows.end(), [&](const Row& r) { return r.pass == pass; })) continue;
        for (const std::string& m : plotMetrics) {
            if (!isEffectMetric(metricIndex(m))) continue;
            plotNames.push_back(fmt::format("{}_{}.png", pass, m));
            if (!outputs.add(opt.outputDir + "/" + plotNames.back(), error)) {
                log::error("{}: {}", kCommand, error);
                return false;
            }
        }
    }
    return true;
}

}  // namespace

const std::vector<AccuracyMetricInfo>& accuracyMetrics() {
    static const std::vector<AccuracyMetricInfo> metrics = {
        {"depth_rel_mean", false},      {"depth_rel_p99", false},  {"depth_rel_max", false},
        {"depth_rel_rmse", false},      {"depth_psnr_db", true},   {"depth_ssim", true},
        {"silhouette_mismatch", false}, {"id_mismatch", false},    {"normal_mean_deg", false},
        {"normal_p99_deg", false},      {"normal_max_deg", false}, {"effect_mean", false},
        {"effect_p99", false},          {"effect_max", false},     {"effect_rmse", false},
        {"effect_psnr_db", true},       {"effect_ssim", true}};
    return metrics;
}

CLI::App* addBenchAccuracyCommand(CLI::App& group, BenchAccuracyOptions& opt) {
    CLI::App* cmd = group.add_subcommand(
        "accuracy",
        "Speed against error (docs/ACCURACY.md): sweeps the SDF trace settings around the medium preset, "
        "and the shadow and AO settings, on each scene and backend, compares the depth / normal / ids, "
        "shadow and AO AOVs with the CPU reference and writes DIR/accuracy.csv, DIR/accuracy.md (Pareto "
        "fronts) and DIR/<pass>_<metric>.png plots");
    cmd->add_option("-o,--output", opt.outputDir,
                    "Output folder: accuracy.csv, accuracy.md, <pass>_<metric>.png")
        ->required();
    cmd->add_option("--scenes", opt.scenes,
                    "Comma-separated scene files (.json, .gltf, .glb) with sdf objects")
        ->delimiter(',')
        ->capture_default_str();
    addBenchBackendOption(cmd, opt.backend);
    addSizeOption(cmd, "--width", opt.width, "Image width in pixels (1 .. device max)")
        ->capture_default_str();
    addSizeOption(cmd, "--height", opt.height, "Image height in pixels (1 .. device max)")
        ->capture_default_str();
    cmd->add_option(
           "--frames", opt.frames,
           "Timed frames per setting: rounds of one frame per setting, in alternating order (the CSV gives "
           "their median)")
        ->check(CLI::Range(1u, 100000u))
        ->capture_default_str();
    cmd->add_option("--warmup", opt.warmup,
                    "Untimed frames per setting before the timed rounds (uploads, pipeline compilation)")
        ->check(CLI::Range(0u, 100000u))
        ->capture_default_str();
    cmd->add_option("--sweep", opt.sweep,
                    "default: quality low/medium/high/reference, maxSteps 16..256, hitEpsilon 2..0.02, "
                    "overRelaxation 1..1.5, fieldSafety 0/0.5/1, refineSteps 0..32, bakeResolution 32..256 "
                    "(scenes with mesh bakes); quick: one value of each besides medium")
        ->check(CLI::IsMember({"default", "quick"}))
        ->capture_default_str();
    cmd->add_option("--passes", opt.passes,
                    "Comma-separated rows to measure: trace (sdf_trace), shadow (sdf_shadow, scenes with "
                    "shadowed lights), ao (sdf_ao)")
        ->delimiter(',')
        ->check(CLI::IsMember({"trace", "shadow", "ao"}))
        ->capture_default_str();
    addSizeOption(cmd, "--effect-width", opt.effectWidth,
                  "Image width of the shadow and AO rows (their Monte Carlo reference is slow)")
        ->capture_default_str();
    addSizeOption(cmd, "--effect-height", opt.effectHeight, "Image height of the shadow and AO rows")
        ->capture_default_str();
    cmd->add_option(
           "--effect-error", opt.effectError,
           "Size of the shadow and AO errors to resolve: the reference takes the smallest k*k samples "
           "whose standard-error bound is at most a third of it (0.05 -> 900)")
        ->check(CLI::Range(0.001, 1.0))
        ->capture_default_str();
    cmd->add_option("--threads", opt.threads, "Reference renderer threads (0: one per CPU)")
        ->capture_default_str();
    cmd->add_option("--cache-dir", opt.cacheDir,
                    "Processed-asset cache folder, for fields baked at load and by the bakeResolution sweep "
                    "(default: $PENUMBRA_CACHE_DIR, $XDG_CACHE_HOME/penumbra or ~/.cache/penumbra)");
    cmd->add_flag("--no-cache", opt.noCache, "Do not read or write the processed-asset cache");
    cmd->add_flag("--no-plots", opt.noPlots, "Write the CSV and the Markdown only");
    cmd->add_option("--python", opt.python,
                    "Python with matplotlib for the plots (default: $PENUMBRA_PYTHON, else python3 or "
                    "/usr/bin/python3, the "
                    "first with matplotlib)");
    cmd->add_option("--plot-script", opt.plotScript,
                    "The plot script (default: tools/bench/plot_accuracy.py of the source tree)");
    return cmd;
}

int runBenchAccuracy(const BenchAccuracyOptions& opt) {
    std::string error;
    std::vector<rhi::Backend> backends;
    if (!benchBackends(opt.backend, backends)) {
        log::error("{}: --backend '{}': use vulkan, gl or both", kCommand, opt.backend);
        return 2;
    }
    if (opt.scenes.empty()) {
        log::error("{}: --scenes: no scene given", kCommand);
        return 2;
    }
    for (size_t i = 0; i < opt.scenes.size(); ++i)
        for (size_t j = 0; j < i; ++j)
            if (opt.scenes[i] == opt.scenes[j]) {
                log::error("{}: --scenes: {} is listed twice", kCommand, opt.scenes[i]);
                return 2;
            }
    for (const std::string& s : opt.scenes)
        if (!checkInputFile(s, "scene file (.json, .gltf or .glb)", error)) {
            log::error("{}: {}{}", kCommand, error,
                       s.rfind("scenes/", 0) == 0
                           ? " (scene paths are relative: run from the repository root)"
                           : "");
            return 1;
        }

    // Plots: a Python with matplotlib and the script, found before the work.
    std::string python, plotScript, plotsSkipped;
    if (!findPlotter(opt, python, plotScript, plotsSkipped)) return 1;
    const bool plots = plotsSkipped.empty();
    std::vector<std::string> plotMetrics;  // the trace's, then the effect passes' (not PSNR: as RMSE)
    for (const AccuracyMetricInfo& m : accuracyMetrics())
        if (std::string(m.name).find("psnr") == std::string::npos) plotMetrics.push_back(m.name);

    const std::string csvPath = opt.outputDir + "/accuracy.csv", mdPath = opt.outputDir + "/accuracy.md";
    std::vector<std::string> outputPaths = {csvPath, mdPath};
    std::vector<std::string> plotNames;
    if (plots && opt.wantTrace())
        for (size_t m = 0; m < plotMetrics.size(); ++m)
            if (!isEffectMetric(metricIndex(plotMetrics[m]))) {
                plotNames.push_back(fmt::format("{}_{}.png", kTracePass, plotMetrics[m]));
                outputPaths.push_back(opt.outputDir + "/" + plotNames.back());
            }
    OutputFiles outputs;
    if (!prepareOutputs(outputs, outputPaths, kCommand)) return 1;
    if (!plots) fmt::print(stderr, "{}: plots will be skipped: {}\n", kCommand, plotsSkipped);

    const std::string cacheDir =
        opt.noCache ? std::string() : (opt.cacheDir.empty() ? defaultCacheDir() : opt.cacheDir);
    const std::string date = utcNow(), loadBefore = loadAverage();
    const auto start = std::chrono::steady_clock::now();
    std::vector<Row> rows;
    std::vector<SceneInfo> scenes;
    std::vector<accuracy::EffectSceneInfo> effectScenes;
    for (size_t sceneIndex = 0; sceneIndex < opt.scenes.size(); ++sceneIndex) {
        const std::string& path = opt.scenes[sceneIndex];
        fmt::print(stderr, "[{}] scene {}/{}: loading\n", path, sceneIndex + 1, opt.scenes.size());
        EngineDesc engineDesc;
        engineDesc.cacheDir = cacheDir;
        std::unique_ptr<Engine> engine = Engine::create(engineDesc, error);
        if (!engine || !engine->loadScene(path, error)) {
            log::error("{}: {}", kCommand, error);
            return 1;
        }
        app::FrameTime time;
        if (!engine->updateOffline(0.0, time, error)) {  // every frame and the reference at t = 0
            log::error("{}: {}: {}", kCommand, path, error);
            return 1;
        }
        SceneInfo info;
        info.path = path;
        info.sdfObjects = uint32_t(engine->world().count<ecs::SdfRenderer>());
        if (info.sdfObjects == 0) {
            log::error("{}: {}: the scene has no SDF objects (sdf components): nothing to trace", kCommand,
                       path);
            return 1;
        }
        const std::string cameraName = engine->settings().camera;
        const ecs::Entity camera = scene::findCamera(engine->world(), cameraName);
        if (camera == ecs::kNullEntity) {
            log::error("{}: {}: {}", kCommand, path,
                       cameraName.empty() ? std::string("the scene has no camera")
                                          : fmt::format("the scene has no camera named '{}'", cameraName));
            return 1;
        }
        if (opt.wantTrace())
            if (const int rc = runTraceRows(opt, *engine, camera, backends, rows, info); rc != 0) return rc;
        if (opt.wantShadow() || opt.wantAo()) {
            accuracy::EffectSceneInfo effectInfo;
            if (const int rc = runEffectRows(opt, *engine, backends, path, rows, effectInfo); rc != 0)
                return rc;
            effectScenes.push_back(effectInfo);
        }
        if (opt.wantTrace()) scenes.push_back(info);
    }
    const std::string loadAfter = loadAverage();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    if (plots && !addEffectPlots(opt, rows, plotMetrics, plotNames, outputs)) return 1;
    const std::string csv = csvReport(rows);
    const std::string md = markdownReport(opt, rows, scenes, date, loadBefore, loadAfter) +
                           (effectScenes.empty() ? std::string() : effectsMarkdown(opt, rows, effectScenes));
    if (!outputs.writeText(csvPath, csv, error) || !outputs.writeText(mdPath, md, error)) {
        log::error("{}: {}", kCommand, error);
        return 1;
    }
    if (plots && !drawPlots(opt, csv, python, plotScript, plotMetrics, plotNames, outputs, error)) return 1;
    if (!outputs.commit(error)) {
        log::error("{}: {}", kCommand, error);
        return 1;
    }
    fmt::print("penumbra bench accuracy: {} scene(s), {} backend(s), {} rows in {:.0f} s; wrote {}, {}",
               opt.scenes.size(), backends.size(), rows.size(), seconds, csvPath, mdPath);
    if (plots)
        fmt::print(" and {} plot(s) {}/<pass>_<metric>.png\n", plotNames.size(), opt.outputDir);
    else
        fmt::print("\nplots skipped: {}\n", plotsSkipped);
    return 0;
}

}  // namespace penumbra::cli
