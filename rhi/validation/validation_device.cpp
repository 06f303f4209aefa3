// Validation wrapper: a Device + CommandList pair that checks every call against the RHI contract
// (handles, descriptions, ranges, command order, bind groups against reflection, resource states
// against the barriers recorded so far), reports each misuse as one Error message prefixed
// "validation: <function>: ", and forwards the call to the wrapped device unless forwarding would
// be unsafe (dead or foreign handles, out-of-range values, invalid descriptions, draws/dispatches
// the backend cannot execute), in which case the call is dropped.
#include "rhi/validation/validation_device.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rhi/common/backend_factories.h"
#include "rhi/common/resource_kinds.h"
#include "rhi/common/subresource_states.h"
#include "rhi/validation/resource_util.h"

namespace rhi::detail {
namespace {

using namespace resutil;

// --- object records --------------------------------------------------------------------------------

// State tracking of a buffer. A buffer nobody has barriered or written on the GPU yet is
// "host-initialised": any use is fine. The first GPU write (or barrier) ends that.
struct BufferInfo {
    BufferDesc desc;
    bool hostInitialised = true;
    Access state = Access::None;
};

// Per mip and layer: the state the last barrier (or upload) left it in.
struct TextureInfo {
    TextureDesc desc;
    SubresourceStates states;
};

struct SamplerInfo {
    std::string debugName;
};

struct ShaderInfo {
    std::shared_ptr<const OwnedReflection> reflection;
};

// Everything a pipeline contributes to validation. Binding names point into `shaders`.
struct PipelineLayout {
    bool compute = true;
    std::string debugName;
    std::vector<std::shared_ptr<const OwnedReflection>> shaders;
    std::vector<ShaderBinding> bindings;  // merged over stages, sorted by (set, binding)
    uint32_t pushConstantSize = 0;
    std::vector<Format> colorFormats;
    Format depthFormat = Format::Undefined;
    std::vector<VertexBufferLayout> vertexBuffers;

    bool declaresSet(uint32_t set) const {
        return std::any_of(bindings.begin(), bindings.end(),
                           [&](const ShaderBinding& b) { return b.set == set; });
    }
    const ShaderBinding* find(uint32_t set, uint32_t binding) const {
        for (const ShaderBinding& b : bindings)
            if (b.set == set && b.binding == binding) return &b;
        return nullptr;
    }
};

struct PipelineInfo {
    std::shared_ptr<const PipelineLayout> layout;
};

struct BindGroupInfo {
    std::string debugName;
    uint32_t set = 0;
    std::shared_ptr<const PipelineLayout> layout;
    std::vector<BindGroupEntry> entries;
};

struct QueryPoolInfo {
    QueryPoolDesc desc;
};

const std::string& nameOf(const BufferInfo& i) { return i.desc.debugName; }
const std::string& nameOf(const TextureInfo& i) { return i.desc.debugName; }
const std::string& nameOf(const SamplerInfo& i) { return i.debugName; }
const std::string& nameOf(const ShaderInfo& i) { return i.reflection->debugName; }
const std::string& nameOf(const PipelineInfo& i) { return i.layout->debugName; }
const std::string& nameOf(const std::shared_ptr<const BindGroupInfo>& i) { return i->debugName; }
const std::string& nameOf(const QueryPoolInfo& i) { return i.desc.debugName; }

std::string hex(uint32_t v) {
    char buf[16];
    std::snprintf(buf, sizeof(buf), "0x%08x", v);
    return buf;
}

std::string quoted(const std::string& name) { return "'" + name + "'"; }

// Handle registry mirroring the wrapped device's slot pool: per slot index, the generation this
// wrapper saw last and whether that object is alive. A handle whose index was never issued, or
// whose generation is newer than any issued here, did not come from this device.
template <typename Info>
class Registry {
public:
    enum class Status { Null, Alive, Destroyed, Older, Foreign };
    struct Slot {
        uint16_t generation = 0;
        bool alive = false;
        Info info{};
    };

    void add(uint32_t value, Info info) {
        const uint16_t index = uint16_t(value & 0xffffu);
        if (index >= m_slots.size()) m_slots.resize(size_t(index) + 1);
        m_slots[index] = Slot{uint16_t(value >> 16), true, std::move(info)};
    }

    Status lookup(uint32_t value, Slot** out) {
        *out = nullptr;
        if (value == 0) return Status::Null;
        const uint16_t index = uint16_t(value & 0xffffu);
        const uint16_t generation = uint16_t(value >> 16);
        if (index >= m_slots.size() || m_slots[index].generation == 0) return Status::Foreign;
        Slot& s = m_slots[index];
        if (generation == s.generation) {
            *out = &s;
            return s.alive ? Status::Alive : Status::Destroyed;
        }
        return generation < s.generation ? Status::Older : Status::Foreign;
    }

private:
    std::vector<Slot> m_slots;
};

class ValidationDevice;

class ValidationCommandList final : public CommandList {
public:
    ValidationCommandList(ValidationDevice& device, CommandList& inner) : m_device(device), m_inner(inner) {}

#define RHI_COMMAND_LIST_METHOD(ret, name, params, qualifiers) ret name params qualifiers override;
#include "rhi/command_list_api.inc"
#undef RHI_COMMAND_LIST_METHOD

    CommandList& inner() { return m_inner; }
    // Closes what the caller left open (reported by the device's submit()).
    bool inRenderPass() const { return m_inPass; }
    uint32_t debugDepth() const { return m_debugDepth; }
    void closeForSubmit() {
        if (m_inPass) m_inner.endRenderPass();
        m_inPass = false;
        for (; m_debugDepth > 0; --m_debugDepth) m_inner.popDebugGroup();
    }

private:
    struct BoundGroup {
        BindGroupHandle handle;
        std::shared_ptr<const BindGroupInfo> info;
    };

    // Checks shared by every draw and dispatch; false = the command must be dropped.
    bool checkBindings(const char* fn);
    // State checks of every resource the bound pipeline's bindings reach; applies GPU writes.
    void checkResourceStates(const char* fn);
    bool checkIndirect(const char* fn, BufferHandle args, uint64_t offset, uint64_t bytes);
    bool checkDrawState(const char* fn);

    ValidationDevice& m_device;
    CommandList& m_inner;
    std::shared_ptr<const PipelineLayout> m_pipeline;
    std::string m_pipelineName;
    std::array<BoundGroup, kMaxBindGroups> m_groups{};
    bool m_inPass = false;
    std::vector<Format> m_passColorFormats;
    Format m_passDepthFormat = Format::Undefined;
    std::vector<bool> m_vertexBound;
    bool m_indexBound = false;
    uint64_t m_indexOffset = 0;
    uint32_t m_debugDepth = 0;
};

class ValidationDevice final : public WrappingDevice {
public:
    ValidationDevice(std::unique_ptr<Device> inner, LogCallback log, std::shared_ptr<uint64_t> errorCounter)
        : m_inner(std::move(inner)), m_log(std::move(log)), m_errorCounter(std::move(errorCounter)) {}

    ~ValidationDevice() override {
        // Lists still open reference the inner device's lists, which the inner device owns.
        m_openLists.clear();
        m_inner.reset();
    }

    Device& inner() override { return *m_inner; }
    const Device& inner() const override { return *m_inner; }
    uint64_t errorCount() const { return m_errorCounter ? *m_errorCounter : 0; }

    const DeviceInfo& info() const override { return m_inner->info(); }

    // --- reporting -------------------------------------------------------------------------------
    void report(const char* fn, const std::string& message) {
        logMessage(m_log, LogSeverity::Error, std::string("validation: ") + fn + ": " + message);
    }

    // --- handle resolution -----------------------------------------------------------------------
    BufferInfo* buffer(BufferHandle h, const char* fn, const char* role) {
        return resolve(m_buffers, h, fn, "buffer", role);
    }
    TextureInfo* texture(TextureHandle h, const char* fn, const char* role) {
        return resolve(m_textures, h, fn, "texture", role);
    }
    SamplerInfo* sampler(SamplerHandle h, const char* fn, const char* role) {
        return resolve(m_samplers, h, fn, "sampler", role);
    }
    ShaderInfo* shader(ShaderHandle h, const char* fn, const char* role) {
        return resolve(m_shaders, h, fn, "shader", role);
    }
    PipelineInfo* pipeline(PipelineHandle h, const char* fn, const char* role) {
        return resolve(m_pipelines, h, fn, "pipeline", role);
    }
    std::shared_ptr<const BindGroupInfo>* bindGroup(BindGroupHandle h, const char* fn, const char* role) {
        return resolve(m_bindGroups, h, fn, "bind group", role);
    }
    QueryPoolInfo* queryPool(QueryPoolHandle h, const char* fn, const char* role) {
        return resolve(m_queryPools, h, fn, "query pool", role);
    }

    // --- creation --------------------------------------------------------------------------------
    BufferHandle createBuffer(const BufferDesc& desc, const void* initialData) override {
        const char* fn = "createBuffer";
        if (desc.size == 0) {
            report(fn, "buffer " + quoted(desc.debugName) + " has size 0");
            return {};
        }
        BufferHandle h = m_inner->createBuffer(desc, initialData);
        if (h) m_buffers.add(h.value, BufferInfo{desc, true, Access::None});
        return h;
    }

