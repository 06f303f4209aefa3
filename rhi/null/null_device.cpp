// Null backend: records commands, executes transfers on CPU copies, runs no shaders.
#include "rhi/null/null_device.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rhi/common/backend_factories.h"
#include "rhi/common/deferred_release.h"
#include "rhi/common/handle_pool.h"
#include "rhi/common/resource_kinds.h"
#include "rhi/common/subresource_states.h"
#include "rhi/validation/resource_util.h"
#include "rhi/validation/validation_device.h"

namespace rhi::null {
namespace {

using detail::resutil::rangeInside;

struct NullBuffer {
    BufferDesc desc;
    std::vector<uint8_t> bytes;
};

struct NullTexture {
    TextureDesc desc;
    std::vector<std::vector<uint8_t>> subresources;  // [mip * layers + layer]

    size_t index(TextureSubresource sub) const {
        return size_t(sub.mip) * detail::resutil::arrayLayers(desc) + sub.layer;
    }
    // Bytes of one row and one slice of a mip, and where a resolved box starts in its subresource.
    size_t rowPitch(uint32_t mip) const {
        return size_t(detail::resutil::mipExtent(desc.width, mip)) * formatInfo(desc.format).bytesPerTexel;
    }
    size_t slicePitch(uint32_t mip) const {
        return rowPitch(mip) * detail::resutil::mipExtent(desc.height, mip);
    }
    uint8_t* boxStart(const TextureRegion& b) {
        return subresources[index({b.mip, b.layer})].data() + b.z * slicePitch(b.mip) +
               b.y * rowPitch(b.mip) + size_t(b.x) * formatInfo(desc.format).bytesPerTexel;
    }
    // Copies a box of rows x slices rows of rowBytes between two pitched layouts.
    static void copyBox(const uint8_t* src, size_t srcRow, size_t srcSlice, uint8_t* dst, size_t dstRow,
                        size_t dstSlice, size_t rowBytes, uint32_t rows, uint32_t slices) {
        for (uint32_t z = 0; z < slices; ++z)
            for (uint32_t y = 0; y < rows; ++y)
                std::memmove(dst + z * dstSlice + y * dstRow, src + z * srcSlice + y * srcRow, rowBytes);
    }
    // Writes tightly packed texels into a resolved box.
    void writeBox(const TextureRegion& b, const uint8_t* packed) {
        const size_t row = size_t(b.width) * formatInfo(desc.format).bytesPerTexel;
        copyBox(packed, row, row * b.height, boxStart(b), rowPitch(b.mip), slicePitch(b.mip), row, b.height,
                b.depth);
    }
};

struct NullSampler {
    SamplerDesc desc;
};

struct NullShader {
    std::shared_ptr<const detail::resutil::OwnedReflection> reflection;
};

struct NullPipeline {
    bool compute = true;
    std::vector<std::shared_ptr<const detail::resutil::OwnedReflection>> shaders;
    ComputePipelineDesc computeDesc;
    GraphicsPipelineDesc graphicsDesc;
};

struct NullBindGroup {
    BindGroupDesc desc;
};

struct NullQueryPool {
    QueryPoolDesc desc;
    std::vector<uint64_t> values;
    std::vector<bool> written;
};

// A recorded command plus what the null device needs to execute it at submit().
struct Command {
    RecordedCommand rec;
    std::shared_ptr<NullBuffer> dst;
    std::shared_ptr<NullBuffer> src;
    std::shared_ptr<NullQueryPool> pool;
    uint64_t dstOffset = 0;
    uint64_t srcOffset = 0;
    uint64_t size = 0;
    uint32_t value = 0;
    std::vector<uint8_t> bytes;
    std::shared_ptr<NullTexture> dstTexture;
    std::shared_ptr<NullTexture> srcTexture;
    TextureRegion dstBox;
    TextureRegion srcBox;
};

class NullDevice;

class NullCommandList final : public CommandList {
public:
    NullCommandList(NullDevice& device, std::string name) : m_device(device), m_name(std::move(name)) {}

#define RHI_COMMAND_LIST_METHOD(ret, name, params, qualifiers) ret name params qualifiers override;
#include "rhi/command_list_api.inc"
#undef RHI_COMMAND_LIST_METHOD

    std::vector<Command>& commands() { return m_commands; }

private:
    Command& add(RecordedCommand::Kind kind) {
        m_commands.emplace_back();
        m_commands.back().rec.kind = kind;
        return m_commands.back();
    }

    NullDevice& m_device;
    std::string m_name;
    std::vector<Command> m_commands;
};

class NullDevice final : public Device {
public:
    explicit NullDevice(const DeviceDesc& desc) : m_log(desc.log) {
        m_info.backend = Backend::Null;
        m_info.apiVersion = "null 1.0";
        m_info.deviceName = "null";
        m_info.driverName = "null";
        m_info.driverVersion = "1.0";
        m_info.platform = "headless";
        DeviceLimits& l = m_info.limits;
        l.maxTextureSize2D = 16384;
        l.maxTextureSize3D = 2048;
        l.maxTextureArrayLayers = 2048;
        l.maxComputeWorkgroupCount = {65535, 65535, 65535};
        l.maxComputeWorkgroupSize = {1024, 1024, 64};
        l.maxComputeWorkgroupInvocations = 1024;
        l.maxStorageBufferRange = uint64_t(1) << 31;
        l.maxUniformBufferRange = 65536;
        l.maxPushConstantSize = kMaxPushConstantSize;
        l.maxBindGroups = kMaxBindGroups;
        l.maxColorTargets = kMaxColorTargets;
        l.timestampPeriodNs = 1.0;
        l.timestamps = true;
        l.conservativeDepth = false;
    }

