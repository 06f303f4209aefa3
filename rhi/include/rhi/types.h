// penumbra RHI — value types shared by every backend: handles, formats, enums and *Desc aggregates.
// Nothing here knows about signed distance fields or about any graphics API.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace rhi {

// ---------------------------------------------------------------------------------------------
// Handles: 16-bit slot index + 16-bit generation packed in 32 bits. Value 0 is the invalid handle
// (generations start at 1), so a default-constructed handle is always invalid. A destroyed slot
// bumps its generation, so a stale copy of the handle no longer resolves.
// ---------------------------------------------------------------------------------------------
template <typename Tag>
struct Handle {
    uint32_t value = 0;

    constexpr Handle() = default;
    constexpr explicit Handle(uint32_t v) : value(v) {}
    static constexpr Handle make(uint16_t index, uint16_t generation) {
        return Handle{(uint32_t(generation) << 16) | uint32_t(index)};
    }
    constexpr uint16_t index() const { return uint16_t(value & 0xffffu); }
    constexpr uint16_t generation() const { return uint16_t(value >> 16); }
    constexpr bool isValid() const { return value != 0; }
    constexpr explicit operator bool() const { return isValid(); }
    friend constexpr bool operator==(Handle a, Handle b) { return a.value == b.value; }
    friend constexpr bool operator!=(Handle a, Handle b) { return a.value != b.value; }
};

struct BufferTag {};
struct TextureTag {};
struct SamplerTag {};
struct ShaderTag {};
struct PipelineTag {};
struct BindGroupTag {};
struct QueryPoolTag {};

using BufferHandle = Handle<BufferTag>;
using TextureHandle = Handle<TextureTag>;
using SamplerHandle = Handle<SamplerTag>;
using ShaderHandle = Handle<ShaderTag>;
using PipelineHandle = Handle<PipelineTag>;
using BindGroupHandle = Handle<BindGroupTag>;
using QueryPoolHandle = Handle<QueryPoolTag>;

// ---------------------------------------------------------------------------------------------
// Flags helper for enum class bit sets.
// ---------------------------------------------------------------------------------------------
#define RHI_ENUM_FLAGS(E)                                                      \
    constexpr E operator|(E a, E b) {                                          \
        return E(std::underlying_type_t<E>(a) | std::underlying_type_t<E>(b)); \
    }                                                                          \
    constexpr E operator&(E a, E b) {                                          \
        return E(std::underlying_type_t<E>(a) & std::underlying_type_t<E>(b)); \
    }                                                                          \
    constexpr E operator~(E a) { return E(~std::underlying_type_t<E>(a)); }    \
    constexpr E& operator|=(E& a, E b) { return a = a | b; }                   \
    constexpr E& operator&=(E& a, E b) { return a = a & b; }                   \
    constexpr bool any(E a) { return std::underlying_type_t<E>(a) != 0; }

// ---------------------------------------------------------------------------------------------
// Backend selection and logging
// ---------------------------------------------------------------------------------------------
enum class Backend : uint8_t { Auto, Vulkan, OpenGL, Null };

enum class LogSeverity : uint8_t { Debug, Info, Warning, Error };

// One sink for everything the RHI has to say: backend messages, GL debug output, Vulkan
// validation-layer messages and the validation wrapper's misuse reports.
using LogCallback = std::function<void(LogSeverity, std::string_view message)>;

const char* toString(Backend b);
// Parses "vulkan", "vk", "gl", "opengl", "null", "auto" (case-insensitive). Returns false if unknown.
bool parseBackend(std::string_view text, Backend& out);

// ---------------------------------------------------------------------------------------------
// Formats
// ---------------------------------------------------------------------------------------------
enum class Format : uint8_t {
    Undefined,
    R8_UNORM,
    R8_UINT,
    R16_FLOAT,
    R32_FLOAT,
    R32_UINT,
    RG16_FLOAT,
    RG32_FLOAT,
    RGBA8_UNORM,
    RGBA8_SRGB,
    RGBA16_FLOAT,
    RGBA32_FLOAT,
    D32_FLOAT,
    // Vertex-attribute-only formats
    RGB32_FLOAT,
    Count
};

