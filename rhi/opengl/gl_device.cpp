#include "rhi/opengl/gl_device.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "rhi/common/backend_factories.h"
#include "rhi/common/resource_kinds.h"
#include "rhi/common/subresource_states.h"

namespace rhi::gl {

namespace {

uint32_t mipExtent(uint32_t extent, uint32_t mip) { return std::max(1u, extent >> mip); }

uint32_t maxMipLevels(const TextureDesc& d) {
    uint32_t largest = std::max(d.width, d.height);
    if (d.dimension == TextureDimension::Tex3D) largest = std::max(largest, d.depthOrLayers);
    uint32_t levels = 1;
    while (largest > 1) {
        largest >>= 1;
        ++levels;
    }
    return levels;
}

std::string quoted(std::string_view name) {
    return name.empty() ? std::string("(unnamed)") : "'" + std::string(name) + "'";
}

const char* debugSourceName(GLenum source) {
    switch (source) {
        case GL_DEBUG_SOURCE_API:
            return "api";
        case GL_DEBUG_SOURCE_WINDOW_SYSTEM:
            return "window system";
        case GL_DEBUG_SOURCE_SHADER_COMPILER:
            return "shader compiler";
        case GL_DEBUG_SOURCE_THIRD_PARTY:
            return "third party";
        case GL_DEBUG_SOURCE_APPLICATION:
            return "application";
        default:
            return "other";
    }
}

const char* debugTypeName(GLenum type) {
    switch (type) {
        case GL_DEBUG_TYPE_ERROR:
            return "error";
        case GL_DEBUG_TYPE_DEPRECATED_BEHAVIOR:
            return "deprecated";
        case GL_DEBUG_TYPE_UNDEFINED_BEHAVIOR:
            return "undefined behaviour";
        case GL_DEBUG_TYPE_PORTABILITY:
            return "portability";
        case GL_DEBUG_TYPE_PERFORMANCE:
            return "performance";
        case GL_DEBUG_TYPE_MARKER:
            return "marker";
        default:
            return "other";
    }
}

}  // namespace

const BindingSlot* PipelineObj::findSlot(uint32_t set, uint32_t binding) const {
    for (const BindingSlot& s : layout)
        if (s.set == set && s.binding == binding) return &s;
    return nullptr;
}

// ---------------------------------------------------------------------------------------------
// Creation and global state
// ---------------------------------------------------------------------------------------------
GlDevice::GlDevice(const DeviceDesc& desc, std::unique_ptr<Context> context)
    : m_desc(desc), m_context(std::move(context)), m_windowed(!desc.headless) {}

GlDevice::~GlDevice() {
    if (!m_context || !m_context->makeCurrent()) return;
    if (m_initialized) {
        m_gl.Finish();
        for (Fence& f : m_fences) m_gl.DeleteSync(f.sync);
        m_fences.clear();
        m_releases.releaseAll();
        for (auto& [key, fbo] : m_framebuffers) m_gl.DeleteFramebuffers(1, &fbo);
        m_framebuffers.clear();
        if (m_presentFbo) m_gl.DeleteFramebuffers(1, &m_presentFbo);
        if (m_pushConstantUbo) m_gl.DeleteBuffers(1, &m_pushConstantUbo);
        // Objects the application leaked go away with the context.
        m_gl.DebugMessageCallback(nullptr, nullptr);
    }
    m_context.reset();
}

void GlDevice::log(LogSeverity severity, const std::string& message) const {
    detail::logMessage(m_desc.log, severity, "OpenGL: " + message);
}

bool GlDevice::activate() {
    if (m_lost) {
        error("the OpenGL context was lost (GPU reset); the device can no longer be used");
        return false;
    }
    if (m_context->makeCurrent()) return true;
    error("cannot make the device's context current on this thread");
    return false;
}

bool GlDevice::checkContextLost() {
    if (m_lost) return true;
    const GLenum status = m_gl.GetGraphicsResetStatus();
    if (status == GL_NO_ERROR) return false;
    m_lost = true;
    const char* who = status == GL_GUILTY_CONTEXT_RESET     ? "caused by this context"
                      : status == GL_INNOCENT_CONTEXT_RESET ? "caused elsewhere"
                                                            : "cause unknown";
    error(std::string("the OpenGL context was reset (") + who + "); pending work is lost");
    // Nothing the GPU held can be waited on any more: release what was deferred.
    for (Fence& f : m_fences) m_gl.DeleteSync(f.sync);
    m_fences.clear();
    m_completedSerial = m_submittedSerial;
    m_releases.releaseAll();
    return true;
}

void GlDevice::label(GLenum identifier, GLuint name, const std::string& text) {
    if (text.empty() || name == 0) return;
    const GLsizei length = GLsizei(std::min<size_t>(text.size(), size_t(std::max(1, m_maxLabelLength - 1))));
    m_gl.ObjectLabel(identifier, name, length, text.data());
}

void GlDevice::debugCallback(GLenum source, GLenum type, GLuint id, GLenum severity, GLsizei length,
                             const GLchar* message, const void* user) {
    const auto* self = static_cast<const GlDevice*>(user);
    if (!self || self->m_muteDebug) return;
    if (severity == GL_DEBUG_SEVERITY_NOTIFICATION) return;
    if (type == GL_DEBUG_TYPE_PUSH_GROUP || type == GL_DEBUG_TYPE_POP_GROUP || type == GL_DEBUG_TYPE_MARKER)
        return;
    LogSeverity s = LogSeverity::Debug;
    if (type == GL_DEBUG_TYPE_ERROR || severity == GL_DEBUG_SEVERITY_HIGH)
        s = LogSeverity::Error;
    else if (severity == GL_DEBUG_SEVERITY_MEDIUM)
        s = LogSeverity::Warning;
    std::string text = std::string("debug output (") + debugSourceName(source) + ", " + debugTypeName(type) +
                       ", id " + std::to_string(id) + "): ";
    text.append(message, length >= 0 ? size_t(length) : std::strlen(message));
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    self->log(s, text);
}

bool GlDevice::initialize() {
    struct LoaderCtx {
        Context* context;
    } loaderCtx{m_context.get()};
    const std::vector<std::string> missing = m_gl.load(
        [](const char* name, void* user) { return static_cast<LoaderCtx*>(user)->context->getProc(name); },
        &loaderCtx);

    if (!m_gl.GetString || !m_gl.GetIntegerv) {
        error("cannot resolve glGetString / glGetIntegerv through " + std::string(m_context->platformName()));
        return false;
    }
    const auto str = [&](GLenum e) {
        const GLubyte* s = m_gl.GetString(e);
        return s ? std::string(reinterpret_cast<const char*>(s)) : std::string();
    };
    const std::string version = str(GL_VERSION);
    GLint major = 0, minor = 0;
    m_gl.GetIntegerv(GL_MAJOR_VERSION, &major);
    m_gl.GetIntegerv(GL_MINOR_VERSION, &minor);
    if (major < 4 || (major == 4 && minor < 5)) {
        error("OpenGL 4.5 core is required, but the " + std::string(m_context->platformName()) +
              " context provides '" + version + "'");
        return false;
    }
    if (!missing.empty()) {
        std::string list;
        for (const std::string& m : missing) list += (list.empty() ? "" : ", ") + m;
        error("required entry points are missing: " + list);
        return false;
    }

    // Debug output first, so everything below is checked.
    if (m_desc.validation) {
        m_gl.Enable(GL_DEBUG_OUTPUT);
        m_gl.Enable(GL_DEBUG_OUTPUT_SYNCHRONOUS);
        m_gl.DebugMessageCallback(&GlDevice::debugCallback, this);
        m_gl.DebugMessageControl(GL_DONT_CARE, GL_DONT_CARE, GL_DONT_CARE, 0, nullptr, GL_TRUE);
        m_gl.DebugMessageControl(GL_DONT_CARE, GL_DONT_CARE, GL_DEBUG_SEVERITY_NOTIFICATION, 0, nullptr,
                                 GL_FALSE);
    }

    m_gl.ClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    m_gl.Enable(GL_FRAMEBUFFER_SRGB);
    m_gl.Enable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
    m_gl.Enable(GL_SCISSOR_TEST);
    m_gl.Enable(GL_PROGRAM_POINT_SIZE);
    m_gl.Disable(GL_DITHER);  // Vulkan does not dither
    m_gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
    m_gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);

