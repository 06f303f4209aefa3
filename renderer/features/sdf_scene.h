// Feature "sdf_scene": the frame's SDF objects on the GPU (renderer/shaders/sdf_scene.glsl is the
// shader side). The pass "sdf_upload" (Transfer) brings the per-object array, the shape-program
// records and the field table of this frame to the GPU and publishes them, with the field atlas of
// renderer/features/sdf_atlas.h (when a field is in the frame), as SdfSceneBuffers.
//
// With an SdfSceneStore (the scene renderer's) the three arrays live in persistent buffers that
// are updated from deltas: the CPU compares this frame's objects with the copy it last uploaded,
// index by index, and only the changed ones travel, in a small transient delta buffer (uint index
// + the whole 256-byte record each: a moving object changes model, worldToLocal and prevModel,
// 192 of the 256 bytes, so per-field deltas would save little and cost a second layout), which the
// compute pass "sdf_object_scatter" (renderer/shaders/sdf_object_scatter.comp) writes into place.
// A static scene uploads nothing after its first frame. The whole array is written with one plain
// upload instead when the buffer is new or was resized, or when more than half of the objects
// changed (a delta entry is 272 bytes against 256 for the record in a full upload: past half the
// delta saves under half of the bytes and adds a dispatch and a barrier; on the software devices
// the scatter dispatch costs a fixed ~0.25 ms and 2 MB of plain upload ~0.1 ms, so there the bytes
// sent, not GPU time, are what a delta saves: tests/renderer/sdf_instancing_test.cpp
// DeltaAndFullUploadCost prints both). Records and the field table are compared as a whole and
// rewritten when they differ. Without a store (the empty upload of debug_field_slice) everything
// goes into transient buffers every frame.
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

// The objects of a frame with at most this many fit the SDF_OBJECTS_UBO variants (sdf_trace,
// sdf_shadow, sdf_ao, the world-cache update), which read them as a uniform block of this size
// (64 KiB; sdf_scene.glsl) instead of a storage buffer: a CPU device loads a storage buffer lane by
// lane in a loop, a uniform block with one gather (or one scalar load when every lane reads the
// same object).
inline constexpr uint32_t kSdfObjectsUniformCapacity = 256;

// The bytes the frame's objects take as a uniform block (SDF_OBJECTS_UBO), or 0 when they are read
// as a storage buffer: more than kSdfObjectsUniformCapacity of them, none, or a device that cannot
// bind the whole block as one uniform buffer.
uint64_t sdfObjectsUniformBytes(const rhi::DeviceInfo& device, uint32_t objectCount);

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
    fg::BufferRef objects;         // GpuSdfObject[]
    fg::BufferRef records;         // sdf::ShapeInstruction[] (>= 1 record)
    fg::BufferRef fields;          // GpuSdfField[] (field frames only)
    fg::TextureRef atlas;          // R16F 3D atlas (field frames only)
    uint32_t objectCount = 0;      // every object: the effects (shadows, AO, ...) see them all
    uint32_t tracedCount = 0;      // objects [0, tracedCount) are drawn by the trace; the rest are
                                   // occluders only (mesh occlusion fields, --mesh-sdf occlusion)
    bool shapePrimitives = false;  // sdfShapePrimitivesOnly(): no program interpreter needed
    uint64_t bytes = 0;            // buffer bytes
};

// Whether every object of kind Shapes has a program of one shape instruction (a box, a sphere,
// ...: the shape's own transform is the object's model): the SHAPE_PRIMITIVES variants of every
// pass that evaluates the objects (trace, effects, cone prepass, world-cache update) then evaluate
// that shape directly instead of running the program interpreter (on a CPU device every branch of
// the interpreter's loop runs for each instruction).
// False when a program has more instructions, and for a frame without shape objects.
bool sdfShapePrimitivesOnly(const SdfSceneData& data);

// The SDF_FIELDS x SHAPE_PRIMITIVES variant of a pass whose shader has exactly those variants
// (its generated Variant enum has these names) for the frame's field atlas and shape programs.
template <class V>
V sdfSceneVariant(const SdfSceneBuffers& sdf) {
    static constexpr V kVariants[4] = {V::Default, V::SdfFields, V::ShapePrimitives,
                                       V::SdfFieldsShapePrimitives};
    return kVariants[(sdf.atlas.isValid() ? 1 : 0) | (sdf.shapePrimitives ? 2 : 0)];
}
// The same with SDF_OBJECTS_UBO (a shader that also has those variants, sdfObjectsUniformBytes).
template <class V>
V sdfSceneVariant(const SdfSceneBuffers& sdf, bool objectsUniform) {
    static constexpr V kVariants[8] = {V::Default,
                                       V::SdfFields,
                                       V::ShapePrimitives,
                                       V::SdfFieldsShapePrimitives,
                                       V::SdfObjectsUbo,
                                       V::SdfFieldsSdfObjectsUbo,
                                       V::ShapePrimitivesSdfObjectsUbo,
                                       V::SdfFieldsShapePrimitivesSdfObjectsUbo};
    return kVariants[(sdf.atlas.isValid() ? 1 : 0) | (sdf.shapePrimitives ? 2 : 0) |
                     (objectsUniform ? 4 : 0)];
}