    TextureHandle createTexture(const TextureDesc& desc) override {
        const char* fn = "createTexture";
        const std::string name = "texture " + quoted(desc.debugName);
        const FormatInfo& fi = formatInfo(desc.format);
        const DeviceLimits& limits = info().limits;
        if (desc.width == 0 || desc.height == 0 || desc.depthOrLayers == 0) {
            report(fn, name + " has a zero-sized extent (" + std::to_string(desc.width) + "x" +
                           std::to_string(desc.height) + "x" + std::to_string(desc.depthOrLayers) + ")");
            return {};
        }
        if (desc.format == Format::Undefined || desc.format >= Format::Count ||
            desc.format == Format::RGB32_FLOAT) {
            report(fn, name + " has format " + fi.name + ", which is not a texture format");
            return {};
        }
        if (desc.dimension == TextureDimension::Tex2D && desc.depthOrLayers != 1) {
            report(fn, name + " is a Tex2D with depthOrLayers = " + std::to_string(desc.depthOrLayers) +
                           " (must be 1; use Tex2DArray or Tex3D)");
            return {};
        }
        if (desc.mipLevels == 0 || desc.mipLevels > fullMipChain(desc)) {
            report(fn, name + " asks for " + std::to_string(desc.mipLevels) +
                           " mip levels; its full chain has " + std::to_string(fullMipChain(desc)));
            return {};
        }
        if (fi.isDepth && any(desc.usage & TextureUsage::Storage)) {
            report(fn, name + " has depth format " + fi.name +
                           " and Storage usage (depth formats cannot be storage images)");
            return {};
        }
        if (fi.isDepth && any(desc.usage & TextureUsage::ColorTarget)) {
            report(fn, name + " has depth format " + fi.name + " and ColorTarget usage");
            return {};
        }
        if (!fi.isDepth && any(desc.usage & TextureUsage::DepthTarget)) {
            report(fn, name + " has colour format " + fi.name + " and DepthTarget usage");
            return {};
        }
        if (fi.isDepth && desc.dimension == TextureDimension::Tex3D) {
            report(fn, name + " is a Tex3D with depth format " + fi.name);
            return {};
        }
        const FormatSupport support = m_inner->formatSupport(desc.format);
        if (any(desc.usage & TextureUsage::Storage) && !any(support & FormatSupport::Storage)) {
            report(fn, name + " has Storage usage but the device has no storage images of format " + fi.name +
                           " (formatSupport: " + toString(support) + ")");
            return {};
        }
        const bool is3D = desc.dimension == TextureDimension::Tex3D;
        const uint32_t maxSize = is3D ? limits.maxTextureSize3D : limits.maxTextureSize2D;
        if (desc.width > maxSize || desc.height > maxSize || (is3D && desc.depthOrLayers > maxSize)) {
            report(fn, name + " exceeds the device's maximum texture size of " + std::to_string(maxSize));
            return {};
        }
        if (desc.dimension == TextureDimension::Tex2DArray &&
            desc.depthOrLayers > limits.maxTextureArrayLayers) {
            report(fn, name + " has " + std::to_string(desc.depthOrLayers) +
                           " layers, more than the limit of " + std::to_string(limits.maxTextureArrayLayers));
            return {};
        }
        TextureHandle h = m_inner->createTexture(desc);
        if (h) m_textures.add(h.value, TextureInfo{desc, SubresourceStates(desc)});
        return h;
    }

    SamplerHandle createSampler(const SamplerDesc& desc) override {
        if (desc.maxLod < 0.0f) {
            report("createSampler", "sampler " + quoted(desc.debugName) + " has a negative maxLod");
            return {};
        }
        SamplerHandle h = m_inner->createSampler(desc);
        if (h) m_samplers.add(h.value, SamplerInfo{desc.debugName});
        return h;
    }

    ShaderHandle createShader(const ShaderDesc& desc) override {
        const char* fn = "createShader";
        const std::string name = "shader " + quoted(std::string(desc.debugName));
        if (desc.pushConstantSize > kMaxPushConstantSize) {
            report(fn, name + " declares " + std::to_string(desc.pushConstantSize) +
                           " bytes of push constants, more than kMaxPushConstantSize (" +
                           std::to_string(kMaxPushConstantSize) + ")");
            return {};
        }
        for (size_t i = 0; i < desc.bindings.size(); ++i) {
            const ShaderBinding& b = desc.bindings[i];
            if (b.set >= kMaxBindGroups) {
                report(fn, name + " binding '" + (b.name ? b.name : "") + "' uses set " +
                               std::to_string(b.set) + ", beyond kMaxBindGroups (" +
                               std::to_string(kMaxBindGroups) + ")");
                return {};
            }
            if (b.count == 0) {
                report(fn, name + " binding '" + (b.name ? b.name : "") + "' has an array size of 0");
                return {};
            }
            for (size_t j = 0; j < i; ++j) {
                if (desc.bindings[j].set == b.set && desc.bindings[j].binding == b.binding) {
                    report(fn, name + " declares set " + std::to_string(b.set) + ", binding " +
                                   std::to_string(b.binding) + " twice");
                    return {};
                }
            }
        }
        if (desc.stage == ShaderStage::Compute) {
            const DeviceLimits& l = info().limits;
            const auto& wg = desc.workgroupSize;
            const uint64_t invocations = uint64_t(wg[0]) * wg[1] * wg[2];
            if (wg[0] == 0 || wg[1] == 0 || wg[2] == 0 || wg[0] > l.maxComputeWorkgroupSize[0] ||
                wg[1] > l.maxComputeWorkgroupSize[1] || wg[2] > l.maxComputeWorkgroupSize[2] ||
                invocations > l.maxComputeWorkgroupInvocations) {
                report(fn, name + " has workgroup size " + std::to_string(wg[0]) + "x" +
                               std::to_string(wg[1]) + "x" + std::to_string(wg[2]) +
                               ", beyond the device limits");
                return {};
            }
        }
        ShaderHandle h = m_inner->createShader(desc);
        if (h) m_shaders.add(h.value, ShaderInfo{OwnedReflection::capture(desc)});
        return h;
    }

    PipelineHandle createComputePipeline(const ComputePipelineDesc& desc) override {
        const char* fn = "createComputePipeline";
        ShaderInfo* s = shader(desc.shader, fn, "shader");
        if (!s) return {};
        if (s->reflection->stage != ShaderStage::Compute) {
            report(fn, "pipeline " + quoted(desc.debugName) + " is given " + toString(s->reflection->stage) +
                           " shader " + quoted(s->reflection->debugName) +
                           "; a compute pipeline needs a compute shader");
            return {};
        }
        auto layout = std::make_shared<PipelineLayout>();
        layout->compute = true;
        layout->debugName = desc.debugName;
        layout->shaders = {s->reflection};
        layout->bindings = s->reflection->bindings;
        sortBindings(layout->bindings);
        layout->pushConstantSize = s->reflection->pushConstantSize;
        PipelineHandle h = m_inner->createComputePipeline(desc);
        if (h) m_pipelines.add(h.value, PipelineInfo{std::move(layout)});
        return h;
    }

    PipelineHandle createGraphicsPipeline(const GraphicsPipelineDesc& desc) override {
        const char* fn = "createGraphicsPipeline";
        const std::string name = "pipeline " + quoted(desc.debugName);
        ShaderInfo* vs = shader(desc.vertexShader, fn, "vertexShader");
        if (!vs) return {};
        ShaderInfo* fs = shader(desc.fragmentShader, fn, "fragmentShader");
        if (!fs) return {};
        if (vs->reflection->stage != ShaderStage::Vertex) {
            report(fn, name + " is given " + toString(vs->reflection->stage) + " shader " +
                           quoted(vs->reflection->debugName) + " as its vertex shader");
            return {};
        }
        if (fs->reflection->stage != ShaderStage::Fragment) {
            report(fn, name + " is given " + toString(fs->reflection->stage) + " shader " +
                           quoted(fs->reflection->debugName) + " as its fragment shader");
            return {};
        }
        if (desc.colorFormats.size() > kMaxColorTargets) {
            report(fn, name + " has " + std::to_string(desc.colorFormats.size()) +
                           " colour formats, more than kMaxColorTargets (" +
                           std::to_string(kMaxColorTargets) + ")");
            return {};
        }
        if (!desc.blend.empty() && desc.blend.size() != desc.colorFormats.size()) {
            report(fn, name + " has " + std::to_string(desc.blend.size()) + " blend states for " +
                           std::to_string(desc.colorFormats.size()) +
                           " colour targets (need none or one per target)");
            return {};
        }
        for (size_t i = 0; i < desc.colorFormats.size(); ++i) {
            const FormatInfo& fi = formatInfo(desc.colorFormats[i]);
            if (desc.colorFormats[i] == Format::Undefined || fi.isDepth ||
                desc.colorFormats[i] >= Format::Count || desc.colorFormats[i] == Format::RGB32_FLOAT) {
                report(fn, name + " colour target " + std::to_string(i) + " has format " + fi.name +
                               ", which is not a colour-target format");
                return {};
            }
        }
        if (desc.depthFormat != Format::Undefined && !formatInfo(desc.depthFormat).isDepth) {
            report(fn, name + " has depthFormat " + formatInfo(desc.depthFormat).name +
                           ", which is not a depth format");
            return {};
        }
        for (const VertexAttribute& a : desc.vertexAttributes) {
            if (a.bufferSlot >= desc.vertexBuffers.size()) {
                report(fn, name + " vertex attribute at location " + std::to_string(a.location) +
                               " uses buffer slot " + std::to_string(a.bufferSlot) + " but only " +
                               std::to_string(desc.vertexBuffers.size()) +
                               " vertex buffer layouts are given");
                return {};
            }
        }
        auto layout = std::make_shared<PipelineLayout>();
        layout->compute = false;
        layout->debugName = desc.debugName;
        layout->shaders = {vs->reflection, fs->reflection};
        layout->bindings = vs->reflection->bindings;
        for (const ShaderBinding& b : fs->reflection->bindings) {
            auto it = std::find_if(
                layout->bindings.begin(), layout->bindings.end(),
                [&](const ShaderBinding& o) { return o.set == b.set && o.binding == b.binding; });
            if (it == layout->bindings.end()) {
                layout->bindings.push_back(b);
            } else if (it->type != b.type || it->count != b.count ||
                       (!isBufferBinding(b.type) && it->textureDimension != b.textureDimension)) {
                report(fn, name + " set " + std::to_string(b.set) + ", binding " + std::to_string(b.binding) +
                               " is declared differently by the vertex shader (" + toString(it->type) +
                               ") and the fragment shader (" + toString(b.type) + ")");
                return {};
            } else {
                it->writes = it->writes || b.writes;
            }
        }
        sortBindings(layout->bindings);
        layout->pushConstantSize =
            std::max(vs->reflection->pushConstantSize, fs->reflection->pushConstantSize);
        layout->colorFormats = desc.colorFormats;
        layout->depthFormat = desc.depthFormat;
        layout->vertexBuffers = desc.vertexBuffers;
        PipelineHandle h = m_inner->createGraphicsPipeline(desc);
        if (h) m_pipelines.add(h.value, PipelineInfo{std::move(layout)});
        return h;
    }