    m_gl.GetIntegerv(GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT, &m_uboAlignment);
    m_gl.GetIntegerv(GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT, &m_ssboAlignment);
    m_gl.GetIntegerv(GL_MAX_LABEL_LENGTH, &m_maxLabelLength);
    m_uboAlignment = std::max(1, m_uboAlignment);
    m_ssboAlignment = std::max(1, m_ssboAlignment);

    // Info and limits.
    m_info.backend = Backend::OpenGL;
    m_info.apiVersion = "OpenGL " + version;
    m_info.deviceName = str(GL_RENDERER);
    m_flushTimestamps = m_info.deviceName.find("llvmpipe") != std::string::npos;
    m_info.driverName = str(GL_VENDOR);
    // "4.5 (Core Profile) Mesa 22.3.6" -> "Mesa 22.3.6"
    std::string driverVersion = version;
    if (size_t p = driverVersion.find(')'); p != std::string::npos)
        driverVersion = driverVersion.substr(p + 1);
    else if (size_t sp = driverVersion.find(' '); sp != std::string::npos)
        driverVersion = driverVersion.substr(sp + 1);
    while (!driverVersion.empty() && driverVersion.front() == ' ') driverVersion.erase(driverVersion.begin());
    m_info.driverVersion = driverVersion.empty() ? version : driverVersion;
    m_info.platform = m_context->platformName();

    auto geti = [&](GLenum e) {
        GLint v = 0;
        m_gl.GetIntegerv(e, &v);
        return uint32_t(std::max(0, v));
    };
    auto geti64 = [&](GLenum e) {
        GLint64 v = 0;
        m_gl.GetInteger64v(e, &v);
        return uint64_t(std::max<GLint64>(0, v));
    };
    DeviceLimits& l = m_info.limits;
    l.maxTextureSize2D = geti(GL_MAX_TEXTURE_SIZE);
    l.maxTextureSize3D = geti(GL_MAX_3D_TEXTURE_SIZE);
    l.maxTextureArrayLayers = geti(GL_MAX_ARRAY_TEXTURE_LAYERS);
    for (GLuint i = 0; i < 3; ++i) {
        GLint v = 0;
        m_gl.GetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_COUNT, i, &v);
        l.maxComputeWorkgroupCount[i] = uint32_t(std::max(0, v));
        v = 0;
        m_gl.GetIntegeri_v(GL_MAX_COMPUTE_WORK_GROUP_SIZE, i, &v);
        l.maxComputeWorkgroupSize[i] = uint32_t(std::max(0, v));
    }
    l.maxComputeWorkgroupInvocations = geti(GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS);
    l.maxStorageBufferRange = geti64(GL_MAX_SHADER_STORAGE_BLOCK_SIZE);
    l.maxUniformBufferRange = geti64(GL_MAX_UNIFORM_BLOCK_SIZE);
    l.maxPushConstantSize = kMaxPushConstantSize;
    l.maxBindGroups = kMaxBindGroups;
    l.maxColorTargets =
        std::min({geti(GL_MAX_DRAW_BUFFERS), geti(GL_MAX_COLOR_ATTACHMENTS), kMaxColorTargets});
    l.timestampPeriodNs = 1.0;
    l.timestamps = true;
    l.conservativeDepth = true;
    queryCapabilities();

    // Push constants: one reserved UBO.
    m_gl.CreateBuffers(1, &m_pushConstantUbo);
    m_gl.NamedBufferStorage(m_pushConstantUbo, kMaxPushConstantSize, nullptr, GL_DYNAMIC_STORAGE_BIT);
    label(GL_BUFFER, m_pushConstantUbo, "rhi push constants");
    m_gl.BindBufferBase(GL_UNIFORM_BUFFER, kGlPushConstantBinding, m_pushConstantUbo);

    if (m_windowed) {
        m_context->setSwapInterval(m_desc.vsync ? 1 : 0);
        m_gl.CreateFramebuffers(1, &m_presentFbo);
        label(GL_FRAMEBUFFER, m_presentFbo, "rhi present source");
        int w = 0, h = 0;
        m_context->framebufferSize(w, h);
        if (!createBackbuffer(uint32_t(std::max(1, w)), uint32_t(std::max(1, h)))) return false;
    }
    m_initialized = true;
    return true;
}

// ---------------------------------------------------------------------------------------------
// Lookups
// ---------------------------------------------------------------------------------------------
BufferObj* GlDevice::buffer(BufferHandle h, const char* what) {
    auto* p = m_buffers.get(h);
    if (!p) {
        error(std::string(what) + ": invalid or destroyed buffer handle");
        return nullptr;
    }
    return p->get();
}

TextureObj* GlDevice::texture(TextureHandle h, const char* what) {
    auto* p = m_textures.get(h);
    if (!p) {
        error(std::string(what) + ": invalid or destroyed texture handle");
        return nullptr;
    }
    return p->get();
}

const BufferDesc* GlDevice::describe(BufferHandle h) const {
    auto* p = m_buffers.get(h);
    return p ? &(*p)->desc : nullptr;
}

const TextureDesc* GlDevice::describe(TextureHandle h) const {
    auto* p = m_textures.get(h);
    return p ? &(*p)->desc : nullptr;
}

// ---------------------------------------------------------------------------------------------
// Resources
// ---------------------------------------------------------------------------------------------
BufferHandle GlDevice::createBuffer(const BufferDesc& desc, const void* initialData) {
    if (!activate()) return {};
    if (desc.size == 0) {
        error("createBuffer " + quoted(desc.debugName) + ": size is 0");
        return {};
    }
    if (desc.size > uint64_t(std::numeric_limits<GLsizeiptr>::max())) {
        error("createBuffer " + quoted(desc.debugName) + ": size " + std::to_string(desc.size) +
              " is too large");
        return {};
    }
    GLbitfield flags = GL_DYNAMIC_STORAGE_BIT;
    GLbitfield mapFlags = 0;
    if (desc.memory == MemoryType::Upload)
        mapFlags = GL_MAP_WRITE_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
    else if (desc.memory == MemoryType::Readback)
        mapFlags = GL_MAP_READ_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
    flags |= mapFlags;

    // Keep GL errors of this call apart from earlier ones.
    while (m_gl.GetError() != GL_NO_ERROR) {
    }
    auto obj = std::make_unique<BufferObj>();
    obj->desc = desc;
    m_gl.CreateBuffers(1, &obj->name);
    m_gl.NamedBufferStorage(obj->name, GLsizeiptr(desc.size), initialData, flags);
    if (GLenum err = m_gl.GetError(); err != GL_NO_ERROR) {
        error("createBuffer " + quoted(desc.debugName) + ": glNamedBufferStorage of " +
              std::to_string(desc.size) + " bytes failed (GL error 0x" +
              [&] {
                  char b[16];
                  std::snprintf(b, sizeof b, "%04x", err);
                  return std::string(b);
              }() +
              ")");
        m_gl.DeleteBuffers(1, &obj->name);
        return {};
    }
    if (mapFlags) {
        obj->mapped = m_gl.MapNamedBufferRange(obj->name, 0, GLsizeiptr(desc.size), mapFlags);
        if (!obj->mapped) {
            error("createBuffer " + quoted(desc.debugName) + ": persistent mapping failed");
            m_gl.DeleteBuffers(1, &obj->name);
            return {};
        }
    }
    label(GL_BUFFER, obj->name, desc.debugName);
    const GLuint name = obj->name;
    BufferHandle h = m_buffers.insert(std::move(obj));
    if (!h) {
        error("createBuffer " + quoted(desc.debugName) + ": too many live buffers");
        m_gl.DeleteBuffers(1, &name);
    }
    return h;
}

