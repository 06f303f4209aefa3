// `penumbra bench objects` (issue 13 item 5): mTec's Table 2 on our renderer — the cost of the SDF
// trace, shadows and AO against the number of objects and the acceleration toggles.
//   bench objects [--counts 20,40,60,80] [--configs none,culling,id,world,all] [--backend vulkan|gl|both]
//                 [--width 320 --height 180] [--frames 3] [--warmup 1] [--moving 0|1]
//                 [--instancing on|off|both] [--resolution 32] [--mesh-dir data/meshes]
//                 [--csv out.csv] [--markdown out.md]
//   bench objects --write-scene PATH --count N [--no-instancing]   writes the scene and exits
// For each backend, instancing mode and N it generates the objects scene (engine/scene/objects_scene.h),
// loads it like `penumbra render` does and, per configuration (none: every toggle off, mTec's
// baseline; culling; id = idField only; world = worldCache only; all = culling + worldCache +
// idField; prepass = the cone prepass; names joined by + combine, e.g. culling+prepass), renders W warm-up
// then F timed frames and takes per pass the median GPU ms. Passes are charged by name: trace = sdf_trace +
// the passes that exist only for the acceleration (sdf_tile_cull*, sdf_world_cache*, sdf_object_scatter,
// sdf_cone_prepass and sdf_trace_* stand-ins; each group also its own column); shadow = sdf_shadow + the
// effects' culling passes (sdf_tile_cull_effects*, sdf_effects_*: shared by shadows and AO, charged to the
// shadows as a whole); AO = sdf_ao. With --moving 1 the object "object 0" jumps 0.1 units left or
// right every frame; the update share is (sdf_world_cache* + sdf_object_scatter) / the frame's GPU
// total. Exit codes: 0 ok, 1 runtime error, 2 usage.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "engine/engine.h"
#include "renderer/renderer.h"

namespace penumbra::cli {

struct BenchObjectsOptions {
    std::string counts = "20,40,60,80";
    std::string configs = "none,culling,id,world,all";
    std::string backend = "both";
    uint32_t width = 320;
    uint32_t height = 180;
    uint32_t frames = 3;
    uint32_t warmup = 1;
    uint32_t moving = 0;            // objects moved every frame: 0 or 1
    std::string instancing = "on";  // on | off | both
    uint32_t resolution = 32;       // bake resolution of the meshes
    std::string meshDir = "data/meshes";
    std::string quality;  // empty: the scene's (medium)
    std::string csv, markdown;
    std::string cacheDir;
    bool noCache = false;
    // --write-scene mode
    std::string writeScene;
    uint32_t count = 20;
    bool noInstancing = false;
};

CLI::App* addBenchObjectsCommand(CLI::App& group, BenchObjectsOptions& opt);
int runBenchObjects(const BenchObjectsOptions& opt);

// What the benchmarks on the generated objects scene share (bench objects, bench trace-modes):
// --counts (comma-separated, each 1 .. scene::kMaxObjectsSceneCount), false with `error`;
bool parseObjectCounts(const std::string& text, std::vector<uint32_t>& counts, std::string& error);
// the scene's three meshes in `meshDir` (tools/fetch_meshes.sh), false with `error` naming the missing one;
bool checkObjectsMeshes(const std::string& meshDir, std::string& error);
// a fresh engine on the scene file `path`, `configure` applied to it, and a renderer of
// `width` x `height` on `backend` (not the null device). 0, or after logging "<command>: <error>"
// the exit code: 2 for a size the device refuses, 1 otherwise.
int openObjectsBench(const std::string& path, const std::string& cacheDir, rhi::Backend backend,
                     uint32_t width, uint32_t height, const char* command,
                     const std::function<void(Engine&)>& configure, std::unique_ptr<Engine>& engine,
                     std::unique_ptr<Renderer>& renderer);

}  // namespace penumbra::cli