    BindGroupHandle createBindGroup(const BindGroupDesc& desc) override {
        const char* fn = "createBindGroup";
        const std::string name = "bind group " + quoted(desc.debugName);
        PipelineInfo* p = pipeline(desc.pipeline, fn, "pipeline");
        if (!p) return {};
        const PipelineLayout& layout = *p->layout;
        if (desc.set >= kMaxBindGroups) {
            report(fn, name + " has set " + std::to_string(desc.set) + ", beyond kMaxBindGroups (" +
                           std::to_string(kMaxBindGroups) + ")");
            return {};
        }
        const std::string where =
            name + " (pipeline " + quoted(layout.debugName) + ", set " + std::to_string(desc.set) + ")";
        bool ok = true;
        for (size_t i = 0; i < desc.entries.size(); ++i) {
            const BindGroupEntry& e = desc.entries[i];
            const std::string entryName = where + " binding " + std::to_string(e.binding);
            const ShaderBinding* b = layout.find(desc.set, e.binding);
            if (!b) {
                report(fn, entryName + " is not declared by the pipeline's shaders");
                ok = false;
                continue;
            }
            if (e.arrayElement >= b->count) {
                report(fn, entryName + " array element " + std::to_string(e.arrayElement) +
                               " is beyond the array size " + std::to_string(b->count));
                ok = false;
                continue;
            }
            bool duplicate = false;
            for (size_t j = 0; j < i; ++j)
                duplicate |=
                    desc.entries[j].binding == e.binding && desc.entries[j].arrayElement == e.arrayElement;
            if (duplicate) {
                report(fn, entryName + " ('" + b->name + "') appears twice");
                ok = false;
                continue;
            }
            ok &= checkEntry(fn, entryName + " ('" + std::string(b->name) + "')", *b, e);
        }
        for (const ShaderBinding& b : layout.bindings) {
            if (b.set != desc.set) continue;
            for (uint32_t element = 0; element < b.count; ++element) {
                const bool present =
                    std::any_of(desc.entries.begin(), desc.entries.end(), [&](const BindGroupEntry& e) {
                        return e.binding == b.binding && e.arrayElement == element;
                    });
                if (!present) {
                    report(fn, where + " has no entry for binding " + std::to_string(b.binding) + " ('" +
                                   b.name + "'" +
                                   (b.count > 1 ? ", element " + std::to_string(element) : std::string()) +
                                   ", " + toString(b.type) + ")");
                    ok = false;
                }
            }
        }
        if (!ok) return {};
        BindGroupHandle h = m_inner->createBindGroup(desc);
        if (h) {
            auto info = std::make_shared<BindGroupInfo>();
            info->debugName = desc.debugName;
            info->set = desc.set;
            info->layout = p->layout;
            info->entries = desc.entries;
            m_bindGroups.add(h.value, std::move(info));
        }
        return h;
    }

    QueryPoolHandle createQueryPool(const QueryPoolDesc& desc) override {
        if (desc.count == 0) {
            report("createQueryPool", "query pool " + quoted(desc.debugName) + " has 0 slots");
            return {};
        }
        QueryPoolHandle h = m_inner->createQueryPool(desc);
        if (h) m_queryPools.add(h.value, QueryPoolInfo{desc});
        return h;
    }

    // --- destruction -----------------------------------------------------------------------------
#define RHI_DESTROY(Handle, pool, name) \
    void destroy(Handle h) override { destroyIn(pool, h, name); }
    RHI_RESOURCE_KINDS(RHI_DESTROY)
#undef RHI_DESTROY

    bool isAlive(BufferHandle h) const override { return m_inner->isAlive(h); }
    bool isAlive(TextureHandle h) const override { return m_inner->isAlive(h); }
    bool isAlive(SamplerHandle h) const override { return m_inner->isAlive(h); }
    bool isAlive(ShaderHandle h) const override { return m_inner->isAlive(h); }
    bool isAlive(PipelineHandle h) const override { return m_inner->isAlive(h); }
    bool isAlive(BindGroupHandle h) const override { return m_inner->isAlive(h); }
    bool isAlive(QueryPoolHandle h) const override { return m_inner->isAlive(h); }

    const BufferDesc* describe(BufferHandle h) const override { return m_inner->describe(h); }
    const TextureDesc* describe(TextureHandle h) const override { return m_inner->describe(h); }

    // --- uploads ---------------------------------------------------------------------------------
    void writeBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) override {
        const char* fn = "writeBuffer";
        BufferInfo* b = buffer(dst, fn, "dst");
        if (!b) return;
        if (!checkRange(fn, *b, offset, size)) return;
        if (size > 0 && !data) {
            report(fn, "data is null for " + std::to_string(size) + " bytes");
            return;
        }
        m_inner->writeBuffer(dst, offset, data, size);
    }

    void writeTexture(TextureHandle dst, TextureSubresource sub, const void* data, uint64_t size) override {
        const char* fn = "writeTexture";
        TextureInfo* t = texture(dst, fn, "dst");
        if (!t) return;
        if (!checkSubresource(fn, *t, sub)) return;
        const uint64_t expected = subresourceSize(t->desc, sub.mip);
        if (size != expected) {
            report(fn, "texture " + quoted(t->desc.debugName) + " mip " + std::to_string(sub.mip) +
                           " needs exactly " + std::to_string(expected) +
                           " bytes of tightly packed texels, got " + std::to_string(size));
            return;
        }
        if (!data) {
            report(fn, "data is null");
            return;
        }
        m_inner->writeTexture(dst, sub, data, size);
        t->states.setAll(Access::ShaderSampled);
    }

    void writeTextureRegion(TextureHandle dst, const TextureRegion& region, const void* data,
                            uint64_t size) override {
        const char* fn = "writeTextureRegion";
        TextureInfo* t = texture(dst, fn, "dst");
        if (!t) return;
        TextureRegion box;
        std::string why;
        if (!resolveRegion(t->desc, region, box, why)) {
            report(fn, "texture " + quoted(t->desc.debugName) + ": " + why);
            return;
        }
        const uint64_t expected = regionBytes(t->desc, box);
        if (size != expected || !data) {
            report(fn, "texture " + quoted(t->desc.debugName) + " region of " + std::to_string(box.width) +
                           "x" + std::to_string(box.height) + "x" + std::to_string(box.depth) +
                           " needs exactly " + std::to_string(expected) +
                           " bytes of tightly packed texels, got " + std::to_string(size) +
                           (data ? "" : " (null pointer)"));
            return;
        }
        m_inner->writeTextureRegion(dst, region, data, size);
        t->states.setAll(Access::ShaderSampled);
    }

    void* mappedPointer(BufferHandle h) override {
        if (!buffer(h, "mappedPointer", "buffer")) return nullptr;
        return m_inner->mappedPointer(h);
    }

    // --- submission ------------------------------------------------------------------------------
    CommandList& beginCommandList(std::string_view debugName) override {
        CommandList& inner = m_inner->beginCommandList(debugName);
        m_openLists.push_back(std::make_unique<ValidationCommandList>(*this, inner));
        return *m_openLists.back();
    }