TextureHandle GlDevice::createTexture(const TextureDesc& desc) {
    if (!activate()) return {};
    const std::string what = "createTexture " + quoted(desc.debugName);
    const TextureFormatGl fmt = textureFormat(desc.format);
    const FormatInfo& fi = formatInfo(desc.format);
    if (fmt.internalFormat == 0) {
        error(what + ": format " + fi.name + " cannot be used for textures");
        return {};
    }
    if (desc.width == 0 || desc.height == 0 || desc.depthOrLayers == 0 || desc.mipLevels == 0) {
        error(what + ": width, height, depthOrLayers and mipLevels must be non-zero");
        return {};
    }
    const DeviceLimits& l = m_info.limits;
    if (desc.dimension == TextureDimension::Tex3D) {
        if (desc.width > l.maxTextureSize3D || desc.height > l.maxTextureSize3D ||
            desc.depthOrLayers > l.maxTextureSize3D) {
            error(what + ": 3D extent exceeds GL_MAX_3D_TEXTURE_SIZE " + std::to_string(l.maxTextureSize3D));
            return {};
        }
        if (fi.isDepth) {
            error(what + ": depth formats cannot be 3D textures");
            return {};
        }
    } else {
        if (desc.width > l.maxTextureSize2D || desc.height > l.maxTextureSize2D) {
            error(what + ": extent exceeds GL_MAX_TEXTURE_SIZE " + std::to_string(l.maxTextureSize2D));
            return {};
        }
        if (desc.dimension == TextureDimension::Tex2D && desc.depthOrLayers != 1) {
            error(what + ": a Tex2D texture must have depthOrLayers = 1");
            return {};
        }
        if (desc.dimension == TextureDimension::Tex2DArray && desc.depthOrLayers > l.maxTextureArrayLayers) {
            error(what + ": layer count exceeds GL_MAX_ARRAY_TEXTURE_LAYERS");
            return {};
        }
    }
    if (desc.mipLevels > maxMipLevels(desc)) {
        error(what + ": " + std::to_string(desc.mipLevels) + " mip levels requested, at most " +
              std::to_string(maxMipLevels(desc)) + " possible");
        return {};
    }
    if (any(desc.usage & TextureUsage::Storage) && fmt.imageFormat == 0) {
        error(what + ": format " + fi.name + " cannot be a storage texture");
        return {};
    }
    if (any(desc.usage & TextureUsage::DepthTarget) && !fi.isDepth) {
        error(what + ": DepthTarget usage needs a depth format");
        return {};
    }
    if (any(desc.usage & TextureUsage::ColorTarget) && fi.isDepth) {
        error(what + ": ColorTarget usage needs a colour format");
        return {};
    }

    while (m_gl.GetError() != GL_NO_ERROR) {
    }
    auto obj = std::make_unique<TextureObj>();
    obj->desc = desc;
    obj->format = fmt;
    obj->target = textureTarget(desc.dimension);
    m_gl.CreateTextures(obj->target, 1, &obj->name);
    if (desc.dimension == TextureDimension::Tex2D)
        m_gl.TextureStorage2D(obj->name, GLsizei(desc.mipLevels), fmt.internalFormat, GLsizei(desc.width),
                              GLsizei(desc.height));
    else
        m_gl.TextureStorage3D(obj->name, GLsizei(desc.mipLevels), fmt.internalFormat, GLsizei(desc.width),
                              GLsizei(desc.height), GLsizei(desc.depthOrLayers));
    if (m_gl.GetError() != GL_NO_ERROR) {
        error(what + ": glTextureStorage failed (out of memory?)");
        m_gl.DeleteTextures(1, &obj->name);
        return {};
    }
    label(GL_TEXTURE, obj->name, desc.debugName);
    const GLuint name = obj->name;
    TextureHandle h = m_textures.insert(std::move(obj));
    if (!h) {
        error(what + ": too many live textures");
        m_gl.DeleteTextures(1, &name);
    }
    return h;
}

SamplerHandle GlDevice::createSampler(const SamplerDesc& desc) {
    if (!activate()) return {};
    auto obj = std::make_unique<SamplerObj>();
    m_gl.CreateSamplers(1, &obj->name);
    const GLuint s = obj->name;
    m_gl.SamplerParameteri(s, GL_TEXTURE_MIN_FILTER, GLint(minFilter(desc.minFilter, desc.mipFilter)));
    m_gl.SamplerParameteri(s, GL_TEXTURE_MAG_FILTER, GLint(magFilter(desc.magFilter)));
    m_gl.SamplerParameteri(s, GL_TEXTURE_WRAP_S, GLint(addressMode(desc.addressU)));
    m_gl.SamplerParameteri(s, GL_TEXTURE_WRAP_T, GLint(addressMode(desc.addressV)));
    m_gl.SamplerParameteri(s, GL_TEXTURE_WRAP_R, GLint(addressMode(desc.addressW)));
    m_gl.SamplerParameterf(s, GL_TEXTURE_MIN_LOD, 0.0f);
    m_gl.SamplerParameterf(s, GL_TEXTURE_MAX_LOD, desc.maxLod);
    label(GL_SAMPLER, s, desc.debugName);
    SamplerHandle h = m_samplers.insert(std::move(obj));
    if (!h) {
        error("createSampler " + quoted(desc.debugName) + ": too many live samplers");
        m_gl.DeleteSamplers(1, &s);
    }
    return h;
}

ShaderHandle GlDevice::createShader(const ShaderDesc& desc) {
    if (!activate()) return {};
    const std::string what = "createShader " + quoted(desc.debugName);
    if (desc.glsl.empty()) {
        error(what + ": the shader has no GLSL source (ShaderDesc::glsl is empty)");
        return {};
    }
    if (desc.pushConstantSize > kMaxPushConstantSize) {
        error(what + ": push constants of " + std::to_string(desc.pushConstantSize) + " bytes exceed " +
              std::to_string(kMaxPushConstantSize));
        return {};
    }
    GLenum type = GL_COMPUTE_SHADER;
    if (desc.stage == ShaderStage::Vertex)
        type = GL_VERTEX_SHADER;
    else if (desc.stage == ShaderStage::Fragment)
        type = GL_FRAGMENT_SHADER;

    const GLuint shader = m_gl.CreateShader(type);
    const GLchar* src = desc.glsl.data();
    const GLint len = GLint(desc.glsl.size());
    m_gl.ShaderSource(shader, 1, &src, &len);
    // The info log below reports compile errors; the driver's debug-output copy would duplicate it.
    m_muteDebug = true;
    m_gl.CompileShader(shader);
    m_muteDebug = false;
    GLint ok = GL_FALSE;
    m_gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        GLint logLen = 0;
        m_gl.GetShaderiv(shader, GL_INFO_LOG_LENGTH, &logLen);
        std::string infoLog(size_t(std::max(1, logLen)), '\0');
        m_gl.GetShaderInfoLog(shader, GLsizei(infoLog.size()), nullptr, infoLog.data());
        infoLog.resize(std::strlen(infoLog.c_str()));
        while (!infoLog.empty() && infoLog.back() == '\n') infoLog.pop_back();
        error(what + ": GLSL compilation failed:\n" + infoLog);
        m_gl.DeleteShader(shader);
        return {};
    }
    label(GL_SHADER, shader, std::string(desc.debugName));

    auto obj = std::make_unique<ShaderObj>();
    obj->name = shader;
    obj->stage = desc.stage;
    obj->debugName = desc.debugName;
    obj->pushConstantSize = desc.pushConstantSize;
    for (const ShaderBinding& b : desc.bindings)
        obj->bindings.push_back({b.set, b.binding, b.type, std::max(1u, b.count), b.glBinding,
                                 b.textureDimension, b.storageFormat, b.writes, b.name ? b.name : ""});
    obj->vertexInputs.assign(desc.vertexInputs.begin(), desc.vertexInputs.end());
    ShaderHandle h = m_shaders.insert(std::move(obj));
    if (!h) {
        error(what + ": too many live shaders");
        m_gl.DeleteShader(shader);
    }
    return h;
}

