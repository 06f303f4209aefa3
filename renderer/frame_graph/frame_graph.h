// penumbra frame graph: passes declare the resources they read and write; the graph culls passes
// whose results nobody needs, allocates (and aliases) transient resources from a pool that
// persists across frames, places every barrier, times each pass on the GPU and the CPU, and dumps
// itself as Graphviz. Pass code never writes barriers.
//
// Per frame:
//     graph.reset();
//     TextureRef target = graph.importTexture("backbuffer", handle, rhi::Access::None, rhi::Access::Present);
//     const auto& gbuf = graph.addPass<GBufferData>("gbuffer", PassKind::Raster,
//         [&](PassBuilder& b, GBufferData& d) {
//             d.depth = b.write(b.createTexture("depth", depthDesc), rhi::Access::DepthTargetWrite);
//         },
//         [](const GBufferData& d, PassContext& ctx) { ctx.cmd.beginRenderPass(...); ... });
//     ...
//     if (graph.compile()) graph.execute(cmd);
//     device.submit(cmd);
//     for (const fg::FrameTimings& t : graph.pollTimings()) ...   // earlier frames, no waiting
//
// Resources
// - Refs (TextureRef / BufferRef) are small typed ids, valid until the next reset(). A ref kept
//   across reset() is stale and reported as an error when used.
// - Transients (PassBuilder::createTexture/createBuffer) are virtual until compile(). Their rhi
//   usage flags are derived from every access declared on them (plus CopySrc, so any transient can
//   be read back for debugging); the `usage` member of the desc passed in is ignored. Buffers keep
//   the desc's `memory` type. A transient's contents are undefined at its first use in a frame
//   (it enters in rhi::Access::None), so it must be written before it is read.
// - Imported resources (importTexture/importBuffer) are owned by the caller. They enter in
//   `currentState`; at the end of the frame the graph transitions them to `finalState` (default:
//   `currentState`), whether or not a pass used them.
//
// Outputs and culling. A pass is kept when it has a side effect (PassBuilder::sideEffect()) or
// when something kept needs what it writes. What is needed starts from the outputs:
//   (a) every imported resource: its last contents are visible outside the graph, so every pass
//       that writes an imported resource is kept (a pass that only reads one is not);
//   (b) every resource passed to markOutput() (e.g. a transient read back after submission).
// The graph tracks versions: each pass that writes a resource makes a new version of it. A version
// is needed when it is the last version of an output or when a kept pass reads it. A write never
// discards the previous version (LoadOp::Load, blending and partial writes read it), so a kept
// writer also keeps the writer of the version before it. Culling is reference counting from
// these needs backwards (Frostbite's FrameGraph): every pass counts the versions it produces,
// every version counts its readers; versions nobody reads release their producer, a producer
// left with no count is culled and releases the versions it read, iteratively. Culled passes
// never execute; transients used only by culled passes are never allocated.
//
// Transient allocation. Physical textures/buffers come from a pool owned by the graph. Within a
// frame, two transients with the same shape (textures: dimension, format, size, layers, mips;
// buffers: size, memory type) whose lifetimes (first to last use among kept passes, in execution
// order) do not overlap share one physical resource (aliasing); its usage is the union of theirs.
// A transient passed to markOutput() lives to the end of the frame and is not aliased after its
// last use. Across frames a physical resource is reused when a pool entry with the same shape and
// a superset of the usage is free. Pool entries that no frame has used for `poolRetainFrames()`
// consecutive compiles (default 3) are destroyed with Device::destroy (deferred by the RHI).
//
// Barriers. compile() walks the kept passes in order, tracking the state of every physical
// resource, and gives each pass ONE batch of barriers recorded before its commands:
// - the state a pass needs for a resource is the union of the accesses it declared on it;
// - a resource gets a barrier when its state differs from the needed one (a layout change, or a
//   different access to wait for), or when both are the same state and it includes a write
//   (read-after-write / write-after-write between passes, e.g. ShaderWrite -> ShaderWrite or
//   ColorTarget -> ColorTarget). Two passes reading in the same read state need no barrier.
//   (Buffers also get one between different read states, e.g. ShaderRead -> UniformRead: it is
//   cheap, keeps every tracked state exact for the RHI validation layer, and chains the
//   execution dependency so a later write waits for every earlier reader.)
// - every transient (aliased or not) starts each life in rhi::Access::None: its first use gets a
//   barrier None -> needed state (contents discarded);
// - after the last pass, one more batch moves imported resources to their finalState and
//   transients given a final state in markOutput() to that state.
//
// Subresources. A texture may be read or written in parts (Subresource: a mip range, a layer
// range, a 3D box). The graph tracks every mip level and array layer of a physical texture
// separately, so a chain of passes that each sample mip i-1 and write mip i gets exactly the
// barriers of the two mips it touches, and a later whole-texture use transitions only the mips
// that are in another state (consecutive mips in one state share one barrier). Versions and
// culling stay per resource: any write to a part makes a new version of the whole resource.
// Boxes are checked against the mip size and shown in the dump; barriers cover whole mips.
//
// Execution. execute() records, per kept pass: pushDebugGroup(name), a GPU timestamp, the
// barrier batch, the pass's execute callback, a second timestamp, popDebugGroup; then the final
// barrier batch. Timestamps go into a ring of kTimingFramesInFlight query pools owned by the
// graph (one per frame, grown as needed): pollTimings() returns, without waiting, every earlier
// frame whose results have arrived; flushTimings() waits for the rest (end of a run);
// collectTimings() waits for the current frame (tests and one-shot tools). When the device
// reports info().limits.timestamps == false, no timestamps are recorded and every gpuMs is NaN.
//
// Errors (a resource that was never created or a stale ref, reading a transient before any pass
// wrote it, incompatible read and write usages of one resource in one pass, an access that makes
// no sense for the resource or pass kind, addPass/import after compile(), compile() twice) are
// reported through the log callback given to the constructor (default: stderr). After an error,
// compile() returns false and execute() records nothing. Nothing here throws or aborts.
//
// The device must outlive the graph. Not thread-safe: use one graph from one thread.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#include "rhi/device.h"

