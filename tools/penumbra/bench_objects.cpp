// `penumbra bench objects` (bench_objects.h): object-count sweep over the acceleration toggles.
#include "bench_objects.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "cli_common.h"
#include "engine/core/log.h"
#include "engine/core/output_file.h"
#include "engine/ecs/components.h"
#include "engine/engine.h"
#include "engine/scene/objects_scene.h"
#include "renderer/renderer.h"

namespace penumbra::cli {
namespace {

namespace fs = std::filesystem;
constexpr double kFrameDt = 1.0 / 60.0;
constexpr float kMoveStep = 0.1f;  // --moving: "object 0" jumps this far left / right every frame

// What each pass is charged to (bench_objects.h), by name: the acceleration modules' passes carry
// their module's prefix, so passes added later are still counted where they belong.
enum class Group { Trace, TraceCull, TraceCache, Scatter, TraceOther, Shadow, EffectsCull, Ao, Other, Count };

bool startsWith(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

Group groupOf(const std::string& pass) {
    if (pass == "sdf_trace") return Group::Trace;
    if (startsWith(pass, "sdf_tile_cull_effects") || startsWith(pass, "sdf_effects_"))
        return Group::EffectsCull;
    if (startsWith(pass, "sdf_tile_cull")) return Group::TraceCull;
    if (startsWith(pass, "sdf_world_cache")) return Group::TraceCache;
    if (pass == "sdf_object_scatter") return Group::Scatter;
    if (startsWith(pass, "sdf_trace_") || pass == "sdf_cone_prepass")
        return Group::TraceOther;  // e.g. the cache stand-in, the cone prepass
    if (pass == "sdf_shadow") return Group::Shadow;
    if (pass == "sdf_ao") return Group::Ao;
    return Group::Other;
}

struct Config {
    std::string name;
    scene::AccelerationSettings accel;
};

// A configuration: none, or toggles joined by '+' (culling, id, world, prepass, all = culling +
// world + id), e.g. "culling+prepass".
bool configNamed(const std::string& name, Config& out) {
    scene::AccelerationSettings a;
    a.culling = a.worldCache = a.idField = a.prepass = false;
    if (name != "none") {
        size_t start = 0;
        while (start <= name.size()) {
            const size_t plus = std::min(name.find('+', start), name.size());
            const std::string word = name.substr(start, plus - start);
            if (word == "culling")
                a.culling = true;
            else if (word == "id")
                a.idField = true;
            else if (word == "world")
                a.worldCache = true;
            else if (word == "prepass")
                a.prepass = true;
            else if (word == "all")
                a.culling = a.worldCache = a.idField = true;
            else
                return false;
            start = plus + 1;
        }
    }
    out = {name, a};
    return true;
}

bool splitList(const std::string& text, std::vector<std::string>& out) {
    out.clear();
    size_t start = 0;
    while (start <= text.size()) {
        const size_t comma = std::min(text.find(',', start), text.size());
        out.push_back(text.substr(start, comma - start));
        if (out.back().empty()) return false;
        start = comma + 1;
    }
    return !out.empty();
}

// One (backend, instancing, N, configuration): per pass the GPU ms of each timed frame.
struct Cell {
    std::map<std::string, std::vector<double>> passes;
    std::vector<double> total;
    uint32_t sdfObjects = 0;
    double med(const std::string& pass) const {
        auto it = passes.find(pass);
        return it == passes.end() ? 0.0 : median(it->second);  // a pass that did not run costs 0
    }
    // Sum of the medians of the group's passes; NaN when none of them ran.
    double group(Group g) const {
        double sum = 0;
        bool any = false;
        for (const auto& [name, series] : passes)
            if (groupOf(name) == g) {
                sum += median(series);
                any = true;
            }
        return any ? sum : std::nan("");
    }
    double groups(std::initializer_list<Group> gs) const {
        double sum = 0;
        for (Group g : gs)
            if (const double v = group(g); std::isfinite(v)) sum += v;
        return sum;
    }
    double trace() const {
        return groups({Group::Trace, Group::TraceCull, Group::TraceCache, Group::Scatter, Group::TraceOther});
    }
    double shadow() const { return groups({Group::Shadow, Group::EffectsCull}); }
    double ao() const { return groups({Group::Ao}); }
    double frame() const { return median(total); }
    double updateShare() const {
        return frame() > 0 ? groups({Group::TraceCache, Group::Scatter}) / frame() : std::nan("");
    }
};

struct Table {  // one backend and instancing mode
    rhi::Backend backend = rhi::Backend::Auto;
    bool instanced = true;
    std::string device;
    std::map<uint32_t, std::map<std::string, Cell>> cells;  // [N][config]
};

// Timings arrive a few frames late: each rendered frame is tagged (cell or untimed) in order.
class Sink {
public:
    void rendered(Cell* cell) { m_tags.push_back(cell); }
    bool add(const std::vector<fg::FrameTimings>& frames, std::string& error) {
        for (const fg::FrameTimings& f : frames) {
            if (m_next >= m_tags.size()) {
                error = "more frame timings than rendered frames";
                return false;
            }
            Cell* cell = m_tags[m_next++];
            if (!cell) continue;
            double total = 0;
            for (const fg::PassTiming& t : f.passes) {
                cell->passes[t.name].push_back(t.gpuMs);
                if (std::isfinite(t.gpuMs)) total += t.gpuMs;
            }
            cell->total.push_back(total);
        }
        return true;
    }
    bool complete() const { return m_next == m_tags.size(); }

private:
    std::vector<Cell*> m_tags;
    size_t m_next = 0;
};

std::string meshDirFor(const std::string& meshDir, const fs::path& sceneFolder) {
    std::error_code ec;
    const fs::path abs = fs::absolute(meshDir, ec);
    const fs::path rel = fs::relative(abs, fs::absolute(sceneFolder, ec), ec);
    return ec || rel.empty() ? abs.string() : rel.generic_string();
}

bool writeSceneFile(const BenchObjectsOptions& opt, uint32_t count, bool instanced, const std::string& path,
                    std::string& error) {
    scene::ObjectsSceneDesc desc;
    desc.count = count;
    desc.instanced = instanced;
    desc.resolution = opt.resolution;
    desc.aspect = float(opt.width) / float(opt.height);
    desc.meshDir = meshDirFor(opt.meshDir, fs::path(path).parent_path());
    scene::ObjectsScene generated;
    if (!scene::generateObjectsScene(desc, generated, error)) return false;
    OutputFiles outputs;
    return outputs.add(path, error) && outputs.writeText(path, generated.json, error) &&
           outputs.commit(error);
}

ecs::Entity entityNamed(ecs::World& world, const std::string& name) {
    for (auto [entity, n] : world.view<const ecs::Name>())
        if (n.value == name) return entity;
    return ecs::kNullEntity;
}

// Renders warm-up + timed frames of one configuration into `cell`.
bool runConfig(const BenchObjectsOptions& opt, Engine& engine, Renderer& renderer, ecs::Entity mover,
               const Config& config, Cell& cell, Sink& sink, uint64_t& frameNo, std::string& error) {
    engine.settings().acceleration.culling = config.accel.culling;
    engine.settings().acceleration.worldCache = config.accel.worldCache;
    engine.settings().acceleration.idField = config.accel.idField;
    engine.settings().acceleration.prepass = config.accel.prepass;
    const glm::vec3 home =
        mover != ecs::kNullEntity ? engine.world().get<ecs::Transform>(mover)->position : glm::vec3(0.0f);
    app::FrameTime time;
    for (uint32_t f = 0; f < opt.warmup + opt.frames; ++f, ++frameNo) {
        if (mover != ecs::kNullEntity)
            engine.world().get<ecs::Transform>(mover)->position.x =
                home.x + (frameNo % 2 ? kMoveStep : -kMoveStep);
        if (!engine.updateOffline(frameNo == 0 ? 0.0 : kFrameDt, time, error) ||
            !renderer.renderFrame(engine, error))
            return false;
        sink.rendered(f < opt.warmup ? nullptr : &cell);
        if (!sink.add(renderer.takeTimings(false), error)) return false;
    }
    if (mover != ecs::kNullEntity) engine.world().get<ecs::Transform>(mover)->position = home;
    cell.sdfObjects = renderer.stats().sdfObjects;
    return true;
}

// One backend, instancing mode and N: a fresh engine and renderer on the generated scene.
int runScene(const BenchObjectsOptions& opt, rhi::Backend backend, bool instanced, uint32_t count,
             const std::vector<Config>& configs, const std::string& tmpDir, const std::string& cacheDir,
             Table& table) {
    std::string error;
    const std::string path =
        fmt::format("{}/objects_{}_{}.json", tmpDir, count, instanced ? "inst" : "copies");
    BenchObjectsOptions abs = opt;
    abs.meshDir = fs::absolute(opt.meshDir).string();
    if (!writeSceneFile(abs, count, instanced, path, error)) {
        log::error("bench objects: {}", error);
        return 1;
    }
    std::unique_ptr<Engine> engine;
    std::unique_ptr<Renderer> renderer;
    const int rc = openObjectsBench(
        path, cacheDir, backend, opt.width, opt.height, "bench objects",
        [&](Engine& e) {
            if (!opt.quality.empty()) scene::parseTraceQuality(opt.quality, e.settings().quality);
        },
        engine, renderer);
    if (rc != 0) return rc;
    table.device = renderer->device().info().deviceName;
    const ecs::Entity mover = opt.moving ? entityNamed(engine->world(), "object 0") : ecs::kNullEntity;
    Sink sink;
    uint64_t frameNo = 0;
    for (const Config& c : configs) {
        fmt::print(stderr, "[{}] {} objects, {}, {}: {} warm-up + {} timed frames\n", rhi::toString(backend),
                   count, instanced ? "instanced" : "non-instanced", c.name, opt.warmup, opt.frames);
        if (!runConfig(opt, *engine, *renderer, mover, c, table.cells[count][c.name], sink, frameNo, error)) {
            log::error("bench objects: {}: {} objects, {}: {}", rhi::toString(backend), count, c.name, error);
            return 1;
        }
    }
    if (!sink.add(renderer->takeTimings(true), error) || !sink.complete()) {
        log::error("bench objects: {}", error.empty() ? "frame timings missing" : error);
        return 1;
    }
    return 0;
}

}  // namespace

// Defined with the report writers below.
std::string objectsMarkdown(const BenchObjectsOptions& opt, const std::vector<Table>& tables,
                            const std::vector<Config>& configs, const std::string& header);
std::string objectsCsv(const BenchObjectsOptions& opt, const std::vector<Table>& tables,
                       const std::vector<Config>& configs);

CLI::App* addBenchObjectsCommand(CLI::App& group, BenchObjectsOptions& opt) {
    CLI::App* cmd = group.add_subcommand(
        "objects",
        "Object-count sweep (mTec Table 2): median GPU ms of the SDF trace (sdf_trace + the acceleration "
        "passes sdf_tile_cull*, sdf_world_cache*, sdf_object_scatter, sdf_cone_prepass, sdf_trace_*), "
        "shadows (sdf_shadow + "
        "sdf_tile_cull_effects*, sdf_effects_*) and AO (sdf_ao) on the generated objects scene, per object "
        "count and "
        "acceleration configuration (none, culling, id, world, all), with speed-ups against none; or, "
        "with --write-scene, write that scene and exit");
    cmd->add_option("--counts", opt.counts, "Object counts, comma-separated (each 1 .. 100000)")
        ->capture_default_str();
    cmd->add_option(
           "--configs", opt.configs,
           "Configurations, comma-separated: none (every toggle off), culling, id (idField only), "
           "world (worldCache only), all (culling + worldCache + idField), prepass (the cone prepass); "
           "toggles joined by + combine (culling+prepass, all+prepass)")
        ->capture_default_str();
    addBenchBackendOption(cmd, opt.backend);
    addSizeOption(cmd, "--width", opt.width, "Image width in pixels")->capture_default_str();
    addSizeOption(cmd, "--height", opt.height, "Image height in pixels")->capture_default_str();
    cmd->add_option("--frames", opt.frames, "Timed frames per configuration (medians)")
        ->check(CLI::Range(1u, 100000u))
        ->capture_default_str();
    cmd->add_option("--warmup", opt.warmup, "Untimed frames before each configuration's timed ones")
        ->check(CLI::Range(0u, 100000u))
        ->capture_default_str();
    cmd->add_option("--moving", opt.moving,
                    "Objects moved every frame: 0, or 1 (\"object 0\" jumps 0.1 units; the update share "
                    "column is the cache passes' part of the frame)")
        ->check(CLI::Range(0u, 1u))
        ->capture_default_str();
    cmd->add_option("--instancing", opt.instancing,
                    "on: objects of a kind share one field; off: each object its own field (sdf "
                    "\"shared\": false); both")
        ->check(CLI::IsMember({"on", "off", "both"}))
        ->capture_default_str();
    cmd->add_option("--resolution", opt.resolution, "Bake resolution of the meshes (voxels, longest axis)")
        ->check(CLI::Range(8u, 1024u))
        ->capture_default_str();
    cmd->add_option("--mesh-dir", opt.meshDir,
                    "Folder of bunny.ply, teapot.ply, dragon_vrip_res3.ply (tools/fetch_meshes.sh)")
        ->capture_default_str();
    cmd->add_option("--quality", opt.quality, "SDF trace quality preset (default: the scene's, medium)")
        ->check(CLI::IsMember({"low", "medium", "high", "reference"}));
    cmd->add_option("--csv", opt.csv, "Also write the results as CSV (one row per cell and measure)");
    cmd->add_option("--markdown", opt.markdown, "Also write the tables as Markdown (docs/BENCHMARKS.md)");
    cmd->add_option("--cache-dir", opt.cacheDir, "Processed-asset cache folder (baked fields)");
    cmd->add_flag("--no-cache", opt.noCache, "Do not read or write the processed-asset cache");
    cmd->add_option("--write-scene", opt.writeScene,
                    "Write the objects scene of --count objects as scene JSON to this path and exit "
                    "(mesh paths relative to its folder)");
    cmd->add_option("--count", opt.count, "Objects in the --write-scene scene")
        ->check(CLI::Range(1u, scene::kMaxObjectsSceneCount))
        ->capture_default_str();
    cmd->add_flag("--no-instancing", opt.noInstancing,
                  "--write-scene: each object its own field (sdf \"shared\": false)");
    return cmd;
}

namespace {

bool parseRunOptions(const BenchObjectsOptions& opt, std::vector<uint32_t>& counts,
                     std::vector<Config>& configs, std::vector<rhi::Backend>& backends, std::string& error) {
    if (!parseObjectCounts(opt.counts, counts, error)) return false;
    std::vector<std::string> words;
    if (!splitList(opt.configs, words)) {
        error = fmt::format("--configs '{}': expected a comma-separated list", opt.configs);
        return false;
    }
    for (const std::string& w : words) {
        Config c;
        if (!configNamed(w, c)) {
            error = fmt::format(
                "--configs: unknown configuration '{}' (expected none, culling, id, world, all)", w);
            return false;
        }
        configs.push_back(c);
    }
    if (!benchBackends(opt.backend, backends)) {
        error = fmt::format("--backend '{}': use vulkan, gl or both", opt.backend);
        return false;
    }
    return checkObjectsMeshes(opt.meshDir, error);
}

}  // namespace

bool parseObjectCounts(const std::string& text, std::vector<uint32_t>& counts, std::string& error) {
    std::vector<std::string> words;
    if (!splitList(text, words)) {
        error = fmt::format("--counts '{}': expected comma-separated object counts", text);
        return false;
    }
    for (const std::string& w : words) {
        char* end = nullptr;
        const unsigned long n = std::strtoul(w.c_str(), &end, 10);
        if (*end != '\0' || w[0] == '-' || n < 1 || n > scene::kMaxObjectsSceneCount) {
            error = fmt::format("--counts: '{}' is not a count in [1, {}]", w, scene::kMaxObjectsSceneCount);
            return false;
        }
        counts.push_back(uint32_t(n));
    }
    return true;
}

bool checkObjectsMeshes(const std::string& meshDir, std::string& error) {
    for (const char* f : {"bunny.ply", "teapot.ply", "dragon_vrip_res3.ply"})
        if (!checkInputFile(meshDir + "/" + f, "mesh (fetched by tools/fetch_meshes.sh)", error))
            return false;
    return true;
}

int openObjectsBench(const std::string& path, const std::string& cacheDir, rhi::Backend backend,
                     uint32_t width, uint32_t height, const char* command,
                     const std::function<void(Engine&)>& configure, std::unique_ptr<Engine>& engine,
                     std::unique_ptr<Renderer>& renderer) {
    std::string error;
    EngineDesc engineDesc;
    engineDesc.cacheDir = cacheDir;
    engine = Engine::create(engineDesc, error);
    if (!engine || !engine->loadScene(path, error)) {
        log::error("{}: {}", command, error);
        return 1;
    }
    if (configure) configure(*engine);
    RendererDesc rendererDesc;
    rendererDesc.backend = backend;
    rendererDesc.width = width;
    rendererDesc.height = height;
    renderer = Renderer::create(*engine, rendererDesc, error);
    if (!renderer || !refuseNullDevice(renderer->device(), command, error) ||
        !checkImageSize(width, height, renderer->device(), fmt::format("{}: --width/--height", command),
                        error)) {
        log::error("{}: {}", command, error);
        return renderer ? 2 : 1;
    }
    return 0;
}

int runBenchObjects(const BenchObjectsOptions& opt) {
    std::string error;
    if (!opt.writeScene.empty()) {
        if (!writeSceneFile(opt, opt.count, !opt.noInstancing, opt.writeScene, error)) {
            log::error("bench objects: {}", error);
            return 1;
        }
        fmt::print("wrote {} ({} objects, {})\n", opt.writeScene, opt.count,
                   opt.noInstancing ? "non-instanced" : "instanced");
        return 0;
    }
    std::vector<uint32_t> counts;
    std::vector<Config> configs;
    std::vector<rhi::Backend> backends;
    if (!parseRunOptions(opt, counts, configs, backends, error)) {
        log::error("bench objects: {}", error);
        return error.find("mesh") != std::string::npos && error.find("--") == std::string::npos ? 1 : 2;
    }
    OutputFiles outputs;
    if (!prepareOutputs(outputs, {opt.csv, opt.markdown}, "bench objects")) return 1;
    const std::string cacheDir =
        opt.noCache ? std::string() : (opt.cacheDir.empty() ? defaultCacheDir() : opt.cacheDir);
    const fs::path tmpDir = fs::temp_directory_path() / fmt::format("penumbra-bench-objects-{}", ::getpid());
    fs::create_directories(tmpDir);
    const std::string date = utcNow(), loadBefore = loadAverage();
    std::vector<Table> tables;
    std::vector<bool> modes;
    if (opt.instancing != "off") modes.push_back(true);
    if (opt.instancing != "on") modes.push_back(false);
    int rc = 0;
    for (rhi::Backend b : backends)
        for (bool instanced : modes) {
            Table t;
            t.backend = b;
            t.instanced = instanced;
            for (uint32_t n : counts)
                if (rc == 0) rc = runScene(opt, b, instanced, n, configs, tmpDir.string(), cacheDir, t);
            tables.push_back(std::move(t));
        }
    std::error_code ec;
    fs::remove_all(tmpDir, ec);
    if (rc != 0) return rc;
    const std::string header =
        fmt::format("{}. Machine: {}, {} hardware threads. Load average before: {}; after: {}.", date,
                    cpuModel(), std::thread::hardware_concurrency(), loadBefore, loadAverage());
    const std::string md = objectsMarkdown(opt, tables, configs, header);
    fmt::print("\n{}", md);
    if ((!opt.markdown.empty() && !outputs.writeText(opt.markdown, md, error)) ||
        (!opt.csv.empty() && !outputs.writeText(opt.csv, objectsCsv(opt, tables, configs), error)) ||
        !outputs.commit(error)) {
        log::error("bench objects: {}", error);
        return 1;
    }
    if (!opt.markdown.empty()) fmt::print("wrote {}\n", opt.markdown);
    if (!opt.csv.empty()) fmt::print("wrote {}\n", opt.csv);
    return 0;
}

// ---- reports ------------------------------------------------------------------------------------

namespace {

std::string ms(double v) { return std::isfinite(v) ? fmt::format("{:.3f}", v) : std::string("n/a"); }
std::string ratio(double a, double b) {
    return std::isfinite(a) && std::isfinite(b) && b > 0 ? fmt::format("{:.2f}x", a / b) : std::string("n/a");
}
std::string tableTitle(const Table& t) {
    return fmt::format("{} ({}), {}", t.backend == rhi::Backend::Vulkan ? "Vulkan" : "OpenGL", t.device,
                       t.instanced ? "instanced" : "non-instanced");
}

// Rows N, columns configurations: `value` of each cell (Table 2 style), optionally as speed-up
// against the "none" column.
template <class F>
std::string summary(const Table& t, const std::vector<Config>& configs, F value, bool speedup) {
    std::string md = "| N |", rule = "|---:|";
    for (const Config& c : configs) {
        md += " " + c.name + " |";
        rule += "---:|";
    }
    md += "\n" + rule + "\n";
    for (const auto& [n, row] : t.cells) {
        md += fmt::format("| {} |", n);
        const auto none = row.find("none");
        for (const Config& c : configs) {
            const double v = value(row.at(c.name));
            md +=
                " " +
                (speedup ? (none == row.end() ? std::string("n/a") : ratio(value(none->second), v)) : ms(v)) +
                " |";
        }
        md += "\n";
    }
    return md + "\n";
}

// Every group that makes up the columns, per N and configuration: nothing hidden in a sum (the CSV
// has every pass).
std::string detail(const Table& t, const std::vector<Config>& configs) {
    std::string md =
        "| N | config | SDF objects | sdf_trace | culling (sdf_tile_cull*) | world cache (sdf_world_cache*) "
        "| "
        "sdf_object_scatter | other trace (sdf_trace_*, sdf_cone_prepass) | trace total | trace / N | "
        "sdf_shadow | effects "
        "culling (sdf_tile_cull_effects*, sdf_effects_*) | sdf_ao | frame GPU | update share |\n"
        "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const auto& [n, row] : t.cells)
        for (const Config& c : configs) {
            const Cell& x = row.at(c.name);
            auto col = [&](Group g) {
                const double v = x.group(g);
                return std::isfinite(v) ? ms(v) : std::string("–");
            };
            md += fmt::format(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.4f} | {} | {} | {} | {} | {:.1f} % |\n", n,
                c.name, x.sdfObjects, col(Group::Trace), col(Group::TraceCull), col(Group::TraceCache),
                col(Group::Scatter), col(Group::TraceOther), ms(x.trace()), x.trace() / n, col(Group::Shadow),
                col(Group::EffectsCull), col(Group::Ao), ms(x.frame()), 100.0 * x.updateShare());
        }
    return md + "\n";
}

std::string growth(const Table& t) {
    if (t.cells.size() < 2) return {};
    const uint32_t lo = t.cells.count(20) ? 20 : t.cells.begin()->first;
    const uint32_t hi = t.cells.count(80) ? 80 : t.cells.rbegin()->first;
    auto trace = [&](uint32_t n) {
        auto it = t.cells.at(n).find("all");
        return it == t.cells.at(n).end() ? std::nan("") : it->second.trace();
    };
    return fmt::format(
        "All-optimizations trace growth N = {} / N = {}: {} (mTec: 1.62x for 80 / 20; target <= 1.3x)\n\n",
        hi, lo, ratio(trace(hi), trace(lo)));
}

}  // namespace

std::string objectsMarkdown(const BenchObjectsOptions& opt, const std::vector<Table>& tables,
                            const std::vector<Config>& configs, const std::string& header) {
    std::string md = fmt::format(
        "`penumbra bench objects --counts {} --configs {} --backend {} --width {} --height {} --frames {} "
        "--warmup {} "
        "--moving {} --instancing {} --resolution {}{}`, {}\n\n",
        opt.counts, opt.configs, opt.backend, opt.width, opt.height, opt.frames, opt.warmup, opt.moving,
        opt.instancing, opt.resolution, opt.quality.empty() ? "" : " --quality " + opt.quality, header);
    for (const Table& t : tables) {
        md += fmt::format(
            "#### {}\n\nTrace GPU ms (medians; sdf_trace + sdf_tile_cull* + sdf_world_cache* + "
            "sdf_object_scatter + sdf_cone_prepass + sdf_trace_*):\n\n",
            tableTitle(t));
        md += summary(
            t, configs, [](const Cell& c) { return c.trace(); }, false);
        md += "Trace speed-up against none:\n\n";
        md += summary(
            t, configs, [](const Cell& c) { return c.trace(); }, true);
        md += growth(t);
        md += "Shadow GPU ms (sdf_shadow + sdf_tile_cull_effects* + sdf_effects_*):\n\n";
        md += summary(
            t, configs, [](const Cell& c) { return c.shadow(); }, false);
        md += "Shadow speed-up against none:\n\n";
        md += summary(
            t, configs, [](const Cell& c) { return c.shadow(); }, true);
        md += "AO GPU ms (sdf_ao):\n\n";
        md += summary(
            t, configs, [](const Cell& c) { return c.ao(); }, false);
        md += "AO speed-up against none:\n\n";
        md += summary(
            t, configs, [](const Cell& c) { return c.ao(); }, true);
        md +=
            "Every pass group (sum of its passes' median GPU ms; – = no pass of the group ran; update share "
            "= "
            "(sdf_world_cache* + sdf_object_scatter) / frame GPU):\n\n";
        md += detail(t, configs);
    }
    return md;
}

std::string objectsCsv(const BenchObjectsOptions& opt, const std::vector<Table>& tables,
                       const std::vector<Config>& configs) {
    std::string csv =
        "backend,device,instanced,count,config,moving,width,height,frames,measure,gpu_ms_median\n";
    auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string(); };
    for (const Table& t : tables)
        for (const auto& [n, row] : t.cells)
            for (const Config& c : configs) {
                const Cell& x = row.at(c.name);
                const std::string prefix = fmt::format(
                    "{},\"{}\",{},{},{},{},{},{},{}", rhi::toString(t.backend), t.device, t.instanced ? 1 : 0,
                    n, c.name, opt.moving, opt.width, opt.height, opt.frames);
                for (const auto& [pass, series] : x.passes)
                    csv += fmt::format("{},{},{}\n", prefix, pass, num(median(series)));
                csv += fmt::format(
                    "{},trace_total,{}\n{},shadow_total,{}\n{},ao_total,{}\n{},frame_total,{}\n", prefix,
                    num(x.trace()), prefix, num(x.shadow()), prefix, num(x.ao()), prefix, num(x.frame()));
                csv += fmt::format("{},update_share,{}\n", prefix, num(x.updateShare()));
            }
    return csv;
}

}  // namespace penumbra::cli