    uint64_t submit(CommandList& list) override {
        const char* fn = "submit";
        auto it =
            std::find_if(m_openLists.begin(), m_openLists.end(),
                         [&](const std::unique_ptr<ValidationCommandList>& l) { return l.get() == &list; });
        if (it == m_openLists.end()) {
            report(fn, "the command list was not begun on this device or was already submitted");
            return 0;
        }
        std::unique_ptr<ValidationCommandList> owned = std::move(*it);
        m_openLists.erase(it);
        if (owned->inRenderPass())
            report(fn, "the command list still has an open render pass (missing endRenderPass)");
        if (owned->debugDepth() > 0)
            report(fn, "the command list has " + std::to_string(owned->debugDepth()) +
                           " unbalanced pushDebugGroup (missing popDebugGroup)");
        owned->closeForSubmit();
        const uint64_t serial = m_inner->submit(owned->inner());
        m_lastSerial = std::max(m_lastSerial, serial);
        return serial;
    }

    void waitForSubmission(uint64_t serial) override {
        if (serial > m_lastSerial) {
            report("waitForSubmission",
                   "serial " + std::to_string(serial) + " was never returned by submit()");
            return;
        }
        m_inner->waitForSubmission(serial);
    }

    void waitIdle() override { m_inner->waitIdle(); }
    void collectGarbage() override { m_inner->collectGarbage(); }

    // --- readback --------------------------------------------------------------------------------
    bool readBuffer(BufferHandle src, uint64_t offset, uint64_t size, void* out) override {
        const char* fn = "readBuffer";
        BufferInfo* b = buffer(src, fn, "src");
        if (!b) return false;
        if (!checkRange(fn, *b, offset, size)) return false;
        if (size > 0 && !out) {
            report(fn, "output pointer is null");
            return false;
        }
        return m_inner->readBuffer(src, offset, size, out);
    }

    bool readTexture(TextureHandle src, TextureSubresource sub, Access currentAccess,
                     std::vector<uint8_t>& out) override {
        const char* fn = "readTexture";
        TextureInfo* t = texture(src, fn, "src");
        if (!t) return false;
        if (!checkSubresource(fn, *t, sub)) return false;
        const Access tracked = t->states.get(sub.mip, sub.layer);
        if (currentAccess != tracked) {
            report(fn, "texture " + quoted(t->desc.debugName) + " is passed as being in state " +
                           toString(currentAccess) + " but its tracked state (last barrier / upload) is " +
                           toString(tracked));
            return false;
        }
        return m_inner->readTexture(src, sub, currentAccess, out);
    }

    bool readTimestamps(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs) override {
        return checkTimestampRead("readTimestamps", pool, first, count, outNs) &&
               m_inner->readTimestamps(pool, first, count, outNs);
    }

    bool tryReadTimestamps(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs) override {
        return checkTimestampRead("tryReadTimestamps", pool, first, count, outNs) &&
               m_inner->tryReadTimestamps(pool, first, count, outNs);
    }

    bool checkTimestampRead(const char* fn, QueryPoolHandle pool, uint32_t first, uint32_t count,
                            const uint64_t* outNs) {
        QueryPoolInfo* q = queryPool(pool, fn, "pool");
        if (!q) return false;
        if (!rangeInside(first, count, q->desc.count)) {
            report(fn, "queries [" + std::to_string(first) + ", +" + std::to_string(count) +
                           ") exceed query pool " + quoted(q->desc.debugName) + " of " +
                           std::to_string(q->desc.count));
            return false;
        }
        if (count > 0 && !outNs) {
            report(fn, "output pointer is null");
            return false;
        }
        return true;
    }

    DeviceStats stats() const override { return m_inner->stats(); }
    FormatSupport formatSupport(Format format) const override { return m_inner->formatSupport(format); }

    // --- presentation ----------------------------------------------------------------------------
    TextureHandle acquireBackbuffer() override {
        TextureHandle h = m_inner->acquireBackbuffer();
        if (h) {
            Registry<TextureInfo>::Slot* slot = nullptr;
            if (m_textures.lookup(h.value, &slot) != Registry<TextureInfo>::Status::Alive) adoptTexture(h);
        }
        return h;
    }
    Format backbufferFormat() const override { return m_inner->backbufferFormat(); }
    bool present() override { return m_inner->present(); }
    void resizeBackbuffer(uint32_t width, uint32_t height) override {
        if (width == 0 || height == 0) {
            report("resizeBackbuffer",
                   "size " + std::to_string(width) + "x" + std::to_string(height) + " is empty");
            return;
        }
        m_inner->resizeBackbuffer(width, height);
    }

    // --- helpers shared with the command list ----------------------------------------------------
    bool checkRange(const char* fn, const BufferInfo& b, uint64_t offset, uint64_t size) {
        if (rangeInside(offset, size, b.desc.size)) return true;
        report(fn, "range [" + std::to_string(offset) + ", +" + std::to_string(size) + ") exceeds buffer " +
                       quoted(b.desc.debugName) + " of " + std::to_string(b.desc.size) + " bytes");
        return false;
    }

    bool checkSubresource(const char* fn, const TextureInfo& t, TextureSubresource sub) {
        if (subresourceExists(t.desc, sub)) return true;
        report(fn, "texture " + quoted(t.desc.debugName) + " has no mip " + std::to_string(sub.mip) +
                       " layer " + std::to_string(sub.layer) + " (" + std::to_string(t.desc.mipLevels) +
                       " mips, " + std::to_string(arrayLayers(t.desc)) + " layers)");
        return false;
    }

    uint64_t lastSerial() const { return m_lastSerial; }

private:
    static void sortBindings(std::vector<ShaderBinding>& bindings) {
        std::sort(bindings.begin(), bindings.end(), [](const ShaderBinding& a, const ShaderBinding& b) {
            return a.set != b.set ? a.set < b.set : a.binding < b.binding;
        });
    }

    // One bind-group entry against its reflected binding; reports each problem.
    bool checkEntry(const char* fn, const std::string& entryName, const ShaderBinding& b,
                    const BindGroupEntry& e) {
        if (isBufferBinding(b.type)) {
            if (!e.buffer || e.texture) {
                report(fn, entryName + " is a " + toString(b.type) + " binding but the entry " +
                               (e.texture ? "gives a texture" : "gives no buffer"));
                return false;
            }
            BufferInfo* buf = buffer(e.buffer, fn, "entry buffer");
            if (!buf) return false;
            const BufferUsage needed =
                b.type == BindingType::UniformBuffer ? BufferUsage::Uniform : BufferUsage::Storage;
            if (!any(buf->desc.usage & needed)) {
                report(fn, entryName + " binds buffer " + quoted(buf->desc.debugName) + " as a " +
                               toString(b.type) + " but it was created without " +
                               (needed == BufferUsage::Uniform ? "Uniform" : "Storage") + " usage");
                return false;
            }
            const uint64_t size =
                e.size ? e.size : (e.offset < buf->desc.size ? buf->desc.size - e.offset : 0);
            if (!rangeInside(e.offset, size, buf->desc.size) || size == 0) {
                report(fn, entryName + " range [" + std::to_string(e.offset) + ", +" +
                               std::to_string(e.size) + ") exceeds buffer " + quoted(buf->desc.debugName) +
                               " of " + std::to_string(buf->desc.size) + " bytes");
                return false;
            }
            const uint64_t maxRange = b.type == BindingType::UniformBuffer
                                          ? info().limits.maxUniformBufferRange
                                          : info().limits.maxStorageBufferRange;
            if (maxRange && size > maxRange) {
                report(fn, entryName + " binds " + std::to_string(size) +
                               " bytes, more than the device's limit of " + std::to_string(maxRange) +
                               " for a " + toString(b.type));
                return false;
            }
            return true;
        }
        // Texture bindings.
        if (!e.texture || e.buffer) {
            report(fn, entryName + " is a " + toString(b.type) + " binding but the entry " +
                           (e.buffer ? "gives a buffer" : "gives no texture"));
            return false;
        }
        TextureInfo* tex = texture(e.texture, fn, "entry texture");
        if (!tex) return false;
        const std::string texName = "texture " + quoted(tex->desc.debugName);
        if (tex->desc.dimension != b.textureDimension) {
            report(fn, entryName + " expects a " + toString(b.textureDimension) + " texture but " + texName +
                           " is " + toString(tex->desc.dimension));
            return false;
        }
        if (b.type == BindingType::SampledTexture) {
            if (!any(tex->desc.usage & TextureUsage::Sampled)) {
                report(fn, entryName + " samples " + texName + " but it was created without Sampled usage");
                return false;
            }
            if (!e.sampler) {
                report(fn, entryName + " is a SampledTexture binding but the entry has no sampler");
                return false;
            }
            return checkEntryRange(fn, entryName, texName, *tex, e, false) &&
                   sampler(e.sampler, fn, "entry sampler") != nullptr;
        }
        if (!any(tex->desc.usage & TextureUsage::Storage)) {
            report(fn, entryName + " binds " + texName +
                           " as a storage image but it was created without Storage usage");
            return false;
        }
        if (e.mip >= tex->desc.mipLevels) {
            report(fn, entryName + " binds mip " + std::to_string(e.mip) + " of " + texName + ", which has " +
                           std::to_string(tex->desc.mipLevels) + " mip levels");
            return false;
        }
        if (b.storageFormat != Format::Undefined && b.storageFormat != tex->desc.format) {
            report(fn, entryName + " declares storage format " + formatInfo(b.storageFormat).name + " but " +
                           texName + " has format " + formatInfo(tex->desc.format).name);
            return false;
        }
        return checkEntryRange(fn, entryName, texName, *tex, e, true);
    }