bool GlDevice::compileProgram(const std::vector<GLuint>& shaders, const std::string& name, GLuint& program) {
    program = m_gl.CreateProgram();
    for (GLuint s : shaders) m_gl.AttachShader(program, s);
    m_muteDebug = true;
    m_gl.LinkProgram(program);
    m_muteDebug = false;
    for (GLuint s : shaders) m_gl.DetachShader(program, s);
    GLint ok = GL_FALSE;
    m_gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
    if (!ok) {
        GLint logLen = 0;
        m_gl.GetProgramiv(program, GL_INFO_LOG_LENGTH, &logLen);
        std::string infoLog(size_t(std::max(1, logLen)), '\0');
        m_gl.GetProgramInfoLog(program, GLsizei(infoLog.size()), nullptr, infoLog.data());
        infoLog.resize(std::strlen(infoLog.c_str()));
        while (!infoLog.empty() && infoLog.back() == '\n') infoLog.pop_back();
        error("pipeline " + quoted(name) + ": program link failed:\n" + infoLog);
        m_gl.DeleteProgram(program);
        program = 0;
        return false;
    }
    label(GL_PROGRAM, program, name);
    return true;
}

bool GlDevice::mergeLayout(std::vector<BindingSlot>& layout, const ShaderObj& shader,
                           const std::string& pipelineName) {
    for (const BindingSlot& b : shader.bindings) {
        if (b.set >= kMaxBindGroups) {
            error("pipeline " + quoted(pipelineName) + ": shader " + quoted(shader.debugName) + " uses set " +
                  std::to_string(b.set) + " (at most " + std::to_string(kMaxBindGroups) + " sets)");
            return false;
        }
        auto it = std::find_if(layout.begin(), layout.end(), [&](const BindingSlot& s) {
            return s.set == b.set && s.binding == b.binding;
        });
        if (it == layout.end()) {
            layout.push_back(b);
            continue;
        }
        if (it->type != b.type || it->glBinding != b.glBinding || it->count != b.count) {
            error("pipeline " + quoted(pipelineName) + ": set " + std::to_string(b.set) + " binding " +
                  std::to_string(b.binding) + " is declared differently in the vertex and fragment shaders");
            return false;
        }
        it->writes = it->writes || b.writes;
    }
    return true;
}

PipelineHandle GlDevice::createComputePipeline(const ComputePipelineDesc& desc) {
    if (!activate()) return {};
    const std::string what = "createComputePipeline " + quoted(desc.debugName);
    auto* sp = m_shaders.get(desc.shader);
    if (!sp) {
        error(what + ": invalid or destroyed shader handle");
        return {};
    }
    const ShaderObj& shader = **sp;
    if (shader.stage != ShaderStage::Compute) {
        error(what + ": shader " + quoted(shader.debugName) + " is not a compute shader");
        return {};
    }
    auto obj = std::make_shared<PipelineObj>();
    obj->debugName = desc.debugName.empty() ? shader.debugName : desc.debugName;
    if (!mergeLayout(obj->layout, shader, obj->debugName)) return {};
    if (!compileProgram({shader.name}, obj->debugName, obj->program)) return {};
    const GLuint program = obj->program;
    PipelineHandle h = m_pipelines.insert(std::move(obj));
    if (h) ++m_stats.pipelinesCreated;
    if (!h) {
        error(what + ": too many live pipelines");
        m_gl.DeleteProgram(program);
    }
    return h;
}

PipelineHandle GlDevice::createGraphicsPipeline(const GraphicsPipelineDesc& desc) {
    if (!activate()) return {};
    const std::string what = "createGraphicsPipeline " + quoted(desc.debugName);
    auto* vsp = m_shaders.get(desc.vertexShader);
    auto* fsp = m_shaders.get(desc.fragmentShader);
    if (!vsp || !fsp) {
        error(what + ": invalid or destroyed " + std::string(!vsp ? "vertex" : "fragment") +
              " shader handle");
        return {};
    }
    const ShaderObj& vs = **vsp;
    const ShaderObj& fs = **fsp;
    if (vs.stage != ShaderStage::Vertex || fs.stage != ShaderStage::Fragment) {
        error(what + ": expects a vertex and a fragment shader");
        return {};
    }
    if (desc.colorFormats.size() > m_info.limits.maxColorTargets) {
        error(what + ": " + std::to_string(desc.colorFormats.size()) +
              " colour targets exceed the limit of " + std::to_string(m_info.limits.maxColorTargets));
        return {};
    }
    if (!desc.blend.empty() && desc.blend.size() != desc.colorFormats.size()) {
        error(what + ": blend must be empty or hold one entry per colour target");
        return {};
    }
    for (Format f : desc.colorFormats) {
        if (textureFormat(f).internalFormat == 0 || formatInfo(f).isDepth) {
            error(what + ": colour target format " + formatInfo(f).name + " is not renderable");
            return {};
        }
    }
    if (desc.depthFormat != Format::Undefined && !formatInfo(desc.depthFormat).isDepth) {
        error(what + ": depthFormat " + std::string(formatInfo(desc.depthFormat).name) +
              " is not a depth format");
        return {};
    }
    if (desc.vertexBuffers.size() > 16) {
        error(what + ": at most 16 vertex buffers are supported");
        return {};
    }
    for (const VertexAttribute& a : desc.vertexAttributes) {
        if (a.bufferSlot >= desc.vertexBuffers.size()) {
            error(what + ": vertex attribute at location " + std::to_string(a.location) +
                  " uses buffer slot " + std::to_string(a.bufferSlot) + ", but only " +
                  std::to_string(desc.vertexBuffers.size()) + " vertex buffer layouts are declared");
            return {};
        }
        if (vertexFormat(a.format).components == 0) {
            error(what + ": format " + std::string(formatInfo(a.format).name) +
                  " cannot be a vertex attribute");
            return {};
        }
        if (a.location >= 16) {
            error(what + ": vertex attribute location " + std::to_string(a.location) + " is out of range");
            return {};
        }
    }

    auto obj = std::make_shared<PipelineObj>();
    obj->graphics = true;
    obj->debugName = desc.debugName.empty() ? vs.debugName : desc.debugName;
    if (!mergeLayout(obj->layout, vs, obj->debugName) || !mergeLayout(obj->layout, fs, obj->debugName))
        return {};
    if (!compileProgram({vs.name, fs.name}, obj->debugName, obj->program)) return {};
    obj->baseInstanceLocation = m_gl.GetUniformLocation(obj->program, "SPIRV_Cross_BaseInstance");

    m_gl.CreateVertexArrays(1, &obj->vao);
    for (const VertexAttribute& a : desc.vertexAttributes) {
        const VertexFormatGl vf = vertexFormat(a.format);
        m_gl.EnableVertexArrayAttrib(obj->vao, a.location);
        if (vf.integer)
            m_gl.VertexArrayAttribIFormat(obj->vao, a.location, vf.components, vf.type, a.offset);
        else
            m_gl.VertexArrayAttribFormat(obj->vao, a.location, vf.components, vf.type, vf.normalized,
                                         a.offset);
        m_gl.VertexArrayAttribBinding(obj->vao, a.location, a.bufferSlot);
    }
    for (size_t slot = 0; slot < desc.vertexBuffers.size(); ++slot)
        m_gl.VertexArrayBindingDivisor(obj->vao, GLuint(slot), desc.vertexBuffers[slot].perInstance ? 1 : 0);
    label(GL_VERTEX_ARRAY, obj->vao, obj->debugName);

    obj->topology = topology(desc.topology);
    obj->depthTest = desc.depthTest;
    obj->depthWrite = desc.depthWrite;
    obj->depthFunc = compareOp(desc.depthCompare);
    obj->cullMode = desc.cullMode;
    // Vulkan's polygon area carries an extra minus sign for its y-down framebuffer; with
    // glClipControl(GL_LOWER_LEFT) window coordinates equal Vulkan's framebuffer coordinates, so
    // the winding names swap.
    obj->frontFace = desc.frontFace == FrontFace::CounterClockwise ? GL_CW : GL_CCW;
    obj->blend = desc.blend;
    obj->colorFormats = desc.colorFormats;
    obj->depthFormat = desc.depthFormat;
    obj->vertexBuffers = desc.vertexBuffers;

    const GLuint program = obj->program, vao = obj->vao;
    PipelineHandle h = m_pipelines.insert(std::move(obj));
    if (h) ++m_stats.pipelinesCreated;
    if (!h) {
        error(what + ": too many live pipelines");
        m_gl.DeleteProgram(program);
        m_gl.DeleteVertexArrays(1, &vao);
    }
    return h;
}