    ~NullDevice() override {
        m_openLists.clear();
        m_deferred.releaseAll();
    }

    const DeviceInfo& info() const override { return m_info; }

    // --- creation --------------------------------------------------------------------------------
    BufferHandle createBuffer(const BufferDesc& desc, const void* initialData) override {
        if (desc.size == 0) {
            error("createBuffer: buffer '" + desc.debugName + "' has size 0");
            return {};
        }
        if (desc.size > (uint64_t(1) << 32)) {
            error("createBuffer: buffer '" + desc.debugName + "' of " + std::to_string(desc.size) +
                  " bytes is larger than the null device allows (4 GiB)");
            return {};
        }
        auto b = std::make_shared<NullBuffer>();
        b->desc = desc;
        b->bytes.assign(size_t(desc.size), 0);
        if (initialData) std::memcpy(b->bytes.data(), initialData, size_t(desc.size));
        BufferHandle h = m_buffers.insert(std::move(b));
        if (!h) error("createBuffer: too many buffers");
        return h;
    }

    TextureHandle createTexture(const TextureDesc& desc) override {
        const std::string name = "texture '" + desc.debugName + "'";
        if (desc.width == 0 || desc.height == 0 || desc.depthOrLayers == 0 || desc.mipLevels == 0) {
            error("createTexture: " + name + " has a zero extent, layer count or mip count");
            return {};
        }
        if (desc.format == Format::Undefined || desc.format >= Format::Count ||
            desc.format == Format::RGB32_FLOAT) {
            error("createTexture: " + name + " has a format that is not a texture format");
            return {};
        }
        if (desc.mipLevels > detail::resutil::fullMipChain(desc)) {
            error("createTexture: " + name + " asks for " + std::to_string(desc.mipLevels) +
                  " mip levels, more than its full chain of " +
                  std::to_string(detail::resutil::fullMipChain(desc)));
            return {};
        }
        const DeviceLimits& l = m_info.limits;
        const bool is3D = desc.dimension == TextureDimension::Tex3D;
        const uint32_t maxSize = is3D ? l.maxTextureSize3D : l.maxTextureSize2D;
        if (desc.width > maxSize || desc.height > maxSize || (is3D && desc.depthOrLayers > maxSize) ||
            (desc.dimension == TextureDimension::Tex2DArray &&
             desc.depthOrLayers > l.maxTextureArrayLayers) ||
            (desc.dimension == TextureDimension::Tex2D && desc.depthOrLayers != 1)) {
            error("createTexture: " + name + " has an extent beyond the device limits or a Tex2D with " +
                  "depthOrLayers != 1");
            return {};
        }
        auto t = std::make_shared<NullTexture>();
        t->desc = desc;
        const uint32_t layers = detail::resutil::arrayLayers(desc);
        t->subresources.resize(size_t(desc.mipLevels) * layers);
        for (uint32_t mip = 0; mip < desc.mipLevels; ++mip)
            for (uint32_t layer = 0; layer < layers; ++layer)
                t->subresources[t->index({mip, layer})].assign(
                    size_t(detail::resutil::subresourceSize(desc, mip)), 0);
        TextureHandle h = m_textures.insert(std::move(t));
        if (!h) error("createTexture: too many textures");
        return h;
    }

    SamplerHandle createSampler(const SamplerDesc& desc) override {
        SamplerHandle h = m_samplers.insert(std::make_shared<NullSampler>(NullSampler{desc}));
        if (!h) error("createSampler: too many samplers");
        return h;
    }

    ShaderHandle createShader(const ShaderDesc& desc) override {
        if (desc.pushConstantSize > kMaxPushConstantSize) {
            error("createShader: shader '" + std::string(desc.debugName) + "' declares " +
                  std::to_string(desc.pushConstantSize) + " bytes of push constants, more than " +
                  std::to_string(kMaxPushConstantSize));
            return {};
        }
        auto s = std::make_shared<NullShader>();
        s->reflection = detail::resutil::OwnedReflection::capture(desc);
        ShaderHandle h = m_shaders.insert(std::move(s));
        if (!h) error("createShader: too many shaders");
        return h;
    }

    PipelineHandle createComputePipeline(const ComputePipelineDesc& desc) override {
        const NullShader* shader = findShader(desc.shader, "createComputePipeline");
        if (!shader) return {};
        if (shader->reflection->stage != ShaderStage::Compute) {
            error("createComputePipeline: pipeline '" + desc.debugName + "' needs a compute shader, got a " +
                  detail::resutil::toString(shader->reflection->stage) + " shader");
            return {};
        }
        auto p = std::make_shared<NullPipeline>();
        p->compute = true;
        p->shaders.push_back(shader->reflection);
        p->computeDesc = desc;
        PipelineHandle h = m_pipelines.insert(std::move(p));
        if (h) ++m_stats.pipelinesCreated;
        if (!h) error("createComputePipeline: too many pipelines");
        return h;
    }

