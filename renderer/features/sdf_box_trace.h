// Feature "sdf_box_trace": the raster pass "sdf_box_trace", the rasterized alternative to the
// full-screen compute trace (sdf_trace.h; mTec thesis section 8.4, "box tracing"): one draw per
// traced SDF object rasterizes its local bounds box, and the fragment shader traces the pixel's ray
// in that object alone from the box entry, with the full-screen trace's march and hit decision
// (renderer/shaders/sdf_march.glsl, shared) and the object's own step limit, and writes the
// G-buffer and the hardware depth of the hit (renderer/shaders/sdf_box_trace.frag).
//
// Scheme (renderer/shaders/sdf_box_trace.vert):
//   - a box whose eight corners all lie beyond the near plane draws its front faces (back-face
//     culling); the hit lies on or behind the front face, so the fragment shader declares
//     layout(depth_greater) gl_FragDepth and early depth tests still reject hidden fragments;
//   - a box that contains the camera or crosses the near plane, and an unbounded object (a plane),
//     draws a full-screen triangle on the near plane instead (its front faces would be clipped);
//     each fragment intersects the ray with the box (a miss is discarded) and starts at the near
//     plane or the box entry. Depth 0 is in front of every hit, so the same depth_greater pipeline
//     serves both; these draws just get no early rejection;
//   - a box wholly in front of the near plane or beyond the far plane is not drawn.
// Depth test LESS with writes: overlapping boxes resolve to the nearest root, which is the hit the
// full-screen trace's union decides (each object's first root is searched on its own there too).
// With meshes the pass loads the mesh pass's G-buffer and its D32 depth (MeshDepth, the same
// projection's depth), so meshes and box-traced objects occlude each other; without meshes it
// clears the G-buffer to the "nothing hit" values the full-screen trace writes.
// The world cache, the id field and the tile lists are not used (the box is the culling);
// gbuffer.aux y counts the winning object's steps (or evaluations), 0 for pixels no object hit.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <glm/mat4x4.hpp>

#include "engine/scene/scene.h"
#include "renderer/features/frame_context.h"
#include "renderer/features/sdf_scene.h"

namespace penumbra::render {

struct SdfBoxTraceDesc {
    scene::TraceSettings settings;
    bool raster = false;                    // the mesh pass ran first and published MeshDepth
    float nearPlane = 0.1f;                 // linear depth where rays start
    float farPlane = 1000.0f;               // linear depth where rays end
    float footprint = 0.0f;                 // pixel size per unit distance (as SdfTraceDesc)
    bool countEvaluations = false;          // gbuffer.aux y = object evaluations instead of steps
    std::span<const GpuSdfObject> objects;  // the traced objects (bounds, model) in buffer order
    glm::mat4 view{1.0f};                   // world -> view (the draws' classification)
    glm::mat4 proj{1.0f};                   // view -> clip (coverage)
};

// How the objects were drawn.
struct SdfBoxTraceReport {
    uint32_t boxes = 0;      // front faces of the bounds box
    uint32_t nearDraws = 0;  // near-plane triangles (camera inside, crossing the near plane, unbounded)
    uint32_t skipped = 0;    // wholly in front of the near plane or beyond the far plane
    double coverage = 0.0;   // the boxes' summed screen-rectangle area / screen area (near draws 1)
};

// How one object is drawn (CPU side of the scheme above).
enum class BoxDraw : uint8_t { Box, Near, Skip };
// `coverage` gets the object's screen-rectangle fraction (clamped to the screen; 1 for Near).
BoxDraw classifyBoxDraw(const GpuSdfObject& object, const glm::mat4& view, const glm::mat4& proj,
                        float nearPlane, float farPlane, double* coverage = nullptr);

// The boxes' summed screen-rectangle fractions (classifyBoxDraw's coverage: near-plane and
// unbounded objects one screen each, skipped ones 0): the overdraw box mode pays for.
double boxCoverage(std::span<const GpuSdfObject> objects, const glm::mat4& view, const glm::mat4& proj,
                   float nearPlane, float farPlane);

// The mode a frame runs: Fullscreen and Box as asked; Auto picks Box when the frame traces at most
// kAutoBoxMaxObjects objects whose boxes cover at most kAutoBoxMaxCoverage screens (boxCoverage),
// else Fullscreen. The numbers are this project's measurements (docs/BENCHMARKS.md, "Full-screen
// vs box tracing"; llvmpipe, both backends): on the objects scene (1.1-1.5 screens) box tracing was
// faster up to 100-200 objects, about even at 200 and slower at 1000 — the reverse of the thesis's
// GPU, where box tracing overtakes from ~60 objects; box was also faster on shapes.json (1.5
// screens) and default.json (2.7 screens). Larger coverage was not measured: full-screen there.
inline constexpr uint32_t kAutoBoxMaxObjects = 200;
inline constexpr double kAutoBoxMaxCoverage = 3.0;
scene::TraceMode resolveTraceMode(scene::TraceMode requested, uint32_t objects, double coverage);

// The fragment stage of every variant of the pass's program (tests: the depth_greater declaration).
std::vector<const rhi::ShaderDesc*> sdfBoxTraceFragmentStages();

// Adds the pass. Reads SceneBuffers (view; materials with albedo), SdfSceneBuffers; writes every
// GBuffer target as colour targets and the depth (MeshDepth's, or a transient one).
SdfBoxTraceReport addSdfBoxTrace(FrameContext& fc, const SdfBoxTraceDesc& desc);

}  // namespace penumbra::render
