// penumbra bake: mesh -> .psdf, with a phase-timed summary and an optional JSON report
// (schema in docs/FORMATS.md).
#include <chrono>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli_common.h"
#include "cmd_sdf.h"
#include "engine/assets/mesh.h"
#include "engine/core/log.h"
#include "engine/core/output_file.h"
#include "engine/core/progress.h"
#include "engine/sdf/bake.h"
#include "engine/sdf/psdf.h"

namespace penumbra::cli {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

nlohmann::ordered_json vec3Json(const glm::dvec3& v) {
    return nlohmann::ordered_json::array({v.x, v.y, v.z});
}

std::string humanBytes(uint64_t b) {
    if (b >= (1ull << 20)) return fmt::format("{:.1f} MiB", double(b) / double(1ull << 20));
    if (b >= (1ull << 10)) return fmt::format("{:.1f} KiB", double(b) / 1024.0);
    return fmt::format("{} B", b);
}

// The bake settings and the payload encoding of the options; false (usage error) when they are
// unknown or contradict each other.
bool bakeSettingsFrom(const BakeOptions& opt, sdf::BakeSettings& settings, sdf::PsdfEncoding& encoding) {
    if (!sdf::parseSignMethod(opt.sign, settings.sign)) {
        log::error("bake: unknown sign method '{}'", opt.sign);
        return false;
    }
    if (!sdf::parsePsdfEncoding(opt.encoding, encoding)) {
        log::error("bake: unknown encoding '{}'", opt.encoding);
        return false;
    }
    if (encoding != sdf::PsdfEncoding::U8 && opt.bandWidthOption && opt.bandWidthOption->count() > 0) {
        log::error("bake: --band-width applies to --encoding u8 only (encoding is {})", opt.encoding);
        return false;
    }
    if (opt.resolution > 0 && opt.resolution <= 2 * opt.padding) {
        log::error("bake: --resolution {} must exceed twice the padding ({} voxels on each side)",
                   opt.resolution, opt.padding);
        return false;
    }
    settings.resolution = opt.resolution;
    settings.voxelSize = opt.voxelSize;
    settings.padding = opt.padding;
    settings.threads = opt.threads;
    settings.quality = opt.quality == "low"    ? sdf::BakeQuality::Low
                       : opt.quality == "high" ? sdf::BakeQuality::High
                                               : sdf::BakeQuality::Medium;
    return true;
}

// Bakes with a progress bar on stderr (none with --quiet).
sdf::BakeResult bakeWithProgress(const assets::MeshData& mesh, sdf::BakeSettings& settings, bool quiet) {
    StderrProgressOutput progressOut;
    ProgressSettings progressSettings;
    progressSettings.enabled = !quiet;
    ProgressBar bar(progressOut, progressSettings);
    settings.progress = [&bar](double fraction, const char* phase) { bar.update(fraction, phase); };
    sdf::BakeResult result = sdf::bake(mesh, settings);
    bar.finish();
    return result;
}

sdf::PsdfWriteOptions psdfWriteOptions(const sdf::BakeResult& result, sdf::PsdfEncoding encoding,
                                       double bandWidthVoxels) {
    const sdf::MeshDiagnostics& diag = result.diagnostics;
    sdf::PsdfWriteOptions wo;
    wo.encoding = encoding;
    wo.bandWidth = encoding == sdf::PsdfEncoding::U8 ? bandWidthVoxels * result.grid.voxelSize : 0.0;
    wo.sign = sdf::psdfSign(result.signUsed);
    wo.closedManifold = diag.closedManifold;
    wo.boundaryEdges = diag.boundaryEdges > 0;
    wo.nonManifold = diag.nonManifoldEdges > 0;
    wo.boundsMin = diag.boundsMin;
    wo.boundsMax = diag.boundsMax;
    return wo;
}

const char* resolutionSource(const BakeOptions& opt) {
    return opt.resolution ? "--resolution" : opt.voxelSize > 0 ? "--voxel-size" : "automatic";
}

// What the report and the summary tell besides the bake result: the settings, the output and
// the times of the phases the CLI runs itself.
struct BakeOutcome {
    sdf::BakeQuality quality = sdf::BakeQuality::Medium;
    sdf::PsdfEncoding encoding = sdf::PsdfEncoding::F32;
    double bandWidth = 0;  // in mesh units (u8 only)
    uint64_t fileBytes = 0;
    double loadMs = 0, writeMs = 0, totalMs = 0;
};

// Phase name and milliseconds, in the order of the bake.
std::vector<std::pair<const char*, double>> phaseTimes(const sdf::BakeResult& result,
                                                       const BakeOutcome& outcome) {
    return {
        {"load", outcome.loadMs},        {"cleanup", result.timings.cleanupMs},
        {"bvh", result.timings.bvhMs},   {"distance", result.timings.distanceMs},
        {"sign", result.timings.signMs}, {"write", outcome.writeMs},
        {"total", outcome.totalMs},
    };
}

// The JSON report (schema in docs/FORMATS.md).
nlohmann::ordered_json bakeReport(const BakeOptions& opt, const std::string& commandLine,
                                  const sdf::BakeResult& result, const BakeOutcome& outcome) {
    const sdf::SdfGrid& grid = result.grid;
    const sdf::MeshDiagnostics& diag = result.diagnostics;
    nlohmann::ordered_json j;
    j["format"] = "penumbra-bake-report";
    j["version"] = 1;
    j["commandLine"] = commandLine;
    j["input"] = opt.input;
    j["output"] = opt.output;
    j["mesh"] = {
        {"inputTriangles", diag.inputTriangles},
        {"inputVertices", diag.inputVertices},
        {"triangles", diag.triangles},
        {"vertices", diag.vertices},
        {"boundaryEdges", diag.boundaryEdges},
        {"nonManifoldEdges", diag.nonManifoldEdges},
        {"degenerateTrianglesRemoved", diag.degenerateTrianglesRemoved},
        {"duplicateTrianglesRemoved", diag.duplicateTrianglesRemoved},
        {"duplicateVerticesMerged", diag.duplicateVerticesMerged},
        {"closedManifold", diag.closedManifold},
        {"inconsistentEdges", diag.inconsistentEdges},
        {"signedVolume", diag.signedVolume},
        {"inwardOriented", diag.inwardOriented},
        {"flippedInsideOut", result.flippedInsideOut},
        {"bbox", {{"min", vec3Json(diag.boundsMin)}, {"max", vec3Json(diag.boundsMax)}}},
    };
    j["grid"] = {
        {"dims", {grid.dims.x, grid.dims.y, grid.dims.z}},
        {"voxelSize", grid.voxelSize},
        {"origin", vec3Json(grid.origin)},
        {"voxels", uint64_t(grid.distances.size())},
        {"encoding", sdf::toString(outcome.encoding)},
        {"bandWidth", outcome.bandWidth},
        {"fileBytes", outcome.fileBytes},
    };
    j["distance"] = {{"min", result.minDistance}, {"max", result.maxDistance}};
    j["sign"] = {
        {"requested", opt.sign}, {"method", sdf::toString(result.signUsed)}, {"reason", result.signReason}};
    for (const auto& [name, ms] : phaseTimes(result, outcome)) j["timingsMs"][name] = ms;
    j["settings"] = {
        {"resolution", opt.resolution},
        {"voxelSize", opt.voxelSize},
        {"padding", opt.padding},
        {"sign", opt.sign},
        {"threads", opt.threads},
        {"quality", sdf::toString(outcome.quality)},
        {"encoding", opt.encoding},
        {"bandWidthVoxels", outcome.encoding == sdf::PsdfEncoding::U8
                                ? nlohmann::ordered_json(opt.bandWidthVoxels)
                                : nlohmann::ordered_json()},
        {"resolutionSource", resolutionSource(opt)},
        {"automaticResolution", sdf::automaticResolution(diag, outcome.quality)},
    };
    return j;
}

// The summary on stdout: mesh, topology, clean-up, grid, sign, distances, output and phase times.
void printBakeSummary(const BakeOptions& opt, const sdf::BakeResult& result, const BakeOutcome& outcome) {
    const sdf::SdfGrid& grid = result.grid;
    const sdf::MeshDiagnostics& diag = result.diagnostics;
    fmt::print("penumbra bake: {} -> {}\n", opt.input, opt.output);
    fmt::print("mesh        {} triangles, {} vertices (input {} / {})\n", diag.triangles, diag.vertices,
               diag.inputTriangles, diag.inputVertices);
    fmt::print("topology    {} boundary edges, {} non-manifold edges{}\n", diag.boundaryEdges,
               diag.nonManifoldEdges,
               !diag.closedManifold      ? ""
               : result.flippedInsideOut ? " (closed manifold, all triangles facing inward: flipped)"
               : diag.inwardOriented     ? " (closed manifold, all triangles facing inward: not flipped)"
                                         : " (closed manifold)");
    fmt::print("clean-up    {} degenerate and {} duplicate triangles removed, {} duplicate vertices merged\n",
               diag.degenerateTrianglesRemoved, diag.duplicateTrianglesRemoved, diag.duplicateVerticesMerged);
    fmt::print("bounds      ({:.6g}, {:.6g}, {:.6g}) .. ({:.6g}, {:.6g}, {:.6g})\n", diag.boundsMin.x,
               diag.boundsMin.y, diag.boundsMin.z, diag.boundsMax.x, diag.boundsMax.y, diag.boundsMax.z);
    const uint32_t longest = std::max({grid.dims.x, grid.dims.y, grid.dims.z});
    const std::string sourceText = opt.resolution || opt.voxelSize > 0
                                       ? fmt::format("from {}", resolutionSource(opt))
                                       : fmt::format("automatic, quality {}", sdf::toString(outcome.quality));
    fmt::print("grid        {} x {} x {}, voxel size {:.6g} ({} along the longest axis, {}; padding {})\n",
               grid.dims.x, grid.dims.y, grid.dims.z, grid.voxelSize, longest, sourceText, opt.padding);
    if (opt.sign == "auto")
        fmt::print("sign        {} (auto: {})\n", sdf::toString(result.signUsed), result.signReason);
    else
        fmt::print("sign        {} (requested{}{})\n", sdf::toString(result.signUsed),
                   result.signReason.empty() ? "" : "; ", result.signReason);
    fmt::print("distance    min {:.6g}  max {:.6g}  ({:.3f} .. {:.3f} voxels)\n", result.minDistance,
               result.maxDistance, result.minDistance / grid.voxelSize, result.maxDistance / grid.voxelSize);
    fmt::print("output      {} encoding, {}\n", sdf::toString(outcome.encoding),
               humanBytes(outcome.fileBytes));
    fmt::print("{:<10} {:>10}\n", "phase", "ms");
    for (const auto& [name, ms] : phaseTimes(result, outcome)) fmt::print("{:<10} {:>10.1f}\n", name, ms);
    if (!opt.report.empty()) fmt::print("report      {}\n", opt.report);
    fmt::print("wrote {}\n", opt.output);
}

}  // namespace