BindGroupHandle GlDevice::createBindGroup(const BindGroupDesc& desc) {
    if (!activate()) return {};
    const std::string what = "createBindGroup " + quoted(desc.debugName);
    auto* pp = m_pipelines.get(desc.pipeline);
    if (!pp) {
        error(what + ": invalid or destroyed pipeline handle");
        return {};
    }
    const PipelineObj& pipeline = **pp;
    if (desc.set >= kMaxBindGroups) {
        error(what + ": set " + std::to_string(desc.set) + " is out of range");
        return {};
    }
    auto obj = std::make_shared<BindGroupObj>();
    obj->set = desc.set;
    obj->debugName = desc.debugName;
    for (const BindGroupEntry& e : desc.entries) {
        const std::string where =
            what + ": set " + std::to_string(desc.set) + " binding " + std::to_string(e.binding);
        const BindingSlot* slot = pipeline.findSlot(desc.set, e.binding);
        if (!slot) {
            error(where + " is not used by pipeline " + quoted(pipeline.debugName));
            return {};
        }
        if (e.arrayElement >= slot->count) {
            error(where + ": array element " + std::to_string(e.arrayElement) + " is out of range (count " +
                  std::to_string(slot->count) + ")");
            return {};
        }
        GroupBind b;
        b.binding = e.binding;
        b.arrayElement = e.arrayElement;
        b.type = slot->type;
        switch (slot->type) {
            case BindingType::UniformBuffer:
            case BindingType::StorageBuffer:
            case BindingType::ReadOnlyStorageBuffer: {
                auto* bp = m_buffers.get(e.buffer);
                if (!bp) {
                    error(where + " (" + slot->name + "): invalid or destroyed buffer handle");
                    return {};
                }
                const BufferObj& buf = **bp;
                const bool uniform = slot->type == BindingType::UniformBuffer;
                if (!any(buf.desc.usage & (uniform ? BufferUsage::Uniform : BufferUsage::Storage))) {
                    error(where + " (" + slot->name + "): buffer " + quoted(buf.desc.debugName) + " lacks " +
                          (uniform ? "BufferUsage::Uniform" : "BufferUsage::Storage"));
                    return {};
                }
                const uint64_t size =
                    e.size ? e.size : (e.offset < buf.desc.size ? buf.desc.size - e.offset : 0);
                if (e.offset >= buf.desc.size || size == 0 || size > buf.desc.size - e.offset) {
                    error(where + " (" + slot->name + "): range [" + std::to_string(e.offset) + ", +" +
                          std::to_string(size) + ") exceeds buffer " + quoted(buf.desc.debugName) + " of " +
                          std::to_string(buf.desc.size) + " bytes");
                    return {};
                }
                const uint64_t align = uint64_t(uniform ? m_uboAlignment : m_ssboAlignment);
                if (e.offset % align != 0) {
                    error(where + " (" + slot->name + "): offset " + std::to_string(e.offset) +
                          " is not a multiple of the required " + std::to_string(align));
                    return {};
                }
                b.object = buf.name;
                b.offset = GLintptr(e.offset);
                b.size = GLsizeiptr(size);
                break;
            }
            case BindingType::SampledTexture:
            case BindingType::StorageTexture: {
                auto* tp = m_textures.get(e.texture);
                if (!tp) {
                    error(where + " (" + slot->name + "): invalid or destroyed texture handle");
                    return {};
                }
                TextureObj& tex = **tp;
                TextureRange range;
                std::string why;
                if (!detail::entryRange(tex.desc, e, slot->type == BindingType::StorageTexture, range, why)) {
                    error(where + " (" + slot->name + "): texture " + quoted(tex.desc.debugName) + ": " +
                          why);
                    return {};
                }
                const bool allLayers =
                    range.baseLayer == 0 && range.layerCount == detail::stateLayers(tex.desc);
                b.object = tex.name;
                if (slot->type == BindingType::SampledTexture) {
                    auto* sp = m_samplers.get(e.sampler);
                    if (!sp) {
                        error(where + " (" + slot->name + "): invalid or destroyed sampler handle");
                        return {};
                    }
                    if (!any(tex.desc.usage & TextureUsage::Sampled)) {
                        error(where + " (" + slot->name + "): texture " + quoted(tex.desc.debugName) +
                              " lacks TextureUsage::Sampled");
                        return {};
                    }
                    b.sampler = (*sp)->name;
                    if (range.baseMip != 0 || range.mipCount != tex.desc.mipLevels || !allLayers)
                        b.object = rangeView(tex, range);
                } else {
                    if (!any(tex.desc.usage & TextureUsage::Storage)) {
                        error(where + " (" + slot->name + "): texture " + quoted(tex.desc.debugName) +
                              " lacks TextureUsage::Storage");
                        return {};
                    }
                    if (e.mip >= tex.desc.mipLevels) {
                        error(where + " (" + slot->name + "): mip " + std::to_string(e.mip) +
                              " is out of range");
                        return {};
                    }
                    b.mip = GLint(e.mip);
                    b.layered = tex.desc.dimension == TextureDimension::Tex2D ? GL_FALSE : GL_TRUE;
                    b.imageFormat = tex.format.imageFormat;
                    if (!allLayers) {  // a view of the layers; its level 0 is mip e.mip
                        b.object = rangeView(tex, range);
                        b.mip = 0;
                    }
                }
                if (slot->textureDimension != tex.desc.dimension) {
                    error(where + " (" + slot->name +
                          "): the shader expects a different texture dimension than "
                          "texture " +
                          quoted(tex.desc.debugName) + " has");
                    return {};
                }
                if (!b.object) {
                    error(where + " (" + slot->name + "): glTextureView failed");
                    return {};
                }
                break;
            }
        }
        obj->binds.push_back(b);
    }
    BindGroupHandle h = m_bindGroups.insert(std::move(obj));
    if (h) ++m_stats.bindGroupsCreated;
    if (!h) error(what + ": too many live bind groups");
    return h;
}