    PipelineHandle createGraphicsPipeline(const GraphicsPipelineDesc& desc) override {
        const NullShader* vs = findShader(desc.vertexShader, "createGraphicsPipeline");
        if (!vs) return {};
        const NullShader* fs = findShader(desc.fragmentShader, "createGraphicsPipeline");
        if (!fs) return {};
        if (vs->reflection->stage != ShaderStage::Vertex || fs->reflection->stage != ShaderStage::Fragment) {
            error("createGraphicsPipeline: pipeline '" + desc.debugName +
                  "' needs a vertex and a fragment shader");
            return {};
        }
        if (desc.colorFormats.size() > kMaxColorTargets) {
            error("createGraphicsPipeline: pipeline '" + desc.debugName + "' has more than " +
                  std::to_string(kMaxColorTargets) + " colour targets");
            return {};
        }
        auto p = std::make_shared<NullPipeline>();
        p->compute = false;
        p->shaders = {vs->reflection, fs->reflection};
        p->graphicsDesc = desc;
        PipelineHandle h = m_pipelines.insert(std::move(p));
        if (h) ++m_stats.pipelinesCreated;
        if (!h) error("createGraphicsPipeline: too many pipelines");
        return h;
    }

    BindGroupHandle createBindGroup(const BindGroupDesc& desc) override {
        if (!m_pipelines.contains(desc.pipeline)) {
            error("createBindGroup: bind group '" + desc.debugName +
                  "' names an invalid or destroyed pipeline");
            return {};
        }
        if (desc.set >= kMaxBindGroups) {
            error("createBindGroup: bind group '" + desc.debugName + "' has set " + std::to_string(desc.set) +
                  " >= " + std::to_string(kMaxBindGroups));
            return {};
        }
        for (const BindGroupEntry& e : desc.entries) {
            if (e.buffer && !m_buffers.contains(e.buffer)) {
                error("createBindGroup: bind group '" + desc.debugName + "' binding " +
                      std::to_string(e.binding) + " names an invalid or destroyed buffer");
                return {};
            }
            if (e.texture && !m_textures.contains(e.texture)) {
                error("createBindGroup: bind group '" + desc.debugName + "' binding " +
                      std::to_string(e.binding) + " names an invalid or destroyed texture");
                return {};
            }
            if (e.sampler && !m_samplers.contains(e.sampler)) {
                error("createBindGroup: bind group '" + desc.debugName + "' binding " +
                      std::to_string(e.binding) + " names an invalid or destroyed sampler");
                return {};
            }
        }
        BindGroupHandle h = m_bindGroups.insert(std::make_shared<NullBindGroup>(NullBindGroup{desc}));
        if (h) ++m_stats.bindGroupsCreated;
        if (!h) error("createBindGroup: too many bind groups");
        return h;
    }

    QueryPoolHandle createQueryPool(const QueryPoolDesc& desc) override {
        if (desc.count == 0) {
            error("createQueryPool: query pool '" + desc.debugName + "' has 0 slots");
            return {};
        }
        auto q = std::make_shared<NullQueryPool>();
        q->desc = desc;
        q->values.assign(desc.count, 0);
        q->written.assign(desc.count, false);
        QueryPoolHandle h = m_queryPools.insert(std::move(q));
        if (!h) error("createQueryPool: too many query pools");
        return h;
    }

    // --- destruction -----------------------------------------------------------------------------
#define RHI_DESTROY(Handle, pool, name) \
    void destroy(Handle h) override { destroyIn(pool, h, name); }
    RHI_RESOURCE_KINDS(RHI_DESTROY)
#undef RHI_DESTROY

#define RHI_IS_ALIVE(Handle, pool, name) \
    bool isAlive(Handle h) const override { return pool.contains(h); }
    RHI_RESOURCE_KINDS(RHI_IS_ALIVE)
#undef RHI_IS_ALIVE

    const BufferDesc* describe(BufferHandle h) const override {
        const auto* b = m_buffers.get(h);
        return b ? &(*b)->desc : nullptr;
    }
    const TextureDesc* describe(TextureHandle h) const override {
        const auto* t = m_textures.get(h);
        return t ? &(*t)->desc : nullptr;
    }

    // --- uploads ---------------------------------------------------------------------------------
    void writeBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) override {
        NullBuffer* b = findBuffer(dst, "writeBuffer");
        if (!b) return;
        if (!rangeInside(offset, size, b->desc.size)) {
            error(rangeMessage("writeBuffer", *b, offset, size));
            return;
        }
        if (size == 0) return;
        if (!data) {
            error("writeBuffer: data is null");
            return;
        }
        std::memcpy(b->bytes.data() + offset, data, size_t(size));
    }

