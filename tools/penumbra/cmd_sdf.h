// SDF subcommands of the penumbra CLI:
//   penumbra bake <mesh> -o out.psdf [...]      mesh -> .psdf with a summary and a JSON report
//   penumbra sdf info <file.psdf>               header, flags and value range of a .psdf file
//   penumbra sdf sample <file.psdf> --points f  one interpolated distance per input point
// Exit codes: 0 ok, 1 runtime error (bad input file, failed bake, unwritable output), 2 usage.
#pragma once

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

#include "engine/assets/mesh.h"

namespace penumbra::cli {

struct BakeOptions {
    std::string input, output, report;
    uint32_t resolution = 0;
    double voxelSize = 0;
    uint32_t padding = 2;
    std::string sign = "auto";
    uint32_t threads = 0;
    std::string encoding = "f32";
    double bandWidthVoxels = 4.0;
    std::string quality = "medium";
    bool quiet = false;
    uint64_t maxTriangles = assets::MeshLoadLimits{}.maxTriangles;  // load limit (glTF: all instances)
    CLI::Option* bandWidthOption = nullptr;  // to tell an explicit --band-width from the default
};

struct SdfInfoOptions {
    std::string file;
};

struct SdfSampleOptions {
    std::string file, points;
};

CLI::App* addBakeCommand(CLI::App& app, BakeOptions& opt);
int runBake(const BakeOptions& opt, const std::string& commandLine);

// Adds `sdf` with its `info` and `sample` subcommands; returns `sdf`.
CLI::App* addSdfCommand(CLI::App& app, SdfInfoOptions& info, SdfSampleOptions& sample, CLI::App** infoCmd,
                        CLI::App** sampleCmd);
int runSdfInfo(const SdfInfoOptions& opt);
int runSdfSample(const SdfSampleOptions& opt);

}  // namespace penumbra::cli
