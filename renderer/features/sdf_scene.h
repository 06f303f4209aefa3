// Feature "sdf_scene": the frame's SDF objects on the GPU (renderer/shaders/sdf_scene.glsl is the
// shader side). The pass "sdf_upload" (Transfer) writes the per-object array and the shape-program
// records of this frame into frame-graph buffers and publishes them, with the field atlas of
// renderer/features/sdf_atlas.h (when a field is in the frame), as SdfSceneBuffers.
//
// Per object (GpuSdfObject, 256 bytes): world <-> local matrices, the previous model (velocity),
// the local bounds of its solid, sigma_min (the smallest singular value of the model's 3x3 part:
// the conservative world / local distance ratio), kind, record or atlas slot, material and entity
// index, and its step limit. Objects sharing a shape program share its records (instancing): the
// records array holds each program once.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>

#include "engine/sdf/shape_program.h"
#include "renderer/core/shader_params.h"
#include "renderer/features/frame_context.h"

namespace penumbra::render {

enum class SdfKind : uint32_t { Shapes = 0, Field = 1 };

struct GpuSdfObject {
    glm::mat4 worldToLocal;
    glm::mat4 model;
    glm::mat4 prevModel;
    glm::vec4 boundsMin;  // xyz local bounds (+-1e30 when unbounded), w sigma_min of model
    glm::vec4 boundsMax;
    glm::uvec4 info;    // x kind, y first record / atlas slot, z material index, w entity index
    glm::uvec4 params;  // x step limit (0: the pass setting), y flags (kSdfObject*)
};
inline constexpr uint32_t kSdfObjectCastsShadows = 1u;  // params.y: takes part in shadows and AO
static_assert(sizeof(GpuSdfObject) == 256);

// Largest magnitude stored for unbounded bounds (the shaders' slab test stays finite).
inline constexpr float kSdfUnbounded = 1.0e30f;

// This frame's SDF data; `atlas` and `fields` only when a field object is in the frame.
struct SdfSceneData {
    std::vector<GpuSdfObject> objects;  // traced objects first, then occluders
    uint32_t tracedCount = 0;
    std::vector<sdf::ShapeInstruction> records;  // every program used, each header + instructions
    const void* fields = nullptr;                // GpuSdfField[fieldCount] (the atlas' slot table)
    uint64_t fieldBytes = 0;
    rhi::TextureHandle atlas;
    bool hasFields() const { return atlas.value != 0; }
};

struct SdfSceneBuffers {
    fg::BufferRef objects;     // GpuSdfObject[]
    fg::BufferRef records;     // sdf::ShapeInstruction[] (>= 1 record)
    fg::BufferRef fields;      // GpuSdfField[] (field frames only)
    fg::TextureRef atlas;      // R16F 3D atlas (field frames only)
    uint32_t objectCount = 0;  // every object: the effects (shadows, AO, ...) see them all
    uint32_t tracedCount = 0;  // objects [0, tracedCount) are drawn by the trace; the rest are
                               // occluders only (mesh occlusion fields, --mesh-sdf occlusion)
    uint64_t bytes = 0;        // buffer bytes
};

// The smallest singular value of m (0 for a singular matrix), computed in double with Jacobi
// rotations and rounded down: the world distance is at least this times the local distance.
float smallestSingularValue(const glm::mat3& m);

// Adds the "sdf_upload" pass and publishes SdfSceneBuffers. `data` must stay alive and unchanged
// until the graph has executed.
void addSdfSceneUpload(FrameContext& fc, const SdfSceneData& data);

// What every pass that evaluates the SDF scene (trace, effects, field slice) declares and binds.
// The atlas' trilinear, clamped sampler; invalid when the frame has no field (no atlas).
rhi::SamplerHandle sdfAtlasSampler(GpuCache& cache, const SdfSceneBuffers& sdf);
// Declares objects and records (and, in field frames, the field table and atlas) as shader reads.
void readSdfScene(fg::PassBuilder& b, const SdfSceneBuffers& sdf);
// Sets SdfObjects and ShapeRecords (and, in field frames, SdfFields and sdfAtlas with atlasSampler).
void setSdfScene(ShaderParams& params, const fg::PassContext& ctx, const SdfSceneBuffers& sdf,
                 rhi::SamplerHandle atlasSampler);

}  // namespace penumbra::render
