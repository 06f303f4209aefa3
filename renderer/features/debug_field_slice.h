// Feature "debug_field_slice": the full-screen pass "debug_field_slice", the debug view
// `field-slice` (`penumbra render --debug-view field-slice [--slice PLANE]`, or the scene's
// render.debugView / render.slice; docs/FORMATS.md). It shows the signed distance of the frame's
// SDF scene on a plane, where the camera ray through each pixel meets that plane (between the near
// and far planes); every other pixel is black. Meshes play no part (the G-buffer is not read).
//
// The distance at a plane point is the minimum over every SDF object of sdfObjectDistance
// (renderer/shaders/sdf_scene.glsl): the same conservative distance the trace steps with (shape
// programs, and field objects with the trace's fieldSafety; variant SDF_FIELDS binds the atlas).
// Colours (display values, written as they are):
//   outside (d >= 0)  orange (1, 0.55, 0.15), inside (d < 0) blue (0.2, 0.45, 1), each times
//                     0.3 + 0.7 exp(-|d|) (darker away from the surface);
//   iso-lines         every 0.1 scene units the colour times 0.6, every 1.0 times 0.35, about one
//                     pixel wide; each set fades out where its lines would be fewer than 4 pixels
//                     apart (gone at 2: at 0.1 units they need a close view);
//   zero line         (the surface) white, about three pixels wide; faded out as the 1.0 lines are
//                     (far away, where a pixel spans too much of the plane to place it);
//   no SDF object     in the frame: the plane is flat grey (0.5), with no field (this module then
//                     adds an "sdf_upload" pass of an empty object list itself).
#pragma once

#include <glm/vec4.hpp>

#include "renderer/features/frame_context.h"

namespace penumbra::render {

struct FieldSliceDesc {
    glm::vec4 plane{0, 1, 0, 0};  // dot(xyz, p) = w, xyz unit
    float fieldSafety = 1.0f;     // the trace's (scene::TraceSettings::fieldSafety)
    float nearPlane = 0.1f;       // linear depths between which the plane is shown
    float farPlane = 1000.0f;
};

// The iso-line spacing in scene units.
inline constexpr float kFieldSliceIsoSpacing = 0.1f;

// Reads SceneBuffers (view) and SdfSceneBuffers (published by sdf_upload; added here, empty, when
// the frame has none), writes Output.
void addDebugFieldSlice(FrameContext& fc, const FieldSliceDesc& desc);

}  // namespace penumbra::render