void GlDevice::queryCapabilities() {
    GLint extensionCount = 0;
    m_gl.GetIntegerv(GL_NUM_EXTENSIONS, &extensionCount);
    bool subgroups = false;
    for (GLint i = 0; i < extensionCount; ++i) {
        const auto* name = reinterpret_cast<const char*>(m_gl.GetStringi(GL_EXTENSIONS, GLuint(i)));
        if (name && std::string(name) == "GL_KHR_shader_subgroup") subgroups = true;
    }
    DeviceLimits& l = m_info.limits;
    m_info.enabledFeatures.clear();
    if (subgroups) {
        m_info.enabledFeatures.emplace_back("GL_KHR_shader_subgroup");
        GLint size = 0, stages = 0, features = 0;
        m_gl.GetIntegerv(GL_SUBGROUP_SIZE_KHR, &size);
        m_gl.GetIntegerv(GL_SUBGROUP_SUPPORTED_STAGES_KHR, &stages);
        m_gl.GetIntegerv(GL_SUBGROUP_SUPPORTED_FEATURES_KHR, &features);
        // GL_SUBGROUP_FEATURE_*_BIT_KHR and rhi::SubgroupOps share their bit order (basic .. quad).
        l.subgroupSize = uint32_t(std::max(0, size));
        l.subgroupOps = SubgroupOps(uint32_t(features) & 0xffu);
        if (stages & GL_VERTEX_SHADER_BIT) l.subgroupStages |= ShaderStageFlags::Vertex;
        if (stages & GL_FRAGMENT_SHADER_BIT) l.subgroupStages |= ShaderStageFlags::Fragment;
        if (stages & GL_COMPUTE_SHADER_BIT) l.subgroupStages |= ShaderStageFlags::Compute;
    }
    for (uint32_t f = 1; f < uint32_t(Format::Count); ++f) {
        const Format format = Format(f);
        const FormatInfo& fi = formatInfo(format);
        const TextureFormatGl tf = textureFormat(format);
        FormatSupport s = FormatSupport::None;
        if (vertexFormat(format).components != 0) s |= FormatSupport::VertexAttribute;
        if (tf.internalFormat != 0) {
            auto query = [&](GLenum pname) {
                GLint v = 0;
                m_gl.GetInternalformativ(GL_TEXTURE_2D, tf.internalFormat, pname, 1, &v);
                return v;
            };
            if (query(GL_FRAGMENT_TEXTURE) != GL_NONE) s |= FormatSupport::Sampled;
            if (query(GL_FILTER) != GL_NONE) s |= FormatSupport::Filterable;  // a support level, not a bool
            if (tf.imageFormat != 0 && query(GL_SHADER_IMAGE_STORE) != GL_NONE) {
                s |= FormatSupport::Storage;
                // GL 4.5 image atomics operate on r32i / r32ui images only.
                if (format == Format::R32_UINT) s |= FormatSupport::StorageAtomic;
            }
            if (!fi.isDepth && query(GL_COLOR_RENDERABLE) == GL_TRUE) {
                s |= FormatSupport::ColorTarget;
                if (!fi.isInteger) s |= FormatSupport::Blendable;
            }
            if (fi.isDepth && query(GL_DEPTH_RENDERABLE) == GL_TRUE) s |= FormatSupport::DepthTarget;
        }
        m_formatSupport[f] = s;
    }
}

GLuint GlDevice::rangeView(TextureObj& t, const TextureRange& r) {
    const std::array<uint32_t, 4> key{r.baseMip, r.mipCount, r.baseLayer, r.layerCount};
    if (auto it = t.views.find(key); it != t.views.end()) return it->second;
    GLuint view = 0;
    m_gl.GenTextures(1, &view);  // glTextureView needs a name that was never bound
    m_gl.TextureView(view, t.target, t.name, t.format.internalFormat, r.baseMip, r.mipCount, r.baseLayer,
                     r.layerCount);
    t.views.emplace(key, view);
    return view;
}

QueryPoolHandle GlDevice::createQueryPool(const QueryPoolDesc& desc) {
    if (!activate()) return {};
    if (desc.count == 0 || desc.count > 65536) {
        error("createQueryPool " + quoted(desc.debugName) + ": count must be in 1..65536");
        return {};
    }
    auto obj = std::make_shared<QueryPoolObj>();
    obj->queries.resize(desc.count);
    obj->written.assign(desc.count, 0);
    obj->debugName = desc.debugName;
    m_gl.CreateQueries(GL_TIMESTAMP, GLsizei(desc.count), obj->queries.data());
    for (uint32_t i = 0; i < desc.count && !desc.debugName.empty(); ++i)
        label(GL_QUERY, obj->queries[i], desc.debugName + "[" + std::to_string(i) + "]");
    std::vector<GLuint> names = obj->queries;
    QueryPoolHandle h = m_queryPools.insert(std::move(obj));
    if (!h) {
        error("createQueryPool " + quoted(desc.debugName) + ": too many live query pools");
        m_gl.DeleteQueries(GLsizei(names.size()), names.data());
    }
    return h;
}

// ---------------------------------------------------------------------------------------------
// Deferred destruction
// ---------------------------------------------------------------------------------------------
void GlDevice::destroy(BufferHandle h) {
    auto obj = m_buffers.remove(h);
    if (!obj) {
        if (h) error("destroy: invalid or destroyed buffer handle");
        return;
    }
    const GLuint name = (*obj)->name;
    m_releases.push(releaseSerial(), [this, name] { m_gl.DeleteBuffers(1, &name); });
}

void GlDevice::destroy(TextureHandle h) {
    if (h && h == m_backbuffer) {
        error("destroy: the backbuffer is owned by the device");
        return;
    }
    auto obj = m_textures.remove(h);
    if (!obj) {
        if (h) error("destroy: invalid or destroyed texture handle");
        return;
    }
    const GLuint name = (*obj)->name;
    std::vector<GLuint> views;
    for (const auto& [key, view] : (*obj)->views) views.push_back(view);
    m_releases.push(releaseSerial(), [this, name, views] {
        purgeFramebuffers(name);
        m_gl.DeleteTextures(1, &name);
        if (!views.empty()) m_gl.DeleteTextures(GLsizei(views.size()), views.data());
    });
}

void GlDevice::destroy(SamplerHandle h) {
    auto obj = m_samplers.remove(h);
    if (!obj) {
        if (h) error("destroy: invalid or destroyed sampler handle");
        return;
    }
    const GLuint name = (*obj)->name;
    m_releases.push(releaseSerial(), [this, name] { m_gl.DeleteSamplers(1, &name); });
}

void GlDevice::destroy(ShaderHandle h) {
    auto obj = m_shaders.remove(h);
    if (!obj) {
        if (h) error("destroy: invalid or destroyed shader handle");
        return;
    }
    // Linked programs keep their own copy of the code: the shader object can go right away.
    if (activate()) m_gl.DeleteShader((*obj)->name);
}

void GlDevice::destroy(PipelineHandle h) {
    auto obj = m_pipelines.remove(h);
    if (!obj) {
        if (h) error("destroy: invalid or destroyed pipeline handle");
        return;
    }
    const GLuint program = (*obj)->program, vao = (*obj)->vao;
    m_releases.push(releaseSerial(), [this, program, vao] {
        m_gl.DeleteProgram(program);
        if (vao) m_gl.DeleteVertexArrays(1, &vao);
    });
}

void GlDevice::destroy(BindGroupHandle h) {
    auto obj = m_bindGroups.remove(h);
    if (!obj) {
        if (h) error("destroy: invalid or destroyed bind group handle");
        return;
    }
    // A bind group owns no GL object; recorded lists keep their own reference.
}

void GlDevice::destroy(QueryPoolHandle h) {
    auto obj = m_queryPools.remove(h);
    if (!obj) {
        if (h) error("destroy: invalid or destroyed query pool handle");
        return;
    }
    std::shared_ptr<QueryPoolObj> pool = std::move(*obj);
    m_releases.push(releaseSerial(), [this, pool] {
        m_gl.DeleteQueries(GLsizei(pool->queries.size()), pool->queries.data());
    });
}

// ---------------------------------------------------------------------------------------------
// Uploads
// ---------------------------------------------------------------------------------------------
void GlDevice::writeBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) {
    if (!activate()) return;
    BufferObj* b = buffer(dst, "writeBuffer");
    if (!b) return;
    if (!data || size == 0 || offset > b->desc.size || size > b->desc.size - offset) {
        error("writeBuffer " + quoted(b->desc.debugName) + ": range [" + std::to_string(offset) + ", +" +
              std::to_string(size) + ") is empty or exceeds the buffer's " + std::to_string(b->desc.size) +
              " bytes");
        return;
    }
    flushBarriers();
    m_gl.NamedBufferSubData(b->name, GLintptr(offset), GLsizeiptr(size), data);
}

void GlDevice::writeTexture(TextureHandle dst, TextureSubresource sub, const void* data, uint64_t size) {
    writeTextureImpl(dst, TextureRegion{sub.mip, sub.layer}, data, size, "writeTexture");
}

void GlDevice::writeTextureRegion(TextureHandle dst, const TextureRegion& region, const void* data,
                                  uint64_t size) {
    writeTextureImpl(dst, region, data, size, "writeTextureRegion");
}

void GlDevice::writeTextureImpl(TextureHandle dst, const TextureRegion& in, const void* data, uint64_t size,
                                const char* fn) {
    if (!activate()) return;
    TextureObj* t = texture(dst, fn);
    if (!t) return;
    const std::string what = std::string(fn) + " " + quoted(t->desc.debugName);
    TextureRegion box;
    std::string why;
    if (!detail::resolveRegion(t->desc, in, box, why)) {
        error(what + ": " + why);
        return;
    }
    const uint64_t expected = detail::regionBytes(t->desc, box);
    if (!data || size < expected) {
        error(what + ": " + std::to_string(size) + " bytes given, " + std::to_string(expected) + " needed");
        return;
    }
    flushBarriers();
    uploadRegion(*t, box, data);
}