struct FormatInfo {
    const char* name;
    uint32_t bytesPerTexel;  // bytes per texel (or per vertex attribute)
    uint32_t channels;
    bool isDepth;
    bool isInteger;
    bool isSrgb;
};
const FormatInfo& formatInfo(Format f);

// ---------------------------------------------------------------------------------------------
// Resource access states (barriers are data: {resource, before, after}). Stages are implied by
// the access: ShaderRead/ShaderWrite cover every shader stage. The Vulkan backend derives image
// layouts from these; the GL backend derives glMemoryBarrier bits from them.
// ---------------------------------------------------------------------------------------------
enum class Access : uint32_t {
    None = 0,                // undefined / discard previous contents
    ShaderSampled = 1 << 0,  // texture() from a combined image sampler, any stage
    ShaderRead = 1 << 1,     // storage buffer / storage image read, any stage
    ShaderWrite = 1 << 2,    // storage buffer / storage image write, any stage
    UniformRead = 1 << 3,
    VertexRead = 1 << 4,
    IndexRead = 1 << 5,
    IndirectRead = 1 << 6,
    ColorTarget = 1 << 7,       // colour attachment read/write (incl. blending)
    DepthTargetWrite = 1 << 8,  // depth attachment test + write
    DepthTargetRead = 1 << 9,   // depth attachment test only (read-only depth)
    CopySrc = 1 << 10,
    CopyDst = 1 << 11,
    HostRead = 1 << 12,  // readback to the CPU
    HostWrite = 1 << 13,
    Present = 1 << 14,
};
RHI_ENUM_FLAGS(Access)
std::string toString(Access a);
// Every access that writes.
inline constexpr Access kWriteAccesses = Access::ShaderWrite | Access::ColorTarget |
                                         Access::DepthTargetWrite | Access::CopyDst | Access::HostWrite;
constexpr bool isWriteAccess(Access a) { return any(a & kWriteAccesses); }

// ---------------------------------------------------------------------------------------------
// Buffers
// ---------------------------------------------------------------------------------------------
enum class BufferUsage : uint32_t {
    None = 0,
    Vertex = 1 << 0,
    Index = 1 << 1,
    Uniform = 1 << 2,
    Storage = 1 << 3,
    Indirect = 1 << 4,
    CopySrc = 1 << 5,
    CopyDst = 1 << 6,
};
RHI_ENUM_FLAGS(BufferUsage)

enum class MemoryType : uint8_t {
    GpuOnly,   // device local; filled by writeBuffer / copies / shaders
    Upload,    // host visible + coherent, persistently mapped (mappedPointer)
    Readback,  // host visible + cached, for GPU->CPU copies
};

struct BufferDesc {
    uint64_t size = 0;
    BufferUsage usage = BufferUsage::Storage;
    MemoryType memory = MemoryType::GpuOnly;
    std::string debugName;
};

// ---------------------------------------------------------------------------------------------
// Textures and samplers
// ---------------------------------------------------------------------------------------------
enum class TextureDimension : uint8_t { Tex2D, Tex2DArray, Tex3D };

enum class TextureUsage : uint32_t {
    None = 0,
    Sampled = 1 << 0,
    Storage = 1 << 1,
    ColorTarget = 1 << 2,
    DepthTarget = 1 << 3,
    CopySrc = 1 << 4,
    CopyDst = 1 << 5,
};
RHI_ENUM_FLAGS(TextureUsage)

struct TextureDesc {
    TextureDimension dimension = TextureDimension::Tex2D;
    Format format = Format::RGBA8_UNORM;
    uint32_t width = 1;
    uint32_t height = 1;
    uint32_t depthOrLayers = 1;  // depth for Tex3D, layer count for Tex2DArray, 1 for Tex2D
    uint32_t mipLevels = 1;
    TextureUsage usage = TextureUsage::Sampled | TextureUsage::CopyDst;
    std::string debugName;
};

