// Feature "debug_view": the full-screen pass "debug_view" that shows one G-buffer channel in the
// output instead of the lit image (`penumbra render --debug-view VIEW`, or the scene's
// render.debugView; docs/FORMATS.md). Background pixels are black unless a view says otherwise.
//   normals      world normal * 0.5 + 0.5
//   depth        white at the camera, black at depthRange (the scene renderer passes the far side of
//                the farthest drawn mesh's or bounded SDF object's bounding sphere) and where
//                nothing is hit
//   albedo       base colour (the albedo target when the frame has one, else the material's colour)
//   steps        sphere-trace steps per pixel (gbuffer.aux y) as a heat map, scaled by the frame's
//                step limit (the quality preset's maxSteps with the scene's render.trace override;
//                an object's own larger maxSteps can exceed it and clamps to the top colour):
//                s = steps / limit, piecewise linear through
//                  0 black, 1/8 blue (0,0,1), 1/4 cyan (0,1,1), 1/2 green (0,1,0), 3/4 yellow (1,1,0),
//                  1 red (1,0,0) and above;
//                0 steps is black: rasterized pixels, rays that met no object's bounds, and rays
//                that hit at their first point (a surface on the bounds box, e.g. a box's face);
//                background pixels whose ray crossed bounds show the steps spent missing
//   ids          entity index (gbuffer.aux x, meshes and SDF objects) as a stable hash colour:
//                rgb = 0.2 + 0.8 * (bytes 0, 1, 2 of pcg32(index)) / 255, the same for an index in
//                every frame and on every backend; background (-1) black
//   ao           ambient occlusion (effects.ao r), grey: white = unoccluded
//   shadow       visibility of the first shadowed light (effects.shadow layer 0), grey: white = lit
//   bentnormal   the AO pass's bent normal (effects.ao gba, unit) * 0.5 + 0.5
//   thickness    t / (t + r) grey, t the subsurface thickness (effects.thickness, scene units), r the
//                pixel material's subsurfaceRadius: black = none, mid grey t = r, white = thick
//                The four effect views show black on the background. They read the effect's full-
//                resolution target (renderer/features/effects.h); when the effect did not run (AO
//                off, no shadowed light, no subsurface material, no SDF object) they show what the
//                lighting pass uses instead: AO and shadow white, the shading normal, thickness black.
//   tiles        the length n of each 8x8 tile's primary object list (SdfCullLists::primary,
//                renderer/features/sdf_cull.h; the scene renderer builds it for this view even with
//                culling off) through the steps ramp at s = log2(1 + n) / log2(1 + N), N the traced
//                objects: 0 black, N red; the "all objects" fallback (count 0xffffffff) magenta;
//                black everywhere when the frame traces no SDF object
//   field-slice  the pass "debug_field_slice" (renderer/features/debug_field_slice.h) instead of
//                this one: the signed distance of the SDF scene on a plane
// Ids and steps read gbuffer.aux: the scene renderer writes it for them (frameNeedsAux) whether or
// not FrameDesc::aux asked for it. These three views and normals/depth are display values (written
// as they are); albedo is linear colour (sRGB-encoded).
// It is the worked example of docs/ARCHITECTURE.md, "How to add a pass".
#pragma once

#include <string_view>

#include <glm/vec4.hpp>

#include "engine/scene/scene.h"
#include "renderer/features/frame_context.h"

namespace penumbra::render {

// The enumeration and its names live with the scene settings (render.debugView); these are the same
// functions: "none", "normals", "depth", "albedo", "steps", "ids", "field-slice", "ao", "shadow",
// "bentnormal", "thickness", "tiles".
using scene::DebugView;
using scene::parseDebugView;
using scene::toString;

// The view a frame shows: `requested` (FrameDesc::debugView: embedders, tests, RendererDesc) when it
// is not None, else the scene's render.debugView.
DebugView frameDebugView(DebugView requested, const scene::RenderSettings& settings);
// Whether a frame writes gbuffer.aux: asked for (FrameDesc::aux: AOVs) or read by the view (ids, steps).
bool frameNeedsAux(bool requested, DebugView view);

// "y=0.5" (an axis-aligned plane: x, y or z = offset) or "nx,ny,nz,d" (dot(n / |n|, p) = d) as the
// plane (unit normal xyz, offset w). False with `error` for anything else (a zero normal included).
bool parseSlicePlane(std::string_view text, glm::vec4& out, std::string& error);

struct DebugViewDesc {
    DebugView view = DebugView::None;  // must not be None
    float depthRange = 1.0f;           // depth: linear depth shown as black
    uint32_t stepLimit = 128;          // steps: the heat map's top (red)
    glm::vec4 slice{0, 1, 0, 0};       // field-slice: the plane (unit normal, offset)
    float fieldSafety = 1.0f;          // field-slice: the trace's field safety (sdf_scene.glsl)
    float nearPlane = 0.1f;            // field-slice: linear depths where the plane is shown
    float farPlane = 1000.0f;
};

// Reads SceneBuffers and GBuffer (gbuffer.aux for ids and steps, Effects for the effect views),
// writes Output. Field-slice reads SceneBuffers and SdfSceneBuffers instead
// (renderer/features/debug_field_slice.h).
void addDebugView(FrameContext& fc, const DebugViewDesc& desc);

}  // namespace penumbra::render