namespace penumbra::fg {

enum class PassKind : uint8_t { Compute, Raster, Transfer };
const char* toString(PassKind kind);

inline constexpr uint32_t kInvalidIndex = 0xffffffffu;

// Typed ids of virtual resources; `epoch` identifies the frame (reset) that created them.
struct TextureRef {
    uint32_t index = kInvalidIndex;
    uint32_t epoch = 0;
    constexpr bool isValid() const { return index != kInvalidIndex; }
    friend constexpr bool operator==(const TextureRef&, const TextureRef&) = default;
};

struct BufferRef {
    uint32_t index = kInvalidIndex;
    uint32_t epoch = 0;
    constexpr bool isValid() const { return index != kInvalidIndex; }
    friend constexpr bool operator==(const BufferRef&, const BufferRef&) = default;
};

inline constexpr uint32_t kAllMips = rhi::kRemaining;
inline constexpr uint32_t kAllLayers = rhi::kRemaining;

// The part of a texture a pass reads or writes: a range of mip levels and array layers (Tex2DArray)
// as in rhi::TextureRange and, for Tex3D textures, a box inside each of those mips (`extent` 0 on
// an axis: to the end of the mip). The default is the whole texture. Barriers and state are
// tracked per mip level and array layer; a box narrows what the pass declares (it is checked
// against the texture's size and shown in the Graphviz dump) but a barrier always covers the whole
// mip, as GPU image barriers do.
struct Subresource : rhi::TextureRange {
    std::array<uint32_t, 3> offset{0, 0, 0};  // Tex3D box origin (texels of each mip)
    std::array<uint32_t, 3> extent{0, 0, 0};  // Tex3D box size; 0 = to the end of the mip