    bool checkEntryRange(const char* fn, const std::string& entryName, const std::string& texName,
                         const TextureInfo& tex, const BindGroupEntry& e, bool storage) {
        TextureRange range;
        std::string why;
        if (entryRange(tex.desc, e, storage, range, why)) return true;
        report(fn, entryName + " views " + texName + ": " + why);
        return false;
    }

    void adoptTexture(TextureHandle h) {
        if (const TextureDesc* d = m_inner->describe(h))
            m_textures.add(h.value, TextureInfo{*d, SubresourceStates(*d)});
    }
    void adoptBuffer(BufferHandle h) {
        if (const BufferDesc* d = m_inner->describe(h))
            m_buffers.add(h.value, BufferInfo{*d, true, Access::None});
    }

    template <typename Info, typename Tag>
    Info* resolve(Registry<Info>& reg, Handle<Tag> h, const char* fn, const char* kind, const char* role) {
        using Status = typename Registry<Info>::Status;
        typename Registry<Info>::Slot* slot = nullptr;
        Status status = reg.lookup(h.value, &slot);
        if (status == Status::Alive && !m_inner->isAlive(h)) {
            slot->alive = false;  // destroyed inside the backend (swapchain images on resize)
            status = Status::Destroyed;
        }
        if (status == Status::Foreign && m_inner->isAlive(h)) {
            // Objects the backend created itself (backbuffers) are adopted on first use.
            if constexpr (std::is_same_v<Info, TextureInfo>) adoptTexture(h);
            if constexpr (std::is_same_v<Info, BufferInfo>) adoptBuffer(h);
            status = reg.lookup(h.value, &slot);
        }
        const std::string what =
            std::string(kind) + (role && *role ? std::string(" (") + role + ")" : std::string());
        switch (status) {
            case Status::Alive:
                return &slot->info;
            case Status::Null:
                report(fn, "invalid (null) " + what + " handle");
                break;
            case Status::Destroyed:
                report(fn, "stale " + what + " handle " + hex(h.value) + " (" + quoted(nameOf(slot->info)) +
                               "): it was destroyed");
                break;
            case Status::Older:
                report(fn, "stale " + what + " handle " + hex(h.value) + ": generation " +
                               std::to_string(h.generation()) +
                               " of its slot was destroyed and the slot has been reused");
                break;
            case Status::Foreign:
                report(fn, what + " handle " + hex(h.value) +
                               " was not created by this device (a handle from another device?)");
                break;
        }
        return nullptr;
    }

    template <typename Info, typename Tag>
    void destroyIn(Registry<Info>& reg, Handle<Tag> h, const char* kind) {
        using Status = typename Registry<Info>::Status;
        typename Registry<Info>::Slot* slot = nullptr;
        const Status status = reg.lookup(h.value, &slot);
        if (status == Status::Destroyed || status == Status::Older) {
            report("destroy", std::string(kind) + " " + hex(h.value) +
                                  (slot ? " (" + quoted(nameOf(slot->info)) + ")" : std::string()) +
                                  " was already destroyed (double destroy)");
            return;
        }
        if (!resolve(reg, h, "destroy", kind, "")) return;
        reg.lookup(h.value, &slot);
        slot->alive = false;
        m_inner->destroy(h);
    }

    std::unique_ptr<Device> m_inner;
    LogCallback m_log;
    std::shared_ptr<uint64_t> m_errorCounter;
    Registry<BufferInfo> m_buffers;
    Registry<TextureInfo> m_textures;
    Registry<SamplerInfo> m_samplers;
    Registry<ShaderInfo> m_shaders;
    Registry<PipelineInfo> m_pipelines;
    Registry<std::shared_ptr<const BindGroupInfo>> m_bindGroups;
    Registry<QueryPoolInfo> m_queryPools;
    std::vector<std::unique_ptr<ValidationCommandList>> m_openLists;
    uint64_t m_lastSerial = 0;

public:
    // --- resource state tracking (used by the command list) --------------------------------------

    // A use of a buffer by a command. `accepted`: states that allow it; `suggested`: the state a
    // barrier should move it to; `write`: whether the use writes it (ends host initialisation).
    void useBuffer(const char* fn, BufferInfo& b, const std::string& where, const char* verb, Access accepted,
                   Access suggested, bool write) {
        if (b.hostInitialised) {
            if (write) {
                b.hostInitialised = false;
                b.state = suggested;
            }
            return;
        }
        if (any(b.state & accepted)) return;
        report(fn, "buffer " + quoted(b.desc.debugName) + where + " " + verb + " but its state is " +
                       toString(b.state) + "; add a barrier " + toString(b.state) + " -> " +
                       toString(suggested));
    }

    // A use of the subresources `range` of a texture; each must be in an accepted state. One
    // report per run of subresources sharing a wrong state (the range is named unless whole).
    void useTexture(const char* fn, TextureInfo& t, TextureRange range, const std::string& where,
                    const char* verb, Access accepted, Access suggested) {
        TextureRange r;
        if (!resolveRange(t.desc, range, r)) return;  // ranges are checked where they are given
        t.states.forEachRun(r, [&](const TextureRange& run, Access state) {
            if (any(state & accepted)) return;
            const std::string sub = run == t.states.whole() ? std::string() : " (" + describeRange(run) + ")";
            report(fn, "texture " + quoted(t.desc.debugName) + sub + where + " " + verb +
                           " but its state is " + toString(state) + "; add a barrier " + toString(state) +
                           " -> " + toString(suggested));
        });
    }

    // False: the barrier names a range the texture does not have (reported; drop the barrier).
    bool applyBarrier(const char* fn, const Barrier& b) {
        if (b.buffer) {
            BufferInfo* info = buffer(b.buffer, fn, "barrier");
            if (!info) return false;
            if (!info->hostInitialised && b.before != Access::None && b.before != info->state) {
                report(fn, "buffer " + quoted(info->desc.debugName) + " barrier says before = " +
                               toString(b.before) + " but its tracked state is " + toString(info->state));
            }
            info->hostInitialised = false;
            info->state = b.after;
            return true;
        }
        TextureInfo* info = texture(b.texture, fn, "barrier");
        if (!info) return false;
        TextureRange r;
        if (!resolveRange(info->desc, b.range, r)) {
            report(fn, "texture " + quoted(info->desc.debugName) + " barrier names mips " +
                           std::to_string(b.range.baseMip) + " +" + countText(b.range.mipCount) +
                           ", layers " + std::to_string(b.range.baseLayer) + " +" +
                           countText(b.range.layerCount) + " but the texture has " +
                           std::to_string(info->desc.mipLevels) + " mips and " +
                           std::to_string(info->states.layers()) + " layers");
            return false;
        }
        if (b.before != Access::None) {
            info->states.forEachRun(r, [&](const TextureRange& run, Access state) {
                if (state == b.before) return;
                const std::string sub =
                    run == info->states.whole() ? std::string() : " (" + describeRange(run) + ")";
                report(fn, "texture " + quoted(info->desc.debugName) + sub + " barrier says before = " +
                               toString(b.before) + " but its tracked state is " + toString(state));
            });
        }
        info->states.set(r, b.after);
        return true;
    }

    static std::string countText(uint32_t count) {
        return count == kRemaining ? std::string("all") : std::to_string(count);
    }
};

// --- ValidationCommandList ---------------------------------------------------------------------------

void ValidationCommandList::barrier(std::span<const Barrier> barriers) {
    const char* fn = "barrier";
    if (m_inPass) m_device.report(fn, "barriers are not allowed inside a render pass");
    std::vector<Barrier> kept;
    kept.reserve(barriers.size());
    for (const Barrier& b : barriers) {
        if (b.buffer.isValid() == b.texture.isValid()) {
            m_device.report(fn, b.buffer ? "a barrier names both a buffer and a texture"
                                         : "a barrier names neither a buffer nor a texture");
            continue;
        }
        if (b.buffer ? !m_device.buffer(b.buffer, fn, "barrier")
                     : !m_device.texture(b.texture, fn, "barrier"))
            continue;
        if (m_device.applyBarrier(fn, b)) kept.push_back(b);
    }
    if (!kept.empty()) m_inner.barrier(kept);
}

void ValidationCommandList::updateBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) {
    const char* fn = "updateBuffer";
    BufferInfo* b = m_device.buffer(dst, fn, "dst");
    if (!b) return;
    if (size == 0 || size > 65536 || size % 4 != 0 || offset % 4 != 0) {
        m_device.report(fn,
                        "size " + std::to_string(size) + " at offset " + std::to_string(offset) +
                            " is invalid: size must be 4..65536 and a multiple of 4, offset a multiple of 4");
        return;
    }
    if (!m_device.checkRange(fn, *b, offset, size)) return;
    if (!data) {
        m_device.report(fn, "data is null");
        return;
    }
    if (m_inPass) {
        m_device.report(fn, "transfers are not allowed inside a render pass");
        return;
    }
    m_device.useBuffer(fn, *b, "", "is a copy destination", Access::CopyDst, Access::CopyDst, true);
    m_inner.updateBuffer(dst, offset, data, size);
}

