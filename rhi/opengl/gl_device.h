// OpenGL 4.5 core backend: rhi::Device and rhi::CommandList on an EGL surfaceless, OSMesa or GLFW
// window context. Internal to rhi/; created through rhi::detail::createOpenGLDevice().
#pragma once

#include <array>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "rhi/common/deferred_release.h"
#include "rhi/common/handle_pool.h"
#include "rhi/device.h"
#include "rhi/opengl/gl_context.h"
#include "rhi/opengl/gl_formats.h"
#include "rhi/opengl/gl_functions.h"

namespace rhi::gl {

class GlDevice;

struct BufferObj {
    GLuint name = 0;
    BufferDesc desc;
    void* mapped = nullptr;  // Upload / Readback: persistently mapped pointer
};

struct TextureObj {
    GLuint name = 0;
    GLenum target = GL_TEXTURE_2D;
    TextureDesc desc;
    TextureFormatGl format;
    std::map<std::array<uint32_t, 4>, GLuint> views;  // glTextureView per bind-group mip/layer range
};

struct SamplerObj {
    GLuint name = 0;
};

// One reflected resource binding of a program (owned copy of rhi::ShaderBinding).
struct BindingSlot {
    uint32_t set = 0;
    uint32_t binding = 0;
    BindingType type = BindingType::UniformBuffer;
    uint32_t count = 1;
    uint32_t glBinding = 0;
    TextureDimension textureDimension = TextureDimension::Tex2D;
    Format storageFormat = Format::Undefined;
    bool writes = false;
    std::string name;
};

struct ShaderObj {
    GLuint name = 0;
    ShaderStage stage = ShaderStage::Compute;
    std::string debugName;
    std::vector<BindingSlot> bindings;
    std::vector<VertexInputReflection> vertexInputs;
    uint32_t pushConstantSize = 0;
};

// Shared with recorded commands so a destroyed pipeline's description outlives the handle.
struct PipelineObj {
    GLuint program = 0;
    GLuint vao = 0;  // graphics only
    bool graphics = false;
    std::string debugName;
    std::vector<BindingSlot> layout;
    const BindingSlot* findSlot(uint32_t set, uint32_t binding) const;

    // graphics state block
    GLenum topology = GL_TRIANGLES;
    bool depthTest = false;
    bool depthWrite = false;
    GLenum depthFunc = GL_LESS;
    CullMode cullMode = CullMode::None;
    GLenum frontFace = GL_CW;
    std::vector<BlendState> blend;
    std::vector<Format> colorFormats;
    Format depthFormat = Format::Undefined;
    std::vector<VertexBufferLayout> vertexBuffers;
    GLint baseInstanceLocation = -1;  // SPIRV-Cross emulation of gl_InstanceIndex's base, if any
};

// One resource of a bind group, resolved to GL object names at creation time. The flattened GL
// binding is looked up at draw/dispatch time in the bound pipeline's reflection by (set, binding),
// so a group stays correct with any pipeline whose set layout matches.
struct GroupBind {
    uint32_t binding = 0;
    uint32_t arrayElement = 0;
    BindingType type = BindingType::UniformBuffer;
    GLuint object = 0;   // buffer or texture
    GLuint sampler = 0;  // SampledTexture
    GLintptr offset = 0;
    GLsizeiptr size = 0;
    GLint mip = 0;
    GLboolean layered = GL_FALSE;
    GLenum imageFormat = 0;
};

struct BindGroupObj {
    uint32_t set = 0;
    std::string debugName;
    std::vector<GroupBind> binds;
};

struct QueryPoolObj {
    std::vector<GLuint> queries;
    std::vector<uint8_t> written;  // set when a glQueryCounter for the slot has been replayed
    std::string debugName;
};

// A colour or depth attachment resolved at record time.
struct AttachmentRef {
    GLuint texture = 0;
    bool layered = false;  // array / 3D texture: attach one layer
    uint32_t mip = 0;
    uint32_t layer = 0;
    Format format = Format::Undefined;
    LoadOp load = LoadOp::Clear;
    StoreOp store = StoreOp::Store;
    std::array<float, 4> clearColor{0, 0, 0, 0};
};

struct RenderPassRecord {
    std::vector<AttachmentRef> colors;
    bool hasDepth = false;
    AttachmentRef depth;
    float clearDepth = 1.0f;
    bool depthReadOnly = false;
    uint32_t width = 0;
    uint32_t height = 0;
    std::string debugName;
};

class GlCommandList final : public CommandList {
public:
    explicit GlCommandList(GlDevice& device) : m_device(device) {}

#define RHI_COMMAND_LIST_METHOD(ret, name, params, qualifiers) ret name params qualifiers override;
#include "rhi/command_list_api.inc"
#undef RHI_COMMAND_LIST_METHOD

private:
    friend class GlDevice;
    using Command = std::function<void(GlDevice&)>;