// Bytes of a texture's texel storage over all mips (3D mips halve in depth, array layers do not),
// as memory reports count it.
inline uint64_t textureBytes(const TextureDesc& d) {
    const uint64_t texel = formatInfo(d.format).bytesPerTexel;
    const bool is3D = d.dimension == TextureDimension::Tex3D;
    uint64_t total = 0;
    for (uint32_t m = 0; m < (d.mipLevels > 0 ? d.mipLevels : 1u); ++m) {
        const uint64_t w = d.width >> m ? d.width >> m : 1u, h = d.height >> m ? d.height >> m : 1u;
        const uint64_t z = is3D ? (d.depthOrLayers >> m ? d.depthOrLayers >> m : 1u)
                                : (d.depthOrLayers ? d.depthOrLayers : 1u);
        total += w * h * z * texel;
    }
    return total;
}

// Identifies one mip level; for Tex2DArray one layer (layer), for Tex3D the whole volume.
struct TextureSubresource {
    uint32_t mip = 0;
    uint32_t layer = 0;
};

// A box of texels inside one subresource: mip, array layer (Tex2DArray; 0 otherwise), offset and
// extent in texels. A zero width / height / depth reaches the end of the mip in that dimension, so
// the default region is all of mip 0, layer 0. Tex2D / Tex2DArray regions have z = 0 and depth 1.
struct TextureRegion {
    uint32_t mip = 0;
    uint32_t layer = 0;
    uint32_t x = 0, y = 0, z = 0;
    uint32_t width = 0, height = 0, depth = 0;
};

enum class Filter : uint8_t { Nearest, Linear };
enum class AddressMode : uint8_t { ClampToEdge, Repeat, MirroredRepeat };

struct SamplerDesc {
    Filter minFilter = Filter::Linear;
    Filter magFilter = Filter::Linear;
    Filter mipFilter = Filter::Nearest;
    AddressMode addressU = AddressMode::ClampToEdge;
    AddressMode addressV = AddressMode::ClampToEdge;
    AddressMode addressW = AddressMode::ClampToEdge;
    float maxLod = 1000.0f;
    std::string debugName;
};

// ---------------------------------------------------------------------------------------------
// Shaders and reflection. Shader data is produced at build time by tools/shaderc from one GLSL
// 450 source: SPIR-V for Vulkan, GLSL 4.50 with flattened bindings for OpenGL, and reflection.
// ---------------------------------------------------------------------------------------------
enum class ShaderStage : uint8_t { Vertex, Fragment, Compute };

enum class ShaderStageFlags : uint8_t {
    None = 0,
    Vertex = 1 << 0,
    Fragment = 1 << 1,
    Compute = 1 << 2,
    AllGraphics = Vertex | Fragment,
};
RHI_ENUM_FLAGS(ShaderStageFlags)

enum class BindingType : uint8_t {
    UniformBuffer,
    StorageBuffer,          // read-write storage buffer
    ReadOnlyStorageBuffer,  // storage buffer declared readonly
    SampledTexture,         // combined image sampler (texture + sampler in the bind group entry)
    StorageTexture,         // storage image (read and/or write)
};

// One resource binding as reflected by shaderc. glBinding is the flattened binding point the
// OpenGL backend uses (per resource class: UBO, SSBO, texture unit, image unit); shaderc assigns
// it per program so vertex and fragment shaders of one program never collide.
struct ShaderBinding {
    const char* name = "";
    uint32_t set = 0;
    uint32_t binding = 0;
    BindingType type = BindingType::UniformBuffer;
    uint32_t count = 1;  // array size
    uint32_t glBinding = 0;
    TextureDimension textureDimension = TextureDimension::Tex2D;  // textures only
    Format storageFormat = Format::Undefined;                     // storage images only
    bool writes = false;  // storage resource written by the shader (not declared readonly)
};

// On OpenGL, push constants become a uniform block at this binding; shaderc reserves it.
inline constexpr uint32_t kGlPushConstantBinding = 0;
inline constexpr uint32_t kMaxPushConstantSize = 128;
inline constexpr uint32_t kMaxBindGroups = 4;

struct VertexInputReflection {
    uint32_t location = 0;
    Format format = Format::Undefined;
};

