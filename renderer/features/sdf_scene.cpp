#include "renderer/features/sdf_scene.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <utility>

#include <glm/mat3x3.hpp>

#include <shaders/sdf_object_scatter.h>
#include <shaders/sdf_trace.h>

#include "engine/core/log.h"
#include "renderer/features/scene_upload.h"
#include "renderer/features/sdf_atlas.h"

namespace penumbra::render {
namespace {

namespace program = shaders::sdf_trace;
static_assert(sizeof(GpuSdfObject) == sizeof(program::SdfObject));
static_assert(offsetof(GpuSdfObject, boundsMin) == offsetof(program::SdfObject, boundsMin));
static_assert(offsetof(GpuSdfObject, info) == offsetof(program::SdfObject, info));
static_assert(offsetof(GpuSdfObject, params) == offsetof(program::SdfObject, params));
static_assert(sizeof(sdf::ShapeInstruction) == sizeof(program::ShapeInstruction));
static_assert(sizeof(GpuSdfField) == sizeof(program::SdfField));
static_assert(offsetof(GpuSdfField, boundsMin) == offsetof(program::SdfField, boundsMin));

constexpr uint64_t kObjectBytes = sizeof(GpuSdfObject);
constexpr uint32_t kRecordWords = kObjectBytes / sizeof(glm::uvec4);  // sdf_object_scatter.comp
constexpr uint32_t kEntryWords = kRecordWords + 1;                    // index header + record
constexpr uint32_t kMaxGroups = 65535;  // per dispatch (the guaranteed workgroup count limit)
constexpr uint32_t kEntriesPerGroup = 64 / kRecordWords;  // local_size_x 64

// The smallest persistent buffers: a few objects more never reallocate.
uint64_t minimumBytes(uint64_t element) { return element == kObjectBytes ? 64 * element : 16 * element; }

bool sameBytes(const std::vector<uint8_t>& shadow, const void* data, uint64_t size) {
    return shadow.size() == size && (size == 0 || std::memcmp(shadow.data(), data, size) == 0);
}

void assignBytes(std::vector<uint8_t>& shadow, const void* data, uint64_t size) {
    const auto* bytes = static_cast<const uint8_t*>(data);
    shadow.assign(bytes, bytes + size);
}

}  // namespace

float smallestSingularValue(const glm::mat3& m) {
    // Eigenvalues of the symmetric A = m^T m by cyclic Jacobi rotations (double precision).
    double a[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            double s = 0.0;
            for (int k = 0; k < 3; ++k) s += double(m[i][k]) * double(m[j][k]);  // column i . column j
            a[i][j] = s;
        }
    for (int sweep = 0; sweep < 50; ++sweep) {
        const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if (!(off > 1e-30 * (a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2]))) break;
        for (int p = 0; p < 2; ++p)
            for (int q = p + 1; q < 3; ++q) {
                if (a[p][q] == 0.0) continue;
                const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                const double t =
                    (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
                const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < 3; ++k) {  // A <- A J (columns p, q)
                    const double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; ++k) {  // A <- J^T A (rows p, q)
                    const double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
            }
    }
    const double lambda = std::min({a[0][0], a[1][1], a[2][2]});
    if (!(lambda > 0.0) || !std::isfinite(lambda)) return 0.0f;
    // Rounded down by a few float ulps: exact uniform scales stay exact to float precision.
    return float(std::sqrt(lambda) * (1.0 - 4e-7));
}

bool sdfShapePrimitivesOnly(const SdfSceneData& data) {
    bool any = false;
    for (const GpuSdfObject& object : data.objects) {
        const glm::uvec4& info = object.info;
        if (info.x != uint32_t(SdfKind::Shapes)) continue;
        // The header (op 0, i = version, instruction count, stacks), then the instructions.
        const uint64_t first = info.y;
        if (first + 1 >= data.records.size() || data.records[first].i[1] != 1) return false;
        const uint32_t op = data.records[first + 1].op;
        if (op < uint32_t(sdf::ShapeOp::Sphere) || op > uint32_t(sdf::ShapeOp::Plane)) return false;
        any = true;
    }
    return any;
}

uint64_t sdfObjectsUniformBytes(const rhi::DeviceInfo& device, uint32_t objectCount) {
    const uint64_t block = uint64_t(kSdfObjectsUniformCapacity) * kObjectBytes;
    const bool fits = objectCount > 0 && objectCount <= kSdfObjectsUniformCapacity &&
                      device.limits.maxUniformBufferRange >= block;
    return fits ? uint64_t(objectCount) * kObjectBytes : 0;
}

void addSdfSceneUpload(FrameContext& fc, const SdfSceneData& data) {
    SdfSceneBuffers& out = fc.board.add<SdfSceneBuffers>();
    rhi::TextureHandle atlas = data.atlas;
    fg::TextureRef atlasRef;
    if (data.hasFields()) atlasRef = fc.graph.importTexture("sdf.atlas", atlas, rhi::Access::ShaderSampled);
    fc.graph.addPass<SdfSceneBuffers>(
        "sdf_upload", fg::PassKind::Transfer,
        [&](fg::PassBuilder& b, SdfSceneBuffers& d) {
            auto buffer = [&](const char* name, uint64_t size) {
                return uploadBuffer(b, name, size, d.bytes);
            };
            d.objects = buffer("sdf.objects", arrayBytes(data.objects));
            d.records = buffer("sdf.records", arrayBytes(data.records));
            if (data.hasFields()) {
                d.fields = buffer("sdf.fields", std::max<uint64_t>(data.fieldBytes, 16));
                d.atlas = atlasRef;
            }
            d.objectCount = uint32_t(data.objects.size());
            d.tracedCount = std::min(data.tracedCount, d.objectCount);
            d.shapePrimitives = sdfShapePrimitivesOnly(data);
            out = d;
        },
        [&data](const SdfSceneBuffers& d, fg::PassContext& ctx) {
            updateArray(ctx.cmd, ctx.buffer(d.objects), data.objects);
            updateArray(ctx.cmd, ctx.buffer(d.records), data.records);
            if (data.hasFields() && data.fieldBytes > 0)
                updateChunked(ctx.cmd, ctx.buffer(d.fields), data.fields, data.fieldBytes);
        });
}

// ---- the persistent store ------------------------------------------------------------------------

SdfSceneStore::~SdfSceneStore() {
    for (Buffer* b : {&m_objects, &m_records, &m_fields})
        if (b->handle) m_device.destroy(b->handle);
}

void SdfSceneStore::destroy(fg::FrameGraph& graph, Buffer& b) {
    if (b.handle) {
        graph.forgetPersistent(b.handle);
        m_device.destroy(b.handle);  // deferred until frames in flight are done with it
    }
    b = {};
}

void SdfSceneStore::release(fg::FrameGraph& graph) {
    for (Buffer* b : {&m_objects, &m_records, &m_fields}) destroy(graph, *b);
}

bool SdfSceneStore::reserve(fg::FrameGraph& graph, Buffer& b, uint64_t bytes, const char* name) {
    const uint64_t element = &b == &m_objects   ? kObjectBytes
                             : &b == &m_records ? sizeof(sdf::ShapeInstruction)
                                                : 16;
    const uint64_t minimum = minimumBytes(element);
    const bool fits = bytes <= b.capacity;
    const bool tooLarge = b.capacity > minimum && b.capacity > 4 * bytes;
    if (b.handle && fits && !tooLarge) return false;
    // New: half again the need (objects spawned later fit without a rewrite). Growth: at least
    // double, and half again the need. Shrink: twice the need (hysteresis against a count that
    // oscillates around a threshold).
    const uint64_t headroom = bytes + bytes / 2;
    uint64_t capacity = !b.handle ? headroom : !fits ? std::max(headroom, 2 * b.capacity) : 2 * bytes;
    capacity = (std::max(capacity, minimum) + element - 1) / element * element;
    // The headroom never takes a buffer past what one binding may cover (maxStorageBufferRange):
    // the object count is bounded by the device's limit only, not by the growth policy.
    const uint64_t limit = m_device.info().limits.maxStorageBufferRange / element * element;
    if (limit > 0) capacity = std::max(bytes, std::min(capacity, limit));
    destroy(graph, b);
    rhi::BufferDesc desc;
    desc.size = capacity;
    desc.usage = rhi::BufferUsage::Storage | rhi::BufferUsage::CopyDst | rhi::BufferUsage::CopySrc;
    if (&b == &m_objects) desc.usage = desc.usage | rhi::BufferUsage::Uniform;  // SDF_OBJECTS_UBO
    desc.debugName = name;
    b.handle = m_device.createBuffer(desc);
    if (b.handle) b.capacity = capacity;
    return true;
}

namespace {

// The delta of this frame: object indices whose record differs from the uploaded copy.
void findChangedObjects(const std::vector<GpuSdfObject>& objects, const std::vector<uint8_t>& shadow,
                        std::vector<uint32_t>& changed) {
    changed.clear();
    for (size_t i = 0; i < objects.size(); ++i) {
        const uint64_t at = i * kObjectBytes;
        if (at + kObjectBytes > shadow.size() ||
            std::memcmp(shadow.data() + at, &objects[i], kObjectBytes) != 0)
            changed.push_back(uint32_t(i));
    }
}

void addObjectScatter(FrameContext& fc, fg::BufferRef delta, fg::BufferRef objects, uint32_t entries) {
    namespace scatter = shaders::sdf_object_scatter;
    struct Data {
        fg::BufferRef delta, objects;
    };
    const rhi::ShaderDesc& cs = scatter::compute();
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    fc.graph.addPass<Data>(
        "sdf_object_scatter", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.delta = b.read(delta, rhi::Access::ShaderRead);
            d.objects = b.write(objects, rhi::Access::ShaderWrite);
        },
        [&cache = fc.cache, &cs, pipeline, entries](const Data& d, fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("SdfObjectDeltas", ctx.buffer(d.delta)).set("SdfObjectWords", ctx.buffer(d.objects));
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            // Dispatches of at most kMaxGroups workgroups: any number of changed objects.
            const uint32_t perDispatch = kMaxGroups * kEntriesPerGroup;
            for (uint32_t first = 0; first < entries; first += perDispatch) {
                const uint32_t count = std::min(perDispatch, entries - first);
                const scatter::PushConstants push{glm::uvec4(first, entries, 0u, 0u)};
                ctx.cmd.pushConstants(&push, sizeof(push));
                ctx.cmd.dispatch((count + kEntriesPerGroup - 1) / kEntriesPerGroup, 1, 1);
            }
        });
}

}  // namespace