    void begin(std::string_view name);
    void reset();
    void error(const std::string& message) const;
    bool checkGraphicsDraw(const char* what) const;
    bool checkIndirectBuffer(BufferHandle args, uint64_t offset, uint64_t bytes, const char* what,
                             GLuint& name) const;

    GlDevice& m_device;
    std::vector<Command> m_commands;
    std::string m_name;
    bool m_recording = false;
    bool m_inRenderPass = false;
    int m_debugDepth = 0;
    std::shared_ptr<PipelineObj> m_pipeline;  // bound at record time (for checks)
    uint32_t m_passColorCount = 0;
    bool m_indexBound = false;
};

class GlDevice final : public Device {
public:
    GlDevice(const DeviceDesc& desc, std::unique_ptr<Context> context);
    ~GlDevice() override;
    // Loads entry points, checks the version and sets up global state. False: already logged.
    bool initialize();

#define RHI_DEVICE_METHOD(ret, name, params, qualifiers) ret name params qualifiers override;
#include "rhi/device_api.inc"
#undef RHI_DEVICE_METHOD

private:
    friend class GlCommandList;
    static constexpr Format kBackbufferFormat = Format::RGBA8_SRGB;

    static void debugCallback(GLenum source, GLenum type, GLuint id, GLenum severity, GLsizei length,
                              const GLchar* message, const void* user);
    void log(LogSeverity severity, const std::string& message) const;
    void error(const std::string& message) const { log(LogSeverity::Error, message); }
    bool activate();
    // Polls glGetGraphicsResetStatus; a reset marks the device lost (reported once).
    bool checkContextLost();
    void label(GLenum identifier, GLuint name, const std::string& text);
    uint64_t releaseSerial() const { return m_submittedSerial + 1; }
    void retireFences(bool wait, uint64_t upToSerial);

    BufferObj* buffer(BufferHandle h, const char* what);
    TextureObj* texture(TextureHandle h, const char* what);
    bool compileProgram(const std::vector<GLuint>& shaders, const std::string& name, GLuint& program);
    bool mergeLayout(std::vector<BindingSlot>& layout, const ShaderObj& shader,
                     const std::string& pipelineName);
    bool createBackbuffer(uint32_t width, uint32_t height);
    // Subgroup limits (GL_KHR_shader_subgroup), format support and DeviceInfo::enabledFeatures.
    void queryCapabilities();
    // A texture view (glTextureView) of a resolved mip/layer range, created once per range.
    GLuint rangeView(TextureObj& t, const TextureRange& r);
    void writeTextureImpl(TextureHandle dst, const TextureRegion& region, const void* data, uint64_t size,
                          const char* fn);
    // glTextureSubImage{2D,3D} of a resolved region from `pixels` (a pointer, or an offset into the
    // bound GL_PIXEL_UNPACK_BUFFER).
    void uploadRegion(const TextureObj& t, const TextureRegion& box, const void* pixels);
    bool readTimestampsImpl(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs, bool wait,
                            const char* fn);

