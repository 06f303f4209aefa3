// `penumbra bench trace-modes` (issue 14 item 1): full-screen against box tracing (mTec thesis
// section 8.4, Table 7) over the object count.
//   bench trace-modes [--counts 20,40,60,80,100,200,1000] [--backend vulkan|gl|both]
//                     [--width 320 --height 180] [--frames 3] [--warmup 1] [--instancing on|off]
//                     [--resolution 32] [--mesh-dir data/meshes] [--markdown out.md] [--csv out.csv]
// For each backend and N it generates the objects scene (engine/scene/objects_scene.h), turns
// shadows and AO off (as Table 7: only the primary trace's outputs), and renders W warm-up then F
// timed frames in each mode, the modes interleaved frame by frame on one renderer so both see the
// same machine load. Per mode the median GPU ms of the trace — fullscreen: sdf_trace + its tile
// culling (sdf_tile_cull*); box: sdf_box_trace — and of the whole frame; the ratio box / fullscreen
// (< 1: box tracing is faster), and the counts where each mode was faster.
// Exit codes: 0 ok, 1 runtime error, 2 usage.
#pragma once

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

namespace penumbra::cli {

struct BenchTraceModesOptions {
    std::string counts = "20,40,60,80,100,200,1000";
    std::string backend = "both";
    uint32_t width = 320;
    uint32_t height = 180;
    uint32_t frames = 3;
    uint32_t warmup = 1;
    std::string instancing = "on";  // on | off
    uint32_t resolution = 32;
    std::string meshDir = "data/meshes";
    std::string csv, markdown;
    std::string cacheDir;
    bool noCache = false;
};

CLI::App* addBenchTraceModesCommand(CLI::App& group, BenchTraceModesOptions& opt);
int runBenchTraceModes(const BenchTraceModesOptions& opt);

}  // namespace penumbra::cli