struct ShaderDesc {
    ShaderStage stage = ShaderStage::Compute;
    std::span<const uint32_t> spirv;  // Vulkan
    std::string_view glsl;            // OpenGL (GLSL 4.50 core, bindings flattened)
    std::span<const ShaderBinding> bindings;
    std::span<const VertexInputReflection> vertexInputs;  // vertex stage only
    uint32_t pushConstantSize = 0;                        // bytes, <= kMaxPushConstantSize
    std::array<uint32_t, 3> workgroupSize{1, 1, 1};       // compute only
    std::string_view debugName;
};

// ---------------------------------------------------------------------------------------------
// Pipelines
// ---------------------------------------------------------------------------------------------
struct ComputePipelineDesc {
    ShaderHandle shader;
    std::string debugName;
};

enum class PrimitiveTopology : uint8_t { TriangleList, TriangleStrip, LineList, PointList };
enum class CullMode : uint8_t { None, Front, Back };
enum class FrontFace : uint8_t { CounterClockwise, Clockwise };
enum class CompareOp : uint8_t { Never, Less, LessEqual, Greater, GreaterEqual, Equal, NotEqual, Always };
enum class BlendFactor : uint8_t {
    Zero,
    One,
    SrcColor,
    OneMinusSrcColor,
    SrcAlpha,
    OneMinusSrcAlpha,
    DstColor,
    OneMinusDstColor,
    DstAlpha,
    OneMinusDstAlpha,
};
enum class BlendOp : uint8_t { Add, Subtract, ReverseSubtract, Min, Max };
enum class IndexType : uint8_t { Uint16, Uint32 };

struct VertexAttribute {
    uint32_t location = 0;
    uint32_t bufferSlot = 0;
    Format format = Format::RGB32_FLOAT;
    uint32_t offset = 0;
};

struct VertexBufferLayout {
    uint32_t stride = 0;
    bool perInstance = false;
};

struct BlendState {
    bool enable = false;
    BlendFactor srcColor = BlendFactor::One;
    BlendFactor dstColor = BlendFactor::Zero;
    BlendOp colorOp = BlendOp::Add;
    BlendFactor srcAlpha = BlendFactor::One;
    BlendFactor dstAlpha = BlendFactor::Zero;
    BlendOp alphaOp = BlendOp::Add;
};

inline constexpr uint32_t kMaxColorTargets = 8;

struct GraphicsPipelineDesc {
    ShaderHandle vertexShader;
    ShaderHandle fragmentShader;
    std::vector<VertexBufferLayout> vertexBuffers;
    std::vector<VertexAttribute> vertexAttributes;
    PrimitiveTopology topology = PrimitiveTopology::TriangleList;
    CullMode cullMode = CullMode::None;
    FrontFace frontFace = FrontFace::CounterClockwise;
    bool depthTest = false;
    bool depthWrite = false;
    CompareOp depthCompare = CompareOp::Less;
    std::vector<Format> colorFormats;  // one per colour target, in attachment order
    std::vector<BlendState> blend;     // empty = no blending on every target; else one per target
    Format depthFormat = Format::Undefined;
    std::string debugName;
};

// ---------------------------------------------------------------------------------------------
// Bind groups: immutable sets of resources, laid out by the pipeline's reflected set `set`.
// ---------------------------------------------------------------------------------------------
struct BindGroupEntry {
    uint32_t binding = 0;
    uint32_t arrayElement = 0;
    // Buffers (UniformBuffer / StorageBuffer / ReadOnlyStorageBuffer)
    BufferHandle buffer;
    uint64_t offset = 0;
    uint64_t size = 0;  // 0 = whole buffer from offset
    // Textures (SampledTexture needs sampler too). A SampledTexture sees mips [mip, mip + mipCount)
    // as its levels 0.. (mipCount 0: to the last mip); a StorageTexture binds the one level `mip`.
    // Both see layers [baseLayer, baseLayer + layerCount) of a Tex2DArray (layerCount 0: to the last).
    TextureHandle texture;
    SamplerHandle sampler;
    uint32_t mip = 0;
    uint32_t mipCount = 0;
    uint32_t baseLayer = 0;
    uint32_t layerCount = 0;