bool SdfSceneStore::plan(fg::FrameGraph& graph, const SdfSceneData& data) {
    static const sdf::ShapeInstruction kZeroRecord{};  // bound when no object uses a shape program
    const uint32_t n = uint32_t(data.objects.size());
    m_recordData = data.records.empty() ? &kZeroRecord : data.records.data();
    m_recordBytes = arrayBytes(data.records);
    const uint64_t fieldBytes = data.hasFields() ? std::max<uint64_t>(data.fieldBytes, 16) : 0;
    const bool newObjects = reserve(graph, m_objects, arrayBytes(data.objects), "sdf.objects");
    const bool newRecords = reserve(graph, m_records, m_recordBytes, "sdf.records");
    const bool newFields = data.hasFields() && reserve(graph, m_fields, fieldBytes, "sdf.fields");
    m_stats = {};
    const uint64_t limit = m_device.info().limits.maxStorageBufferRange;
    if (limit > 0 && arrayBytes(data.objects) > limit && !std::exchange(m_warnedLimit, true))
        log::warn(
            "sdf_upload: {} SDF objects need {} bytes, more than the device's storage buffer range ({} "
            "bytes, {} objects): the passes cannot bind them",
            n, arrayBytes(data.objects), limit, limit / kObjectBytes);
    if (!m_objects.handle || !m_records.handle || (data.hasFields() && !m_fields.handle)) return false;

    findChangedObjects(data.objects, m_objects.shadow, m_changed);  // a new buffer has no shadow
    const uint32_t changed = uint32_t(m_changed.size());
    m_fullObjects = n > 0 && (newObjects || 2 * uint64_t(changed) > n);
    m_delta.clear();
    if (!m_fullObjects && changed > 0) {
        m_delta.resize(size_t(changed) * kEntryWords);
        for (uint32_t e = 0; e < changed; ++e) {
            glm::uvec4* entry = m_delta.data() + size_t(e) * kEntryWords;
            entry[0] = glm::uvec4(m_changed[e], 0u, 0u, 0u);
            std::memcpy(static_cast<void*>(entry + 1), &data.objects[m_changed[e]], kObjectBytes);
        }
    }
    m_writeRecords = newRecords || !sameBytes(m_records.shadow, m_recordData, m_recordBytes);
    m_writeFields = data.hasFields() && data.fieldBytes > 0 &&
                    (newFields || !sameBytes(m_fields.shadow, data.fields, data.fieldBytes));

    m_stats.fullUpload = m_fullObjects;
    m_stats.objectsUploaded = m_fullObjects ? n : changed;
    m_stats.recordsUploaded = m_writeRecords;
    m_stats.fieldsUploaded = m_writeFields;
    m_stats.deltaBytes = m_delta.size() * sizeof(glm::uvec4);
    m_stats.uploadBytes = (m_fullObjects ? uint64_t(n) * kObjectBytes : m_stats.deltaBytes) +
                          (m_writeRecords ? m_recordBytes : 0) + (m_writeFields ? data.fieldBytes : 0);
    m_stats.objectBufferBytes = m_objects.capacity;
    m_stats.persistentBytes = m_objects.capacity + m_records.capacity + m_fields.capacity;
    return true;
}