    static Subresource whole() { return {}; }
    static Subresource mips(uint32_t base, uint32_t count = 1) {
        Subresource s;
        s.baseMip = base;
        s.mipCount = count;
        return s;
    }
    static Subresource layers(uint32_t base, uint32_t count = 1) {
        Subresource s;
        s.baseLayer = base;
        s.layerCount = count;
        return s;
    }
    static Subresource region(uint32_t mip, std::array<uint32_t, 3> origin, std::array<uint32_t, 3> size) {
        Subresource s = mips(mip);
        s.offset = origin;
        s.extent = size;
        return s;
    }
    bool isWhole() const {
        return TextureRange::isWhole() && offset == std::array<uint32_t, 3>{0, 0, 0} &&
               extent == std::array<uint32_t, 3>{0, 0, 0};
    }
};

// "mip 1", "layers 2+3", "box (0,0,0) size (8,8,8)"; empty for the whole texture.
std::string toString(const Subresource& part);

struct PassTiming {
    std::string name;
    double gpuMs = 0.0;  // NaN when the device has no timestamps or they could not be read
    double cpuMs = 0.0;  // time spent recording the pass (barriers + execute callback)
};

// The timings of one executed frame; `frame` counts reset() calls of the graph.
struct FrameTimings {
    uint64_t frame = 0;
    std::vector<PassTiming> passes;  // kept passes in execution order
};

// How many frames' timestamps may be in flight before execute() must wait for the oldest.
inline constexpr uint32_t kTimingFramesInFlight = 4;

struct CompiledPass {
    std::string name;
    PassKind kind = PassKind::Compute;
    std::vector<rhi::Barrier> barriers;  // the one batch recorded before the pass's commands
};

// What compile() decided; valid until the next reset().
struct CompiledInfo {
    std::vector<CompiledPass> passes;         // kept passes, in execution order
    std::vector<std::string> culledPasses;    // in declaration order
    std::vector<rhi::Barrier> finalBarriers;  // end-of-frame transitions (imports, outputs)
    uint32_t transientCount = 0;              // virtual transients that were allocated
    uint32_t physicalTextureCount = 0;        // physical textures backing them this frame
    uint32_t physicalBufferCount = 0;         // physical buffers backing them this frame
    uint32_t physicalResourceCount = 0;       // textures + buffers
    uint32_t texturesCreated = 0;             // created this frame (0 when the pool served all)
    uint32_t buffersCreated = 0;
    uint32_t poolEntriesReleased = 0;  // pool entries destroyed this compile (unused too long)
    // Estimated memory of the physical transients used this frame: for textures the sum over mips
    // of width * height * depth-or-layers * bytes per texel, for buffers their size.
    uint64_t transientMemoryBytes = 0;

    const CompiledPass* findPass(std::string_view name) const;
    bool isCulled(std::string_view name) const;
};

class FrameGraph;
class PassContext;

namespace detail {
struct PassExecutor {
    virtual ~PassExecutor() = default;
    virtual void run(PassContext& ctx) = 0;
};
}  // namespace detail

// Handed to a pass's setup callback: declares what the pass creates, reads and writes.
// Every method returns the ref it was given (or created), for chaining.
class PassBuilder {
public:
    // Transient resources, allocated by compile() only when a kept pass uses them.
    TextureRef createTexture(std::string name, const rhi::TextureDesc& desc);
    BufferRef createBuffer(std::string name, const rhi::BufferDesc& desc);
    // `usage` must be read-only accesses (ShaderSampled, ShaderRead, UniformRead, VertexRead,
    // IndexRead, IndirectRead, DepthTargetRead, CopySrc, HostRead, Present).
    TextureRef read(TextureRef ref, rhi::Access usage);
    BufferRef read(BufferRef ref, rhi::Access usage);
    // A part of a texture (mip range, layer range, 3D box). One pass may declare several parts of
    // one texture with different accesses as long as parts with incompatible accesses share no
    // mip level and layer (e.g. sample mip 0 and write mip 1: a mip chain step).
    TextureRef read(TextureRef ref, rhi::Access usage, const Subresource& part);
    // `usage` must include a write (ShaderWrite, ColorTarget, DepthTargetWrite, CopyDst,
    // HostWrite). A pass may read and write one resource only as ShaderRead + ShaderWrite,
    // DepthTargetRead + DepthTargetWrite, or (buffers) CopySrc + CopyDst.
    TextureRef write(TextureRef ref, rhi::Access usage);
    BufferRef write(BufferRef ref, rhi::Access usage);
    TextureRef write(TextureRef ref, rhi::Access usage, const Subresource& part);
    // The pass does something outside the graph (readback, presentation, counters): never culled.
    void sideEffect();

private:
    friend class FrameGraph;
    PassBuilder(FrameGraph& graph, uint32_t pass) : m_graph(graph), m_pass(pass) {}
    FrameGraph& m_graph;
    uint32_t m_pass;
};

// Handed to a pass's execute callback.
class PassContext {
public:
    rhi::CommandList& cmd;
    rhi::Device& device;