    static BindGroupEntry makeBuffer(uint32_t binding, BufferHandle b, uint64_t offset = 0,
                                     uint64_t size = 0) {
        BindGroupEntry e;
        e.binding = binding;
        e.buffer = b;
        e.offset = offset;
        e.size = size;
        return e;
    }
    static BindGroupEntry makeSampled(uint32_t binding, TextureHandle t, SamplerHandle s) {
        BindGroupEntry e;
        e.binding = binding;
        e.texture = t;
        e.sampler = s;
        return e;
    }
    // A sampled view of `mipCount` mips from `baseMip` (e.g. read mip N while mip N + 1 is written).
    static BindGroupEntry makeSampledMips(uint32_t binding, TextureHandle t, SamplerHandle s,
                                          uint32_t baseMip, uint32_t mipCount = 1) {
        BindGroupEntry e = makeSampled(binding, t, s);
        e.mip = baseMip;
        e.mipCount = mipCount;
        return e;
    }
    static BindGroupEntry makeStorage(uint32_t binding, TextureHandle t, uint32_t mip = 0) {
        BindGroupEntry e;
        e.binding = binding;
        e.texture = t;
        e.mip = mip;
        return e;
    }
};

struct BindGroupDesc {
    PipelineHandle pipeline;  // the layout comes from this pipeline's reflection ...
    uint32_t set = 0;         // ... for this set index (< kMaxBindGroups)
    std::vector<BindGroupEntry> entries;
    std::string debugName;
};

// ---------------------------------------------------------------------------------------------
// Render passes (dynamic rendering on Vulkan, a cached FBO on OpenGL)
// ---------------------------------------------------------------------------------------------
enum class LoadOp : uint8_t { Load, Clear, DontCare };
enum class StoreOp : uint8_t { Store, DontCare };

struct ColorAttachment {
    TextureHandle texture;
    uint32_t mip = 0;
    uint32_t layer = 0;
    LoadOp load = LoadOp::Clear;
    StoreOp store = StoreOp::Store;
    std::array<float, 4> clearColor{0, 0, 0, 0};
};

struct DepthAttachment {
    TextureHandle texture;
    LoadOp load = LoadOp::Clear;
    StoreOp store = StoreOp::Store;
    float clearDepth = 1.0f;
    bool readOnly = false;
};

struct RenderPassDesc {
    std::vector<ColorAttachment> colorAttachments;
    DepthAttachment depthAttachment;  // texture invalid = no depth
    std::string debugName;
};

struct Viewport {
    float x = 0, y = 0, width = 0, height = 0, minDepth = 0, maxDepth = 1;
};
struct Rect {
    int32_t x = 0, y = 0;
    uint32_t width = 0, height = 0;
};

// ---------------------------------------------------------------------------------------------
// Barriers (data). The frame graph emits these; pass code never does.
// ---------------------------------------------------------------------------------------------
// Mip levels and array layers of a texture; kRemaining counts run to the end of the texture.
inline constexpr uint32_t kRemaining = 0xffffffffu;
struct TextureRange {
    uint32_t baseMip = 0;
    uint32_t mipCount = kRemaining;
    uint32_t baseLayer = 0;
    uint32_t layerCount = kRemaining;
    bool isWhole() const {
        return baseMip == 0 && mipCount == kRemaining && baseLayer == 0 && layerCount == kRemaining;
    }
    friend bool operator==(const TextureRange&, const TextureRange&) = default;
};

struct Barrier {
    BufferHandle buffer;    // exactly one of buffer / texture is valid
    TextureHandle texture;  // the subresources in `range` (default: all mips and layers)
    Access before = Access::None;
    Access after = Access::None;
    TextureRange range;  // textures only

    static Barrier buf(BufferHandle b, Access before, Access after) { return {b, {}, before, after, {}}; }
    static Barrier tex(TextureHandle t, Access before, Access after, TextureRange range = {}) {
        return {{}, t, before, after, range};
    }
};

// ---------------------------------------------------------------------------------------------
// Queries
// ---------------------------------------------------------------------------------------------
struct QueryPoolDesc {
    uint32_t count = 64;  // timestamp slots
    std::string debugName;
};

