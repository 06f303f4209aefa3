// penumbra-bake-bench: the SDF bake benchmark behind docs/BENCHMARKS.md (a benchmark, not a test).
//  1. Runs `penumbra bake <mesh> -o <tmp> --resolution R --threads T --quiet --report <tmp.json>` as
//     a child process, --repeat times per thread count, and takes the wall time around the whole
//     process (start-up, mesh load, bake, write: end to end). The per-phase split comes from the
//     report JSON of the fastest run.
//  2. Reads the .psdf back and measures the trilinear interpolation error against exact signed
//     distances at random points: |d| by brute force over every triangle (tests/sdf/
//     acceptance_support.h, independent of the baker), the sign from the winding number. Points are
//     uniform in the box of voxel centres, plus points jittered around voxels near the surface.
// Prints a Markdown report (and writes it to --markdown if given).
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "engine/assets/mesh.h"
#include "engine/sdf/psdf.h"
#include "engine/sdf/winding.h"
#include "sdf/acceptance_support.h"

extern char** environ;

namespace {

using namespace penumbra;

struct Run {
    double wallMs = 0;
    double cpuMs = 0;  // user + system time of the child
    nlohmann::json report;
};

bool runChild(const std::vector<std::string>& args, double& wallMs, double& cpuMs, std::string& error) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const auto t0 = std::chrono::steady_clock::now();
    pid_t pid = 0;
    if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) {
        error = fmt::format("cannot start {}", args[0]);
        return false;
    }
    int status = 0;
    struct rusage usage {};
    if (wait4(pid, &status, 0, &usage) != pid) {
        error = "wait4 failed";
        return false;
    }
    wallMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    cpuMs = (double(usage.ru_utime.tv_sec) + double(usage.ru_stime.tv_sec)) * 1e3 +
            (double(usage.ru_utime.tv_usec) + double(usage.ru_stime.tv_usec)) * 1e-3;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        error = fmt::format("{} failed (status {})", args[0], status);
        return false;
    }
    return true;
}

std::string loadAverage() {
    std::ifstream in("/proc/loadavg");
    double one = 0, five = 0;
    in >> one >> five;
    return fmt::format("{:.2f} (1 min) / {:.2f} (5 min)", one, five);
}

std::string cpuModel() {
    std::ifstream in("/proc/cpuinfo");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
    return "unknown CPU";
}