    void writeTexture(TextureHandle dst, TextureSubresource sub, const void* data, uint64_t size) override {
        writeTextureImpl(dst, TextureRegion{sub.mip, sub.layer}, data, size, "writeTexture");
    }
    void writeTextureRegion(TextureHandle dst, const TextureRegion& region, const void* data,
                            uint64_t size) override {
        writeTextureImpl(dst, region, data, size, "writeTextureRegion");
    }
    void writeTextureImpl(TextureHandle dst, const TextureRegion& in, const void* data, uint64_t size,
                          const char* fn) {
        NullTexture* t = findTexture(dst, fn);
        if (!t) return;
        TextureRegion box;
        std::string why;
        if (!detail::resolveRegion(t->desc, in, box, why)) {
            error(std::string(fn) + ": texture '" + t->desc.debugName + "': " + why);
            return;
        }
        const uint64_t expected = detail::regionBytes(t->desc, box);
        if (size != expected || !data) {
            error(std::string(fn) + ": texture '" + t->desc.debugName + "' mip " + std::to_string(box.mip) +
                  " needs " + std::to_string(expected) + " bytes of data, got " + std::to_string(size) +
                  (data ? "" : " (null pointer)"));
            return;
        }
        t->writeBox(box, static_cast<const uint8_t*>(data));
    }

    void* mappedPointer(BufferHandle h) override {
        NullBuffer* b = findBuffer(h, "mappedPointer");
        if (!b || b->desc.memory == MemoryType::GpuOnly) return nullptr;
        return b->bytes.data();
    }

    // --- submission ------------------------------------------------------------------------------
    CommandList& beginCommandList(std::string_view debugName) override {
        m_openLists.push_back(std::make_unique<NullCommandList>(*this, std::string(debugName)));
        return *m_openLists.back();
    }

    uint64_t submit(CommandList& list) override {
        auto it = std::find_if(m_openLists.begin(), m_openLists.end(),
                               [&](const std::unique_ptr<NullCommandList>& l) { return l.get() == &list; });
        if (it == m_openLists.end()) {
            error("submit: the command list was not begun on this device or was already submitted");
            return 0;
        }
        std::unique_ptr<NullCommandList> owned = std::move(*it);
        m_openLists.erase(it);
        for (Command& c : owned->commands()) {
            execute(c);
            m_recorded.push_back(std::move(c.rec));
        }
        owned.reset();
        // The CPU executed everything already: the submission is complete at once.
        const uint64_t serial = ++m_submitted;
        m_deferred.collect(serial);
        return serial;
    }

    void waitForSubmission(uint64_t serial) override {
        if (serial > m_submitted)
            error("waitForSubmission: serial " + std::to_string(serial) + " was never submitted");
    }

    void waitIdle() override { m_deferred.releaseAll(); }
    void collectGarbage() override { m_deferred.collect(m_submitted); }

    // --- readback --------------------------------------------------------------------------------
    bool readBuffer(BufferHandle src, uint64_t offset, uint64_t size, void* out) override {
        NullBuffer* b = findBuffer(src, "readBuffer");
        if (!b) return false;
        if (!rangeInside(offset, size, b->desc.size)) {
            error(rangeMessage("readBuffer", *b, offset, size));
            return false;
        }
        if (size == 0) return true;
        if (!out) {
            error("readBuffer: output pointer is null");
            return false;
        }
        std::memcpy(out, b->bytes.data() + offset, size_t(size));
        return true;
    }

    bool readTexture(TextureHandle src, TextureSubresource sub, Access, std::vector<uint8_t>& out) override {
        NullTexture* t = findTexture(src, "readTexture");
        if (!t) return false;
        if (!detail::resutil::subresourceExists(t->desc, sub)) {
            error("readTexture: texture '" + t->desc.debugName + "' has no mip " + std::to_string(sub.mip) +
                  " layer " + std::to_string(sub.layer));
            return false;
        }
        out = t->subresources[t->index(sub)];
        return true;
    }

    bool readTimestamps(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs) override {
        ++m_stats.blockingTimestampReads;
        return readTimestampsImpl(pool, first, count, outNs, true);
    }
    // Timestamps of submitted lists are available at once (the CPU clock at submission).
    bool tryReadTimestamps(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs) override {
        return readTimestampsImpl(pool, first, count, outNs, false);
    }
    DeviceStats stats() const override { return m_stats; }
    // The null device records any use, so it claims what the format's kind allows: depth formats
    // sample and are depth targets; colour formats sample, filter and blend unless integer, are
    // storage images unless sRGB, colour targets and vertex attributes; R32_UINT has atomics;
    // RGB32_FLOAT is a vertex format only.
    FormatSupport formatSupport(Format format) const override {
        if (format == Format::Undefined || format >= Format::Count) return FormatSupport::None;
        const FormatInfo& fi = formatInfo(format);
        if (format == Format::RGB32_FLOAT) return FormatSupport::VertexAttribute;
        if (fi.isDepth) return FormatSupport::Sampled | FormatSupport::DepthTarget;
        FormatSupport s =
            FormatSupport::Sampled | FormatSupport::ColorTarget | FormatSupport::VertexAttribute;
        if (!fi.isInteger) s |= FormatSupport::Filterable | FormatSupport::Blendable;
        if (!fi.isSrgb) s |= FormatSupport::Storage;
        if (format == Format::R32_UINT) s |= FormatSupport::StorageAtomic;
        return s;
    }

