// `penumbra render <scene.json|.gltf|.glb> -o out.png [--backend vulkan|gl] [--width W --height H]
//  [--frames N] [--fixed-dt S] [--camera NAME] [--stats stats.json]` — loads a scene through the
// embedding API (penumbra::Engine + penumbra::Renderer), runs N frames of deterministic time, writes
// the last frame as PNG and prints the per-pass GPU/CPU table (medians over the frames).
// Exit codes: 0 ok, 1 runtime error (bad scene, device failure, unwritable output), 2 usage.
#pragma once

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

namespace penumbra::cli {

struct RenderOptions {
    std::string scene;
    std::string output = "out/render.png";
    std::string backend;  // empty: $PENUMBRA_BACKEND or auto
    bool validation = false;
    uint32_t width = 0;  // 0: the scene's render settings
    uint32_t height = 0;
    uint32_t frames = 1;
    double fixedDt = 1.0 / 60.0;
    std::string camera;
    std::string stats;
    std::string graphviz;
    std::string cacheDir;  // empty: $PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra or ~/.cache/penumbra
    bool noCache = false;
    std::string meshSdf;     // --mesh-sdf off | trace | occlusion | auto; empty: the scene's render.meshSdf
    std::string pluginDir;   // empty: none
    std::string shading;     // override: cook-torrance | blinn-phong
    std::string toneMapper;  // override: clamp | reinhard | aces
    std::string quality;     // override: low | medium | high | reference (SDF trace preset)
    std::string shadows;     // override: on | off | hard (render.shadows)
    std::string ao;          // override: off | five-tap | multi-ray | cones (render.ao.variant)
    std::string debugView;   // empty: the scene's | none | normals | depth | albedo | steps |
                             // ids | field-slice
    std::string slice;       // --slice AXIS=OFFSET | NX,NY,NZ,OFFSET; empty: the scene's
    std::string aov;         // --aov NAME=PATH.pfm,... (aov_output.h); empty: none
    std::string traceMode;   // --trace-mode fullscreen|box|auto; empty: the scene's
    std::string accel;       // --accel all | none | culling,cache,id,prepass; empty: the scene's
    std::string taa;         // override: on | off (render.taa)
    std::string motionBlur;  // override: on | off (render.motionBlur.enabled)
};

CLI::App* addRenderCommand(CLI::App& app, RenderOptions& opt);
int runRender(const RenderOptions& opt);

}  // namespace penumbra::cli