// ---------------------------------------------------------------------------------------------
// Device creation and information
// ---------------------------------------------------------------------------------------------
struct DeviceDesc {
    Backend backend = Backend::Auto;  // Auto tries Vulkan, then OpenGL
    bool headless = true;             // false: present to `window`
    bool validation = false;          // RHI validation wrapper + Vulkan validation layers / GL debug
    void* window = nullptr;           // GLFWwindow* when !headless
    bool vsync = true;
    LogCallback log;  // null = messages go to stderr
};

// What a device can do with a format (Device::formatSupport).
enum class FormatSupport : uint32_t {
    None = 0,
    Sampled = 1 << 0,          // SampledTexture bindings
    Filterable = 1 << 1,       // Filter::Linear sampling
    Storage = 1 << 2,          // StorageTexture bindings (imageLoad / imageStore)
    StorageAtomic = 1 << 3,    // imageAtomic* on storage images
    ColorTarget = 1 << 4,      // colour attachment
    Blendable = 1 << 5,        // colour attachment with blending
    DepthTarget = 1 << 6,      // depth attachment
    VertexAttribute = 1 << 7,  // vertex buffer attribute
};
RHI_ENUM_FLAGS(FormatSupport)
std::string toString(FormatSupport s);  // "sampled|filterable|storage" / "none"

// Subgroup operation classes (GLSL GL_KHR_shader_subgroup_*), as Vulkan / GL report them.
enum class SubgroupOps : uint32_t {
    None = 0,
    Basic = 1 << 0,
    Vote = 1 << 1,
    Arithmetic = 1 << 2,
    Ballot = 1 << 3,
    Shuffle = 1 << 4,
    ShuffleRelative = 1 << 5,
    Clustered = 1 << 6,
    Quad = 1 << 7,
};
RHI_ENUM_FLAGS(SubgroupOps)
std::string toString(SubgroupOps ops);  // "basic|vote|arithmetic" / "none"

struct DeviceLimits {
    uint32_t maxTextureSize2D = 0;
    uint32_t maxTextureSize3D = 0;
    uint32_t maxTextureArrayLayers = 0;
    std::array<uint32_t, 3> maxComputeWorkgroupCount{0, 0, 0};
    std::array<uint32_t, 3> maxComputeWorkgroupSize{0, 0, 0};
    uint32_t maxComputeWorkgroupInvocations = 0;
    uint64_t maxStorageBufferRange = 0;
    uint64_t maxUniformBufferRange = 0;
    uint32_t maxPushConstantSize = kMaxPushConstantSize;
    uint32_t maxBindGroups = kMaxBindGroups;
    uint32_t maxColorTargets = 0;
    double timestampPeriodNs = 1.0;  // nanoseconds per timestamp tick (already applied by readTimestamps)
    bool timestamps = false;
    bool conservativeDepth = false;
    uint32_t subgroupSize = 0;  // 0: subgroups unavailable
    SubgroupOps subgroupOps = SubgroupOps::None;
    ShaderStageFlags subgroupStages = ShaderStageFlags::None;  // stages that support subgroup ops
};

// What a device has done since it was created (Device::stats()), for tests and tools: creations
// that should not happen every frame, and blocking waits that should not happen inside a frame loop.
struct DeviceStats {
    uint64_t pipelinesCreated = 0;  // compute and graphics pipelines
    uint64_t bindGroupsCreated = 0;
    uint64_t blockingTimestampReads = 0;  // readTimestamps calls: each waits for the GPU
};

struct DeviceInfo {
    Backend backend = Backend::Null;
    std::string apiVersion;     // "Vulkan 1.3.230" / "OpenGL 4.5 (Core Profile) Mesa 22.3.6"
    std::string deviceName;     // "llvmpipe (LLVM 15.0.6, 256 bits)"
    std::string driverName;     // "llvmpipe" / "NVIDIA"
    std::string driverVersion;  // "Mesa 22.3.6"
    std::string platform;       // "headless", "EGL surfaceless", "OSMesa", "GLFW window"
    DeviceLimits limits;
    // Optional capabilities in use. Vulkan: the optional device features it enabled, each only after
    // querying it as supported ("independentBlend", ...). OpenGL: the extensions it relies on.
    std::vector<std::string> enabledFeatures;
};

}  // namespace rhi