void GlDevice::uploadRegion(const TextureObj& t, const TextureRegion& box, const void* pixels) {
    if (t.desc.dimension == TextureDimension::Tex2D)
        m_gl.TextureSubImage2D(t.name, GLint(box.mip), GLint(box.x), GLint(box.y), GLsizei(box.width),
                               GLsizei(box.height), t.format.pixelFormat, t.format.pixelType, pixels);
    else  // z is the array layer for Tex2DArray
        m_gl.TextureSubImage3D(t.name, GLint(box.mip), GLint(box.x), GLint(box.y), GLint(box.z + box.layer),
                               GLsizei(box.width), GLsizei(box.height), GLsizei(box.depth),
                               t.format.pixelFormat, t.format.pixelType, pixels);
}

void* GlDevice::mappedPointer(BufferHandle h) {
    BufferObj* b = buffer(h, "mappedPointer");
    return b ? b->mapped : nullptr;
}

// ---------------------------------------------------------------------------------------------
// Submission
// ---------------------------------------------------------------------------------------------
CommandList& GlDevice::beginCommandList(std::string_view debugName) {
    GlCommandList* list = nullptr;
    for (auto& l : m_lists)
        if (!l->m_recording) {
            list = l.get();
            break;
        }
    if (!list) {
        m_lists.push_back(std::make_unique<GlCommandList>(*this));
        list = m_lists.back().get();
    }
    list->begin(debugName);
    return *list;
}

void GlDevice::resetReplayState() {
    m_rs = ReplayState{};
    m_gl.BindBufferBase(GL_UNIFORM_BUFFER, kGlPushConstantBinding, m_pushConstantUbo);
}

uint64_t GlDevice::submit(CommandList& listIn) {
    auto* list = dynamic_cast<GlCommandList*>(&listIn);
    if (!list || &list->m_device != this) {
        error("submit: the command list does not belong to this device");
        return m_submittedSerial;
    }
    if (!list->m_recording) {
        error("submit: the command list is not recording (already submitted?)");
        return m_submittedSerial;
    }
    if (!activate()) {
        list->reset();
        return m_submittedSerial;
    }
    if (list->m_inRenderPass) {
        error("submit: command list " + quoted(list->m_name) + " ends inside a render pass; ending it");
        list->endRenderPass();
    }
    if (list->m_debugDepth > 0)
        error("submit: command list " + quoted(list->m_name) + " has " + std::to_string(list->m_debugDepth) +
              " unbalanced pushDebugGroup call(s)");

    resetReplayState();
    const bool named = !list->m_name.empty();
    if (named)
        m_gl.PushDebugGroup(GL_DEBUG_SOURCE_APPLICATION, 0, GLsizei(list->m_name.size()),
                            list->m_name.data());
    for (auto& cmd : list->m_commands) cmd(*this);
    while (m_rs.debugDepth > 0) {
        m_gl.PopDebugGroup();
        --m_rs.debugDepth;
    }
    if (named) m_gl.PopDebugGroup();
    // Host reads happen outside the GL command stream: their barrier cannot wait for a next use.
    if (m_pendingBarriers & GL_CLIENT_MAPPED_BUFFER_BARRIER_BIT) flushBarriers();
    m_rs = ReplayState{};
    list->reset();

    const uint64_t serial = ++m_submittedSerial;
    GLsync sync = m_gl.FenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    m_fences.push_back({serial, sync});
    m_gl.Flush();
    if (!checkContextLost()) collectGarbage();
    return serial;
}

void GlDevice::retireFences(bool wait, uint64_t upToSerial) {
    while (!m_fences.empty() && m_fences.front().serial <= upToSerial) {
        Fence& f = m_fences.front();
        GLenum r = m_gl.ClientWaitSync(f.sync, wait ? GL_SYNC_FLUSH_COMMANDS_BIT : 0, 0);
        while (wait && r == GL_TIMEOUT_EXPIRED) {
            if (checkContextLost()) return;
            r = m_gl.ClientWaitSync(f.sync, GL_SYNC_FLUSH_COMMANDS_BIT, 1000000000ull);
        }
        if (r == GL_WAIT_FAILED) {
            error("glClientWaitSync failed for submission " + std::to_string(f.serial));
        } else if (r == GL_TIMEOUT_EXPIRED) {
            break;
        }
        m_gl.DeleteSync(f.sync);
        m_completedSerial = std::max(m_completedSerial, f.serial);
        m_fences.pop_front();
    }
    m_releases.collect(m_completedSerial);
}

void GlDevice::waitForSubmission(uint64_t serial) {
    if (!activate()) return;
    if (serial > m_submittedSerial) {
        error("waitForSubmission: serial " + std::to_string(serial) + " has not been submitted (last is " +
              std::to_string(m_submittedSerial) + ")");
        return;
    }
    retireFences(true, serial);
}

void GlDevice::waitIdle() {
    if (!activate()) return;
    m_gl.Finish();
    for (Fence& f : m_fences) m_gl.DeleteSync(f.sync);
    m_fences.clear();
    m_completedSerial = m_submittedSerial;
    // Everything destroyed so far is unused by the GPU now, including objects destroyed after the
    // last submission.
    m_releases.releaseAll();
}

void GlDevice::collectGarbage() {
    if (!activate()) return;
    retireFences(false, m_submittedSerial);
}

// ---------------------------------------------------------------------------------------------
// Readback
// ---------------------------------------------------------------------------------------------
bool GlDevice::readBuffer(BufferHandle src, uint64_t offset, uint64_t size, void* out) {
    if (!activate()) return false;
    BufferObj* b = buffer(src, "readBuffer");
    if (!b) return false;
    if (!out || size == 0 || offset > b->desc.size || size > b->desc.size - offset) {
        error("readBuffer " + quoted(b->desc.debugName) + ": range [" + std::to_string(offset) + ", +" +
              std::to_string(size) + ") is empty or exceeds the buffer's " + std::to_string(b->desc.size) +
              " bytes");
        return false;
    }
    m_pendingBarriers |= GL_BUFFER_UPDATE_BARRIER_BIT | GL_CLIENT_MAPPED_BUFFER_BARRIER_BIT;
    flushBarriers();
    m_gl.GetNamedBufferSubData(b->name, GLintptr(offset), GLsizeiptr(size), out);
    return true;
}

bool GlDevice::readTexture(TextureHandle src, TextureSubresource sub, Access /*currentAccess*/,
                           std::vector<uint8_t>& out) {
    if (!activate()) return false;
    TextureObj* t = texture(src, "readTexture");
    if (!t) return false;
    const TextureDesc& d = t->desc;
    const std::string what = "readTexture " + quoted(d.debugName);
    if (sub.mip >= d.mipLevels) {
        error(what + ": mip " + std::to_string(sub.mip) + " is out of range");
        return false;
    }
    const bool isArray = d.dimension == TextureDimension::Tex2DArray;
    if ((isArray && sub.layer >= d.depthOrLayers) || (!isArray && sub.layer != 0)) {
        error(what + ": layer " + std::to_string(sub.layer) + " is out of range");
        return false;
    }
    const uint32_t w = mipExtent(d.width, sub.mip), h = mipExtent(d.height, sub.mip);
    const uint32_t depth = d.dimension == TextureDimension::Tex3D ? mipExtent(d.depthOrLayers, sub.mip) : 1;
    const uint64_t bytes = uint64_t(w) * h * depth * formatInfo(d.format).bytesPerTexel;
    if (bytes > uint64_t(std::numeric_limits<GLsizei>::max())) {
        error(what + ": the subresource is too large to read back at once");
        return false;
    }
    out.resize(size_t(bytes));
    m_pendingBarriers |= GL_TEXTURE_UPDATE_BARRIER_BIT | GL_PIXEL_BUFFER_BARRIER_BIT;
    flushBarriers();
    m_gl.GetTextureSubImage(t->name, GLint(sub.mip), 0, 0, GLint(isArray ? sub.layer : 0), GLsizei(w),
                            GLsizei(h), GLsizei(depth), t->format.pixelFormat, t->format.pixelType,
                            GLsizei(bytes), out.data());
    return true;
}