void SdfSceneStore::addPasses(FrameContext& fc, const SdfSceneData& data) {
    SdfSceneBuffers& out = fc.board.add<SdfSceneBuffers>();
    out.objects = fc.graph.importPersistent("sdf.objects", m_objects.handle, rhi::Access::ShaderRead);
    out.records = fc.graph.importPersistent("sdf.records", m_records.handle, rhi::Access::ShaderRead);
    if (data.hasFields()) {
        out.fields = fc.graph.importPersistent("sdf.fields", m_fields.handle, rhi::Access::ShaderRead);
        out.atlas = fc.graph.importTexture("sdf.atlas", data.atlas, rhi::Access::ShaderSampled);
    }
    out.objectCount = uint32_t(data.objects.size());
    out.tracedCount = std::min(data.tracedCount, out.objectCount);
    out.shapePrimitives = sdfShapePrimitivesOnly(data);
    out.bytes = m_stats.persistentBytes + m_stats.deltaBytes;
    struct Data {
        fg::BufferRef objects, delta, records, fields;
    };
    const Data& up = fc.graph.addPass<Data>(
        "sdf_upload", fg::PassKind::Transfer,
        [&](fg::PassBuilder& b, Data& d) {
            uint64_t unused = 0;
            if (m_fullObjects) d.objects = b.write(out.objects, rhi::Access::CopyDst);
            if (!m_delta.empty()) d.delta = uploadBuffer(b, "sdf.object_delta", m_stats.deltaBytes, unused);
            if (m_writeRecords) d.records = b.write(out.records, rhi::Access::CopyDst);
            if (m_writeFields) d.fields = b.write(out.fields, rhi::Access::CopyDst);
            // A static frame writes nothing; the pass stays (empty) so every SDF frame has it.
            if (!m_fullObjects && m_delta.empty() && !m_writeRecords && !m_writeFields) b.sideEffect();
        },
        [this, &data](const Data& d, fg::PassContext& ctx) {
            // The shadow copies follow what this command list writes.
            std::vector<uint8_t>& shadow = m_objects.shadow;
            shadow.resize(data.objects.size() * kObjectBytes);
            if (m_fullObjects) {
                updateChunked(ctx.cmd, ctx.buffer(d.objects), data.objects.data(), shadow.size());
                assignBytes(shadow, data.objects.data(), shadow.size());
            } else if (!m_delta.empty()) {
                updateChunked(ctx.cmd, ctx.buffer(d.delta), m_delta.data(), m_stats.deltaBytes);
                for (uint32_t i : m_changed)
                    std::memcpy(shadow.data() + i * kObjectBytes, &data.objects[i], kObjectBytes);
            }
            if (m_writeRecords) {
                updateChunked(ctx.cmd, ctx.buffer(d.records), m_recordData, m_recordBytes);
                assignBytes(m_records.shadow, m_recordData, m_recordBytes);
            }
            if (m_writeFields) {
                updateChunked(ctx.cmd, ctx.buffer(d.fields), data.fields, data.fieldBytes);
                assignBytes(m_fields.shadow, data.fields, data.fieldBytes);
            }
        });
    if (!m_delta.empty()) addObjectScatter(fc, up.delta, out.objects, uint32_t(m_changed.size()));
}