    // --- replay (GL calls issued at submit) ---------------------------------------------------------
    struct VertexBinding {
        GLuint buffer = 0;
        GLintptr offset = 0;
    };
    struct ReplayState {
        std::shared_ptr<PipelineObj> pipeline;
        std::array<std::shared_ptr<BindGroupObj>, kMaxBindGroups> groups;
        bool bindingsDirty = false;
        std::array<VertexBinding, 16> vertexBuffers{};
        bool vertexDirty = false;
        GLuint indexBuffer = 0;
        GLenum indexType = GL_UNSIGNED_INT;
        uint64_t indexOffset = 0;
        bool indexDirty = false;
        bool inPass = false;
        bool passValid = false;
        bool passDepthReadOnly = false;
        GLuint passFbo = 0;
        RenderPassRecord pass;
        int debugDepth = 0;
    };
    void resetReplayState();
    void flushBarriers();
    void addBarrierBits(GLbitfield bits) { m_pendingBarriers |= bits; }
    void applyPipelineState(const PipelineObj& p);
    void applyBindings();
    bool prepareDraw();
    void execBindPipeline(const std::shared_ptr<PipelineObj>& p);
    void execBeginRenderPass(const RenderPassRecord& pass);
    void execEndRenderPass();
    GLuint framebufferFor(const RenderPassRecord& pass);
    void purgeFramebuffers(GLuint texture);

    DeviceDesc m_desc;
    std::unique_ptr<Context> m_context;
    Functions m_gl;
    DeviceInfo m_info;
    bool m_windowed = false;
    bool m_initialized = false;
    GLint m_uboAlignment = 256;
    GLint m_ssboAlignment = 256;
    GLint m_maxLabelLength = 256;
    bool m_muteDebug = false;
    // llvmpipe takes a timestamp when it rasterizes the queued scene, not where the query stands
    // among compute dispatches (which run at once): without a flush before and after each
    // timestamp, a compute pass's time can be charged to another pass (penumbra bench objects on
    // OpenGL: sdf_ao read 0 ms and sdf_shadow carried its time).
    bool m_flushTimestamps = false;
    bool m_lost = false;

    detail::HandlePool<BufferTag, std::unique_ptr<BufferObj>> m_buffers;
    detail::HandlePool<TextureTag, std::unique_ptr<TextureObj>> m_textures;
    detail::HandlePool<SamplerTag, std::unique_ptr<SamplerObj>> m_samplers;
    detail::HandlePool<ShaderTag, std::unique_ptr<ShaderObj>> m_shaders;
    detail::HandlePool<PipelineTag, std::shared_ptr<PipelineObj>> m_pipelines;
    detail::HandlePool<BindGroupTag, std::shared_ptr<BindGroupObj>> m_bindGroups;
    detail::HandlePool<QueryPoolTag, std::shared_ptr<QueryPoolObj>> m_queryPools;

    detail::DeferredReleaseQueue m_releases;
    struct Fence {
        uint64_t serial;
        GLsync sync;
    };
    std::deque<Fence> m_fences;
    uint64_t m_submittedSerial = 0;
    uint64_t m_completedSerial = 0;

    std::vector<std::unique_ptr<GlCommandList>> m_lists;
    GLuint m_pushConstantUbo = 0;
    GLbitfield m_pendingBarriers = 0;
    ReplayState m_rs;
    std::map<std::vector<uint32_t>, GLuint> m_framebuffers;  // attachment set -> FBO

    // windowed presentation
    TextureHandle m_backbuffer;
    uint32_t m_backbufferWidth = 0;
    uint32_t m_backbufferHeight = 0;
    GLuint m_presentFbo = 0;
    DeviceStats m_stats;
    std::array<FormatSupport, size_t(Format::Count)> m_formatSupport{};
};

}  // namespace rhi::gl