struct ErrorStats {
    size_t n = 0;
    double sum = 0, sumSq = 0, max = 0;
    void add(double e) {
        ++n;
        sum += e;
        sumSq += e * e;
        max = std::max(max, e);
    }
    double mean() const { return n ? sum / double(n) : 0; }
    double rms() const { return n ? std::sqrt(sumSq / double(n)) : 0; }
};

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"penumbra-bake-bench: end-to-end bake timing and interpolation error (docs/BENCHMARKS.md)"};
    std::string cli = PENUMBRA_CLI_PATH;
    std::string mesh = std::string(PENUMBRA_SOURCE_DIR) + "/data/meshes/dragon_vrip.ply";
    uint32_t resolution = 128;
    std::vector<uint32_t> threads = {2, 1};
    uint32_t repeat = 3;
    uint32_t errorSamples = 1000;
    std::string markdown;
    app.add_option("--penumbra", cli, "The penumbra CLI to time")->capture_default_str();
    app.add_option("--mesh", mesh, "Mesh to bake")->capture_default_str();
    app.add_option("--resolution", resolution, "Bake resolution")->capture_default_str();
    app.add_option("--threads", threads, "Thread counts to time (in this order)")->delimiter(',');
    app.add_option("--repeat", repeat, "Runs per thread count (min and median reported)")
        ->capture_default_str();
    app.add_option(
           "--error-samples", errorSamples,
           "Random points of each kind (uniform / near-surface) for the interpolation error; 0 = skip")
        ->capture_default_str();
    app.add_option("--markdown", markdown, "Also write the Markdown report here");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    if (!std::filesystem::exists(mesh)) {
        std::fprintf(stderr, "%s is missing: run tools/fetch_meshes.sh\n", mesh.c_str());
        return 1;
    }
    const std::string tmpDir = std::filesystem::temp_directory_path().string();
    const std::string out = tmpDir + "/penumbra_bench.psdf", reportPath = tmpDir + "/penumbra_bench.json";

    std::string md;
    auto emit = [&md](const std::string& s) {
        std::fputs(s.c_str(), stdout);
        std::fflush(stdout);
        md += s;
    };
    char date[64];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    emit(fmt::format("Machine: {}, {} hardware threads; {}; load average before: {}\n\n", cpuModel(),
                     std::thread::hardware_concurrency(), date, loadAverage()));
    emit(fmt::format(
        "`penumbra bake {} --resolution {}` (f32, default padding 2, sign auto), wall time of the "
        "whole process, {} runs each:\n\n",
        std::filesystem::path(mesh).filename().string(), resolution, repeat));
    emit(
        "| threads | min wall s | median wall s | CPU s (min-wall run) | load | cleanup | bvh | distance | "
        "sign | write | in-process total |\n");
    emit("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    nlohmann::json lastReport;
    for (uint32_t t : threads) {
        std::vector<Run> runs;
        for (uint32_t r = 0; r < repeat; ++r) {
            Run run;
            std::string error;
            if (!runChild({cli, "bake", mesh, "-o", out, "--resolution", std::to_string(resolution),
                           "--threads", std::to_string(t), "--quiet", "--report", reportPath},
                          run.wallMs, run.cpuMs, error)) {
                std::fprintf(stderr, "%s\n", error.c_str());
                return 1;
            }
            std::ifstream in(reportPath);
            run.report = nlohmann::json::parse(in, nullptr, false);
            if (run.report.is_discarded()) {
                std::fprintf(stderr, "%s: unreadable report\n", reportPath.c_str());
                return 1;
            }
            runs.push_back(std::move(run));
        }
        std::sort(runs.begin(), runs.end(), [](const Run& a, const Run& b) { return a.wallMs < b.wallMs; });
        const nlohmann::json& tm = runs.front().report["timingsMs"];
        auto s = [&tm](const char* k) { return fmt::format("{:.2f}", tm[k].get<double>() / 1000.0); };
        emit(fmt::format("| {} | {:.2f} | {:.2f} | {:.2f} | {} | {} | {} | {} | {} | {} | {} |\n", t,
                         runs.front().wallMs / 1000, runs[runs.size() / 2].wallMs / 1000,
                         runs.front().cpuMs / 1000, s("load"), s("cleanup"), s("bvh"), s("distance"),
                         s("sign"), s("write"), s("total")));
        lastReport = runs.front().report;
    }
    const auto& dims = lastReport["grid"]["dims"];
    emit(fmt::format(
        "\nPhases in seconds from the fastest run's --report. Grid {} x {} x {}, voxel size {:.6g}; "
        "{} triangles after clean-up; sign: {} ({}). Load average after: {}.\n",
        dims[0].get<int>(), dims[1].get<int>(), dims[2].get<int>(),
        lastReport["grid"]["voxelSize"].get<double>(), lastReport["mesh"]["triangles"].get<uint64_t>(),
        lastReport["sign"]["method"].get<std::string>(), lastReport["sign"]["reason"].get<std::string>(),
        loadAverage()));

    if (errorSamples > 0) {
        sdf::PsdfAsset asset;
        std::string error;
        assets::MeshData meshData;
        if (!sdf::readPsdf(out, asset, error) || !assets::loadMesh(mesh, meshData, error)) {
            std::fprintf(stderr, "%s\n", error.c_str());
            return 1;
        }
        const sdf::SdfGrid& g = asset.grid;
        const sdf::SdfSampler sampler(asset);
        const auto tris = acceptance::toTriangles(meshData);
        std::vector<glm::dvec3> positions(meshData.positions.begin(), meshData.positions.end());
        std::vector<glm::uvec3> triangles(meshData.triangleCount());
        for (size_t i = 0; i < triangles.size(); ++i)
            triangles[i] = {meshData.indices[3 * i], meshData.indices[3 * i + 1],
                            meshData.indices[3 * i + 2]};
        const sdf::WindingNumber winding(positions, triangles);

        std::mt19937_64 rng(12345);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::vector<uint64_t> band;
        for (uint64_t i = 0; i < g.distances.size(); ++i)
            if (std::fabs(g.distances[i]) < 2 * g.voxelSize) band.push_back(i);
        std::vector<glm::dvec3> points;
        for (uint32_t i = 0; i < errorSamples; ++i)
            points.push_back(sampler.sampleBoxMin() + glm::dvec3(u(rng), u(rng), u(rng)) *
                                                          (sampler.sampleBoxMax() - sampler.sampleBoxMin()));
        for (uint32_t i = 0; i < errorSamples && !band.empty(); ++i) {
            const uint64_t v = band[rng() % band.size()];
            const uint32_t x = uint32_t(v % g.dims.x), y = uint32_t((v / g.dims.x) % g.dims.y);
            const uint32_t z = uint32_t(v / (uint64_t(g.dims.x) * g.dims.y));
            const glm::dvec3 jitter = glm::dvec3(u(rng), u(rng), u(rng)) - 0.5;
            points.push_back(glm::clamp(g.voxelCenter(x, y, z) + jitter * g.voxelSize, sampler.sampleBoxMin(),
                                        sampler.sampleBoxMax()));
        }
        std::vector<double> exact(points.size());
        const auto t0 = std::chrono::steady_clock::now();
        acceptance::parallelIndices(points.size(), acceptance::hardwareThreads(), [&](size_t i) {
            const double d = acceptance::bruteForceDistance(tris, points[i]);
            exact[i] = winding.fast(points[i]) > 0.5 ? -d : d;
        });
        const double refSeconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        ErrorStats uniform, near, nearUnsigned;
        for (size_t i = 0; i < points.size(); ++i) {
            const double s = sampler.sample(points[i]);
            const double e = std::fabs(s - exact[i]) / g.voxelSize;
            if (i < errorSamples) {
                uniform.add(e);
            } else {
                near.add(e);
                nearUnsigned.add(std::fabs(std::fabs(s) - std::fabs(exact[i])) / g.voxelSize);
            }
        }
        emit(
            fmt::format("\nTrilinear interpolation error of that grid against exact signed distances (brute "
                        "force over all "
                        "{} triangles, sign from the winding number; {:.0f} s to compute), in voxels:\n\n",
                        tris.size(), refSeconds));
        emit("| points | count | mean | RMS | max |\n|---|---:|---:|---:|---:|\n");
        emit(fmt::format("| uniform in the box of voxel centres | {} | {:.4f} | {:.4f} | {:.4f} |\n",
                         uniform.n, uniform.mean(), uniform.rms(), uniform.max));
        emit(fmt::format(
            "| within ~2 voxels of the surface (jittered voxel centres) | {} | {:.4f} | {:.4f} | {:.4f} |\n",
            near.n, near.mean(), near.rms(), near.max));
        emit(fmt::format("| same, unsigned: abs(abs(s) - abs(d)) | {} | {:.4f} | {:.4f} | {:.4f} |\n",
                         nearUnsigned.n, nearUnsigned.mean(), nearUnsigned.rms(), nearUnsigned.max));
    }
    std::remove(out.c_str());
    std::remove(reportPath.c_str());
    if (!markdown.empty()) {
        std::ofstream f(markdown);
        f << md;
        if (!f) {
            std::fprintf(stderr, "%s: cannot write\n", markdown.c_str());
            return 1;
        }
    }
    return 0;
}
