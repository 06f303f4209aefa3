// `penumbra reference <scene> -o DIR --aov depth,normal,ids,ao,shadow [--samples N] [--width W
//  --height H] [--error E] [--camera NAME] [--ao-distance D|inf] [--seed S] [--threads T] [--report FILE]` —
// the CPU reference renderer (tools/reference/reference.h, docs/ACCURACY.md): loads the scene
// through penumbra::Engine, renders the requested AOVs from the original geometry and writes one PFM
// per AOV (DIR/<aov>.pfm) plus a JSON report with the standard error of every image (default
// DIR/reference.json). Outputs are validated before the work and written all or nothing.
// Exit codes: 0 ok, 1 runtime error (bad scene, unwritable output), 2 usage.
#pragma once

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

namespace penumbra::cli {

struct ReferenceOptions {
    std::string scene;
    std::string outputDir = "out/reference";
    std::string aovs = "depth,normal,ids";
    uint32_t samples = 1024;
    double targetError = 0.0;  // > 0: samples from reference::samplesForError (overrides samples)
    uint32_t width = 0;        // 0: the scene's render settings
    uint32_t height = 0;
    std::string camera;
    std::string aoDistance = "1";
    uint64_t seed = 1;
    uint32_t threads = 0;
    std::string report;  // empty: <outputDir>/reference.json
    bool quiet = false;
};

CLI::App* addReferenceCommand(CLI::App& app, ReferenceOptions& opt);
int runReference(const ReferenceOptions& opt);

}  // namespace penumbra::cli