bool GlDevice::readTimestamps(QueryPoolHandle poolHandle, uint32_t first, uint32_t count, uint64_t* outNs) {
    ++m_stats.blockingTimestampReads;
    return readTimestampsImpl(poolHandle, first, count, outNs, true, "readTimestamps");
}

bool GlDevice::tryReadTimestamps(QueryPoolHandle poolHandle, uint32_t first, uint32_t count,
                                 uint64_t* outNs) {
    return readTimestampsImpl(poolHandle, first, count, outNs, false, "tryReadTimestamps");
}

bool GlDevice::readTimestampsImpl(QueryPoolHandle poolHandle, uint32_t first, uint32_t count, uint64_t* outNs,
                                  bool wait, const char* fn) {
    if (!activate()) return false;
    auto* pp = m_queryPools.get(poolHandle);
    if (!pp) {
        error(std::string(fn) + ": invalid or destroyed query pool handle");
        return false;
    }
    QueryPoolObj& pool = **pp;
    if (!outNs || count == 0 || first >= pool.queries.size() || count > pool.queries.size() - first) {
        error(std::string(fn) + " " + quoted(pool.debugName) + ": range [" + std::to_string(first) + ", +" +
              std::to_string(count) + ") is empty or out of range");
        return false;
    }
    for (uint32_t i = first; i < first + count; ++i) {
        if (pool.written[i]) continue;
        if (!wait) return false;  // its command list was not submitted yet
        error(std::string(fn) + " " + quoted(pool.debugName) + ": slot " + std::to_string(i) +
              " was never written by a submitted command list");
        return false;
    }
    if (!wait) {
        for (uint32_t i = first; i < first + count; ++i) {
            GLuint64 available = 0;
            m_gl.GetQueryObjectui64v(pool.queries[i], GL_QUERY_RESULT_AVAILABLE, &available);
            if (!available) return false;
        }
    }
    for (uint32_t i = 0; i < count; ++i) {
        GLuint64 v = 0;
        m_gl.GetQueryObjectui64v(pool.queries[first + i], GL_QUERY_RESULT, &v);
        outNs[i] = uint64_t(v);
    }
    return true;
}

// ---------------------------------------------------------------------------------------------
// Presentation
// ---------------------------------------------------------------------------------------------
bool GlDevice::createBackbuffer(uint32_t width, uint32_t height) {
    TextureDesc d;
    d.dimension = TextureDimension::Tex2D;
    d.format = kBackbufferFormat;
    d.width = width;
    d.height = height;
    d.usage =
        TextureUsage::ColorTarget | TextureUsage::Sampled | TextureUsage::CopySrc | TextureUsage::CopyDst;
    d.debugName = "backbuffer";
    TextureHandle h = createTexture(d);
    if (!h) return false;
    m_backbuffer = h;
    m_backbufferWidth = width;
    m_backbufferHeight = height;
    m_gl.NamedFramebufferTexture(m_presentFbo, GL_COLOR_ATTACHMENT0, (*m_textures.get(h))->name, 0);
    m_gl.NamedFramebufferReadBuffer(m_presentFbo, GL_COLOR_ATTACHMENT0);
    return true;
}

TextureHandle GlDevice::acquireBackbuffer() {
    if (!m_windowed) {
        error("acquireBackbuffer: the device is headless and has no backbuffer");
        return {};
    }
    return m_backbuffer;
}

bool GlDevice::present() {
    if (!m_windowed) {
        error("present: the device is headless");
        return false;
    }
    if (!activate() || !m_backbuffer) return false;
    int w = 0, h = 0;
    m_context->framebufferSize(w, h);
    if (w > 0 && h > 0) {
        flushBarriers();
        // Raw copy (no sRGB decode/encode, no scissor), flipped: backbuffer row 0 is the top of the
        // image, the window's row 0 is its bottom.
        m_gl.Disable(GL_FRAMEBUFFER_SRGB);
        m_gl.Disable(GL_SCISSOR_TEST);
        const bool sameSize = uint32_t(w) == m_backbufferWidth && uint32_t(h) == m_backbufferHeight;
        m_gl.BlitNamedFramebuffer(m_presentFbo, 0, 0, 0, GLint(m_backbufferWidth), GLint(m_backbufferHeight),
                                  0, h, w, 0, GL_COLOR_BUFFER_BIT, sameSize ? GL_NEAREST : GL_LINEAR);
        m_gl.Enable(GL_SCISSOR_TEST);
        m_gl.Enable(GL_FRAMEBUFFER_SRGB);
    }
    m_context->swapBuffers();
    collectGarbage();
    return true;
}

void GlDevice::resizeBackbuffer(uint32_t width, uint32_t height) {
    if (!m_windowed) {
        error("resizeBackbuffer: the device is headless");
        return;
    }
    if (!activate()) return;
    if (width == 0 || height == 0) {
        error("resizeBackbuffer: width and height must be non-zero");
        return;
    }
    if (width == m_backbufferWidth && height == m_backbufferHeight && m_backbuffer) return;
    TextureHandle old = m_backbuffer;
    m_backbuffer = {};
    if (!createBackbuffer(width, height)) {
        m_backbuffer = old;
        return;
    }
    destroy(old);
}

// Inline-sized overrides (declared from rhi/device_api.inc).
const DeviceInfo& GlDevice::info() const { return m_info; }
#define RHI_IS_ALIVE(Handle, pool, name) \
    bool GlDevice::isAlive(Handle h) const { return pool.contains(h); }
RHI_RESOURCE_KINDS(RHI_IS_ALIVE)
#undef RHI_IS_ALIVE
DeviceStats GlDevice::stats() const { return m_stats; }
FormatSupport GlDevice::formatSupport(Format format) const {
    return format < Format::Count ? m_formatSupport[size_t(format)] : FormatSupport::None;
}
Format GlDevice::backbufferFormat() const { return kBackbufferFormat; }

}  // namespace rhi::gl

// ---------------------------------------------------------------------------------------------
// Factory
// ---------------------------------------------------------------------------------------------

namespace rhi::detail {

std::unique_ptr<Device> createOpenGLDevice(const DeviceDesc& desc) {
    std::unique_ptr<gl::Context> context;
    std::string error;
    if (!desc.headless) {
        context = gl::createGlfwContext(desc.window, error);
        if (!context) {
            logMessage(desc.log, LogSeverity::Error, "OpenGL: " + error);
            return nullptr;
        }
    } else {
        std::string platform;
        if (const char* env = std::getenv("PENUMBRA_GL_PLATFORM"); env && *env) platform = env;
        if (!platform.empty() && platform != "egl" && platform != "osmesa") {
            logMessage(desc.log, LogSeverity::Error,
                       "OpenGL: PENUMBRA_GL_PLATFORM='" + platform + "' is not one of egl|osmesa");
            return nullptr;
        }
        if (platform.empty() || platform == "egl") {
            context = gl::createEglSurfacelessContext(desc.validation, error);
            if (!context && platform == "egl") {
                logMessage(desc.log, LogSeverity::Error, "OpenGL: " + error);
                return nullptr;
            }
            if (!context) logMessage(desc.log, LogSeverity::Info, "OpenGL: " + error + "; trying OSMesa");
        }
        if (!context) {
            std::string osError;
            context = gl::createOsMesaContext(osError);
            if (!context) {
                logMessage(desc.log, LogSeverity::Error,
                           "OpenGL: no headless context: " + (error.empty() ? "" : error + "; ") + osError);
                return nullptr;
            }
        }
    }
    auto device = std::make_unique<gl::GlDevice>(desc, std::move(context));
    if (!device->initialize()) return nullptr;
    return device;
}

}  // namespace rhi::detail