void ValidationCommandList::copyBuffer(BufferHandle src, uint64_t srcOffset, BufferHandle dst,
                                       uint64_t dstOffset, uint64_t size) {
    const char* fn = "copyBuffer";
    BufferInfo* s = m_device.buffer(src, fn, "src");
    BufferInfo* d = m_device.buffer(dst, fn, "dst");
    if (!s || !d) return;
    if (!m_device.checkRange(fn, *s, srcOffset, size) || !m_device.checkRange(fn, *d, dstOffset, size))
        return;
    if (src == dst && srcOffset < dstOffset + size && dstOffset < srcOffset + size) {
        m_device.report(fn,
                        "source and destination ranges of buffer " + quoted(s->desc.debugName) + " overlap");
        return;
    }
    if (m_inPass) {
        m_device.report(fn, "transfers are not allowed inside a render pass");
        return;
    }
    m_device.useBuffer(fn, *s, " (src)", "is a copy source", Access::CopySrc, Access::CopySrc, false);
    m_device.useBuffer(fn, *d, " (dst)", "is a copy destination", Access::CopyDst, Access::CopyDst, true);
    m_inner.copyBuffer(src, srcOffset, dst, dstOffset, size);
}

void ValidationCommandList::fillBuffer(BufferHandle dst, uint64_t offset, uint64_t size, uint32_t value) {
    const char* fn = "fillBuffer";
    BufferInfo* b = m_device.buffer(dst, fn, "dst");
    if (!b) return;
    if (offset % 4 != 0 || size % 4 != 0) {
        m_device.report(fn, "offset " + std::to_string(offset) + " and size " + std::to_string(size) +
                                " must be multiples of 4");
        return;
    }
    if (!m_device.checkRange(fn, *b, offset, size)) return;
    if (m_inPass) {
        m_device.report(fn, "transfers are not allowed inside a render pass");
        return;
    }
    m_device.useBuffer(fn, *b, "", "is a copy destination", Access::CopyDst, Access::CopyDst, true);
    m_inner.fillBuffer(dst, offset, size, value);
}

void ValidationCommandList::copyTexture(TextureHandle src, const TextureRegion& srcRegion, TextureHandle dst,
                                        const TextureRegion& dstRegion) {
    const char* fn = "copyTexture";
    TextureInfo* s = m_device.texture(src, fn, "src");
    TextureInfo* d = s ? m_device.texture(dst, fn, "dst") : nullptr;
    if (!s || !d) return;
    if (!any(s->desc.usage & TextureUsage::CopySrc) || !any(d->desc.usage & TextureUsage::CopyDst)) {
        m_device.report(fn, "texture " + quoted(s->desc.debugName) + " needs CopySrc usage and texture " +
                                quoted(d->desc.debugName) + " CopyDst usage");
        return;
    }
    TextureRegion a, b;
    std::string why;
    if (!checkTextureCopy(s->desc, srcRegion, d->desc, dstRegion, s == d, a, b, why)) {
        m_device.report(fn, quoted(s->desc.debugName) + " -> " + quoted(d->desc.debugName) + ": " + why);
        return;
    }
    if (m_inPass) {
        m_device.report(fn, "transfers are not allowed inside a render pass");
        return;
    }
    m_device.useTexture(fn, *s, TextureRange{a.mip, 1, a.layer, 1}, " (src)", "is a copy source",
                        Access::CopySrc, Access::CopySrc);
    m_device.useTexture(fn, *d, TextureRange{b.mip, 1, b.layer, 1}, " (dst)", "is a copy destination",
                        Access::CopyDst, Access::CopyDst);
    m_inner.copyTexture(src, srcRegion, dst, dstRegion);
}

void ValidationCommandList::copyBufferToTexture(BufferHandle src, uint64_t srcOffset, TextureHandle dst,
                                                const TextureRegion& dstRegion) {
    const char* fn = "copyBufferToTexture";
    BufferInfo* s = m_device.buffer(src, fn, "src");
    TextureInfo* d = s ? m_device.texture(dst, fn, "dst") : nullptr;
    if (!s || !d) return;
    if (!any(s->desc.usage & BufferUsage::CopySrc) || !any(d->desc.usage & TextureUsage::CopyDst)) {
        m_device.report(fn, "buffer " + quoted(s->desc.debugName) + " needs CopySrc usage and texture " +
                                quoted(d->desc.debugName) + " CopyDst usage");
        return;
    }
    TextureRegion box;
    std::string why;
    if (!checkBufferToTexture(s->desc.size, srcOffset, d->desc, dstRegion, box, why)) {
        m_device.report(fn, quoted(s->desc.debugName) + " -> " + quoted(d->desc.debugName) + ": " + why);
        return;
    }
    if (m_inPass) {
        m_device.report(fn, "transfers are not allowed inside a render pass");
        return;
    }
    m_device.useBuffer(fn, *s, " (src)", "is a copy source", Access::CopySrc, Access::CopySrc, false);
    m_device.useTexture(fn, *d, TextureRange{box.mip, 1, box.layer, 1}, " (dst)", "is a copy destination",
                        Access::CopyDst, Access::CopyDst);
    m_inner.copyBufferToTexture(src, srcOffset, dst, dstRegion);
}

void ValidationCommandList::bindPipeline(PipelineHandle pipeline) {
    PipelineInfo* p = m_device.pipeline(pipeline, "bindPipeline", "pipeline");
    if (!p) return;
    m_pipeline = p->layout;
    m_vertexBound.assign(p->layout->vertexBuffers.size(), false);
    m_inner.bindPipeline(pipeline);
}

void ValidationCommandList::bindGroup(uint32_t set, BindGroupHandle group) {
    const char* fn = "bindGroup";
    if (set >= kMaxBindGroups) {
        m_device.report(fn, "out-of-range bind: set " + std::to_string(set) + " >= kMaxBindGroups (" +
                                std::to_string(kMaxBindGroups) + ")");
        return;
    }
    std::shared_ptr<const BindGroupInfo>* g = m_device.bindGroup(group, fn, "group");
    if (!g) return;
    if ((*g)->set != set) {
        m_device.report(fn, "bind group " + quoted((*g)->debugName) + " was created for set " +
                                std::to_string((*g)->set) + " but is bound to set " + std::to_string(set));
        return;
    }
    m_groups[set] = BoundGroup{group, *g};
    m_inner.bindGroup(set, group);
}

void ValidationCommandList::pushConstants(const void* data, uint32_t size, uint32_t offset) {
    const char* fn = "pushConstants";
    if (!m_pipeline) {
        m_device.report(fn, "no pipeline is bound");
        return;
    }
    if (!rangeInside(offset, size, kMaxPushConstantSize)) {
        m_device.report(fn, "range [" + std::to_string(offset) + ", +" + std::to_string(size) +
                                ") exceeds kMaxPushConstantSize (" + std::to_string(kMaxPushConstantSize) +
                                ")");
        return;
    }
    if (!rangeInside(offset, size, m_pipeline->pushConstantSize)) {
        m_device.report(fn, "range [" + std::to_string(offset) + ", +" + std::to_string(size) +
                                ") exceeds the " + std::to_string(m_pipeline->pushConstantSize) +
                                " bytes of push constants of pipeline " + quoted(m_pipeline->debugName));
        return;
    }
    if (size % 4 != 0 || offset % 4 != 0) {
        m_device.report(fn, "offset " + std::to_string(offset) + " and size " + std::to_string(size) +
                                " must be multiples of 4");
        return;
    }
    if (size > 0 && !data) {
        m_device.report(fn, "data is null");
        return;
    }
    m_inner.pushConstants(data, size, offset);
}

bool ValidationCommandList::checkBindings(const char* fn) {
    bool ok = true;
    for (uint32_t set = 0; set < kMaxBindGroups; ++set) {
        if (!m_pipeline->declaresSet(set)) continue;
        const BoundGroup& bound = m_groups[set];
        if (!bound.info) {
            m_device.report(fn, "pipeline " + quoted(m_pipeline->debugName) + " declares set " +
                                    std::to_string(set) + " but no bind group was bound to it");
            ok = false;
            continue;
        }
        // Set layouts must match: the group was laid out by another pipeline's reflection.
        const PipelineLayout& groupLayout = *bound.info->layout;
        if (&groupLayout == m_pipeline.get()) continue;
        bool same = true;
        std::vector<const ShaderBinding*> a, b;
        for (const ShaderBinding& x : m_pipeline->bindings)
            if (x.set == set) a.push_back(&x);
        for (const ShaderBinding& x : groupLayout.bindings)
            if (x.set == set) b.push_back(&x);
        same = a.size() == b.size();
        for (size_t i = 0; same && i < a.size(); ++i)
            same = a[i]->binding == b[i]->binding && a[i]->type == b[i]->type && a[i]->count == b[i]->count &&
                   a[i]->textureDimension == b[i]->textureDimension;
        if (!same) {
            m_device.report(fn, "bind group " + quoted(bound.info->debugName) + " at set " +
                                    std::to_string(set) + " was created for pipeline " +
                                    quoted(groupLayout.debugName) + ", whose set " + std::to_string(set) +
                                    " layout differs from pipeline " + quoted(m_pipeline->debugName) + "'s");
            ok = false;
        }
    }
    return ok;
}