    bool readTimestampsImpl(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs,
                            bool wait) {
        NullQueryPool* q = findQueryPool(pool, "readTimestamps");
        if (!q) return false;
        if (!rangeInside(first, count, q->desc.count)) {
            error("readTimestamps: queries [" + std::to_string(first) + ", +" + std::to_string(count) +
                  ") exceed query pool '" + q->desc.debugName + "' of " + std::to_string(q->desc.count));
            return false;
        }
        for (uint32_t i = 0; i < count; ++i) {
            if (!q->written[first + i]) {
                if (!wait) return false;  // not submitted yet: not available
                error("readTimestamps: query " + std::to_string(first + i) + " of pool '" +
                      q->desc.debugName + "' was never written by a submitted command list");
                return false;
            }
        }
        if (count && !outNs) {
            error("readTimestamps: output pointer is null");
            return false;
        }
        for (uint32_t i = 0; i < count; ++i) outNs[i] = q->values[first + i];
        return true;
    }

    // --- presentation ----------------------------------------------------------------------------
    TextureHandle acquireBackbuffer() override {
        error("acquireBackbuffer: the null device is headless and has no backbuffer");
        return {};
    }
    Format backbufferFormat() const override { return Format::Undefined; }
    bool present() override {
        error("present: the null device is headless and cannot present");
        return false;
    }
    void resizeBackbuffer(uint32_t, uint32_t) override {
        error("resizeBackbuffer: the null device is headless and has no backbuffer");
    }

    // --- internals used by NullCommandList and the inspection functions -------------------------
    void error(const std::string& message) {
        detail::logMessage(m_log, LogSeverity::Error, "null: " + message);
    }

    std::shared_ptr<NullTexture> textureRef(TextureHandle h, const char* fn) {
        auto* t = m_textures.get(h);
        if (!t) {
            error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") + " texture handle");
            return nullptr;
        }
        return *t;
    }
    std::shared_ptr<NullBuffer> bufferRef(BufferHandle h, const char* fn) {
        auto* b = m_buffers.get(h);
        if (!b) {
            error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") + " buffer handle");
            return nullptr;
        }
        return *b;
    }
    std::shared_ptr<NullQueryPool> queryPoolRef(QueryPoolHandle h, const char* fn) {
        auto* q = m_queryPools.get(h);
        if (!q) {
            error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") +
                  " query pool handle");
            return nullptr;
        }
        return *q;
    }
    bool checkAlive(TextureHandle h, const char* fn) {
        if (m_textures.contains(h)) return true;
        error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") + " texture handle");
        return false;
    }
    bool checkAlive(PipelineHandle h, const char* fn) {
        if (m_pipelines.contains(h)) return true;
        error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") + " pipeline handle");
        return false;
    }
    bool checkAlive(BindGroupHandle h, const char* fn) {
        if (m_bindGroups.contains(h)) return true;
        error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") + " bind group handle");
        return false;
    }

    std::vector<RecordedCommand>& recorded() { return m_recorded; }
    const std::vector<RecordedCommand>& recorded() const { return m_recorded; }

    size_t liveObjects() const {
        return m_buffers.size() + m_textures.size() + m_samplers.size() + m_shaders.size() +
               m_pipelines.size() + m_bindGroups.size() + m_queryPools.size() + m_deferred.pending();
    }

    static std::string rangeMessage(const char* fn, const NullBuffer& b, uint64_t offset, uint64_t size) {
        return std::string(fn) + ": range [" + std::to_string(offset) + ", +" + std::to_string(size) +
               ") exceeds buffer '" + b.desc.debugName + "' of " + std::to_string(b.desc.size) + " bytes";
    }

private:
    template <typename Tag, typename T>
    void destroyIn(detail::HandlePool<Tag, std::shared_ptr<T>>& pool, Handle<Tag> h, const char* what) {
        std::optional<std::shared_ptr<T>> obj = pool.remove(h);
        if (!obj) {
            error(std::string("destroy: ") + (h ? "stale or foreign " : "invalid (null) ") + what +
                  " handle");
            return;
        }
        // Lists still being recorded may use it: it lives until the next submission completes.
        std::shared_ptr<T> keep = std::move(*obj);
        m_deferred.push(m_submitted + 1, [keep]() mutable { keep.reset(); });
    }

    NullBuffer* findBuffer(BufferHandle h, const char* fn) {
        auto* b = m_buffers.get(h);
        if (!b)
            error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") + " buffer handle");
        return b ? b->get() : nullptr;
    }
    NullTexture* findTexture(TextureHandle h, const char* fn) {
        auto* t = m_textures.get(h);
        if (!t)
            error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") + " texture handle");
        return t ? t->get() : nullptr;
    }
    const NullShader* findShader(ShaderHandle h, const char* fn) {
        auto* s = m_shaders.get(h);
        if (!s)
            error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") + " shader handle");
        return s ? s->get() : nullptr;
    }
    NullQueryPool* findQueryPool(QueryPoolHandle h, const char* fn) {
        auto* q = m_queryPools.get(h);
        if (!q)
            error(std::string(fn) + ": " + (h ? "stale or foreign" : "invalid (null)") +
                  " query pool handle");
        return q ? q->get() : nullptr;
    }