    // Physical handles of resources this pass declared (read or write). Anything else is an
    // error: it is logged and an invalid handle is returned.
    rhi::TextureHandle texture(TextureRef ref) const;
    rhi::BufferHandle buffer(BufferRef ref) const;
    // Descriptions (transients: as created, with the derived usage; imports: as the device
    // describes them). Never null: an empty desc is returned for bad refs.
    const rhi::TextureDesc& textureDesc(TextureRef ref) const;
    const rhi::BufferDesc& bufferDesc(BufferRef ref) const;
    const std::string& name() const;

private:
    friend class FrameGraph;
    PassContext(rhi::CommandList& c, rhi::Device& d, const FrameGraph& g, uint32_t pass)
        : cmd(c), device(d), m_graph(g), m_pass(pass) {}
    const FrameGraph& m_graph;
    uint32_t m_pass;
};

namespace detail {
template <typename Data, typename Execute>
struct TypedPass final : PassExecutor {
    explicit TypedPass(Execute&& e) : execute(std::move(e)) {}
    explicit TypedPass(const Execute& e) : execute(e) {}
    void run(PassContext& ctx) override { execute(static_cast<const Data&>(data), ctx); }
    Data data{};
    Execute execute;
};
}  // namespace detail

class FrameGraph {
public:
    // `log` receives every error (null: messages go to stderr).
    explicit FrameGraph(rhi::Device& device, rhi::LogCallback log = {});
    ~FrameGraph();
    FrameGraph(const FrameGraph&) = delete;
    FrameGraph& operator=(const FrameGraph&) = delete;

    // How many consecutive compiles a pool entry may go unused before it is destroyed (default 3;
    // 0 destroys entries at the first compile that does not use them).
    void setPoolRetainFrames(uint32_t frames) { m_retainFrames = frames; }
    uint32_t poolRetainFrames() const { return m_retainFrames; }
    // Destroys every pool entry not used by the current compiled frame (e.g. after a resize).
    void trimPool();
    size_t pooledTextureCount() const { return m_texturePool.size(); }
    size_t pooledBufferCount() const { return m_bufferPool.size(); }

    // Starts a new frame: forgets every pass and resource of the previous one (refs become stale)
    // and frees the pool entries for reuse. Call once per frame before adding passes.
    void reset();

    // External resources, entering the frame in `currentState` and left in `finalState` (default:
    // `currentState`). One handle may be imported only once per frame.
    TextureRef importTexture(std::string name, rhi::TextureHandle texture, rhi::Access currentState);
    TextureRef importTexture(std::string name, rhi::TextureHandle texture, rhi::Access currentState,
                             rhi::Access finalState);
    BufferRef importBuffer(std::string name, rhi::BufferHandle buffer, rhi::Access currentState);
    BufferRef importBuffer(std::string name, rhi::BufferHandle buffer, rhi::Access currentState,
                           rhi::Access finalState);

    // Persistent textures (render targets, histories, atlases kept across frames): the graph
    // remembers the state every compiled frame leaves them in, so their owner never tracks it.
    // importPersistent() imports with the remembered state (Access::None the first time) and
    // leaves the texture in `finalState`; persistentState() is where the last compiled frame left
    // it (e.g. for a readback); forgetPersistent() drops a destroyed texture. Persistent buffers
    // (e.g. the SDF object array updated from deltas) work the same way.
    TextureRef importPersistent(std::string name, rhi::TextureHandle texture, rhi::Access finalState);
    rhi::Access persistentState(rhi::TextureHandle texture) const;
    void forgetPersistent(rhi::TextureHandle texture);
    BufferRef importPersistent(std::string name, rhi::BufferHandle buffer, rhi::Access finalState);
    rhi::Access persistentState(rhi::BufferHandle buffer) const;
    void forgetPersistent(rhi::BufferHandle buffer);

    // Marks a result that must survive the frame: its producers are kept and (for transients) the
    // physical resource is not aliased after it. With finalState != None the resource is
    // transitioned to it at the end of the frame. Read the handle with physicalTexture() and the
    // state it is left in with finalState() after compile().
    void markOutput(TextureRef ref, rhi::Access finalState = rhi::Access::None);
    void markOutput(BufferRef ref, rhi::Access finalState = rhi::Access::None);

    // Adds a pass. `setup(PassBuilder&, Data&)` runs at once and declares resources; `execute(const
    // Data&, PassContext&)` runs in execute() if the pass survives culling. Data must be default
    // constructible; the returned reference stays valid until reset().
    template <typename Data, typename Setup, typename Execute>
    const Data& addPass(std::string name, PassKind kind, Setup&& setup, Execute&& execute) {
        using Exec = std::decay_t<Execute>;
        auto pass = std::make_unique<detail::TypedPass<Data, Exec>>(std::forward<Execute>(execute));
        Data& data = pass->data;
        uint32_t index = beginPass(std::move(name), kind, std::move(pass));
        PassBuilder builder(*this, index);
        setup(builder, data);
        return data;
    }