void ValidationCommandList::checkResourceStates(const char* fn) {
    struct PendingWrite {
        BufferInfo* buffer;
    };
    std::vector<PendingWrite> writes;
    for (uint32_t set = 0; set < kMaxBindGroups; ++set) {
        const BoundGroup& bound = m_groups[set];
        if (!bound.info || !m_pipeline->declaresSet(set)) continue;
        for (const BindGroupEntry& e : bound.info->entries) {
            const ShaderBinding* b = m_pipeline->find(set, e.binding);
            if (!b) continue;
            const std::string where =
                " (set " + std::to_string(set) + ", binding " + std::to_string(e.binding) + ")";
            if (isBufferBinding(b->type)) {
                BufferInfo* buf = m_device.buffer(e.buffer, fn, "bind group entry");
                if (!buf) continue;
                switch (b->type) {
                    case BindingType::UniformBuffer:
                        m_device.useBuffer(fn, *buf, where, "is read as a uniform buffer",
                                           Access::UniformRead, Access::UniformRead, false);
                        break;
                    case BindingType::ReadOnlyStorageBuffer:
                        m_device.useBuffer(fn, *buf, where, "is read as a storage buffer", Access::ShaderRead,
                                           Access::ShaderRead, false);
                        break;
                    default:
                        if (b->writes) {
                            // Checked now, applied after every binding was checked against the
                            // state before this command.
                            if (!buf->hostInitialised)
                                m_device.useBuffer(fn, *buf, where, "is written as a storage buffer",
                                                   Access::ShaderWrite, Access::ShaderWrite, true);
                            writes.push_back({buf});
                        } else {
                            m_device.useBuffer(fn, *buf, where, "is accessed as a storage buffer",
                                               Access::ShaderRead | Access::ShaderWrite, Access::ShaderRead,
                                               false);
                        }
                        break;
                }
            } else {
                TextureInfo* tex = m_device.texture(e.texture, fn, "bind group entry");
                if (!tex) continue;
                TextureRange range;  // the subresources the entry views (checked at creation)
                std::string why;
                if (!entryRange(tex->desc, e, b->type == BindingType::StorageTexture, range, why)) continue;
                if (b->type == BindingType::SampledTexture) {
                    m_device.useTexture(fn, *tex, range, where, "is sampled", Access::ShaderSampled,
                                        Access::ShaderSampled);
                } else if (b->writes) {
                    m_device.useTexture(fn, *tex, range, where, "is written as a storage image",
                                        Access::ShaderWrite, Access::ShaderWrite);
                } else {
                    m_device.useTexture(fn, *tex, range, where, "is read as a storage image",
                                        Access::ShaderRead | Access::ShaderWrite, Access::ShaderRead);
                }
            }
        }
    }
    for (const PendingWrite& w : writes) {
        if (w.buffer->hostInitialised) {
            w.buffer->hostInitialised = false;
            w.buffer->state = Access::ShaderWrite;
        }
    }
}

bool ValidationCommandList::checkIndirect(const char* fn, BufferHandle args, uint64_t offset,
                                          uint64_t bytes) {
    BufferInfo* b = m_device.buffer(args, fn, "args");
    if (!b) return false;
    if (!any(b->desc.usage & BufferUsage::Indirect)) {
        m_device.report(fn, "buffer " + quoted(b->desc.debugName) +
                                " is used for indirect arguments but was created "
                                "without Indirect usage");
        return false;
    }
    if (offset % 4 != 0) {
        m_device.report(fn, "offset " + std::to_string(offset) + " must be a multiple of 4");
        return false;
    }
    if (!m_device.checkRange(fn, *b, offset, bytes)) return false;
    m_device.useBuffer(fn, *b, " (args)", "is read as indirect arguments", Access::IndirectRead,
                       Access::IndirectRead, false);
    return true;
}

void ValidationCommandList::dispatch(uint32_t x, uint32_t y, uint32_t z) {
    const char* fn = "dispatch";
    if (!m_pipeline || !m_pipeline->compute) {
        m_device.report(fn, m_pipeline ? "the bound pipeline " + quoted(m_pipeline->debugName) +
                                             " is not a compute pipeline"
                                       : std::string("no compute pipeline is bound"));
        return;
    }
    if (m_inPass) {
        m_device.report(fn, "dispatch inside a render pass");
        return;
    }
    const auto& maxCount = m_device.info().limits.maxComputeWorkgroupCount;
    if (x > maxCount[0] || y > maxCount[1] || z > maxCount[2]) {
        m_device.report(fn, "groups " + std::to_string(x) + "x" + std::to_string(y) + "x" +
                                std::to_string(z) + " exceed the device limit of " +
                                std::to_string(maxCount[0]) + "x" + std::to_string(maxCount[1]) + "x" +
                                std::to_string(maxCount[2]));
        return;
    }
    if (!checkBindings(fn)) return;
    checkResourceStates(fn);
    m_inner.dispatch(x, y, z);
}

void ValidationCommandList::dispatchIndirect(BufferHandle args, uint64_t offset) {
    const char* fn = "dispatchIndirect";
    if (!m_pipeline || !m_pipeline->compute) {
        m_device.report(fn, m_pipeline ? "the bound pipeline " + quoted(m_pipeline->debugName) +
                                             " is not a compute pipeline"
                                       : std::string("no compute pipeline is bound"));
        return;
    }
    if (m_inPass) {
        m_device.report(fn, "dispatch inside a render pass");
        return;
    }
    if (!checkIndirect(fn, args, offset, 12)) return;
    if (!checkBindings(fn)) return;
    checkResourceStates(fn);
    m_inner.dispatchIndirect(args, offset);
}

void ValidationCommandList::beginRenderPass(const RenderPassDesc& desc) {
    const char* fn = "beginRenderPass";
    const std::string pass = "render pass " + quoted(desc.debugName);
    if (m_inPass) {
        m_device.report(fn, "nested render pass: " + pass + " begins while another render pass is open");
        return;
    }
    if (desc.colorAttachments.size() > kMaxColorTargets) {
        m_device.report(fn, pass + " has " + std::to_string(desc.colorAttachments.size()) +
                                " colour attachments, more than kMaxColorTargets");
        return;
    }
    if (desc.colorAttachments.empty() && !desc.depthAttachment.texture) {
        m_device.report(fn, pass + " has no attachments");
        return;
    }
    struct Use {
        TextureInfo* tex;
        std::string where;
        bool depth;
        TextureRange range;  // the attached subresource
    };
    std::vector<Use> uses;
    uint32_t width = 0, height = 0;
    bool ok = true;
    auto checkExtent = [&](const TextureInfo& t, uint32_t mip, const std::string& where) {
        const uint32_t w = mipExtent(t.desc.width, mip), h = mipExtent(t.desc.height, mip);
        if (width == 0) {
            width = w;
            height = h;
        } else if (w != width || h != height) {
            m_device.report(fn, pass + where + " is " + std::to_string(w) + "x" + std::to_string(h) +
                                    " but the other attachments are " + std::to_string(width) + "x" +
                                    std::to_string(height));
            ok = false;
        }
    };
    std::vector<Format> colorFormats;
    for (size_t i = 0; i < desc.colorAttachments.size(); ++i) {
        const ColorAttachment& a = desc.colorAttachments[i];
        const std::string where = " (colour attachment " + std::to_string(i) + ")";
        TextureInfo* t = m_device.texture(a.texture, fn, "colour attachment");
        if (!t) return;
        if (!any(t->desc.usage & TextureUsage::ColorTarget)) {
            m_device.report(fn, "texture " + quoted(t->desc.debugName) + where +
                                    " was created without ColorTarget usage");
            ok = false;
        }
        if (!m_device.checkSubresource(fn, *t,
                                       {a.mip, t->desc.dimension == TextureDimension::Tex3D ? 0 : a.layer}) ||
            (t->desc.dimension == TextureDimension::Tex3D &&
             a.layer >= mipExtent(t->desc.depthOrLayers, a.mip))) {
            ok = false;
            continue;
        }
        checkExtent(*t, a.mip, where);
        colorFormats.push_back(t->desc.format);
        uses.push_back(
            {t, where, false,
             TextureRange{a.mip, 1, t->desc.dimension == TextureDimension::Tex3D ? 0 : a.layer, 1}});
    }
    Format depthFormat = Format::Undefined;
    if (desc.depthAttachment.texture) {
        TextureInfo* t = m_device.texture(desc.depthAttachment.texture, fn, "depth attachment");
        if (!t) return;
        if (!any(t->desc.usage & TextureUsage::DepthTarget) || !formatInfo(t->desc.format).isDepth) {
            m_device.report(fn, "texture " + quoted(t->desc.debugName) +
                                    " (depth attachment) needs a depth format and DepthTarget usage");
            ok = false;
        } else {
            checkExtent(*t, 0, " (depth attachment)");
            depthFormat = t->desc.format;
            uses.push_back({t, " (depth attachment)", true, TextureRange{0, 1, 0, 1}});
        }
    }
    if (!ok) return;
    for (const Use& u : uses) {
        if (!u.depth)
            m_device.useTexture(fn, *u.tex, u.range, u.where, "is rendered to", Access::ColorTarget,
                                Access::ColorTarget);
        else if (desc.depthAttachment.readOnly)
            m_device.useTexture(fn, *u.tex, u.range, u.where, "is a read-only depth target",
                                Access::DepthTargetRead | Access::DepthTargetWrite, Access::DepthTargetRead);
        else
            m_device.useTexture(fn, *u.tex, u.range, u.where, "is a depth target", Access::DepthTargetWrite,
                                Access::DepthTargetWrite);
    }
    m_inPass = true;
    m_passColorFormats = std::move(colorFormats);
    m_passDepthFormat = depthFormat;
    m_inner.beginRenderPass(desc);
}