    void execute(Command& c) {
        using K = RecordedCommand::Kind;
        switch (c.rec.kind) {
            case K::UpdateBuffer:
                if (!c.bytes.empty())
                    std::memcpy(c.dst->bytes.data() + c.dstOffset, c.bytes.data(), c.bytes.size());
                break;
            case K::CopyBuffer:
                std::memmove(c.dst->bytes.data() + c.dstOffset, c.src->bytes.data() + c.srcOffset,
                             size_t(c.size));
                break;
            case K::FillBuffer:
                for (uint64_t i = 0; i < c.size; i += 4)
                    std::memcpy(c.dst->bytes.data() + c.dstOffset + i, &c.value, 4);
                break;
            case K::CopyTexture: {
                const TextureRegion& a = c.srcBox;
                const size_t row = size_t(a.width) * formatInfo(c.srcTexture->desc.format).bytesPerTexel;
                NullTexture::copyBox(c.srcTexture->boxStart(a), c.srcTexture->rowPitch(a.mip),
                                     c.srcTexture->slicePitch(a.mip), c.dstTexture->boxStart(c.dstBox),
                                     c.dstTexture->rowPitch(c.dstBox.mip),
                                     c.dstTexture->slicePitch(c.dstBox.mip), row, a.height, a.depth);
                break;
            }
            case K::CopyBufferToTexture:
                c.dstTexture->writeBox(c.dstBox, c.src->bytes.data() + c.srcOffset);
                break;
            case K::ResetQueries:
                for (uint32_t i = 0; i < c.rec.counts[1]; ++i) {
                    c.pool->written[c.rec.counts[0] + i] = false;
                    c.pool->values[c.rec.counts[0] + i] = 0;
                }
                break;
            case K::WriteTimestamp: {
                const uint64_t now = uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                                  std::chrono::steady_clock::now().time_since_epoch())
                                                  .count());
                m_lastTimestamp = std::max(now, m_lastTimestamp + 1);
                c.pool->values[c.rec.counts[0]] = m_lastTimestamp;
                c.pool->written[c.rec.counts[0]] = true;
                break;
            }
            default:
                break;
        }
    }

    LogCallback m_log;
    DeviceInfo m_info;
    detail::HandlePool<BufferTag, std::shared_ptr<NullBuffer>> m_buffers;
    detail::HandlePool<TextureTag, std::shared_ptr<NullTexture>> m_textures;
    detail::HandlePool<SamplerTag, std::shared_ptr<NullSampler>> m_samplers;
    detail::HandlePool<ShaderTag, std::shared_ptr<NullShader>> m_shaders;
    detail::HandlePool<PipelineTag, std::shared_ptr<NullPipeline>> m_pipelines;
    detail::HandlePool<BindGroupTag, std::shared_ptr<NullBindGroup>> m_bindGroups;
    detail::HandlePool<QueryPoolTag, std::shared_ptr<NullQueryPool>> m_queryPools;
    detail::DeferredReleaseQueue m_deferred;
    std::vector<std::unique_ptr<NullCommandList>> m_openLists;
    std::vector<RecordedCommand> m_recorded;
    DeviceStats m_stats;
    uint64_t m_submitted = 0;
    uint64_t m_lastTimestamp = 0;
};

// --- NullCommandList -----------------------------------------------------------------------------

void NullCommandList::barrier(std::span<const Barrier> barriers) {
    std::vector<Barrier> kept;
    kept.reserve(barriers.size());
    for (const Barrier& b : barriers) {
        if (b.buffer.isValid() == b.texture.isValid()) {
            m_device.error("barrier: exactly one of buffer / texture must be set");
            continue;
        }
        if (b.buffer && !m_device.isAlive(b.buffer)) {
            m_device.error("barrier: stale or foreign buffer handle");
            continue;
        }
        if (b.texture && !m_device.isAlive(b.texture)) {
            m_device.error("barrier: stale or foreign texture handle");
            continue;
        }
        TextureRange range;
        if (b.texture && !detail::resolveRange(*m_device.describe(b.texture), b.range, range)) {
            m_device.error("barrier: the texture has no such subresource range");
            continue;
        }
        kept.push_back(b);
    }
    if (kept.empty()) return;
    add(RecordedCommand::Kind::Barrier).rec.barriers = std::move(kept);
}

void NullCommandList::updateBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) {
    auto b = m_device.bufferRef(dst, "updateBuffer");
    if (!b) return;
    if (!rangeInside(offset, size, b->desc.size)) {
        m_device.error(NullDevice::rangeMessage("updateBuffer", *b, offset, size));
        return;
    }
    if (size && !data) {
        m_device.error("updateBuffer: data is null");
        return;
    }
    Command& c = add(RecordedCommand::Kind::UpdateBuffer);
    c.dst = std::move(b);
    c.dstOffset = offset;
    const auto* p = static_cast<const uint8_t*>(data);
    c.bytes.assign(p, p + size);
}

