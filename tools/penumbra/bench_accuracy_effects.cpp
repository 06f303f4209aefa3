#include "bench_accuracy_effects.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <glm/trigonometric.hpp>

#include "aov_output.h"
#include "cli_common.h"
#include "cmd_bench_accuracy.h"
#include "engine/core/log.h"
#include "engine/core/progress.h"
#include "engine/engine.h"
#include "reference/metrics.h"
#include "reference/reference.h"
#include "renderer/renderer.h"

namespace penumbra::cli::accuracy {
namespace {

constexpr const char* kCommand = "bench accuracy";
using Q = scene::TraceQuality;

// One setting of an effect pass: the frame's settings besides the medium trace preset.
struct EffectSetting {
    const char* pass = kShadowPass;
    std::string param, value;
    Q quality = Q::Medium;
    scene::ShadowSettings shadows;  // sdf_shadow rows (AO off)
    scene::AoSettings ao;           // sdf_ao rows (shadows off)
    bool baseline = false;
};

std::string scaleText(float v) { return fmt::format("{}", v); }

std::vector<Q> qualities(bool quick) {
    if (quick) return {Q::Medium};
    return {Q::Low, Q::Medium, Q::High, Q::Reference};
}

// Each changes one value of the default shadow settings (soft, scale 0.5, steps from the preset) at
// the medium preset; the medium preset's shadow step limit is 64.
std::vector<EffectSetting> shadowSweep(bool quick) {
    std::vector<EffectSetting> out;
    auto add = [&](std::string param, std::string value, Q q, scene::ShadowSettings s, bool baseline) {
        EffectSetting e;
        e.pass = kShadowPass;
        e.param = std::move(param);
        e.value = std::move(value);
        e.quality = q;
        e.shadows = s;
        e.baseline = baseline;
        out.push_back(e);
    };
    for (Q q : qualities(quick)) add("quality", scene::toString(q), q, {}, q == Q::Medium);
    for (float v : quick ? std::vector<float>{1.0f, 0.5f} : std::vector<float>{1.0f, 0.5f, 0.25f}) {
        scene::ShadowSettings s;
        s.resolutionScale = v;
        add("resolutionScale", scaleText(v), Q::Medium, s, v == 0.5f);
    }
    for (uint32_t v : quick ? std::vector<uint32_t>{32} : std::vector<uint32_t>{16, 32, 64, 128}) {
        scene::ShadowSettings s;
        s.maxSteps = v;
        add("maxSteps", std::to_string(v), Q::Medium, s, v == 64);
    }
    scene::ShadowSettings hard;
    hard.hard = true;
    add("hard", "on", Q::Medium, hard, false);
    return out;
}

// Each variant at each resolution scale, multi-ray's ray count, and the quality presets with the
// scene's variant (cones when the scene has AO off). Strength 1: the reference has no strength.
std::vector<EffectSetting> aoSweep(bool quick, const scene::AoSettings& sceneAo) {
    scene::AoSettings base;
    base.maxDistance = sceneAo.maxDistance;
    base.strength = 1.0f;
    std::vector<EffectSetting> out;
    auto add = [&](std::string param, std::string value, Q q, scene::AoSettings a, bool baseline) {
        EffectSetting e;
        e.pass = kAoPass;
        e.param = std::move(param);
        e.value = std::move(value);
        e.quality = q;
        e.ao = a;
        e.baseline = baseline;
        out.push_back(e);
    };
    const scene::AoVariant presetVariant =
        sceneAo.variant == scene::AoVariant::Off ? scene::AoVariant::Cones : sceneAo.variant;
    for (Q q : qualities(quick)) {
        scene::AoSettings a = base;
        a.variant = presetVariant;
        add("quality", scene::toString(q), q, a, false);  // repeats a variant row: not starred twice
    }
    for (scene::AoVariant v :
         {scene::AoVariant::FiveTap, scene::AoVariant::MultiRay, scene::AoVariant::Cones})
        for (float s : quick ? std::vector<float>{0.25f} : std::vector<float>{1.0f, 0.5f, 0.25f}) {
            scene::AoSettings a = base;
            a.variant = v;
            a.resolutionScale = s;
            add(scene::toString(v), "scale=" + scaleText(s), Q::Medium, a, s == 0.25f);
        }
    for (uint32_t r : quick ? std::vector<uint32_t>{4} : std::vector<uint32_t>{4, 8, 16, 64}) {
        scene::AoSettings a = base;
        a.variant = scene::AoVariant::MultiRay;
        a.rays = r;
        add("multi-ray", "rays=" + std::to_string(r), Q::Medium, a, false);
    }
    return out;
}

// ---- the reference -----------------------------------------------------------------------------

struct EffectReference {
    reference::FloatImage depth, ids, ao;
    std::vector<reference::FloatImage> shadow;  // per shadowed light
    reference::AovImage aoInfo;                 // samples and standard errors (data dropped)
    std::vector<reference::AovImage> shadowInfo;
};

reference::FloatImage floatImage(reference::AovImage& a) {
    reference::FloatImage f;
    f.width = a.width;
    f.height = a.height;
    f.channels = a.channels;
    f.data = std::move(a.data);
    return f;
}

std::string lightLabel(const reference::ReferenceLight& l, size_t index) {
    switch (l.type) {
        case ecs::LightType::Directional:
            return l.angularRadius > 0.0
                       ? fmt::format("{}:directional ({:.3g} deg)", index, glm::degrees(l.angularRadius))
                       : fmt::format("{}:directional (hard)", index);
        case ecs::LightType::Point:
            return fmt::format("{}:point", index);
        case ecs::LightType::Sphere:
            return fmt::format("{}:sphere (r {:.3g})", index, l.radius);
    }
    return std::to_string(index);
}

bool renderEffectReference(const BenchAccuracyOptions& opt, Engine& engine, EffectReference& ref,
                           EffectSceneInfo& info, std::string& error) {
    const ecs::Entity camera = scene::findCamera(engine.world(), engine.settings().camera);
    reference::ReferenceCamera cam;
    if (!reference::makeCamera(engine.world(), camera, opt.effectWidth, opt.effectHeight, cam, error))
        return false;
    std::unique_ptr<reference::ReferenceScene> scene = reference::ReferenceScene::create(error);
    if (!scene || !reference::buildFromWorld(engine.world(), engine.assets(), *scene, error) ||
        !scene->commit(error))
        return false;
    for (size_t i = 0; i < scene->lights().size(); ++i)
        info.lights.push_back(lightLabel(scene->lights()[i], i));
    info.shadowRows = opt.wantShadow() && !info.lights.empty();
    info.aoRows = opt.wantAo();
    if (!info.shadowRows && !info.aoRows) return true;
    reference::RenderDesc desc;
    desc.aovs.push_back({reference::AovKind::Depth, 0});
    desc.aovs.push_back({reference::AovKind::Ids, 0});
    if (info.aoRows) desc.aovs.push_back({reference::AovKind::Ao, 0});
    if (info.shadowRows)
        for (uint32_t l = 0; l < info.lights.size(); ++l)
            desc.aovs.push_back({reference::AovKind::Shadow, l});
    desc.samples = info.samples;
    desc.aoMaxDistance = info.aoMaxDistance;
    desc.threads = opt.threads;
    StderrProgressOutput progressOutput;
    ProgressBar progress(progressOutput);
    desc.progress = [&](double f) { progress.update(f, "effect reference"); };
    const auto start = std::chrono::steady_clock::now();
    std::vector<reference::AovImage> images;
    if (!reference::render(*scene, cam, desc, images, error)) return false;
    progress.finish();
    info.referenceSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    info.unconverged = scene->sdfStats().unconverged;
    ref.shadow.resize(info.shadowRows ? info.lights.size() : 0);
    ref.shadowInfo.resize(ref.shadow.size());
    for (size_t i = 0; i < images.size(); ++i) {
        const reference::AovRequest& r = desc.aovs[i];
        reference::AovImage& a = images[i];
        if (r.kind == reference::AovKind::Depth) ref.depth = floatImage(a);
        if (r.kind == reference::AovKind::Ids) ref.ids = floatImage(a);
        if (r.kind == reference::AovKind::Ao) {
            ref.ao = floatImage(a);
            ref.aoInfo = a;
        }
        if (r.kind == reference::AovKind::Shadow) {
            ref.shadow[r.light] = floatImage(a);
            ref.shadowInfo[r.light] = a;
        }
    }
    return true;
}

// ---- metrics -------------------------------------------------------------------------------------

// The mask of pixels hit in both whose entity ids agree, and the silhouette / id columns.
bool comparedMask(const reference::FloatImage& depth, const reference::FloatImage& ids,
                  const EffectReference& ref, std::vector<uint8_t>& mask, Row& row, std::string& error) {
    reference::SilhouetteStats sil;
    if (!reference::silhouetteMismatch(depth, ref.depth, sil, error)) return false;
    row.metrics[kSilhouette] = sil.mismatchRate;
    row.pixelsTest = sil.hitA;
    row.pixelsReference = sil.hitB;
    mask = reference::bothHitMask(depth, ref.depth);
    size_t differ = 0, compared = 0;
    for (size_t i = 0; i < mask.size(); ++i) {
        if (!mask[i]) continue;
        if (std::lround(ids.data[i]) != std::lround(ref.ids.data[i])) {
            mask[i] = 0;
            ++differ;
        } else {
            ++compared;
        }
    }
    row.metrics[kIdMismatch] = sil.hitBoth ? double(differ) / double(sil.hitBoth) : std::nan("");
    row.pixelsBoth = compared;
    return true;
}

// The effect metrics of `test` against `reference` over `mask` (images of any height: the "all"
// shadow row stacks the lights' layers); `ssimValue` is given separately (per-layer mean).
bool effectMetrics(const reference::FloatImage& test, const reference::FloatImage& reference,
                   const std::vector<uint8_t>& mask, Row& row, std::string& error) {
    if (std::none_of(mask.begin(), mask.end(), [](uint8_t m) { return m != 0; }))
        return true;  // nothing compared: the metrics stay empty
    reference::MetricsDesc desc;
    desc.mask = mask;
    reference::ErrorStats st;
    if (!reference::compareImages(test, reference, desc, st, error)) return false;
    row.metrics[kEffectMean] = st.meanAbs;
    row.metrics[kEffectP99] = st.p99Abs;
    row.metrics[kEffectMax] = st.maxAbs;
    row.metrics[kEffectRmse] = st.rmse;
    row.metrics[kEffectPsnr] = st.psnr;
    row.metrics[kEffectSsim] = reference::ssim(test, reference, mask, 1.0);
    return true;
}

// Stacks images of one size vertically (the "all lights" row).
reference::FloatImage stack(const std::vector<reference::FloatImage>& images) {
    reference::FloatImage out;
    out.width = images.empty() ? 0 : images[0].width;
    out.channels = 1;
    for (const reference::FloatImage& i : images) {
        out.height += i.height;
        out.data.insert(out.data.end(), i.data.begin(), i.data.end());
    }
    return out;
}

// ---- timing --------------------------------------------------------------------------------------

// Renders frames and files their GPU timings by setting: tags[k] is the setting of the k-th frame
// (-1: untimed). GPU ms of a setting = its pass + effects_upsample; frame ms = every pass.
class FrameTimer {
public:
    FrameTimer(Renderer& renderer, size_t settings) : m_renderer(renderer), gpu(settings), frame(settings) {
        m_renderer.takeTimings(true);  // nothing from before
    }
    void tag(int setting, const char* pass) {
        m_tags.push_back(setting);
        m_passes.push_back(pass);
    }
    bool collect(bool wait) {
        for (const fg::FrameTimings& t : m_renderer.takeTimings(wait)) {
            if (m_received >= m_tags.size()) return false;
            const size_t k = m_received++;
            if (m_tags[k] < 0) continue;
            double pass = 0, sum = 0;
            bool found = false, any = false;
            for (const fg::PassTiming& p : t.passes) {
                if ((p.name == m_passes[k] || p.name == kUpsamplePass) && std::isfinite(p.gpuMs)) {
                    pass += p.gpuMs;
                    found = found || p.name == m_passes[k];
                }
                if (std::isfinite(p.gpuMs)) {
                    sum += p.gpuMs;
                    any = true;
                }
            }
            gpu[size_t(m_tags[k])].push_back(found ? pass : std::nan(""));
            frame[size_t(m_tags[k])].push_back(any ? sum : std::nan(""));
        }
        return true;
    }
    bool complete() const { return m_received == m_tags.size(); }

private:
    Renderer& m_renderer;
    std::vector<int> m_tags;
    std::vector<const char*> m_passes;
    size_t m_received = 0;

public:
    std::vector<std::vector<double>> gpu, frame;
};

double minimum(const std::vector<double>& v) {
    double m = std::nan("");
    for (double x : v)
        if (std::isfinite(x) && !(m <= x)) m = x;
    return m;
}

// ---- one backend ---------------------------------------------------------------------------------

struct BackendRun {
    const BenchAccuracyOptions& opt;
    Engine& engine;
    const EffectReference& ref;
    const std::vector<EffectSetting>& sweep;
    const EffectSceneInfo& info;
    std::string label, backend, device;
};

void applySetting(scene::RenderSettings& settings, const scene::RenderSettings& original,
                  const EffectSetting& s) {
    settings = original;
    settings.quality = s.quality;
    settings.trace = {};  // the scene's own trace overrides are dropped, as in the trace rows
    if (std::string(s.pass) == kShadowPass) {
        settings.shadows = s.shadows;
        settings.ao.variant = scene::AoVariant::Off;
    } else {
        settings.shadows.enabled = false;
        settings.ao = s.ao;
    }
}

// The rows of one setting from its untimed frame: sdf_ao one row, sdf_shadow one per light and "all".
bool settingRows(const BackendRun& run, Renderer& renderer, const EffectSetting& s, Row base,
                 std::vector<Row>& rows, std::string& error) {
    render::SceneRenderer& sr = renderer.sceneRenderer();
    const uint32_t w = run.opt.effectWidth, h = run.opt.effectHeight;
    TargetTexels d, a;
    reference::FloatImage depth, ids;
    if (!sr.readTarget("gbuffer.depth", d.texels, d.format, error) ||
        !sr.readTarget("gbuffer.aux", a.texels, a.format, error) ||
        !convertAov(RenderAov::Depth, w, h, &d, nullptr, &a, depth, error) ||
        !convertAov(RenderAov::Ids, w, h, &d, nullptr, &a, ids, error))
        return false;
    std::vector<uint8_t> mask;
    if (!comparedMask(depth, ids, run.ref, mask, base, error)) return false;
    const bool shadow = std::string(s.pass) == kShadowPass;
    TargetTexels effect;
    if (!sr.readTarget(shadow ? "effects.shadow" : "effects.ao", effect.texels, effect.format, error)) {
        error =
            fmt::format("the frame has no {} target: {}", shadow ? "effects.shadow" : "effects.ao", error);
        return false;
    }
    if (!shadow) {
        reference::FloatImage ao;
        if (!convertEffectAov({RenderAov::Ao, {}, 0}, w, h, d, effect, ao, error) ||
            !effectMetrics(ao, run.ref.ao, mask, base, error))
            return false;
        base.refSamples = run.ref.aoInfo.samples;
        base.refStdMean = run.ref.aoInfo.meanStdError;
        base.refStdMax = run.ref.aoInfo.maxStdError;
        rows.push_back(base);
        return true;
    }
    std::vector<reference::FloatImage> layers(run.ref.shadow.size());
    std::vector<uint8_t> allMask;
    Row all = base;
    all.light = "all";
    all.refStdMean = all.refStdMax = 0.0;
    double ssimSum = 0.0;
    for (uint32_t l = 0; l < layers.size(); ++l) {
        if (!convertEffectAov({RenderAov::Shadow, {}, l}, w, h, d, effect, layers[l], error)) return false;
        Row row = base;
        row.light = run.info.lights[l];
        if (!effectMetrics(layers[l], run.ref.shadow[l], mask, row, error)) return false;
        const reference::AovImage& ri = run.ref.shadowInfo[l];
        row.refSamples = ri.samples;
        row.refStdMean = ri.meanStdError;
        row.refStdMax = ri.maxStdError;
        all.refSamples = std::max(all.refSamples, ri.samples);
        all.refStdMean += ri.meanStdError / double(layers.size());
        all.refStdMax = std::max(all.refStdMax, ri.maxStdError);
        ssimSum += row.metrics[kEffectSsim];
        allMask.insert(allMask.end(), mask.begin(), mask.end());
        rows.push_back(row);
    }
    if (!effectMetrics(stack(layers), stack(run.ref.shadow), allMask, all, error)) return false;
    all.metrics[kEffectSsim] = ssimSum / double(layers.size());    // the mean of the lights' SSIM
    rows.insert(rows.end() - std::ptrdiff_t(layers.size()), all);  // "all" first, then each light
    return true;
}

// One untimed frame with gbuffer.aux for setting `si` (the engine's settings applied): its rows,
// with the setting's timings. False (logged) on failure.
bool measureSetting(const BackendRun& run, Renderer& renderer, size_t si, FrameTimer& timer,
                    const std::string& label, std::vector<Row>& rows) {
    std::string error;
    const EffectSetting& s = run.sweep[si];
    render::FrameDesc fd;
    fd.camera = scene::findCamera(run.engine.world(), run.engine.settings().camera);
    fd.settings = run.engine.settings();
    fd.width = run.opt.effectWidth;
    fd.height = run.opt.effectHeight;
    fd.aux = true;
    Row base;
    base.scene = run.info.path;
    base.pass = s.pass;
    base.backend = run.backend;
    base.device = run.device;
    base.setting = s.param;
    base.value = s.value;
    base.baseline = s.baseline;
    base.frames = run.opt.frames;
    const size_t first = rows.size();
    if (!renderer.sceneRenderer().render(run.engine.world(), run.engine.assets(), fd, error) ||
        !settingRows(run, renderer, s, base, rows, error)) {
        log::error("{}: {}: {}={}: {}", kCommand, label, s.param, s.value, error);
        return false;
    }
    timer.tag(-1, s.pass);
    if (!timer.collect(true)) {
        log::error("{}: {}: more frame timings than frames", kCommand, label);
        return false;
    }
    for (size_t r = first; r < rows.size(); ++r) {
        rows[r].gpuMedian = median(timer.gpu[si]);
        rows[r].frameMedian = median(timer.frame[si]);
        rows[r].gpuMin = minimum(timer.gpu[si]);
        rows[r].frameMin = minimum(timer.frame[si]);
    }
    const Row& shown = rows[first];
    fmt::print(stderr, "[{}] {}/{} {} {}={}: {} ms, mean |err| {}, p99 {}\n", label, si + 1, run.sweep.size(),
               s.pass, s.param, s.value, num(shown.gpuMedian), num(shown.metrics[kEffectMean]),
               num(shown.metrics[kEffectP99]));
    return true;
}

int runEffectBackend(BackendRun& run, rhi::Backend backend, std::vector<Row>& rows) {
    std::string error;
    const BenchAccuracyOptions& opt = run.opt;
    run.backend = rhi::toString(backend);
    RendererDesc rendererDesc;
    rendererDesc.backend = backend;
    rendererDesc.width = opt.effectWidth;
    rendererDesc.height = opt.effectHeight;
    std::unique_ptr<Renderer> renderer = Renderer::create(run.engine, rendererDesc, error);
    if (!renderer) {
        log::error("{}: {}: {}", kCommand, run.backend, error);
        return 1;
    }
    if (!refuseNullDevice(renderer->device(), kCommand, error) ||
        !checkImageSize(opt.effectWidth, opt.effectHeight, renderer->device(),
                        "bench accuracy: --effect-width/--effect-height", error)) {
        log::error("{}", error);
        return 2;
    }
    const rhi::DeviceInfo& di = renderer->device().info();
    run.device = fmt::format("{}; {} {}", di.deviceName, di.driverName, di.driverVersion);
    scene::RenderSettings& settings = run.engine.settings();
    const scene::RenderSettings original = settings;
    const std::string label = fmt::format("{} {} effects", run.info.path, run.backend);
    const size_t count = run.sweep.size();
    fmt::print(stderr,
               "[{}] {}x{}: {} settings; {} warm-up frame(s) each, then {} round(s) of one timed frame per "
               "setting\n",
               label, opt.effectWidth, opt.effectHeight, count, opt.warmup, opt.frames);
    FrameTimer timer(*renderer, count);
    auto renderOne = [&](size_t si, bool timed) {
        applySetting(settings, original, run.sweep[si]);
        if (!renderer->renderFrame(run.engine, error)) {
            log::error("{}: {}: {}={}: {}", kCommand, label, run.sweep[si].param, run.sweep[si].value, error);
            return false;
        }
        timer.tag(timed ? int(si) : -1, run.sweep[si].pass);
        return timer.collect(false);
    };
    for (size_t si = 0; si < count; ++si)
        for (uint32_t w = 0; w < opt.warmup; ++w)
            if (!renderOne(si, false)) return 1;
    for (uint32_t round = 0; round < opt.frames; ++round) {
        for (size_t i = 0; i < count; ++i)
            if (!renderOne(round % 2 ? count - 1 - i : i, true)) return 1;
        fmt::print(stderr, "[{}] timed round {}/{} ({} frames)\n", label, round + 1, opt.frames, count);
    }
    for (size_t si = 0; si < count; ++si) {
        applySetting(settings, original, run.sweep[si]);
        if (!measureSetting(run, *renderer, si, timer, label, rows)) return 1;
    }
    if (!timer.collect(true) || !timer.complete()) {
        log::error("{}: {}: frame timings and frames disagree", kCommand, label);
        return 1;
    }
    settings = original;
    return 0;
}

// ---- Markdown ------------------------------------------------------------------------------------

std::vector<std::string> backendsOf(const std::vector<Row>& rows, const std::string& scene,
                                    const char* pass) {
    std::vector<std::string> out;
    for (const Row& r : rows)
        if (r.scene == scene && r.pass == pass && std::find(out.begin(), out.end(), r.backend) == out.end())
            out.push_back(r.backend);
    return out;
}

bool plotted(const Row& r) { return r.light.empty() || r.light == "all"; }

std::string noiseNote(const Row& r) {
    // The reference's noise must be >= 3x smaller than the error measured (docs/ACCURACY.md).
    return std::isfinite(r.refStdMean) && std::isfinite(r.metrics[kEffectMean]) &&
                   r.metrics[kEffectMean] < 3.0 * r.refStdMean
               ? " †"
               : "";
}

// Per scene and backend the Pareto-front settings (front on mean |err| and p99 |err|).
std::string paretoTables(const std::vector<Row>& rows, const std::vector<EffectSceneInfo>& scenes,
                         const char* pass) {
    std::string md;
    for (const EffectSceneInfo& sc : scenes)
        for (const std::string& b : backendsOf(rows, sc.path, pass)) {
            std::vector<const Row*> group;
            for (const Row& r : rows)
                if (r.scene == sc.path && r.backend == b && r.pass == pass && plotted(r)) group.push_back(&r);
            const std::vector<bool> m = paretoFront(group, kEffectMean), p = paretoFront(group, kEffectP99);
            std::vector<size_t> order;
            for (size_t i = 0; i < group.size(); ++i)
                if (m[i] || p[i]) order.push_back(i);
            std::sort(order.begin(), order.end(),
                      [&](size_t x, size_t y) { return group[x]->gpuMedian < group[y]->gpuMedian; });
            md += fmt::format("\n**{}** — {}\n\n", sc.path, b);
            md +=
                "| setting | GPU ms | frame ms | mean \\|err\\| | p99 \\|err\\| | max \\|err\\| | RMSE | "
                "SSIM | front "
                "|\n|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
            for (size_t i : order) {
                const Row& r = *group[i];
                md += fmt::format("| {}={}{} | {} | {} | {}{} | {} | {} | {} | {} | {}{} |\n", r.setting,
                                  r.value, r.baseline ? " (default)" : "", msText(r.gpuMedian),
                                  msText(r.frameMedian), sig(r.metrics[kEffectMean]), noiseNote(r),
                                  sig(r.metrics[kEffectP99]), sig(r.metrics[kEffectMax]),
                                  sig(r.metrics[kEffectRmse]), sig(r.metrics[kEffectSsim]), m[i] ? "M" : "",
                                  p[i] ? "P" : "");
            }
        }
    return md;
}

// The default quality preset: AO per variant, shadows per light type.
std::string presetTables(const std::vector<Row>& rows, const std::vector<EffectSceneInfo>& scenes) {
    std::string md =
        "\nDefault quality preset (medium; shadows: soft, resolutionScale 0.5, 64 steps; AO: "
        "resolutionScale 0.25, multi-ray 8 rays, strength 1). AO error per variant:\n\n"
        "| scene | backend | variant | mean \\|err\\| | p99 \\|err\\| | RMSE | GPU ms | ref. std. error "
        "(mean / max) "
        "|\n|---|---|---|---:|---:|---:|---:|---|\n";
    for (const EffectSceneInfo& sc : scenes)
        for (const Row& r : rows)
            if (r.scene == sc.path && r.pass == std::string(kAoPass) && r.baseline)
                md += fmt::format("| {} | {} | {} | {}{} | {} | {} | {} | {} / {} |\n", sc.path, r.backend,
                                  r.setting, sig(r.metrics[kEffectMean]), noiseNote(r),
                                  sig(r.metrics[kEffectP99]), sig(r.metrics[kEffectRmse]),
                                  msText(r.gpuMedian), sig(r.refStdMean), sig(r.refStdMax));
    md +=
        "\nShadow error per light (the `quality=medium` row; GPU ms is the whole pass, every light):\n\n"
        "| scene | backend | light | mean \\|err\\| | p99 \\|err\\| | RMSE | GPU ms | ref. std. error (mean "
        "/ max) "
        "|\n|---|---|---|---:|---:|---:|---:|---|\n";
    for (const EffectSceneInfo& sc : scenes)
        for (const Row& r : rows)
            if (r.scene == sc.path && r.pass == std::string(kShadowPass) && r.setting == "quality" &&
                r.value == "medium")
                md += fmt::format("| {} | {} | {} | {}{} | {} | {} | {} | {} / {} |\n", sc.path, r.backend,
                                  r.light, sig(r.metrics[kEffectMean]), noiseNote(r),
                                  sig(r.metrics[kEffectP99]), sig(r.metrics[kEffectRmse]),
                                  msText(r.gpuMedian), sig(r.refStdMean), sig(r.refStdMax));
    return md;
}

}  // namespace

std::string effectsMarkdown(const BenchAccuracyOptions& opt, const std::vector<Row>& rows,
                            const std::vector<EffectSceneInfo>& scenes) {
    std::string md = fmt::format(
        "\n### Effect rows\n\nAt {}x{}; reference target error {} ({} samples per pixel: every pixel's "
        "standard-error bound <= {:.3g}); GPU ms = the pass + effects_upsample (median of {} frames). "
        "Front: M = mean |err|, P = p99 |err|; † = mean |err| below 3x the reference's mean standard error "
        "(the reference's noise is not negligible there).\n\n",
        opt.effectWidth, opt.effectHeight, opt.effectError, reference::samplesForError(opt.effectError),
        0.5 / std::sqrt(double(reference::samplesForError(opt.effectError))), opt.frames);
    for (const EffectSceneInfo& sc : scenes) {
        md += fmt::format(
            "- **{}**: reference {:.1f} s ({} unconverged rays), AO max distance {}; shadowed lights: {}\n",
            sc.path, sc.referenceSeconds, sc.unconverged, sc.aoMaxDistance,
            sc.lights.empty() ? std::string("none") : fmt::format("{}", fmt::join(sc.lights, ", ")));
    }
    md +=
        "\nPareto-front settings of sdf_shadow (the \"all\" rows: every shadowed light's layer together):\n";
    md += paretoTables(rows, scenes, kShadowPass);
    md += "\nPareto-front settings of sdf_ao:\n";
    md += paretoTables(rows, scenes, kAoPass);
    md += presetTables(rows, scenes);
    return md;
}

int runEffectRows(const BenchAccuracyOptions& opt, Engine& engine, const std::vector<rhi::Backend>& backends,
                  const std::string& scenePath, std::vector<Row>& rows, EffectSceneInfo& info) {
    std::string error;
    info.path = scenePath;
    info.width = opt.effectWidth;
    info.height = opt.effectHeight;
    info.targetError = opt.effectError;
    info.samples = reference::samplesForError(opt.effectError);
    info.aoMaxDistance = engine.settings().ao.maxDistance;
    if (info.samples == 0) {
        log::error("{}: --effect-error {}: needs more than 2^24 samples", kCommand, opt.effectError);
        return 2;
    }
    fmt::print(stderr, "[{}] effect reference {}x{}, {} samples per pixel (target error {})\n", scenePath,
               opt.effectWidth, opt.effectHeight, info.samples, opt.effectError);
    EffectReference ref;
    if (!renderEffectReference(opt, engine, ref, info, error)) {
        log::error("{}: {}: effect reference: {}", kCommand, scenePath, error);
        return 1;
    }
    if (!info.shadowRows && !info.aoRows) return 0;
    fmt::print(stderr, "[{}] effect reference: {:.1f} s, {} unconverged rays\n", scenePath,
               info.referenceSeconds, info.unconverged);
    std::vector<EffectSetting> sweep;
    if (info.shadowRows) sweep = shadowSweep(opt.sweep == "quick");
    if (info.aoRows)
        for (EffectSetting& s : aoSweep(opt.sweep == "quick", engine.settings().ao)) sweep.push_back(s);
    for (rhi::Backend b : backends) {
        BackendRun run{opt, engine, ref, sweep, info, {}, {}, {}};
        if (const int rc = runEffectBackend(run, b, rows); rc != 0) return rc;
    }
    return 0;
}

}  // namespace penumbra::cli::accuracy
