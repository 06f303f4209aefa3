// Feature "sdf_trace": the compute pass "sdf_trace" that sphere-traces every SDF object of the
// frame (SdfSceneBuffers, renderer/features/sdf_scene.h) into the G-buffer, one invocation per pixel
// (renderer/shaders/sdf_trace.comp describes the algorithm step by step).
//
// Hybrid rendering: when the mesh pass ran first, the trace reads its linear depth and ends every
// ray there, and writes only the pixels where an SDF is nearer; otherwise it writes every pixel
// (the G-buffer's "nothing hit" values where nothing is hit). Either way the G-buffer holds the
// nearest surface of meshes and SDFs with their own depth, normal, material, velocity (and albedo,
// aux when the frame has them).
//
// Settings (scene::TraceSettings; --quality low|medium|high|reference presets, each overridable in
// the scene's render block):
//   maxSteps        step limit per ray; an object's own maxSteps raises it for rays crossing it
//   hitEpsilon      hit when d < hitEpsilon * footprint(t), footprint(t) = the size of one pixel at
//                   distance t (2 t / (height * proj[1][1])): coarse where a pixel is coarse
//   normalEpsilon   the gradient's central-difference step, in the same footprints (at least 1e-5
//                   of the point's distance from the origin, for float precision)
//   overRelaxation  Keinert's omega; a step whose unbounding spheres do not overlap the previous
//                   one is taken back (safe fallback) and omega drops to 1 for the rest of the ray
//   fieldSafety     times the trilinear interpolation bound subtracted from field distances: 1
//                   never steps through the baked surface, 0 trusts the interpolated value
//   refineSteps     the hit decision: at a candidate (raw distance below hitEpsilon) the first
//                   root along the ray of each object that could be crossed first is searched
//                   (secant steps, regula falsi on a bracket; sdf_march.glsl RootSearch) with at
//                   most this many evaluations per object (a baked field's search walks its cells
//                   for the exact root of its interpolant, bounded by the step limit only); the
//                   earliest root is the hit, none is a near miss. 0: every candidate is a hit
//                   where it is (no refinement)
//
// Acceleration (scene::AccelerationSettings; each toggle changes speed only: the hit decision does
// not depend on where the march's samples land, so the picture stays within the parity rule of the
// unaccelerated trace: tests/renderer/sdf_accel_parity_test.cpp):
//   culling         the pixel's tile list (SdfCullLists::primary on the blackboard, every traced
//                   object without it) narrowed to the boxes the ray crosses; off: every traced
//                   object at every step (mTec's "no optimization"; the march interval, from the
//                   first box entry, is the same either way)
//   worldCache      (SdfWorldCacheView) plain safe steps of the cached world distance far from
//                   surfaces (above two voxels and two hit epsilons), no object evaluated
//   idField         near surfaces only the object the id field names for the point's cell
//   prepass         the coarse-to-fine cone prepass (issue 13 item 6): the compute pass
//                   "sdf_cone_prepass" (sdf_cone_prepass.comp, one invocation per 8x8 tile)
//                   marches one conservative cone around each tile's rays over its tile list and
//                   writes where it touched a surface (8 bytes per tile: start, evaluations); every
//                   ray of the tile starts no nearer. Full-screen tracing only (box tracing starts
//                   each fragment at its box)
#pragma once

#include "engine/scene/scene.h"
#include "renderer/features/frame_context.h"
#include "renderer/features/sdf_scene.h"

namespace penumbra::render {

struct SdfTraceDesc {
    scene::TraceSettings settings;
    bool raster = false;                // the mesh pass wrote the G-buffer first (bounded trace)
    float nearPlane = 0.1f;             // linear depth where rays start
    float farPlane = 1000.0f;           // linear depth where rays end when no mesh is nearer
    float footprint = 0.0f;             // pixel size per unit distance: 2 / (height * proj[1][1])
    scene::AccelerationSettings accel;  // culling, world cache, id field, cone prepass
    bool countEvaluations = false;      // gbuffer.aux y = object evaluations instead of steps
};

// Adds the pass. Reads SceneBuffers (view; materials when the frame has albedo), SdfSceneBuffers
// and, when present and enabled, SdfCullLists::primary and SdfWorldCacheView; reads and writes the
// GBuffer as storage images. Returns whether the pass reads the objects as a uniform block (the
// SDF_OBJECTS_UBO variants: at most kSdfObjectsUniformCapacity objects, sdfObjectsUniformBytes).
bool addSdfTrace(FrameContext& fc, const SdfTraceDesc& desc);

// The ALBEDO x AUX x SDF_FIELDS x SHAPE_PRIMITIVES variant of a trace program (sdf_box_trace;
// sdf_trace adds WORLD_CACHE: each has its own generated Variant enum with these names) for the
// frame's G-buffer, field atlas and shape programs (SdfSceneBuffers::shapePrimitives).
template <class V>
V traceVariant(const GBuffer& gbuffer, const SdfSceneBuffers& sdf) {
    static constexpr V kVariants[16] = {V::Default,
                                        V::Albedo,
                                        V::Aux,
                                        V::AlbedoAux,
                                        V::SdfFields,
                                        V::AlbedoSdfFields,
                                        V::AuxSdfFields,
                                        V::AlbedoAuxSdfFields,
                                        V::ShapePrimitives,
                                        V::AlbedoShapePrimitives,
                                        V::AuxShapePrimitives,
                                        V::AlbedoAuxShapePrimitives,
                                        V::SdfFieldsShapePrimitives,
                                        V::AlbedoSdfFieldsShapePrimitives,
                                        V::AuxSdfFieldsShapePrimitives,
                                        V::AlbedoAuxSdfFieldsShapePrimitives};
    return kVariants[(gbuffer.albedo.isValid() ? 1 : 0) | (gbuffer.aux.isValid() ? 2 : 0) |
                     (sdf.atlas.isValid() ? 4 : 0) | (sdf.shapePrimitives ? 8 : 0)];
}

}  // namespace penumbra::render