void NullCommandList::copyBuffer(BufferHandle src, uint64_t srcOffset, BufferHandle dst, uint64_t dstOffset,
                                 uint64_t size) {
    auto s = m_device.bufferRef(src, "copyBuffer");
    if (!s) return;
    auto d = m_device.bufferRef(dst, "copyBuffer");
    if (!d) return;
    if (!rangeInside(srcOffset, size, s->desc.size)) {
        m_device.error(NullDevice::rangeMessage("copyBuffer", *s, srcOffset, size));
        return;
    }
    if (!rangeInside(dstOffset, size, d->desc.size)) {
        m_device.error(NullDevice::rangeMessage("copyBuffer", *d, dstOffset, size));
        return;
    }
    Command& c = add(RecordedCommand::Kind::CopyBuffer);
    c.src = std::move(s);
    c.dst = std::move(d);
    c.srcOffset = srcOffset;
    c.dstOffset = dstOffset;
    c.size = size;
}

void NullCommandList::copyTexture(TextureHandle src, const TextureRegion& srcRegion, TextureHandle dst,
                                  const TextureRegion& dstRegion) {
    auto s = m_device.textureRef(src, "copyTexture");
    auto d = s ? m_device.textureRef(dst, "copyTexture") : nullptr;
    if (!s || !d) return;
    TextureRegion a, b;
    std::string why;
    if (!detail::checkTextureCopy(s->desc, srcRegion, d->desc, dstRegion, s == d, a, b, why)) {
        m_device.error("copyTexture: " + why);
        return;
    }
    Command& c = add(RecordedCommand::Kind::CopyTexture);
    c.srcTexture = std::move(s);
    c.dstTexture = std::move(d);
    c.srcBox = a;
    c.dstBox = b;
}

void NullCommandList::copyBufferToTexture(BufferHandle src, uint64_t srcOffset, TextureHandle dst,
                                          const TextureRegion& dstRegion) {
    auto s = m_device.bufferRef(src, "copyBufferToTexture");
    auto d = s ? m_device.textureRef(dst, "copyBufferToTexture") : nullptr;
    if (!s || !d) return;
    TextureRegion box;
    std::string why;
    if (!detail::checkBufferToTexture(s->desc.size, srcOffset, d->desc, dstRegion, box, why)) {
        m_device.error("copyBufferToTexture: " + why);
        return;
    }
    Command& c = add(RecordedCommand::Kind::CopyBufferToTexture);
    c.src = std::move(s);
    c.srcOffset = srcOffset;
    c.dstTexture = std::move(d);
    c.dstBox = box;
}

void NullCommandList::fillBuffer(BufferHandle dst, uint64_t offset, uint64_t size, uint32_t value) {
    auto b = m_device.bufferRef(dst, "fillBuffer");
    if (!b) return;
    if (!rangeInside(offset, size, b->desc.size) || size % 4 != 0) {
        m_device.error(NullDevice::rangeMessage("fillBuffer", *b, offset, size) +
                       " or is not a multiple of 4");
        return;
    }
    Command& c = add(RecordedCommand::Kind::FillBuffer);
    c.dst = std::move(b);
    c.dstOffset = offset;
    c.size = size;
    c.value = value;
}

void NullCommandList::bindPipeline(PipelineHandle pipeline) {
    if (!m_device.checkAlive(pipeline, "bindPipeline")) return;
    add(RecordedCommand::Kind::BindPipeline).rec.pipeline = pipeline;
}

void NullCommandList::bindGroup(uint32_t set, BindGroupHandle group) {
    if (!m_device.checkAlive(group, "bindGroup")) return;
    if (set >= kMaxBindGroups) {
        m_device.error("bindGroup: set " + std::to_string(set) + " is out of range");
        return;
    }
    Command& c = add(RecordedCommand::Kind::BindGroup);
    c.rec.group = group;
    c.rec.set = set;
}

void NullCommandList::pushConstants(const void*, uint32_t size, uint32_t offset) {
    if (!rangeInside(offset, size, kMaxPushConstantSize)) {
        m_device.error("pushConstants: range exceeds " + std::to_string(kMaxPushConstantSize) + " bytes");
        return;
    }
    Command& c = add(RecordedCommand::Kind::PushConstants);
    c.rec.counts[0] = size;
    c.rec.counts[1] = offset;
}

void NullCommandList::dispatch(uint32_t x, uint32_t y, uint32_t z) {
    Command& c = add(RecordedCommand::Kind::Dispatch);
    c.rec.counts[0] = x;
    c.rec.counts[1] = y;
    c.rec.counts[2] = z;
}

void NullCommandList::dispatchIndirect(BufferHandle args, uint64_t offset) {
    auto b = m_device.bufferRef(args, "dispatchIndirect");
    if (!b) return;
    if (!rangeInside(offset, 12, b->desc.size)) {
        m_device.error(NullDevice::rangeMessage("dispatchIndirect", *b, offset, 12));
        return;
    }
    add(RecordedCommand::Kind::DispatchIndirect);
}

void NullCommandList::beginRenderPass(const RenderPassDesc& desc) {
    std::vector<TextureHandle> attachments;
    for (const ColorAttachment& a : desc.colorAttachments) {
        if (!m_device.checkAlive(a.texture, "beginRenderPass")) return;
        attachments.push_back(a.texture);
    }
    if (desc.depthAttachment.texture) {
        if (!m_device.checkAlive(desc.depthAttachment.texture, "beginRenderPass")) return;
        attachments.push_back(desc.depthAttachment.texture);
    }
    Command& c = add(RecordedCommand::Kind::BeginRenderPass);
    c.rec.label = desc.debugName;
    c.rec.attachments = std::move(attachments);
}