// The smallest singular value of m (0 for a singular matrix), computed in double with Jacobi
// rotations and rounded down: the world distance is at least this times the local distance.
float smallestSingularValue(const glm::mat3& m);

// The persistent GPU copy of the SDF scene and the CPU copy of what was last uploaded into it.
// Capacities start at 1.5 times the need, grow geometrically (at least double, at least 1.5 times
// the need) when a frame needs more and shrink (to twice the need) when more than four times
// larger than needed; a new or resized buffer is written in full.
// The CPU copy is updated when the upload pass executes, so a frame whose graph never ran leaves
// the next frame comparing against what really is on the GPU.
class SdfSceneStore {
public:
    explicit SdfSceneStore(rhi::Device& device) : m_device(device) {}
    ~SdfSceneStore();
    SdfSceneStore(const SdfSceneStore&) = delete;
    SdfSceneStore& operator=(const SdfSceneStore&) = delete;

    // What the last addSdfSceneUpload with this store sends and holds.
    struct Stats {
        uint32_t objectsUploaded = 0;    // records written into the object buffer (delta or full)
        bool fullUpload = false;         // the whole object array was rewritten
        bool recordsUploaded = false;    // shape records rewritten
        bool fieldsUploaded = false;     // field table rewritten
        uint64_t deltaBytes = 0;         // the transient delta buffer (0: no scatter this frame)
        uint64_t uploadBytes = 0;        // every byte sent: objects (delta or full) + records + fields
        uint64_t objectBufferBytes = 0;  // the persistent object buffer (capacity)
        uint64_t persistentBytes = 0;    // objects + records + field table buffers
    };
    const Stats& stats() const { return m_stats; }
    rhi::BufferHandle objectBuffer() const { return m_objects.handle; }  // GpuSdfObject[capacity]
    uint32_t objectCapacity() const { return uint32_t(m_objects.capacity / sizeof(GpuSdfObject)); }
    // Destroys the buffers (forgotten by `graph`): the next frame uploads everything.
    void release(fg::FrameGraph& graph);

private:
    friend void addSdfSceneUpload(FrameContext&, const SdfSceneData&, SdfSceneStore&);
    struct Buffer {
        rhi::BufferHandle handle;
        uint64_t capacity = 0;        // bytes
        std::vector<uint8_t> shadow;  // what the GPU copy holds (bytes [0, shadow.size()))
    };
    // Compares `data` with the uploaded copies and fills this frame's plan and stats; false when a
    // buffer could not be created.
    bool plan(fg::FrameGraph& graph, const SdfSceneData& data);
    // "sdf_upload" (and "sdf_object_scatter") for the plan; publishes SdfSceneBuffers.
    void addPasses(FrameContext& fc, const SdfSceneData& data);
    // Makes `b` hold `bytes` (resizing as described above); true when it was (re)created.
    bool reserve(fg::FrameGraph& graph, Buffer& b, uint64_t bytes, const char* name);
    void destroy(fg::FrameGraph& graph, Buffer& b);

    rhi::Device& m_device;
    Buffer m_objects, m_records, m_fields;
    // This frame's plan, read by the passes' execute callbacks.
    std::vector<uint32_t> m_changed;  // object indices to scatter (ascending)
    std::vector<glm::uvec4> m_delta;  // 17 uvec4 per changed object (index, record)
    bool m_fullObjects = false, m_writeRecords = false, m_writeFields = false;
    const void* m_recordData = nullptr;  // the frame's records (or one zero record)
    uint64_t m_recordBytes = 0;
    bool m_warnedLimit = false;  // a frame had more objects than one binding covers (warned once)
    Stats m_stats;
};

// Adds the "sdf_upload" pass and publishes SdfSceneBuffers. `data` must stay alive and unchanged
// until the graph has executed. Without a store: transient buffers written in full.
void addSdfSceneUpload(FrameContext& fc, const SdfSceneData& data);
// With a store: the persistent buffers, updated from deltas ("sdf_object_scatter" when only some
// objects changed); `store` must outlive the graph's execution.
void addSdfSceneUpload(FrameContext& fc, const SdfSceneData& data, SdfSceneStore& store);

// What every pass that evaluates the SDF scene (trace, effects, field slice) declares and binds.
// The atlas' trilinear, clamped sampler; invalid when the frame has no field (no atlas).
rhi::SamplerHandle sdfAtlasSampler(GpuCache& cache, const SdfSceneBuffers& sdf);
// Declares objects and records (and, in field frames, the field table and atlas) as shader reads;
// objectsUniform: the objects as a uniform block too (SDF_OBJECTS_UBO).
void readSdfScene(fg::PassBuilder& b, const SdfSceneBuffers& sdf, bool objectsUniform = false);
// Sets SdfObjects and ShapeRecords (and, in field frames, SdfFields and sdfAtlas with atlasSampler).
// objectsUniformBytes > 0 (sdfObjectsUniformBytes): the program reads the objects as the uniform
// block SdfObjectsUniform (SDF_OBJECTS_UBO), bound over that many bytes (readSdfScene's
// objectsUniform declares them UniformRead).
void setSdfScene(ShaderParams& params, const fg::PassContext& ctx, const SdfSceneBuffers& sdf,
                 rhi::SamplerHandle atlasSampler, uint64_t objectsUniformBytes = 0);

}  // namespace penumbra::render