void addSdfSceneUpload(FrameContext& fc, const SdfSceneData& data, SdfSceneStore& store) {
    if (!store.plan(fc.graph, data)) {
        log::warn("sdf_upload: creating a persistent SDF scene buffer failed; transient buffers this frame");
        store.release(fc.graph);
        addSdfSceneUpload(fc, data);
        return;
    }
    store.addPasses(fc, data);
}

rhi::SamplerHandle sdfAtlasSampler(GpuCache& cache, const SdfSceneBuffers& sdf) {
    if (!sdf.atlas.isValid()) return {};
    rhi::SamplerDesc linear;  // trilinear, clamped (slots are sampled inside)
    linear.debugName = "sdf.atlas";
    return cache.sampler(linear);
}

void readSdfScene(fg::PassBuilder& b, const SdfSceneBuffers& sdf, bool objectsUniform) {
    b.read(sdf.objects, rhi::Access::ShaderRead);
    if (objectsUniform) b.read(sdf.objects, rhi::Access::UniformRead);
    b.read(sdf.records, rhi::Access::ShaderRead);
    if (sdf.atlas.isValid()) {
        b.read(sdf.fields, rhi::Access::ShaderRead);
        b.read(sdf.atlas, rhi::Access::ShaderSampled);
    }
}

void setSdfScene(ShaderParams& params, const fg::PassContext& ctx, const SdfSceneBuffers& sdf,
                 rhi::SamplerHandle atlasSampler, uint64_t objectsUniformBytes) {
    if (objectsUniformBytes > 0)
        params.set("SdfObjectsUniform", ctx.buffer(sdf.objects), 0, objectsUniformBytes);
    else
        params.set("SdfObjects", ctx.buffer(sdf.objects));
    params.set("ShapeRecords", ctx.buffer(sdf.records));
    if (sdf.atlas.isValid())
        params.set("SdfFields", ctx.buffer(sdf.fields)).set("sdfAtlas", ctx.texture(sdf.atlas), atlasSampler);
}

}  // namespace penumbra::render