    // Culls, allocates transients and places barriers. Returns false (after logging) on any error
    // in this frame's declarations, on a failed allocation, or when called twice in one frame.
    bool compile();
    // Records every kept pass into `cmd`. Does nothing if compile() did not succeed.
    void execute(rhi::CommandList& cmd);
    // Per-pass timings of this frame's executed passes, in execution order (culled passes have
    // none). Call after the command list given to execute() was submitted: it WAITS for the GPU.
    // For tests and one-shot tools; frame loops use pollTimings().
    std::vector<PassTiming> collectTimings();
    // Non-blocking: the timings of every executed frame whose GPU timestamps are available now and
    // were not returned before, oldest first (typically one to three frames late). Each frame's
    // timestamps live in their own query pool of a ring of kTimingFramesInFlight; only when a
    // frame's pool is needed again before its results arrived does execute() wait for them (the
    // results are then returned by the next poll).
    std::vector<FrameTimings> pollTimings();
    // Waits for every outstanding frame and returns their timings, oldest first (end of a run).
    std::vector<FrameTimings> flushTimings();
    // The frame number of the current frame (counts reset() calls).
    uint64_t frameNumber() const { return m_frame; }

    // Graphviz digraph: pass nodes (boxes; culled ones dashed and grey), resource nodes (imported:
    // bold double ellipses; transients: ellipses with their physical resource and the transients
    // aliased with it), read edges resource -> pass and write edges pass -> resource labelled with
    // the access. Before compile() nothing is shown as culled.
    std::string toGraphviz() const;

    const CompiledInfo& compiled() const { return m_info; }
    bool isCompiled() const { return m_compiled && !m_failed; }
    bool hasErrors() const { return m_failed; }

    // After a successful compile(): the physical handle behind a ref (invalid for transients that
    // were not allocated) and the state the resource is left in at the end of the frame.
    rhi::TextureHandle physicalTexture(TextureRef ref) const;
    rhi::BufferHandle physicalBuffer(BufferRef ref) const;
    rhi::Access finalState(TextureRef ref) const;
    rhi::Access finalState(BufferRef ref) const;

private:
    friend class PassBuilder;
    friend class PassContext;

    enum class ResourceType : uint8_t { Texture, Buffer };

    struct ResourceNode {
        std::string name;
        ResourceType type = ResourceType::Texture;
        bool imported = false;
        bool output = false;
        rhi::TextureDesc textureDesc;
        rhi::BufferDesc bufferDesc;
        rhi::TextureHandle importedTexture;
        rhi::BufferHandle importedBuffer;
        rhi::Access initialState = rhi::Access::None;
        rhi::Access finalState = rhi::Access::None;  // imports: target; outputs: None = as left
        uint32_t creatorPass = kInvalidIndex;
        uint32_t version = 0;             // passes that have written it so far (during setup)
        std::vector<uint32_t> producers;  // producers[v - 1] = pass that made version v
        // compile results
        std::vector<uint32_t> versionRefs;  // versionRefs[v - 1]
        bool allocated = false;
        uint32_t firstUse = kInvalidIndex;  // execution indices
        uint32_t lastUse = 0;
        uint32_t slot = kInvalidIndex;  // state-tracking slot (physical resource or import)
        rhi::Access endState = rhi::Access::None;
    };

    // One declared part of a texture and the access to it (buffers and whole-texture uses have a
    // single part covering everything).
    struct Part {
        Subresource range;
        rhi::Access access = rhi::Access::None;
    };

    struct ResourceUse {
        uint32_t resource = kInvalidIndex;
        rhi::Access read = rhi::Access::None;   // union over the parts
        rhi::Access write = rhi::Access::None;  // union over the parts
        std::vector<Part> parts;
        uint32_t inputVersion = 0;   // version read (and overwritten) by the pass
        uint32_t outputVersion = 0;  // version produced (writes only)
    };

    struct PassNode {
        std::string name;
        PassKind kind = PassKind::Compute;
        bool sideEffect = false;
        bool culled = false;
        uint32_t refCount = 0;
        std::vector<ResourceUse> uses;
        std::unique_ptr<detail::PassExecutor> executor;
    };