CLI::App* addBakeCommand(CLI::App& app, BakeOptions& opt) {
    auto* cmd = app.add_subcommand(
        "bake", "Bake a triangle mesh into a signed distance field (.psdf, see docs/FORMATS.md)");
    cmd->add_option("mesh", opt.input, "Input mesh: .gltf, .glb, .obj or .ply")->required();
    cmd->add_option("-o,--output", opt.output, "Output .psdf file")->required();
    auto* res =
        cmd->add_option("--resolution", opt.resolution, "Voxels along the longest axis of the padded grid")
            ->check(CLI::Range(1u, 4096u));
    auto* vs = cmd->add_option("--voxel-size", opt.voxelSize, "Voxel edge length in mesh units")
                   ->check(CLI::PositiveNumber);
    res->excludes(vs);
    vs->excludes(res);
    cmd->add_option("--padding", opt.padding, "Empty voxels added on every side of the mesh bounds")
        ->check(CLI::Range(0u, 256u))
        ->capture_default_str();
    cmd->add_option("--sign", opt.sign,
                    "Inside/outside method: auto (closed manifold -> pseudonormal, otherwise winding), "
                    "winding, pseudonormal or parity")
        ->check(CLI::IsMember({"auto", "winding", "pseudonormal", "parity"}))
        ->capture_default_str();
    cmd->add_option("--threads", opt.threads, "Worker threads (0 = all hardware threads)")
        ->check(CLI::Range(0u, 1024u))
        ->capture_default_str();
    cmd->add_option("--report", opt.report, "Also write a JSON report (mesh diagnostics, timings, settings)");
    cmd->add_option("--encoding", opt.encoding, "Payload encoding: f32, f16 or u8 (8-bit narrow band)")
        ->check(CLI::IsMember({"f32", "f16", "u8"}))
        ->capture_default_str();
    opt.bandWidthOption =
        cmd->add_option("--band-width", opt.bandWidthVoxels,
                        "u8 only: half-width of the narrow band in voxels (distances beyond are clamped)")
            ->check(CLI::PositiveNumber)
            ->capture_default_str();
    cmd->add_option("--quality", opt.quality,
                    "Automatic resolution when neither --resolution nor --voxel-size is given: low, medium "
                    "or high = 64, 128 or 256 voxels along the longest axis, up to twice that for "
                    "elongated meshes (docs/FORMATS.md)")
        ->check(CLI::IsMember({"low", "medium", "high"}))
        ->capture_default_str();
    cmd->add_option("--max-triangles", opt.maxTriangles,
                    "Refuse meshes with more triangles (glTF: counted over every node instance, before "
                    "merging)")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    cmd->add_flag("-q,--quiet", opt.quiet, "No progress bar and no summary; errors only");
    return cmd;
}

