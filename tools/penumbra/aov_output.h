// `penumbra render --aov depth=d.pfm,normal=n.pfm,ids=i.pfm,steps=s.pfm`: float images of the last
// frame's G-buffer, one PFM per AOV (tools/reference/pfm.h; conventions in docs/FORMATS.md "AOV
// images", the same as `penumbra reference`):
//   depth   Pf  linear view depth along the camera's -Z, scene units (gbuffer.depth); 0: nothing hit
//   normal  PF  world-space unit normal (gbuffer.normal, octahedral RG16F, decoded); 0 where depth is 0
//   ids     Pf  entity index (gbuffer.aux x); -1: background
//   steps   Pf  sphere-trace steps (gbuffer.aux y); 0 for rasterized pixels and the background
//   ao          Pf  ambient occlusion in [0, 1] (effects.ao r, 1 = unoccluded); 0 on the background
//   shadow      Pf  visibility in [0, 1] of the first shadowed light (effects.shadow layer 0);
//   shadowN         of shadowed light N (layer N; lights with castShadows in ascending entity
//                   index, N from 0: shadow0 = shadow); 0 on the background
//   bentnormal  PF  the AO pass's bent normal (effects.ao gba decoded, unit); 0 on the background
//   thickness   Pf  subsurface thickness in scene units (effects.thickness); 0: none / background
// An effect AOV needs its effect to have run in the frame (the error names the setting that turns
// it on); shadowN needs shadowed light N.
// The list is parsed and every path checked (name, duplicate, ".pfm") before any work; the paths go
// through OutputFiles like -o, so they appear only when the whole command succeeds.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "engine/core/output_file.h"
#include "reference/pfm.h"
#include "rhi/types.h"

namespace penumbra {
struct RendererDesc;
namespace render {
class SceneRenderer;
}
}  // namespace penumbra

namespace penumbra::cli {

enum class RenderAov { Depth, Normal, Ids, Steps, Ao, Shadow, BentNormal, Thickness };

struct AovOutput {
    RenderAov kind = RenderAov::Depth;
    std::string path;
    uint32_t light = 0;  // Shadow: the shadowed light (its layer of effects.shadow)
};

// "shadow" for light 0, else "shadowN"; the AOV's name otherwise.
std::string aovLabel(const AovOutput& aov);

const char* aovName(RenderAov aov);

// Adds "--aov NAME=PATH,..." to a command that renders through penumbra::Renderer.
CLI::Option* addAovOption(CLI::App* cmd, std::string& spec);

// Parses the --aov value (empty: no AOV). Errors: an unknown name, a name listed twice, an item
// without "=", an empty path, a path not ending in ".pfm".
bool parseAovOutputs(const std::string& spec, std::vector<AovOutput>& out, std::string& error);

// The output paths, for prepareOutputs().
std::vector<std::string> aovPaths(const std::vector<AovOutput>& aovs);

// Whether the frame needs the auxiliary G-buffer target gbuffer.aux (ids or steps requested).
bool aovsNeedAux(const std::vector<AovOutput>& aovs);

// Asks the renderer for gbuffer.aux (RendererDesc::aux -> render::FrameDesc::aux) only when the AOVs
// need it. False with `error` when they do and the renderer of this build has no such switch.
bool requestAuxTarget(RendererDesc& desc, const std::vector<AovOutput>& aovs, std::string& error);

// Raw texels of a G-buffer target as read back by render::SceneRenderer::readTarget.
struct TargetTexels {
    std::vector<uint8_t> texels;
    rhi::Format format = rhi::Format::Undefined;
};

// Converts read-back targets into one AOV image (row 0 = top). `depth` is gbuffer.depth (needed by
// Depth and Normal), `normal` gbuffer.normal (Normal), `aux` gbuffer.aux (Ids, Steps). Checks the
// formats and the sizes. Exposed for tests.
bool convertAov(RenderAov aov, uint32_t width, uint32_t height, const TargetTexels* depth,
                const TargetTexels* normal, const TargetTexels* aux, reference::FloatImage& out,
                std::string& error);

// Converts a read-back effect target into an effect AOV image (Ao, Shadow, BentNormal, Thickness):
// `depth` is gbuffer.depth (0: background), `effect` effects.ao / effects.shadow / effects.thickness.
// Checks the formats and sizes; Shadow fails when the target has no layer `aov.light`. Exposed for
// tests.
bool convertEffectAov(const AovOutput& aov, uint32_t width, uint32_t height, const TargetTexels& depth,
                      const TargetTexels& effect, reference::FloatImage& out, std::string& error);

// Reads the targets the AOVs need from the last frame of `renderer` and writes each AOV's PFM to
// its temporary file in `outputs` (added by prepareOutputs before the work).
bool writeAovOutputs(OutputFiles& outputs, render::SceneRenderer& renderer, uint32_t width, uint32_t height,
                     const std::vector<AovOutput>& aovs, std::string& error);

}  // namespace penumbra::cli