void NullCommandList::endRenderPass() { add(RecordedCommand::Kind::EndRenderPass); }

void NullCommandList::setViewport(const Viewport&) { add(RecordedCommand::Kind::SetViewport); }

void NullCommandList::setScissor(const Rect&) { add(RecordedCommand::Kind::SetScissor); }

void NullCommandList::bindVertexBuffer(uint32_t slot, BufferHandle buffer, uint64_t) {
    if (!m_device.bufferRef(buffer, "bindVertexBuffer")) return;
    add(RecordedCommand::Kind::BindVertexBuffer).rec.counts[0] = slot;
}

void NullCommandList::bindIndexBuffer(BufferHandle buffer, IndexType type, uint64_t) {
    if (!m_device.bufferRef(buffer, "bindIndexBuffer")) return;
    add(RecordedCommand::Kind::BindIndexBuffer).rec.counts[0] = type == IndexType::Uint16 ? 2 : 4;
}

void NullCommandList::draw(uint32_t vertexCount, uint32_t instanceCount, uint32_t firstVertex, uint32_t) {
    Command& c = add(RecordedCommand::Kind::Draw);
    c.rec.counts[0] = vertexCount;
    c.rec.counts[1] = instanceCount;
    c.rec.counts[2] = firstVertex;
}

void NullCommandList::drawIndexed(uint32_t indexCount, uint32_t instanceCount, uint32_t firstIndex, int32_t,
                                  uint32_t) {
    Command& c = add(RecordedCommand::Kind::DrawIndexed);
    c.rec.counts[0] = indexCount;
    c.rec.counts[1] = instanceCount;
    c.rec.counts[2] = firstIndex;
}

void NullCommandList::drawIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) {
    auto b = m_device.bufferRef(args, "drawIndirect");
    if (!b) return;
    if (drawCount > (uint64_t(1) << 32) / 16 ||
        !rangeInside(offset, uint64_t(drawCount) * 16, b->desc.size)) {
        m_device.error(NullDevice::rangeMessage("drawIndirect", *b, offset, uint64_t(drawCount) * 16));
        return;
    }
    add(RecordedCommand::Kind::DrawIndirect).rec.counts[0] = drawCount;
}

void NullCommandList::drawIndexedIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) {
    auto b = m_device.bufferRef(args, "drawIndexedIndirect");
    if (!b) return;
    if (drawCount > (uint64_t(1) << 32) / 20 ||
        !rangeInside(offset, uint64_t(drawCount) * 20, b->desc.size)) {
        m_device.error(NullDevice::rangeMessage("drawIndexedIndirect", *b, offset, uint64_t(drawCount) * 20));
        return;
    }
    add(RecordedCommand::Kind::DrawIndexedIndirect).rec.counts[0] = drawCount;
}

void NullCommandList::resetQueries(QueryPoolHandle pool, uint32_t first, uint32_t count) {
    auto q = m_device.queryPoolRef(pool, "resetQueries");
    if (!q) return;
    if (!rangeInside(first, count, q->desc.count)) {
        m_device.error("resetQueries: queries exceed pool '" + q->desc.debugName + "'");
        return;
    }
    Command& c = add(RecordedCommand::Kind::ResetQueries);
    c.pool = std::move(q);
    c.rec.counts[0] = first;
    c.rec.counts[1] = count;
}

void NullCommandList::writeTimestamp(QueryPoolHandle pool, uint32_t index) {
    auto q = m_device.queryPoolRef(pool, "writeTimestamp");
    if (!q) return;
    if (index >= q->desc.count) {
        m_device.error("writeTimestamp: query " + std::to_string(index) + " exceeds pool '" +
                       q->desc.debugName + "' of " + std::to_string(q->desc.count));
        return;
    }
    Command& c = add(RecordedCommand::Kind::WriteTimestamp);
    c.pool = std::move(q);
    c.rec.counts[0] = index;
}

void NullCommandList::pushDebugGroup(std::string_view name) {
    add(RecordedCommand::Kind::PushDebugGroup).rec.label = std::string(name);
}

void NullCommandList::popDebugGroup() { add(RecordedCommand::Kind::PopDebugGroup); }

const NullDevice* asNull(const Device& device) {
    return dynamic_cast<const NullDevice*>(&detail::innermostDevice(device));
}

}  // namespace

const std::vector<RecordedCommand>& recordedCommands(const Device& device) {
    static const std::vector<RecordedCommand> kEmpty;
    const NullDevice* d = asNull(device);
    return d ? d->recorded() : kEmpty;
}

void clearRecordedCommands(Device& device) {
    if (auto* d = const_cast<NullDevice*>(asNull(device))) d->recorded().clear();
}

size_t liveObjectCount(const Device& device) {
    const NullDevice* d = asNull(device);
    return d ? d->liveObjects() : 0;
}

}  // namespace rhi::null

namespace rhi::detail {

std::unique_ptr<Device> createNullDevice(const DeviceDesc& desc) {
    return std::make_unique<null::NullDevice>(desc);
}

}  // namespace rhi::detail