int runBake(const BakeOptions& opt, const std::string& commandLine) {
    const Clock::time_point tStart = Clock::now();

    sdf::BakeSettings settings;
    sdf::PsdfEncoding encoding;
    if (!bakeSettingsFrom(opt, settings, encoding)) return 2;

    // Input and outputs are checked before the (possibly long) bake; outputs are written to
    // temporary files and renamed into place only when everything succeeded.
    std::string error;
    if (!checkInputFile(opt.input, "mesh file (.ply, .obj, .gltf or .glb)", error)) {
        log::error("bake: {}", error);
        return 1;
    }
    OutputFiles outputs;
    if (!prepareOutputs(outputs, {opt.output, opt.report}, "bake")) return 1;

    // load
    Clock::time_point t0 = Clock::now();
    assets::MeshData mesh;
    assets::MeshLoadLimits loadLimits;
    loadLimits.maxTriangles = opt.maxTriangles;
    if (!assets::loadMesh(opt.input, mesh, error, loadLimits)) {
        log::error("bake: {}", error);
        return 1;
    }
    BakeOutcome outcome;
    outcome.loadMs = msSince(t0);

    // cleanup, bvh, distance, sign
    const sdf::BakeResult result = bakeWithProgress(mesh, settings, opt.quiet);
    if (!result.ok) {
        log::error("bake: {}: {}", opt.input, result.error);
        return 1;
    }
    const sdf::SdfGrid& grid = result.grid;

    // write
    t0 = Clock::now();
    const sdf::PsdfWriteOptions wo = psdfWriteOptions(result, encoding, opt.bandWidthVoxels);
    if (!outputs.write(
            opt.output,
            [&](const std::string& temp, std::string& why) {
                if (sdf::writePsdf(temp, grid, wo, why)) return true;
                why = fmt::format("cannot write {}: {}", opt.output, why);
                return false;
            },
            error)) {
        log::error("bake: {}", error);
        return 1;
    }
    outcome.writeMs = msSince(t0);
    outcome.totalMs = msSince(tStart);
    outcome.quality = settings.quality;
    outcome.encoding = encoding;
    outcome.bandWidth = wo.bandWidth;
    outcome.fileBytes =
        sdf::kPsdfHeaderBytes + uint64_t(grid.distances.size()) * sdf::bytesPerVoxel(encoding);

    if (!opt.report.empty() &&
        !outputs.writeText(opt.report, bakeReport(opt, commandLine, result, outcome).dump(2) + "\n", error)) {
        log::error("bake: {}", error);
        return 1;
    }
    if (!outputs.commit(error)) {
        log::error("bake: {}", error);
        return 1;
    }

    if (!opt.quiet) printBakeSummary(opt, result, outcome);
    return 0;
}

}  // namespace penumbra::cli
