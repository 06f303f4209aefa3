// Frame graph: declaration (PassBuilder), compilation (culling, transient allocation with
// aliasing and a cross-frame pool, barrier placement) and execution with per-pass timing.
// The Graphviz dump lives in frame_graph_graphviz.cpp.
#include "renderer/frame_graph/frame_graph.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

namespace penumbra::fg {

namespace {

using rhi::Access;

constexpr Access kWriteMask = rhi::kWriteAccesses;
constexpr Access kTextureAccesses = Access::ShaderSampled | Access::ShaderRead | Access::ShaderWrite |
                                    Access::ColorTarget | Access::DepthTargetWrite | Access::DepthTargetRead |
                                    Access::CopySrc | Access::CopyDst | Access::HostRead | Access::HostWrite |
                                    Access::Present;
constexpr Access kBufferAccesses = Access::ShaderRead | Access::ShaderWrite | Access::UniformRead |
                                   Access::VertexRead | Access::IndexRead | Access::IndirectRead |
                                   Access::CopySrc | Access::CopyDst | Access::HostRead | Access::HostWrite;
constexpr Access kRasterOnly = Access::ColorTarget | Access::DepthTargetWrite | Access::DepthTargetRead |
                               Access::VertexRead | Access::IndexRead;
constexpr Access kTransferAllowed =
    Access::CopySrc | Access::CopyDst | Access::HostRead | Access::HostWrite | Access::Present;

// Every graph epoch is unique across all graphs, so refs from another frame or graph are caught.
std::atomic<uint32_t> g_nextEpoch{1};

uint32_t newEpoch() {
    uint32_t e = g_nextEpoch.fetch_add(1, std::memory_order_relaxed);
    return e == 0 ? g_nextEpoch.fetch_add(1, std::memory_order_relaxed) : e;
}

bool hasSingleBit(Access a) {
    uint32_t v = uint32_t(a);
    return v != 0 && (v & (v - 1)) == 0;
}

rhi::TextureUsage textureUsageFor(Access a) {
    rhi::TextureUsage u = rhi::TextureUsage::None;
    if (any(a & Access::ShaderSampled)) u |= rhi::TextureUsage::Sampled;
    if (any(a & (Access::ShaderRead | Access::ShaderWrite))) u |= rhi::TextureUsage::Storage;
    if (any(a & Access::ColorTarget)) u |= rhi::TextureUsage::ColorTarget;
    if (any(a & (Access::DepthTargetWrite | Access::DepthTargetRead))) u |= rhi::TextureUsage::DepthTarget;
    if (any(a & (Access::CopySrc | Access::HostRead))) u |= rhi::TextureUsage::CopySrc;
    if (any(a & (Access::CopyDst | Access::HostWrite))) u |= rhi::TextureUsage::CopyDst;
    return u;
}

rhi::BufferUsage bufferUsageFor(Access a) {
    rhi::BufferUsage u = rhi::BufferUsage::None;
    if (any(a & (Access::ShaderRead | Access::ShaderWrite))) u |= rhi::BufferUsage::Storage;
    if (any(a & Access::UniformRead)) u |= rhi::BufferUsage::Uniform;
    if (any(a & Access::VertexRead)) u |= rhi::BufferUsage::Vertex;
    if (any(a & Access::IndexRead)) u |= rhi::BufferUsage::Index;
    if (any(a & Access::IndirectRead)) u |= rhi::BufferUsage::Indirect;
    if (any(a & Access::CopySrc)) u |= rhi::BufferUsage::CopySrc;
    if (any(a & Access::CopyDst)) u |= rhi::BufferUsage::CopyDst;
    return u;
}

bool sameShape(const rhi::TextureDesc& a, const rhi::TextureDesc& b) {
    return a.dimension == b.dimension && a.format == b.format && a.width == b.width && a.height == b.height &&
           a.depthOrLayers == b.depthOrLayers && a.mipLevels == b.mipLevels;
}

bool sameShape(const rhi::BufferDesc& a, const rhi::BufferDesc& b) {
    return a.size == b.size && a.memory == b.memory;
}

const char* typeName(bool texture) { return texture ? "texture" : "buffer"; }

// Whether one pass may combine these reads and writes on one subresource.
bool compatibleUse(Access read, Access write, bool isTexture) {
    if (!any(write)) return true;
    Access compatibleReads = Access::None;
    if (write == Access::ShaderWrite)
        compatibleReads = Access::ShaderRead;
    else if (write == Access::DepthTargetWrite)
        compatibleReads = Access::DepthTargetRead;
    else if (write == Access::CopyDst && !isTexture)
        compatibleReads = Access::CopySrc;
    return hasSingleBit(write) && !any(read & ~compatibleReads);
}

// Mip levels and array layers a texture's state is tracked in.
uint32_t mipCountOf(const rhi::TextureDesc& d) { return std::max(d.mipLevels, 1u); }
uint32_t layerCountOf(const rhi::TextureDesc& d) {
    return d.dimension == rhi::TextureDimension::Tex2DArray ? std::max(d.depthOrLayers, 1u) : 1u;
}

// [first, end) of a range with kAllMips/kAllLayers meaning "to the end".
std::pair<uint32_t, uint32_t> span(uint32_t base, uint32_t count, uint32_t total) {
    const uint32_t end = count == kAllMips ? total : base + std::min(count, total - std::min(base, total));
    return {std::min(base, total), std::max(std::min(end, total), std::min(base, total))};
}

}  // namespace

std::string toString(const Subresource& p) {
    if (p.isWhole()) return {};
    std::string out;
    if (p.baseMip != 0 || p.mipCount != kAllMips)
        out += p.mipCount == 1
                   ? "mip " + std::to_string(p.baseMip)
                   : "mips " + std::to_string(p.baseMip) + "+" +
                         (p.mipCount == kAllMips ? std::string("all") : std::to_string(p.mipCount));
    if (p.baseLayer != 0 || p.layerCount != kAllLayers) {
        if (!out.empty()) out += ", ";
        out += p.layerCount == 1
                   ? "layer " + std::to_string(p.baseLayer)
                   : "layers " + std::to_string(p.baseLayer) + "+" +
                         (p.layerCount == kAllLayers ? std::string("all") : std::to_string(p.layerCount));
    }
    if (p.offset != std::array<uint32_t, 3>{0, 0, 0} || p.extent != std::array<uint32_t, 3>{0, 0, 0}) {
        if (!out.empty()) out += ", ";
        out += "box (" + std::to_string(p.offset[0]) + "," + std::to_string(p.offset[1]) + "," +
               std::to_string(p.offset[2]) + ") size (" + std::to_string(p.extent[0]) + "," +
               std::to_string(p.extent[1]) + "," + std::to_string(p.extent[2]) + ")";
    }
    return out;
}

const char* toString(PassKind kind) {
    switch (kind) {
        case PassKind::Compute:
            return "Compute";
        case PassKind::Raster:
            return "Raster";
        case PassKind::Transfer:
            return "Transfer";
    }
    return "?";
}

const CompiledPass* CompiledInfo::findPass(std::string_view name) const {
    for (const CompiledPass& p : passes)
        if (p.name == name) return &p;
    return nullptr;
}

bool CompiledInfo::isCulled(std::string_view name) const {
    return std::find(culledPasses.begin(), culledPasses.end(), name) != culledPasses.end();
}

// ---------------------------------------------------------------------------------------------
// PassBuilder
// ---------------------------------------------------------------------------------------------
TextureRef PassBuilder::createTexture(std::string name, const rhi::TextureDesc& desc) {
    const rhi::FormatInfo& fi = rhi::formatInfo(desc.format);
    if (desc.width == 0 || desc.height == 0 || desc.depthOrLayers == 0 || desc.mipLevels == 0 ||
        desc.format == rhi::Format::Undefined || desc.format >= rhi::Format::RGB32_FLOAT ||
        fi.bytesPerTexel == 0) {
        m_graph.error("pass '" + m_graph.m_passes[m_pass].name + "' creates texture '" + name +
                      "' with an invalid description (zero size or mips, or a non-texture format)");
        return {};
    }
    uint32_t r = m_graph.createResource(m_pass, std::move(name), FrameGraph::ResourceType::Texture);
    m_graph.m_resources[r].textureDesc = desc;
    m_graph.m_resources[r].textureDesc.usage = rhi::TextureUsage::None;
    return TextureRef{r, m_graph.m_epoch};
}

BufferRef PassBuilder::createBuffer(std::string name, const rhi::BufferDesc& desc) {
    if (desc.size == 0) {
        m_graph.error("pass '" + m_graph.m_passes[m_pass].name + "' creates buffer '" + name + "' of size 0");
        return {};
    }
    uint32_t r = m_graph.createResource(m_pass, std::move(name), FrameGraph::ResourceType::Buffer);
    m_graph.m_resources[r].bufferDesc = desc;
    m_graph.m_resources[r].bufferDesc.usage = rhi::BufferUsage::None;
    return BufferRef{r, m_graph.m_epoch};
}

TextureRef PassBuilder::read(TextureRef ref, rhi::Access usage) {
    return m_graph.declareTexture(m_pass, ref, usage, false, {});
}

TextureRef PassBuilder::read(TextureRef ref, rhi::Access usage, const Subresource& part) {
    return m_graph.declareTexture(m_pass, ref, usage, false, part);
}

BufferRef PassBuilder::read(BufferRef ref, rhi::Access usage) {
    uint32_t r = m_graph.resolve(ref.index, ref.epoch, FrameGraph::ResourceType::Buffer);
    if (r == kInvalidIndex) {
        if (!m_graph.m_failed || ref.isValid())
            m_graph.error("pass '" + m_graph.m_passes[m_pass].name +
                          "' reads a buffer that was never created (invalid or stale ref)");
        return ref;
    }
    m_graph.declare(m_pass, r, usage, false);
    return ref;
}

TextureRef PassBuilder::write(TextureRef ref, rhi::Access usage) {
    return m_graph.declareTexture(m_pass, ref, usage, true, {});
}

TextureRef PassBuilder::write(TextureRef ref, rhi::Access usage, const Subresource& part) {
    return m_graph.declareTexture(m_pass, ref, usage, true, part);
}

BufferRef PassBuilder::write(BufferRef ref, rhi::Access usage) {
    uint32_t r = m_graph.resolve(ref.index, ref.epoch, FrameGraph::ResourceType::Buffer);
    if (r == kInvalidIndex) {
        if (!m_graph.m_failed || ref.isValid())
            m_graph.error("pass '" + m_graph.m_passes[m_pass].name +
                          "' writes a buffer that was never created (invalid or stale ref)");
        return ref;
    }
    m_graph.declare(m_pass, r, usage, true);
    return ref;
}

void PassBuilder::sideEffect() { m_graph.m_passes[m_pass].sideEffect = true; }

// ---------------------------------------------------------------------------------------------
// PassContext
// ---------------------------------------------------------------------------------------------
rhi::TextureHandle PassContext::texture(TextureRef ref) const {
    uint32_t r = m_graph.resolve(ref.index, ref.epoch, FrameGraph::ResourceType::Texture);
    const std::string& pass = m_graph.m_passes[m_pass].name;
    if (r == kInvalidIndex) {
        m_graph.log(rhi::LogSeverity::Error,
                    "frame graph: pass '" + pass +
                        "' asks for a texture that was never created (invalid or stale ref)");
        return {};
    }
    if (!m_graph.findUse(m_pass, r)) {
        m_graph.log(rhi::LogSeverity::Error, "frame graph: pass '" + pass + "' asks for texture '" +
                                                 m_graph.m_resources[r].name + "' that it did not declare");
        return {};
    }
    return m_graph.m_slots[m_graph.m_resources[r].slot].texture;
}

rhi::BufferHandle PassContext::buffer(BufferRef ref) const {
    uint32_t r = m_graph.resolve(ref.index, ref.epoch, FrameGraph::ResourceType::Buffer);
    const std::string& pass = m_graph.m_passes[m_pass].name;
    if (r == kInvalidIndex) {
        m_graph.log(rhi::LogSeverity::Error,
                    "frame graph: pass '" + pass +
                        "' asks for a buffer that was never created (invalid or stale ref)");
        return {};
    }
    if (!m_graph.findUse(m_pass, r)) {
        m_graph.log(rhi::LogSeverity::Error, "frame graph: pass '" + pass + "' asks for buffer '" +
                                                 m_graph.m_resources[r].name + "' that it did not declare");
        return {};
    }
    return m_graph.m_slots[m_graph.m_resources[r].slot].buffer;
}

const rhi::TextureDesc& PassContext::textureDesc(TextureRef ref) const {
    static const rhi::TextureDesc kEmpty{};
    uint32_t r = m_graph.resolve(ref.index, ref.epoch, FrameGraph::ResourceType::Texture);
    return r == kInvalidIndex ? kEmpty : m_graph.m_resources[r].textureDesc;
}

const rhi::BufferDesc& PassContext::bufferDesc(BufferRef ref) const {
    static const rhi::BufferDesc kEmpty{};
    uint32_t r = m_graph.resolve(ref.index, ref.epoch, FrameGraph::ResourceType::Buffer);
    return r == kInvalidIndex ? kEmpty : m_graph.m_resources[r].bufferDesc;
}

const std::string& PassContext::name() const { return m_graph.m_passes[m_pass].name; }

// ---------------------------------------------------------------------------------------------
// FrameGraph: setup
// ---------------------------------------------------------------------------------------------
FrameGraph::FrameGraph(rhi::Device& device, rhi::LogCallback log)
    : m_device(device), m_log(std::move(log)), m_epoch(newEpoch()) {}

FrameGraph::~FrameGraph() {
    for (PooledTexture& t : m_texturePool) m_device.destroy(t.handle);
    for (PooledBuffer& b : m_bufferPool) m_device.destroy(b.handle);
    for (TimingFrame& t : m_timingRing)
        if (t.pool) m_device.destroy(t.pool);
}

void FrameGraph::log(rhi::LogSeverity severity, const std::string& message) const {
    if (m_log) {
        m_log(severity, message);
        return;
    }
    static const char* kTags[] = {"debug", "info", "warning", "error"};
    std::fprintf(stderr, "[%s] %s\n", kTags[int(severity)], message.c_str());
}

void FrameGraph::error(const std::string& message) {
    m_failed = true;
    log(rhi::LogSeverity::Error, "frame graph: " + message);
}

void FrameGraph::reset() {
    m_passes.clear();
    m_resources.clear();
    m_order.clear();
    m_slots.clear();
    m_info = CompiledInfo{};
    m_compiled = false;
    m_failed = false;
    m_executed = false;
    m_timingsCollected = false;
    m_timings.clear();
    for (PooledTexture& t : m_texturePool) t.inUse = false;
    for (PooledBuffer& b : m_bufferPool) b.inUse = false;
    ++m_frame;
    m_epoch = newEpoch();
}

uint32_t FrameGraph::beginPass(std::string name, PassKind kind,
                               std::unique_ptr<detail::PassExecutor> executor) {
    if (m_compiled) error("addPass('" + name + "') after compile(); call reset() to start a new frame");
    PassNode node;
    node.name = std::move(name);
    node.kind = kind;
    node.executor = std::move(executor);
    m_passes.push_back(std::move(node));
    return uint32_t(m_passes.size() - 1);
}

uint32_t FrameGraph::createResource(uint32_t pass, std::string name, ResourceType type) {
    ResourceNode node;
    node.name = std::move(name);
    node.type = type;
    node.creatorPass = pass;
    m_resources.push_back(std::move(node));
    return uint32_t(m_resources.size() - 1);
}

uint32_t FrameGraph::resolve(uint32_t index, uint32_t epoch, ResourceType type) const {
    if (index == kInvalidIndex || epoch != m_epoch || index >= m_resources.size()) return kInvalidIndex;
    if (m_resources[index].type != type) return kInvalidIndex;
    return index;
}

const FrameGraph::ResourceUse* FrameGraph::findUse(uint32_t pass, uint32_t resource) const {
    for (const ResourceUse& u : m_passes[pass].uses)
        if (u.resource == resource) return &u;
    return nullptr;
}

TextureRef FrameGraph::declareTexture(uint32_t pass, TextureRef ref, rhi::Access usage, bool isWrite,
                                      const Subresource& part) {
    uint32_t r = resolve(ref.index, ref.epoch, ResourceType::Texture);
    if (r == kInvalidIndex) {
        if (!m_failed || ref.isValid())
            error("pass '" + m_passes[pass].name + "' " + (isWrite ? "writes" : "reads") +
                  " a texture that was never created (invalid or stale ref)");
        return ref;
    }
    declare(pass, r, usage, isWrite, part);
    return ref;
}

bool FrameGraph::checkPart(const PassNode& p, const ResourceNode& res, const Subresource& part) const {
    if (part.isWhole()) return true;
    const rhi::TextureDesc& d = res.textureDesc;
    const uint32_t mips = mipCountOf(d), layers = layerCountOf(d);
    const bool mipsOk = part.baseMip < mips && part.mipCount != 0 &&
                        (part.mipCount == kAllMips || part.mipCount <= mips - part.baseMip);
    const bool layersOk = part.baseLayer < layers && part.layerCount != 0 &&
                          (part.layerCount == kAllLayers || part.layerCount <= layers - part.baseLayer);
    bool boxOk = mipsOk;
    if (mipsOk) {
        const auto [m0, m1] = span(part.baseMip, part.mipCount, mips);
        const bool is3D = d.dimension == rhi::TextureDimension::Tex3D;
        for (uint32_t m = m0; m < m1 && boxOk; ++m) {
            const uint32_t size[3] = {std::max(d.width >> m, 1u), std::max(d.height >> m, 1u),
                                      is3D ? std::max(d.depthOrLayers >> m, 1u) : 1u};
            for (int a = 0; a < 3; ++a) {
                const uint32_t extent =
                    part.extent[a] ? part.extent[a] : size[a] - std::min(part.offset[a], size[a]);
                if (part.offset[a] >= size[a] || extent > size[a] - part.offset[a]) boxOk = false;
            }
        }
    }
    if (mipsOk && layersOk && boxOk) return true;
    const_cast<FrameGraph*>(this)->error(
        "pass '" + p.name + "' declares " + toString(part) + " of texture '" + res.name +
        "', which is outside the texture (" + std::to_string(mips) + " mip(s), " + std::to_string(layers) +
        " layer(s), " + std::to_string(d.width) + "x" + std::to_string(d.height) + "x" +
        std::to_string(d.depthOrLayers) + ")");
    return false;
}

// Every subresource the parts of `use` cover must be used in one compatible way.
bool FrameGraph::checkParts(const PassNode& p, const ResourceNode& res, const ResourceUse& use) {
    const bool isTexture = res.type == ResourceType::Texture;
    const uint32_t mips = isTexture ? mipCountOf(res.textureDesc) : 1;
    const uint32_t layers = isTexture ? layerCountOf(res.textureDesc) : 1;
    std::vector<Access> read(size_t(mips) * layers, Access::None), write(read);
    for (const Part& part : use.parts) {
        const auto [m0, m1] = span(part.range.baseMip, part.range.mipCount, mips);
        const auto [l0, l1] = span(part.range.baseLayer, part.range.layerCount, layers);
        for (uint32_t m = m0; m < m1; ++m)
            for (uint32_t l = l0; l < l1; ++l) {
                read[m * layers + l] |= part.access & ~kWriteMask;
                write[m * layers + l] |= part.access & kWriteMask;
            }
    }
    for (size_t i = 0; i < read.size(); ++i) {
        if (compatibleUse(read[i], write[i], isTexture)) continue;
        std::string what = std::string(typeName(isTexture)) + " '" + res.name + "'";
        if (mips * layers > 1)
            what += " (mip " + std::to_string(i / layers) + ", layer " + std::to_string(i % layers) + ")";
        std::string readText = any(read[i]) ? rhi::toString(read[i]) : std::string("nothing");
        error("pass '" + p.name + "' uses " + what + " with incompatible usages in one pass (reads " +
              readText + ", writes " + rhi::toString(write[i]) +
              "); a pass may only combine ShaderRead+ShaderWrite, DepthTargetRead+DepthTargetWrite or, for "
              "buffers, CopySrc+CopyDst on one subresource");
        return false;
    }
    return true;
}

bool FrameGraph::declare(uint32_t pass, uint32_t resource, rhi::Access usage, bool isWrite,
                         const Subresource& part) {
    PassNode& p = m_passes[pass];
    ResourceNode& res = m_resources[resource];
    const bool isTexture = res.type == ResourceType::Texture;
    const std::string what = std::string(typeName(isTexture)) + " '" + res.name + "'";
    const std::string verb = isWrite ? "writes " : "reads ";

    if (usage == Access::None) {
        error("pass '" + p.name + "' " + verb + what + " with no access (Access::None)");
        return false;
    }
    Access allowed = isTexture ? kTextureAccesses : kBufferAccesses;
    if (any(usage & ~allowed)) {
        error("pass '" + p.name + "' " + verb + what + " as " + rhi::toString(usage & ~allowed) +
              ", which is not an access a " + typeName(isTexture) + " supports");
        return false;
    }
    if (!isWrite && any(usage & kWriteMask)) {
        error("pass '" + p.name + "' declares " + what + " as read with the write access " +
              rhi::toString(usage & kWriteMask) + "; use write()");
        return false;
    }
    if (isWrite && !any(usage & kWriteMask)) {
        error("pass '" + p.name + "' declares " + what + " as written with the read-only access " +
              rhi::toString(usage) + "; use read()");
        return false;
    }
    if (p.kind != PassKind::Raster && any(usage & kRasterOnly)) {
        error("pass '" + p.name + "' (" + toString(p.kind) + ") uses " + what + " as " +
              rhi::toString(usage & kRasterOnly) + ", which only a Raster pass can");
        return false;
    }
    if (p.kind == PassKind::Transfer && any(usage & ~kTransferAllowed)) {
        error("pass '" + p.name + "' (Transfer) uses " + what + " as " +
              rhi::toString(usage & ~kTransferAllowed) +
              "; Transfer passes only copy (CopySrc, CopyDst, HostRead, HostWrite)");
        return false;
    }
    if (!res.imported && any(usage & Access::Present)) {
        error("pass '" + p.name + "' uses transient " + what +
              " as Present; only imported textures can be presented");
        return false;
    }

    ResourceUse* use = nullptr;
    for (ResourceUse& u : p.uses)
        if (u.resource == resource) use = &u;
    if (!use) {
        ResourceUse u;
        u.resource = resource;
        u.inputVersion = res.version;
        p.uses.push_back(u);
        use = &p.uses.back();
    }

    Access reads = usage & ~kWriteMask;
    Access writes = usage & kWriteMask;
    if (any(reads) && !res.imported && use->inputVersion == 0) {
        error("pass '" + p.name + "' reads transient " + what + " before any pass writes it");
        return false;
    }

    if (isTexture && !checkPart(p, res, part)) return false;
    auto same = std::find_if(use->parts.begin(), use->parts.end(), [&](const Part& x) {
        return x.range.baseMip == part.baseMip && x.range.mipCount == part.mipCount &&
               x.range.baseLayer == part.baseLayer && x.range.layerCount == part.layerCount &&
               x.range.offset == part.offset && x.range.extent == part.extent;
    });
    if (same != use->parts.end())
        same->access |= usage;
    else
        use->parts.push_back(Part{part, usage});
    if (!checkParts(p, res, *use)) return false;
    use->read = use->read | reads;
    use->write = use->write | writes;
    if (any(writes) && use->outputVersion == 0) {
        res.producers.push_back(pass);
        res.version = uint32_t(res.producers.size());
        use->outputVersion = res.version;
    }
    return true;
}

uint32_t FrameGraph::importResource(std::string name, ResourceType type, rhi::TextureHandle texture,
                                    rhi::BufferHandle buffer, rhi::Access currentState,
                                    rhi::Access finalState) {
    const bool isTexture = type == ResourceType::Texture;
    const std::string what = std::string(typeName(isTexture)) + " '" + name + "'";
    if (m_compiled) {
        error("import of " + what + " after compile(); call reset() to start a new frame");
        return kInvalidIndex;
    }
    bool alive = isTexture ? (texture.isValid() && m_device.isAlive(texture))
                           : (buffer.isValid() && m_device.isAlive(buffer));
    if (!alive) {
        error("import of " + what + ": the handle is not a live " + typeName(isTexture));
        return kInvalidIndex;
    }
    Access allowed = isTexture ? kTextureAccesses : kBufferAccesses;
    if (any((currentState | finalState) & ~allowed)) {
        error("import of " + what + ": state " + rhi::toString((currentState | finalState) & ~allowed) +
              " is not valid for a " + typeName(isTexture));
        return kInvalidIndex;
    }
    for (const ResourceNode& r : m_resources) {
        if (!r.imported || r.type != type) continue;
        if ((isTexture && r.importedTexture == texture) || (!isTexture && r.importedBuffer == buffer)) {
            error("import of " + what + ": the same " + typeName(isTexture) + " is already imported as '" +
                  r.name + "'");
            return kInvalidIndex;
        }
    }
    uint32_t index = createResource(kInvalidIndex, std::move(name), type);
    ResourceNode& r = m_resources[index];
    r.imported = true;
    r.output = true;
    r.initialState = currentState;
    r.finalState = finalState;
    if (isTexture) {
        r.importedTexture = texture;
        if (const rhi::TextureDesc* d = m_device.describe(texture)) r.textureDesc = *d;
    } else {
        r.importedBuffer = buffer;
        if (const rhi::BufferDesc* d = m_device.describe(buffer)) r.bufferDesc = *d;
    }
    return index;
}

TextureRef FrameGraph::importTexture(std::string name, rhi::TextureHandle texture, rhi::Access currentState) {
    return importTexture(std::move(name), texture, currentState, currentState);
}

TextureRef FrameGraph::importTexture(std::string name, rhi::TextureHandle texture, rhi::Access currentState,
                                     rhi::Access finalState) {
    uint32_t r =
        importResource(std::move(name), ResourceType::Texture, texture, {}, currentState, finalState);
    return r == kInvalidIndex ? TextureRef{} : TextureRef{r, m_epoch};
}

TextureRef FrameGraph::importPersistent(std::string name, rhi::TextureHandle texture,
                                        rhi::Access finalState) {
    auto it = m_persistent.find(texture.value);
    const rhi::Access current = it == m_persistent.end() ? Access::None : it->second;
    TextureRef ref = importTexture(std::move(name), texture, current, finalState);
    if (ref.isValid()) m_persistent[texture.value] = current;  // updated by compile()
    return ref;
}

rhi::Access FrameGraph::persistentState(rhi::TextureHandle texture) const {
    auto it = m_persistent.find(texture.value);
    return it == m_persistent.end() ? Access::None : it->second;
}

void FrameGraph::forgetPersistent(rhi::TextureHandle texture) { m_persistent.erase(texture.value); }

BufferRef FrameGraph::importPersistent(std::string name, rhi::BufferHandle buffer, rhi::Access finalState) {
    auto it = m_persistentBuffers.find(buffer.value);
    const rhi::Access current = it == m_persistentBuffers.end() ? Access::None : it->second;
    BufferRef ref = importBuffer(std::move(name), buffer, current, finalState);
    if (ref.isValid()) m_persistentBuffers[buffer.value] = current;  // updated by compile()
    return ref;
}

rhi::Access FrameGraph::persistentState(rhi::BufferHandle buffer) const {
    auto it = m_persistentBuffers.find(buffer.value);
    return it == m_persistentBuffers.end() ? Access::None : it->second;
}

void FrameGraph::forgetPersistent(rhi::BufferHandle buffer) { m_persistentBuffers.erase(buffer.value); }

BufferRef FrameGraph::importBuffer(std::string name, rhi::BufferHandle buffer, rhi::Access currentState) {
    return importBuffer(std::move(name), buffer, currentState, currentState);
}

BufferRef FrameGraph::importBuffer(std::string name, rhi::BufferHandle buffer, rhi::Access currentState,
                                   rhi::Access finalState) {
    uint32_t r = importResource(std::move(name), ResourceType::Buffer, {}, buffer, currentState, finalState);
    return r == kInvalidIndex ? BufferRef{} : BufferRef{r, m_epoch};
}

void FrameGraph::markOutputResource(uint32_t resource, rhi::Access finalState) {
    ResourceNode& r = m_resources[resource];
    if (m_compiled) {
        error("markOutput('" + r.name + "') after compile()");
        return;
    }
    const bool isTexture = r.type == ResourceType::Texture;
    if (any(finalState & ~(isTexture ? kTextureAccesses : kBufferAccesses)) ||
        (!r.imported && any(finalState & Access::Present))) {
        error("markOutput('" + r.name + "'): final state " + rhi::toString(finalState) +
              " is not valid for it");
        return;
    }
    r.output = true;
    if (finalState != Access::None) r.finalState = finalState;
}

void FrameGraph::markOutput(TextureRef ref, rhi::Access finalState) {
    uint32_t r = resolve(ref.index, ref.epoch, ResourceType::Texture);
    if (r == kInvalidIndex) {
        if (!m_failed || ref.isValid())
            error("markOutput of a texture that was never created (invalid or stale ref)");
        return;
    }
    markOutputResource(r, finalState);
}

void FrameGraph::markOutput(BufferRef ref, rhi::Access finalState) {
    uint32_t r = resolve(ref.index, ref.epoch, ResourceType::Buffer);
    if (r == kInvalidIndex) {
        if (!m_failed || ref.isValid())
            error("markOutput of a buffer that was never created (invalid or stale ref)");
        return;
    }
    markOutputResource(r, finalState);
}

// ---------------------------------------------------------------------------------------------
// FrameGraph: compile
// ---------------------------------------------------------------------------------------------
bool FrameGraph::compile() {
    if (m_compiled) {
        error("compile() called twice in one frame; call reset() to start a new frame");
        return false;
    }
    m_compiled = true;
    if (m_failed) return false;  // the declaration errors were already reported

    cull();
    if (!allocate()) return false;
    placeBarriers();
    if (m_failed) return false;
    for (const ResourceNode& r : m_resources) {
        if (r.imported && r.type == ResourceType::Texture && m_persistent.count(r.importedTexture.value))
            m_persistent[r.importedTexture.value] = r.endState;
        if (r.imported && r.type == ResourceType::Buffer && m_persistentBuffers.count(r.importedBuffer.value))
            m_persistentBuffers[r.importedBuffer.value] = r.endState;
    }
    return true;
}

void FrameGraph::cull() {
    // Reference counts: a version counts its readers (every use of the resource by a pass that
    // starts from that version: explicit reads and, since writes never discard, writes too) plus
    // one if it is the last version of an output; a pass counts the versions it produces plus one
    // for a side effect.
    for (ResourceNode& r : m_resources) r.versionRefs.assign(r.producers.size(), 0);
    for (PassNode& p : m_passes) {
        p.culled = false;
        p.refCount = p.sideEffect ? 1 : 0;
        for (const ResourceUse& u : p.uses) {
            if (u.inputVersion >= 1) ++m_resources[u.resource].versionRefs[u.inputVersion - 1];
            if (any(u.write)) ++p.refCount;
        }
    }
    for (ResourceNode& r : m_resources)
        if (r.output && !r.versionRefs.empty()) ++r.versionRefs.back();

    std::vector<std::pair<uint32_t, uint32_t>> unread;  // (resource, version) with no reader left
    for (uint32_t ri = 0; ri < m_resources.size(); ++ri)
        for (uint32_t v = 1; v <= m_resources[ri].versionRefs.size(); ++v)
            if (m_resources[ri].versionRefs[v - 1] == 0) unread.emplace_back(ri, v);

    auto cullPass = [&](uint32_t pi) {
        PassNode& p = m_passes[pi];
        p.culled = true;
        for (const ResourceUse& u : p.uses)
            if (u.inputVersion >= 1 && --m_resources[u.resource].versionRefs[u.inputVersion - 1] == 0)
                unread.emplace_back(u.resource, u.inputVersion);
    };
    for (uint32_t pi = 0; pi < m_passes.size(); ++pi)
        if (m_passes[pi].refCount == 0) cullPass(pi);
    while (!unread.empty()) {
        auto [ri, v] = unread.back();
        unread.pop_back();
        uint32_t producer = m_resources[ri].producers[v - 1];
        PassNode& p = m_passes[producer];
        if (!p.culled && --p.refCount == 0) cullPass(producer);
    }

    m_order.clear();
    for (uint32_t pi = 0; pi < m_passes.size(); ++pi) {
        if (m_passes[pi].culled)
            m_info.culledPasses.push_back(m_passes[pi].name);
        else
            m_order.push_back(pi);
    }
}

bool FrameGraph::allocate() {
    // Lifetimes and accumulated usage over the kept passes.
    std::vector<Access> accumulated(m_resources.size(), Access::None);
    for (uint32_t e = 0; e < m_order.size(); ++e) {
        for (const ResourceUse& u : m_passes[m_order[e]].uses) {
            ResourceNode& r = m_resources[u.resource];
            if (r.firstUse == kInvalidIndex) r.firstUse = e;
            r.lastUse = e;
            accumulated[u.resource] |= u.read | u.write;
        }
    }

    m_slots.clear();
    // Imports: one slot each, entering in their current state.
    for (uint32_t ri = 0; ri < m_resources.size(); ++ri) {
        ResourceNode& r = m_resources[ri];
        if (!r.imported) continue;
        const bool isTexture = r.type == ResourceType::Texture;
        if (isTexture && r.textureDesc.usage != rhi::TextureUsage::None) {
            rhi::TextureUsage missing = textureUsageFor(accumulated[ri]) & ~r.textureDesc.usage;
            if (any(missing)) {
                error("imported texture '" + r.name + "' is used as " + rhi::toString(accumulated[ri]) +
                      " but was created without the matching TextureUsage flags");
                return false;
            }
        } else if (!isTexture && r.bufferDesc.usage != rhi::BufferUsage::None) {
            rhi::BufferUsage missing = bufferUsageFor(accumulated[ri]) & ~r.bufferDesc.usage;
            if (any(missing)) {
                error("imported buffer '" + r.name + "' is used as " + rhi::toString(accumulated[ri]) +
                      " but was created without the matching BufferUsage flags");
                return false;
            }
        }
        Slot s;
        s.type = r.type;
        s.imported = true;
        s.texture = r.importedTexture;
        s.buffer = r.importedBuffer;
        s.textureDesc = r.textureDesc;
        initSlotState(s, r.initialState);
        s.resources.push_back(ri);
        r.slot = uint32_t(m_slots.size());
        r.endState = r.initialState;
        m_slots.push_back(std::move(s));
    }

    // Transients used by kept passes, by first use; greedy interval assignment to slots of the same
    // shape whose previous occupant's lifetime has ended (aliasing).
    std::vector<uint32_t> transients;
    for (uint32_t ri = 0; ri < m_resources.size(); ++ri) {
        ResourceNode& r = m_resources[ri];
        if (r.imported) continue;
        if (r.firstUse == kInvalidIndex) {
            if (r.output)
                log(rhi::LogSeverity::Warning,
                    "frame graph: output '" + r.name +
                        "' is not written by any executed pass; it is not allocated");
            continue;
        }
        if (r.output) r.lastUse = std::numeric_limits<uint32_t>::max();
        transients.push_back(ri);
    }
    std::stable_sort(transients.begin(), transients.end(), [&](uint32_t a, uint32_t b) {
        return m_resources[a].firstUse < m_resources[b].firstUse;
    });
    const size_t firstTransientSlot = m_slots.size();
    m_firstTransientSlot = uint32_t(firstTransientSlot);
    for (uint32_t ri : transients) {
        ResourceNode& r = m_resources[ri];
        const bool isTexture = r.type == ResourceType::Texture;
        uint32_t chosen = kInvalidIndex;
        for (size_t si = firstTransientSlot; si < m_slots.size() && chosen == kInvalidIndex; ++si) {
            const Slot& s = m_slots[si];
            if (s.type != r.type || s.lastUse >= r.firstUse) continue;
            bool shape =
                isTexture ? sameShape(s.textureDesc, r.textureDesc) : sameShape(s.bufferDesc, r.bufferDesc);
            if (shape) chosen = uint32_t(si);
        }
        if (chosen == kInvalidIndex) {
            Slot s;
            s.type = r.type;
            s.textureDesc = r.textureDesc;
            s.bufferDesc = r.bufferDesc;
            initSlotState(s, Access::None);
            chosen = uint32_t(m_slots.size());
            m_slots.push_back(std::move(s));
        }
        Slot& s = m_slots[chosen];
        s.lastUse = r.lastUse;
        if (isTexture)
            s.textureUsage |= textureUsageFor(accumulated[ri]) | rhi::TextureUsage::CopySrc;
        else
            s.bufferUsage |= bufferUsageFor(accumulated[ri]) | rhi::BufferUsage::CopySrc;
        s.resources.push_back(ri);
        r.slot = chosen;
        r.allocated = true;
    }
    m_info.transientCount = uint32_t(transients.size());

    // Physical resources from the pool.
    for (size_t si = firstTransientSlot; si < m_slots.size(); ++si)
        if (!acquirePhysical(m_slots[si])) return false;
    m_info.physicalResourceCount = m_info.physicalTextureCount + m_info.physicalBufferCount;
    releaseUnusedPoolEntries(false);
    return true;
}

// A physical resource from the pool for a transient slot: same shape, usage a superset (an exact
// match first), or a new one.
bool FrameGraph::acquirePhysical(Slot& s) {
    std::string debugName = "fg";
    for (uint32_t ri : s.resources) debugName += (debugName.size() == 2 ? ":" : "+") + m_resources[ri].name;
    if (s.type == ResourceType::Texture) {
        PooledTexture* best = nullptr;
        for (PooledTexture& t : m_texturePool) {
            if (t.inUse || !sameShape(t.desc, s.textureDesc) || any(s.textureUsage & ~t.desc.usage)) continue;
            if (!best || (t.desc.usage == s.textureUsage && best->desc.usage != s.textureUsage)) best = &t;
        }
        if (!best) {
            rhi::TextureDesc desc = s.textureDesc;
            desc.usage = s.textureUsage;
            desc.debugName = debugName;
            rhi::TextureHandle h = m_device.createTexture(desc);
            if (!h) {
                error("could not create the physical texture for '" + debugName.substr(3) + "'");
                return false;
            }
            m_texturePool.push_back(PooledTexture{h, desc, m_frame, false});
            best = &m_texturePool.back();
            ++m_info.texturesCreated;
        }
        best->inUse = true;
        best->lastUsedFrame = m_frame;
        s.texture = best->handle;
        s.textureUsage = best->desc.usage;
        ++m_info.physicalTextureCount;
        m_info.transientMemoryBytes += rhi::textureBytes(best->desc);
        for (uint32_t ri : s.resources) m_resources[ri].textureDesc.usage = s.textureUsage;
    } else {
        PooledBuffer* best = nullptr;
        for (PooledBuffer& b : m_bufferPool) {
            if (b.inUse || !sameShape(b.desc, s.bufferDesc) || any(s.bufferUsage & ~b.desc.usage)) continue;
            if (!best || (b.desc.usage == s.bufferUsage && best->desc.usage != s.bufferUsage)) best = &b;
        }
        if (!best) {
            rhi::BufferDesc desc = s.bufferDesc;
            desc.usage = s.bufferUsage;
            desc.debugName = debugName;
            rhi::BufferHandle h = m_device.createBuffer(desc);
            if (!h) {
                error("could not create the physical buffer for '" + debugName.substr(3) + "'");
                return false;
            }
            m_bufferPool.push_back(PooledBuffer{h, desc, m_frame, false});
            best = &m_bufferPool.back();
            ++m_info.buffersCreated;
        }
        best->inUse = true;
        best->lastUsedFrame = m_frame;
        s.buffer = best->handle;
        s.bufferUsage = best->desc.usage;
        ++m_info.physicalBufferCount;
        m_info.transientMemoryBytes += best->desc.size;
        for (uint32_t ri : s.resources) m_resources[ri].bufferDesc.usage = s.bufferUsage;
    }
    return true;
}

void FrameGraph::releaseUnusedPoolEntries(bool all) {
    auto expired = [&](uint64_t lastUsed, bool inUse) {
        if (inUse) return false;
        return all || m_frame - lastUsed >= m_retainFrames;
    };
    uint32_t released = 0;
    std::erase_if(m_texturePool, [&](const PooledTexture& t) {
        if (!expired(t.lastUsedFrame, t.inUse)) return false;
        m_device.destroy(t.handle);
        ++released;
        return true;
    });
    std::erase_if(m_bufferPool, [&](const PooledBuffer& b) {
        if (!expired(b.lastUsedFrame, b.inUse)) return false;
        m_device.destroy(b.handle);
        ++released;
        return true;
    });
    m_info.poolEntriesReleased += released;
}

void FrameGraph::trimPool() { releaseUnusedPoolEntries(true); }

void FrameGraph::initSlotState(Slot& s, rhi::Access state) const {
    const bool isTexture = s.type == ResourceType::Texture;
    s.mips = isTexture ? mipCountOf(s.textureDesc) : 1;
    s.layers = isTexture ? layerCountOf(s.textureDesc) : 1;
    s.state.assign(size_t(s.mips) * s.layers, state);
}

// Moves the subresources of `s` whose entry in `need` is not None to that state and appends the
// barriers this takes to `out`. With `onlyChanges` a barrier is placed only where the state
// differs (end-of-frame transitions); otherwise also between two uses of one state that includes
// a write (RAW / WAW between passes). When the whole resource moves from one state to one state,
// that is a single whole-resource barrier; otherwise one barrier per run of layers of a mip, runs
// of consecutive mips with the same layers and states merged.
void FrameGraph::transition(Slot& s, const std::vector<std::optional<rhi::Access>>& target,
                            std::vector<rhi::Barrier>& out, bool onlyChanges) const {
    std::vector<Access> need(target.size(), Access::None);
    for (size_t i = 0; i < target.size(); ++i) need[i] = target[i].value_or(Access::None);
    auto wants = [&](size_t i) {
        return target[i] && (s.state[i] != need[i] || (!onlyChanges && rhi::isWriteAccess(s.state[i])));
    };
    bool uniform = true;
    for (size_t i = 0; i < s.state.size() && uniform; ++i)
        uniform = target[i] && need[i] == need[0] && s.state[i] == s.state[0];
    if (uniform) {
        if (wants(0))
            out.push_back(s.type == ResourceType::Texture ? rhi::Barrier::tex(s.texture, s.state[0], need[0])
                                                          : rhi::Barrier::buf(s.buffer, s.state[0], need[0]));
        std::fill(s.state.begin(), s.state.end(), need[0]);
        return;
    }
    const size_t first = out.size();
    for (uint32_t m = 0; m < s.mips; ++m) {
        for (uint32_t l = 0; l < s.layers;) {
            const size_t i = size_t(m) * s.layers + l;
            if (!wants(i)) {
                ++l;
                continue;
            }
            uint32_t end = l + 1;
            while (end < s.layers && wants(i + (end - l)) && s.state[i + (end - l)] == s.state[i] &&
                   need[i + (end - l)] == need[i])
                ++end;
            rhi::TextureRange range{m, 1, l, end - l};
            if (range.baseLayer == 0 && end == s.layers) range.layerCount = rhi::kRemaining;
            rhi::Barrier b = rhi::Barrier::tex(s.texture, s.state[i], need[i], range);
            // Merge with the previous mip's barrier when it covers the same layers and states.
            bool merged = false;
            for (size_t k = out.size(); k-- > first && !merged;) {
                rhi::Barrier& prev = out[k];
                if (prev.range.baseMip + prev.range.mipCount == m &&
                    prev.range.baseLayer == range.baseLayer && prev.range.layerCount == range.layerCount &&
                    prev.before == b.before && prev.after == b.after) {
                    ++prev.range.mipCount;
                    merged = true;
                }
            }
            if (!merged) out.push_back(b);
            l = end;
        }
    }
    for (size_t i = 0; i < s.state.size(); ++i)
        if (target[i]) s.state[i] = need[i];
}

// The state of a resource when all its subresources are in one state, else Access::None.
rhi::Access FrameGraph::uniformState(const Slot& s) const {
    for (Access a : s.state)
        if (a != s.state.front()) return Access::None;
    return s.state.empty() ? Access::None : s.state.front();
}

void FrameGraph::placeBarriers() {
    for (uint32_t e = 0; e < m_order.size(); ++e) {
        const PassNode& p = m_passes[m_order[e]];
        CompiledPass cp;
        cp.name = p.name;
        cp.kind = p.kind;
        for (const ResourceUse& u : p.uses) {
            ResourceNode& r = m_resources[u.resource];
            Slot& s = m_slots[r.slot];
            // Every life of a transient starts with undefined contents.
            if (!r.imported && r.firstUse == e) std::fill(s.state.begin(), s.state.end(), Access::None);
            // The state each subresource needs: the union of the accesses declared on it.
            std::vector<std::optional<Access>> need(s.state.size());
            for (const Part& part : u.parts) {
                const auto [m0, m1] = span(part.range.baseMip, part.range.mipCount, s.mips);
                const auto [l0, l1] = span(part.range.baseLayer, part.range.layerCount, s.layers);
                for (uint32_t m = m0; m < m1; ++m)
                    for (uint32_t l = l0; l < l1; ++l) {
                        std::optional<Access>& n = need[size_t(m) * s.layers + l];
                        n = n.value_or(Access::None) | part.access;
                    }
            }
            // A state change (layout, or a different kind of access to wait for), or a hazard
            // between passes in one state that includes a write (RAW / WAW). Between readers in the
            // same read state nothing is needed.
            transition(s, need, cp.barriers, false);
            r.endState = uniformState(s);
        }
        m_info.passes.push_back(std::move(cp));
    }

    for (ResourceNode& r : m_resources) {
        if (r.slot == kInvalidIndex) continue;
        Slot& s = m_slots[r.slot];
        bool wantsFinal = r.imported || (r.output && r.finalState != Access::None);
        if (wantsFinal) {
            transition(s, std::vector<std::optional<Access>>(s.state.size(), r.finalState),
                       m_info.finalBarriers, true);
            r.endState = r.finalState;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// FrameGraph: execute and timings
// ---------------------------------------------------------------------------------------------
void FrameGraph::execute(rhi::CommandList& cmd) {
    if (m_failed) {
        log(rhi::LogSeverity::Warning, "frame graph: execute() skipped because the frame has errors");
        return;
    }
    if (!m_compiled) {
        error("execute() called before compile()");
        return;
    }
    if (m_executed) {
        error("execute() called twice in one frame");
        return;
    }
    m_executed = true;

    const uint32_t passCount = uint32_t(m_order.size());
    TimingFrame& tf = currentTimingFrame();
    if (tf.pending) {
        // The ring came round before this pool's results were collected: read them now (without
        // waiting if they are there) and hand them to the next pollTimings().
        std::optional<FrameTimings> early = readTimings(tf, false);
        if (!early) early = readTimings(tf, true);
        if (early) m_timingsReady.push_back(std::move(*early));
    }
    bool timestamps = m_device.info().limits.timestamps && passCount > 0;
    if (timestamps && tf.capacity < 2 * passCount) {
        // (Re)create the pools of every idle slot of the ring at once, so a steady frame loop
        // creates nothing after its first frame.
        const uint32_t capacity = std::max({2 * passCount, 2 * tf.capacity, 32u});
        for (TimingFrame& slot : m_timingRing) {
            if ((slot.pending && &slot != &tf) || slot.capacity >= 2 * passCount) continue;
            if (slot.pool) m_device.destroy(slot.pool);
            slot.pool = m_device.createQueryPool(rhi::QueryPoolDesc{capacity, "frame graph timestamps"});
            slot.capacity = slot.pool ? capacity : 0;
        }
        if (!tf.pool)
            log(rhi::LogSeverity::Warning,
                "frame graph: could not create the timestamp query pool; no GPU timings");
    }
    timestamps = timestamps && tf.pool;
    if (timestamps) cmd.resetQueries(tf.pool, 0, 2 * passCount);
    tf.frame = m_frame;
    tf.pending = true;
    tf.timestamps = timestamps;
    tf.names.clear();
    tf.cpuMs.assign(passCount, 0.0);

    for (uint32_t e = 0; e < passCount; ++e) {
        PassNode& p = m_passes[m_order[e]];
        const CompiledPass& cp = m_info.passes[e];
        tf.names.push_back(p.name);
        auto start = std::chrono::steady_clock::now();
        cmd.pushDebugGroup(p.name);
        if (timestamps) cmd.writeTimestamp(tf.pool, 2 * e);
        if (!cp.barriers.empty()) cmd.barrier(std::span<const rhi::Barrier>(cp.barriers));
        PassContext ctx(cmd, m_device, *this, m_order[e]);
        p.executor->run(ctx);
        if (timestamps) cmd.writeTimestamp(tf.pool, 2 * e + 1);
        cmd.popDebugGroup();
        tf.cpuMs[e] =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    }
    if (!m_info.finalBarriers.empty()) cmd.barrier(std::span<const rhi::Barrier>(m_info.finalBarriers));
}

std::optional<FrameTimings> FrameGraph::readTimings(TimingFrame& t, bool blocking) {
    if (!t.pending) return std::nullopt;
    const uint32_t passCount = uint32_t(t.names.size());
    FrameTimings out;
    out.frame = t.frame;
    out.passes.resize(passCount);
    for (uint32_t e = 0; e < passCount; ++e) {
        out.passes[e].name = t.names[e];
        out.passes[e].cpuMs = t.cpuMs[e];
        out.passes[e].gpuMs = std::numeric_limits<double>::quiet_NaN();
    }
    if (t.timestamps && passCount > 0) {
        std::vector<uint64_t> ns(2 * size_t(passCount), 0);
        const bool ok = blocking ? m_device.readTimestamps(t.pool, 0, 2 * passCount, ns.data())
                                 : m_device.tryReadTimestamps(t.pool, 0, 2 * passCount, ns.data());
        if (!ok && !blocking) return std::nullopt;
        if (ok) {
            for (uint32_t e = 0; e < passCount; ++e) {
                const uint64_t begin = ns[2 * e], end = ns[2 * e + 1];
                out.passes[e].gpuMs = end >= begin ? double(end - begin) * 1e-6 : 0.0;
            }
        } else {
            log(rhi::LogSeverity::Warning, "frame graph: reading the pass timestamps failed; gpuMs is NaN");
        }
    }
    t.pending = false;
    if (t.frame == m_frame && m_executed) {
        m_timings = out.passes;
        m_timingsCollected = true;
    }
    return out;
}

std::vector<PassTiming> FrameGraph::collectTimings() {
    if (!m_executed) return {};
    if (m_timingsCollected) return m_timings;
    readTimings(currentTimingFrame(), true);
    return m_timings;
}

std::vector<FrameTimings> FrameGraph::pollTimings() {
    std::vector<FrameTimings> out = std::move(m_timingsReady);
    m_timingsReady.clear();
    for (TimingFrame& t : m_timingRing)
        if (std::optional<FrameTimings> r = readTimings(t, false)) out.push_back(std::move(*r));
    std::sort(out.begin(), out.end(),
              [](const FrameTimings& a, const FrameTimings& b) { return a.frame < b.frame; });
    return out;
}

std::vector<FrameTimings> FrameGraph::flushTimings() {
    std::vector<FrameTimings> out = std::move(m_timingsReady);
    m_timingsReady.clear();
    for (TimingFrame& t : m_timingRing)
        if (std::optional<FrameTimings> r = readTimings(t, true)) out.push_back(std::move(*r));
    std::sort(out.begin(), out.end(),
              [](const FrameTimings& a, const FrameTimings& b) { return a.frame < b.frame; });
    return out;
}

// ---------------------------------------------------------------------------------------------
// FrameGraph: queries after compile
// ---------------------------------------------------------------------------------------------
rhi::TextureHandle FrameGraph::physicalTexture(TextureRef ref) const {
    uint32_t r = resolve(ref.index, ref.epoch, ResourceType::Texture);
    if (r == kInvalidIndex || !isCompiled() || m_resources[r].slot == kInvalidIndex) return {};
    return m_slots[m_resources[r].slot].texture;
}

rhi::BufferHandle FrameGraph::physicalBuffer(BufferRef ref) const {
    uint32_t r = resolve(ref.index, ref.epoch, ResourceType::Buffer);
    if (r == kInvalidIndex || !isCompiled() || m_resources[r].slot == kInvalidIndex) return {};
    return m_slots[m_resources[r].slot].buffer;
}

rhi::Access FrameGraph::finalState(TextureRef ref) const {
    uint32_t r = resolve(ref.index, ref.epoch, ResourceType::Texture);
    if (r == kInvalidIndex || !isCompiled()) return Access::None;
    return m_resources[r].endState;
}

rhi::Access FrameGraph::finalState(BufferRef ref) const {
    uint32_t r = resolve(ref.index, ref.epoch, ResourceType::Buffer);
    if (r == kInvalidIndex || !isCompiled()) return Access::None;
    return m_resources[r].endState;
}

}  // namespace penumbra::fg