void ValidationCommandList::endRenderPass() {
    if (!m_inPass) {
        m_device.report("endRenderPass", "no render pass is open (endRenderPass without beginRenderPass)");
        return;
    }
    m_inPass = false;
    m_inner.endRenderPass();
}

void ValidationCommandList::setViewport(const Viewport& vp) {
    if (!(vp.width > 0.0f) || !(vp.height > 0.0f) || vp.minDepth < 0.0f || vp.maxDepth > 1.0f) {
        m_device.report("setViewport", "viewport " + std::to_string(vp.width) + "x" +
                                           std::to_string(vp.height) + " with depth range [" +
                                           std::to_string(vp.minDepth) + ", " + std::to_string(vp.maxDepth) +
                                           "] is invalid");
        return;
    }
    m_inner.setViewport(vp);
}

void ValidationCommandList::setScissor(const Rect& rect) {
    if (rect.x < 0 || rect.y < 0) {
        m_device.report("setScissor", "scissor offset (" + std::to_string(rect.x) + ", " +
                                          std::to_string(rect.y) + ") is negative");
        return;
    }
    m_inner.setScissor(rect);
}

void ValidationCommandList::bindVertexBuffer(uint32_t slot, BufferHandle buffer, uint64_t offset) {
    const char* fn = "bindVertexBuffer";
    BufferInfo* b = m_device.buffer(buffer, fn, "buffer");
    if (!b) return;
    if (!any(b->desc.usage & BufferUsage::Vertex)) {
        m_device.report(fn, "buffer " + quoted(b->desc.debugName) + " was created without Vertex usage");
        return;
    }
    if (offset >= b->desc.size) {
        m_device.report(fn, "offset " + std::to_string(offset) + " is beyond buffer " +
                                quoted(b->desc.debugName) + " of " + std::to_string(b->desc.size) + " bytes");
        return;
    }
    m_device.useBuffer(fn, *b, " (slot " + std::to_string(slot) + ")", "is read as a vertex buffer",
                       Access::VertexRead, Access::VertexRead, false);
    if (slot < m_vertexBound.size()) m_vertexBound[slot] = true;
    m_inner.bindVertexBuffer(slot, buffer, offset);
}

void ValidationCommandList::bindIndexBuffer(BufferHandle buffer, IndexType type, uint64_t offset) {
    const char* fn = "bindIndexBuffer";
    BufferInfo* b = m_device.buffer(buffer, fn, "buffer");
    if (!b) return;
    if (!any(b->desc.usage & BufferUsage::Index)) {
        m_device.report(fn, "buffer " + quoted(b->desc.debugName) + " was created without Index usage");
        return;
    }
    const uint64_t indexSize = type == IndexType::Uint16 ? 2 : 4;
    if (offset >= b->desc.size || offset % indexSize != 0) {
        m_device.report(fn, "offset " + std::to_string(offset) + " is beyond buffer " +
                                quoted(b->desc.debugName) + " or not a multiple of the index size");
        return;
    }
    m_device.useBuffer(fn, *b, "", "is read as an index buffer", Access::IndexRead, Access::IndexRead, false);
    m_indexBound = true;
    m_indexOffset = offset;
    m_inner.bindIndexBuffer(buffer, type, offset);
}

bool ValidationCommandList::checkDrawState(const char* fn) {
    if (!m_inPass) {
        m_device.report(fn, "draw outside a render pass");
        return false;
    }
    if (!m_pipeline || m_pipeline->compute) {
        m_device.report(fn, m_pipeline ? "the bound pipeline " + quoted(m_pipeline->debugName) +
                                             " is not a graphics pipeline"
                                       : std::string("no graphics pipeline is bound"));
        return false;
    }
    bool ok = true;
    if (m_pipeline->colorFormats != m_passColorFormats || m_pipeline->depthFormat != m_passDepthFormat) {
        auto list = [](const std::vector<Format>& formats, Format depth) {
            std::string s = "[";
            for (size_t i = 0; i < formats.size(); ++i)
                s += (i ? ", " : "") + std::string(formatInfo(formats[i]).name);
            return s + "] depth " + formatInfo(depth).name;
        };
        m_device.report(fn, "pipeline " + quoted(m_pipeline->debugName) + " renders to " +
                                list(m_pipeline->colorFormats, m_pipeline->depthFormat) +
                                " but the render pass attachments are " +
                                list(m_passColorFormats, m_passDepthFormat));
        ok = false;
    }
    for (size_t slot = 0; slot < m_vertexBound.size(); ++slot) {
        if (!m_vertexBound[slot]) {
            m_device.report(fn, "pipeline " + quoted(m_pipeline->debugName) + " reads vertex buffer slot " +
                                    std::to_string(slot) + " but no vertex buffer was bound to it");
            ok = false;
        }
    }
    return checkBindings(fn) && ok;
}

void ValidationCommandList::draw(uint32_t vertexCount, uint32_t instanceCount, uint32_t firstVertex,
                                 uint32_t firstInstance) {
    if (!checkDrawState("draw")) return;
    checkResourceStates("draw");
    m_inner.draw(vertexCount, instanceCount, firstVertex, firstInstance);
}

void ValidationCommandList::drawIndexed(uint32_t indexCount, uint32_t instanceCount, uint32_t firstIndex,
                                        int32_t vertexOffset, uint32_t firstInstance) {
    const char* fn = "drawIndexed";
    if (!checkDrawState(fn)) return;
    if (!m_indexBound) {
        m_device.report(fn, "no index buffer is bound");
        return;
    }
    checkResourceStates(fn);
    m_inner.drawIndexed(indexCount, instanceCount, firstIndex, vertexOffset, firstInstance);
}

void ValidationCommandList::drawIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) {
    const char* fn = "drawIndirect";
    if (!checkDrawState(fn)) return;
    if (!checkIndirect(fn, args, offset, uint64_t(drawCount) * 16)) return;
    checkResourceStates(fn);
    m_inner.drawIndirect(args, offset, drawCount);
}

void ValidationCommandList::drawIndexedIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) {
    const char* fn = "drawIndexedIndirect";
    if (!checkDrawState(fn)) return;
    if (!m_indexBound) {
        m_device.report(fn, "no index buffer is bound");
        return;
    }
    if (m_indexOffset != 0) {
        m_device.report(fn, "the index buffer is bound at offset " + std::to_string(m_indexOffset) +
                                "; indexed indirect draws need offset 0 (use firstIndex in the arguments)");
        return;
    }
    if (!checkIndirect(fn, args, offset, uint64_t(drawCount) * 20)) return;
    checkResourceStates(fn);
    m_inner.drawIndexedIndirect(args, offset, drawCount);
}

void ValidationCommandList::resetQueries(QueryPoolHandle pool, uint32_t first, uint32_t count) {
    const char* fn = "resetQueries";
    QueryPoolInfo* q = m_device.queryPool(pool, fn, "pool");
    if (!q) return;
    if (!rangeInside(first, count, q->desc.count)) {
        m_device.report(fn, "queries [" + std::to_string(first) + ", +" + std::to_string(count) +
                                ") exceed query pool " + quoted(q->desc.debugName) + " of " +
                                std::to_string(q->desc.count));
        return;
    }
    if (m_inPass) {
        m_device.report(fn, "resetQueries is not allowed inside a render pass");
        return;
    }
    m_inner.resetQueries(pool, first, count);
}

void ValidationCommandList::writeTimestamp(QueryPoolHandle pool, uint32_t index) {
    const char* fn = "writeTimestamp";
    QueryPoolInfo* q = m_device.queryPool(pool, fn, "pool");
    if (!q) return;
    if (index >= q->desc.count) {
        m_device.report(fn, "query " + std::to_string(index) + " exceeds query pool " +
                                quoted(q->desc.debugName) + " of " + std::to_string(q->desc.count));
        return;
    }
    m_inner.writeTimestamp(pool, index);
}

void ValidationCommandList::pushDebugGroup(std::string_view name) {
    ++m_debugDepth;
    m_inner.pushDebugGroup(name);
}

void ValidationCommandList::popDebugGroup() {
    if (m_debugDepth == 0) {
        m_device.report("popDebugGroup", "no debug group is open (popDebugGroup without pushDebugGroup)");
        return;
    }
    --m_debugDepth;
    m_inner.popDebugGroup();
}

}  // namespace

std::unique_ptr<Device> createValidationDevice(std::unique_ptr<Device> inner, LogCallback log,
                                               std::shared_ptr<uint64_t> errorCounter) {
    if (!inner) return nullptr;
    return std::make_unique<ValidationDevice>(std::move(inner), std::move(log), std::move(errorCounter));
}

uint64_t validationErrorCountOf(const Device& device) {
    if (const auto* v = dynamic_cast<const ValidationDevice*>(&device)) return v->errorCount();
    return 0;
}

}  // namespace rhi::detail