    // One tracked physical identity this frame: a physical transient or an import.
    struct Slot {
        ResourceType type = ResourceType::Texture;
        bool imported = false;
        rhi::TextureHandle texture;
        rhi::BufferHandle buffer;
        rhi::TextureDesc textureDesc;  // shape of a transient slot (usage: union of its occupants)
        rhi::BufferDesc bufferDesc;
        uint32_t lastUse = 0;  // aliasing: last execution index of the current occupant
        rhi::TextureUsage textureUsage = rhi::TextureUsage::None;
        rhi::BufferUsage bufferUsage = rhi::BufferUsage::None;
        std::vector<uint32_t> resources;  // virtual resources mapped to it, in order of first use
        // Current state per subresource: index mip * layers + layer (buffers: one entry).
        std::vector<rhi::Access> state;
        uint32_t mips = 1, layers = 1;
    };

    struct PooledTexture {
        rhi::TextureHandle handle;
        rhi::TextureDesc desc;
        uint64_t lastUsedFrame = 0;
        bool inUse = false;
    };
    struct PooledBuffer {
        rhi::BufferHandle handle;
        rhi::BufferDesc desc;
        uint64_t lastUsedFrame = 0;
        bool inUse = false;
    };

    uint32_t beginPass(std::string name, PassKind kind, std::unique_ptr<detail::PassExecutor> executor);
    uint32_t createResource(uint32_t pass, std::string name, ResourceType type);
    uint32_t resolve(uint32_t index, uint32_t epoch, ResourceType type) const;
    bool declare(uint32_t pass, uint32_t resource, rhi::Access usage, bool isWrite,
                 const Subresource& part = {});
    TextureRef declareTexture(uint32_t pass, TextureRef ref, rhi::Access usage, bool isWrite,
                              const Subresource& part);
    bool checkPart(const PassNode& p, const ResourceNode& res, const Subresource& part) const;
    bool checkParts(const PassNode& p, const ResourceNode& res, const ResourceUse& use);
    void initSlotState(Slot& s, rhi::Access state) const;
    void transition(Slot& s, const std::vector<std::optional<rhi::Access>>& target,
                    std::vector<rhi::Barrier>& out, bool onlyChanges) const;
    rhi::Access uniformState(const Slot& s) const;
    uint32_t importResource(std::string name, ResourceType type, rhi::TextureHandle texture,
                            rhi::BufferHandle buffer, rhi::Access currentState, rhi::Access finalState);
    void markOutputResource(uint32_t resource, rhi::Access finalState);
    const ResourceUse* findUse(uint32_t pass, uint32_t resource) const;

    void cull();
    bool allocate();
    bool acquirePhysical(Slot& s);
    void placeBarriers();
    void releaseUnusedPoolEntries(bool all);

    void error(const std::string& message);
    void log(rhi::LogSeverity severity, const std::string& message) const;

    rhi::Device& m_device;
    rhi::LogCallback m_log;
    uint32_t m_retainFrames = 3;
    uint64_t m_frame = 0;
    uint32_t m_epoch = 0;

    std::vector<PassNode> m_passes;
    std::vector<ResourceNode> m_resources;
    std::vector<uint32_t> m_order;  // kept passes, execution order
    std::vector<Slot> m_slots;      // imports first, then physical transients
    uint32_t m_firstTransientSlot = 0;
    std::vector<PooledTexture> m_texturePool;
    std::vector<PooledBuffer> m_bufferPool;
    CompiledInfo m_info;
    bool m_compiled = false;
    bool m_failed = false;
    bool m_executed = false;

    // One frame's timestamps: its query pool (2 slots per pass) and what is needed to report them.
    struct TimingFrame {
        rhi::QueryPoolHandle pool;
        uint32_t capacity = 0;
        uint64_t frame = 0;
        bool pending = false;     // executed and not yet returned by any timing call
        bool timestamps = false;  // timestamps were recorded (else gpuMs is NaN)
        std::vector<std::string> names;
        std::vector<double> cpuMs;
    };
    // Reads `t` (blocking or not); nullopt when not available yet. Marks it returned.
    std::optional<FrameTimings> readTimings(TimingFrame& t, bool blocking);
    TimingFrame& currentTimingFrame() { return m_timingRing[m_frame % kTimingFramesInFlight]; }

    std::unordered_map<uint32_t, rhi::Access> m_persistent;         // texture handle -> state
    std::unordered_map<uint32_t, rhi::Access> m_persistentBuffers;  // buffer handle -> state

    TimingFrame m_timingRing[kTimingFramesInFlight];
    std::vector<FrameTimings> m_timingsReady;  // read early (pool reuse), returned by the next poll
    bool m_timingsCollected = false;
    std::vector<PassTiming> m_timings;  // this frame's, once read
};

}  // namespace penumbra::fg
