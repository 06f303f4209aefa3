// penumbra sdf info | sample: inspect a .psdf file and sample it at points in the mesh's own
// coordinates (trilinear inside the grid, the conservative outside rule of docs/FORMATS.md beyond).
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cli_common.h"
#include "cmd_sdf.h"
#include "engine/core/log.h"
#include "engine/sdf/psdf.h"

namespace penumbra::cli {

namespace {

std::string vecText(const glm::dvec3& v) { return fmt::format("({:.9g}, {:.9g}, {:.9g})", v.x, v.y, v.z); }

// Parses one finite double filling the whole token.
bool parseNumber(std::string_view token, double& out) {
    const char* first = token.data();
    const char* last = first + token.size();
    if (first != last && *first == '+') ++first;  // from_chars rejects a leading '+'
    const auto r = std::from_chars(first, last, out);
    return r.ec == std::errc() && r.ptr == last && std::isfinite(out);
}

// Reads "x y z" lines (separated by spaces, tabs or commas). Blank lines and comments ('#' to the
// end of the line, whole-line or trailing) are skipped. A bad line does not stop the reading: its
// "name:line: ..." message is added to `badLines` and the good points are still returned.
// Returns false only when the stream itself fails.
bool readPoints(std::istream& in, const std::string& name, std::vector<glm::dvec3>& points,
                std::vector<std::string>& badLines, std::string& error) {
    std::string line;
    size_t lineNo = 0;
    while (std::getline(in, line)) {
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::string_view rest(line);
        if (const size_t hash = rest.find('#'); hash != std::string_view::npos) rest = rest.substr(0, hash);
        std::vector<std::string_view> tokens;
        while (!rest.empty()) {
            const size_t b = rest.find_first_not_of(" \t,");
            if (b == std::string_view::npos) break;
            rest.remove_prefix(b);
            const size_t e = rest.find_first_of(" \t,");
            tokens.push_back(rest.substr(0, e));
            rest.remove_prefix(e == std::string_view::npos ? rest.size() : e);
        }
        if (tokens.empty()) continue;  // blank or comment only
        glm::dvec3 p;
        bool ok = tokens.size() == 3;
        for (size_t i = 0; ok && i < 3; ++i) ok = parseNumber(tokens[i], p[int(i)]);
        if (!ok) {
            badLines.push_back(fmt::format("{}:{}: expected three finite numbers 'x y z', got '{}'", name,
                                           lineNo, line.size() > 80 ? line.substr(0, 77) + "..." : line));
            continue;
        }
        points.push_back(p);
    }
    if (in.bad()) {
        error = fmt::format("{}: read error after line {}", name, lineNo);
        return false;
    }
    return true;
}

}  // namespace

CLI::App* addSdfCommand(CLI::App& app, SdfInfoOptions& info, SdfSampleOptions& sample, CLI::App** infoCmd,
                        CLI::App** sampleCmd) {
    auto* sdf = app.add_subcommand("sdf", "Inspect and sample .psdf signed distance files");
    sdf->require_subcommand(1);
    auto* i = sdf->add_subcommand("info", "Validate a .psdf file and print its header and value range");
    i->add_option("file", info.file, ".psdf file")->required();
    auto* s = sdf->add_subcommand(
        "sample",
        "Print the distance at each point of a text file (one 'x y z' per line, in the source "
        "mesh's coordinates): trilinear inside the grid, conservative outside");
    s->add_option("file", sample.file, ".psdf file")->required();
    s->add_option(
         "--points", sample.points,
         "Text file with one 'x y z' per line ('#' starts a comment; blank lines are skipped); - = "
         "stdin. A bad line is reported with its number and fails the run; the good ones are printed")
        ->required();
    *infoCmd = i;
    *sampleCmd = s;
    return sdf;
}

int runSdfInfo(const SdfInfoOptions& opt) {
    sdf::PsdfAsset asset;
    std::string error;
    if (!checkInputFile(opt.file, ".psdf file", error) || !sdf::readPsdf(opt.file, asset, error)) {
        log::error("{}", error);
        return 1;
    }
    const sdf::PsdfHeader& h = asset.header;
    const sdf::SdfSampler sampler(asset);
    const glm::dvec3 farCorner = h.origin + glm::dvec3(h.dims) * h.voxelSize;
    std::string mesh = (h.flags & sdf::kPsdfFlagClosedManifold) ? "closed manifold" : "";
    if (h.flags & sdf::kPsdfFlagBoundaryEdges)
        mesh += mesh.empty() ? "open (boundary edges)" : ", boundary edges";
    if (h.flags & sdf::kPsdfFlagNonManifold)
        mesh += mesh.empty() ? "non-manifold edges" : ", non-manifold edges";
    if (mesh.empty()) mesh = "unknown topology";
    fmt::print("file          {}\n", opt.file);
    fmt::print("version       {}\n", h.version);
    fmt::print("dims          {} x {} x {} ({} voxels)\n", h.dims.x, h.dims.y, h.dims.z, h.voxelCount());
    fmt::print("voxel size    {:.9g}\n", h.voxelSize);
    fmt::print("grid box      {} .. {}\n", vecText(h.origin), vecText(farCorner));
    fmt::print("sample box    {} .. {} (voxel centres)\n", vecText(sampler.sampleBoxMin()),
               vecText(sampler.sampleBoxMax()));
    fmt::print("mesh bounds   {} .. {}\n", vecText(h.boundsMin), vecText(h.boundsMax));
    fmt::print("outside rule  {}\n",
               sampler.meshInsideSampleBox()
                   ? "max(sqrt(a^2 + s^2), distance to mesh bounds)"
                   : "max(distance to mesh bounds, s - a) (mesh reaches past the voxel centres)");
    if (h.encoding == sdf::PsdfEncoding::U8)
        fmt::print("encoding      u8 narrow band, band width {:.9g} ({:.3g} voxels), step {:.3g}\n",
                   h.bandWidth, h.bandWidth / h.voxelSize, 2.0 * h.bandWidth / 255.0);
    else
        fmt::print("encoding      {}\n", sdf::toString(h.encoding));
    fmt::print("sign method   {}\n", sdf::toString(h.sign()));
    fmt::print("mesh          {}\n", mesh);
    fmt::print("distance      min {:.9g}  max {:.9g}  ({:.4g} .. {:.4g} voxels)\n", h.minDistance,
               h.maxDistance, h.minDistance / h.voxelSize, h.maxDistance / h.voxelSize);
    fmt::print("payload       {} bytes, crc32 0x{:08x} (ok); header crc32 0x{:08x} (ok)\n", h.payloadBytes,
               h.payloadCrc, h.headerCrc);
    return 0;
}

int runSdfSample(const SdfSampleOptions& opt) {
    sdf::PsdfAsset asset;
    std::string error;
    if (!checkInputFile(opt.file, ".psdf file", error) || !sdf::readPsdf(opt.file, asset, error)) {
        log::error("{}", error);
        return 1;
    }
    const std::string pointsName = opt.points == "-" ? std::string("<stdin>") : opt.points;
    std::vector<glm::dvec3> points;
    std::vector<std::string> badLines;
    bool read = false;
    if (opt.points == "-") {
        read = readPoints(std::cin, pointsName, points, badLines, error);
    } else {
        if (!checkInputFile(opt.points, "points file", error)) {
            log::error("{}", error);
            return 1;
        }
        std::ifstream in(opt.points);
        if (!in) {
            log::error("{}: cannot open the points file", opt.points);
            return 1;
        }
        read = readPoints(in, opt.points, points, badLines, error);
    }
    const sdf::SdfSampler sampler(asset);
    std::string out;
    out.reserve(points.size() * 16);
    for (const glm::dvec3& p : points) fmt::format_to(std::back_inserter(out), "{:.9g}\n", sampler.sample(p));
    fmt::print("{}", out);
    std::fflush(stdout);
    // The good points are printed; the bad lines are reported (the first 20) and fail the run.
    constexpr size_t kMaxReported = 20;
    for (size_t i = 0; i < badLines.size() && i < kMaxReported; ++i) log::error("{}", badLines[i]);
    if (badLines.size() > kMaxReported)
        log::error("{}: {} more bad lines not shown", pointsName, badLines.size() - kMaxReported);
    if (!badLines.empty())
        log::error("{}: {} bad line(s) skipped; {} point(s) sampled", pointsName, badLines.size(),
                   points.size());
    if (!read) {
        log::error("{}", error);
        return 1;
    }
    return badLines.empty() ? 0 : 1;
}

}  // namespace penumbra::cli
