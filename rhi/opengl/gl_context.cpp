#include "rhi/opengl/gl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <dlfcn.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cstring>
#include <mutex>
#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#endif
#include <vector>

namespace rhi::gl {

namespace {
thread_local Context* t_current = nullptr;
}  // namespace

Context::~Context() = default;

void Context::releaseIfCurrent() {
    if (t_current == this) {
        unbindNative();
        t_current = nullptr;
    }
}

bool Context::makeCurrent() {
    if (t_current == this && isNativeCurrent()) return true;
    if (t_current && t_current != this) t_current->unbindNative();
    t_current = nullptr;
    if (!bindNative()) return false;
    t_current = this;
    return true;
}

// ---------------------------------------------------------------------------------------------
// EGL surfaceless (EGL_MESA_platform_surfaceless + EGL_KHR_surfaceless_context). The display is
// shared by every EGL device of the process (eglGetPlatformDisplayEXT returns the same one), so
// it is initialised once per live context count and terminated with the last context.
// ---------------------------------------------------------------------------------------------
namespace {

std::mutex g_eglMutex;
EGLDisplay g_eglDisplay = EGL_NO_DISPLAY;
int g_eglUsers = 0;

const char* eglErrorName(EGLint e) {
    switch (e) {
        case EGL_SUCCESS:
            return "EGL_SUCCESS";
        case EGL_NOT_INITIALIZED:
            return "EGL_NOT_INITIALIZED";
        case EGL_BAD_ACCESS:
            return "EGL_BAD_ACCESS";
        case EGL_BAD_ALLOC:
            return "EGL_BAD_ALLOC";
        case EGL_BAD_ATTRIBUTE:
            return "EGL_BAD_ATTRIBUTE";
        case EGL_BAD_CONFIG:
            return "EGL_BAD_CONFIG";
        case EGL_BAD_CONTEXT:
            return "EGL_BAD_CONTEXT";
        case EGL_BAD_DISPLAY:
            return "EGL_BAD_DISPLAY";
        case EGL_BAD_MATCH:
            return "EGL_BAD_MATCH";
        case EGL_BAD_PARAMETER:
            return "EGL_BAD_PARAMETER";
        case EGL_BAD_SURFACE:
            return "EGL_BAD_SURFACE";
        default:
            return "EGL error";
    }
}

bool hasExtension(const char* list, const char* name) {
    if (!list) return false;
    const size_t n = std::strlen(name);
    for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n) {
        const bool startOk = p == list || p[-1] == ' ';
        const bool endOk = p[n] == ' ' || p[n] == '\0';
        if (startOk && endOk) return true;
    }
    return false;
}

class EglContext final : public Context {
public:
    EglContext(EGLDisplay display, EGLContext context) : m_display(display), m_context(context) {}
    ~EglContext() override {
        releaseIfCurrent();
        eglDestroyContext(m_display, m_context);
        std::lock_guard lock(g_eglMutex);
        if (--g_eglUsers == 0) {
            eglTerminate(g_eglDisplay);
            g_eglDisplay = EGL_NO_DISPLAY;
        }
    }
    const char* platformName() const override { return "EGL surfaceless"; }
    Functions::GenericProc getProc(const char* name) override {
        return reinterpret_cast<Functions::GenericProc>(eglGetProcAddress(name));
    }

protected:
    bool bindNative() override {
        return eglMakeCurrent(m_display, EGL_NO_SURFACE, EGL_NO_SURFACE, m_context) == EGL_TRUE;
    }
    void unbindNative() override {
        eglMakeCurrent(m_display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    bool isNativeCurrent() const override { return eglGetCurrentContext() == m_context; }

private:
    EGLDisplay m_display;
    EGLContext m_context;
};

}  // namespace

std::unique_ptr<Context> createEglSurfacelessContext(bool debug, std::string& error) {
    const char* clientExts = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!hasExtension(clientExts, "EGL_MESA_platform_surfaceless")) {
        error = "EGL: EGL_MESA_platform_surfaceless is not supported";
        return nullptr;
    }
    auto getPlatformDisplay =
        reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (!getPlatformDisplay) {
        error = "EGL: eglGetPlatformDisplayEXT is not available";
        return nullptr;
    }

    EGLDisplay display;
    {
        std::lock_guard lock(g_eglMutex);
        if (g_eglUsers == 0) {
            display = getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
            EGLint major = 0, minor = 0;
            if (display == EGL_NO_DISPLAY || !eglInitialize(display, &major, &minor)) {
                error = std::string("EGL: cannot initialise the surfaceless display (") +
                        eglErrorName(eglGetError()) + ")";
                return nullptr;
            }
            g_eglDisplay = display;
        }
        display = g_eglDisplay;
        ++g_eglUsers;
    }
    // Drops our reference to the display on every failure path below.
    auto fail = [&](std::string message) -> std::unique_ptr<Context> {
        error = std::move(message);
        std::lock_guard lock(g_eglMutex);
        if (--g_eglUsers == 0) {
            eglTerminate(g_eglDisplay);
            g_eglDisplay = EGL_NO_DISPLAY;
        }
        return nullptr;
    };

    const char* displayExts = eglQueryString(display, EGL_EXTENSIONS);
    if (!hasExtension(displayExts, "EGL_KHR_surfaceless_context"))
        return fail("EGL: EGL_KHR_surfaceless_context is not supported");
    if (!hasExtension(displayExts, "EGL_KHR_no_config_context") &&
        !hasExtension(displayExts, "EGL_MESA_configless_context"))
        return fail("EGL: configless contexts (EGL_KHR_no_config_context) are not supported");
    if (!eglBindAPI(EGL_OPENGL_API))
        return fail(std::string("EGL: eglBindAPI(EGL_OPENGL_API) failed (") + eglErrorName(eglGetError()) +
                    ")");

    // Ask for reset notification (so a lost context is reported instead of hanging a wait); retry
    // without it where the driver refuses.
    const bool robustness = hasExtension(displayExts, "EGL_EXT_create_context_robustness");
    EGLContext context = EGL_NO_CONTEXT;
    for (int attempt = robustness ? 0 : 1; attempt < 2 && context == EGL_NO_CONTEXT; ++attempt) {
        std::vector<EGLint> attribs = {EGL_CONTEXT_MAJOR_VERSION,       4,
                                       EGL_CONTEXT_MINOR_VERSION,       5,
                                       EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                       EGL_CONTEXT_OPENGL_DEBUG,        debug ? EGL_TRUE : EGL_FALSE};
        if (attempt == 0)
            attribs.insert(attribs.end(),
                           {EGL_CONTEXT_OPENGL_RESET_NOTIFICATION_STRATEGY, EGL_LOSE_CONTEXT_ON_RESET});
        attribs.push_back(EGL_NONE);
        context = eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs.data());
    }
    if (context == EGL_NO_CONTEXT)
        return fail(std::string("EGL: cannot create an OpenGL 4.5 core context (") +
                    eglErrorName(eglGetError()) + ")");
    auto ctx = std::make_unique<EglContext>(display, context);
    if (!ctx->makeCurrent()) {
        error =
            std::string("EGL: eglMakeCurrent without a surface failed (") + eglErrorName(eglGetError()) + ")";
        return nullptr;  // ~EglContext releases the display reference
    }
    return ctx;
}

// ---------------------------------------------------------------------------------------------
// OSMesa. libOSMesa is loaded with dlopen(RTLD_LOCAL) rather than linked: it exports its own gl*
// symbols, which would otherwise interpose on (or be interposed by) libGL/libOpenGL loaded by
// GLFW or other modules of the process. The library stays loaded for the process lifetime
// (Mesa's LLVM-based drivers do not support being unloaded and reloaded).
// ---------------------------------------------------------------------------------------------
namespace {

// Values from <GL/osmesa.h>, which is not included because it pulls in <GL/gl.h>.
constexpr int kOsMesaFormat = 0x22;
constexpr int kOsMesaDepthBits = 0x30;
constexpr int kOsMesaStencilBits = 0x31;
constexpr int kOsMesaAccumBits = 0x32;
constexpr int kOsMesaProfile = 0x33;
constexpr int kOsMesaCoreProfile = 0x34;
constexpr int kOsMesaContextMajorVersion = 0x36;
constexpr int kOsMesaContextMinorVersion = 0x37;

// libOSMesa 22 leaks a few hundred bytes per context (framebuffer records allocated by
// OSMesaMakeCurrent are never freed). Under LeakSanitizer those allocations are ignored so that
// leak checks report only leaks of our own code.
struct IgnoreDriverLeaks {
#if defined(__SANITIZE_ADDRESS__)
    IgnoreDriverLeaks() { __lsan_disable(); }
    ~IgnoreDriverLeaks() { __lsan_enable(); }
#endif
};

struct OsMesaApi {
    using Ctx = struct osmesa_context*;
    Ctx (*createContextAttribs)(const int*, Ctx) = nullptr;
    void (*destroyContext)(Ctx) = nullptr;
    unsigned char (*makeCurrent)(Ctx, void*, GLenum, GLsizei, GLsizei) = nullptr;
    Ctx (*getCurrentContext)() = nullptr;
    Functions::GenericProc (*getProcAddress)(const char*) = nullptr;
};

template <typename F>
void loadSym(void* lib, const char* name, F& out) {
    void* sym = dlsym(lib, name);
    static_assert(sizeof(sym) == sizeof(out));
    std::memcpy(&out, &sym, sizeof(out));
}

const OsMesaApi* osMesaApi(std::string& error) {
    static std::once_flag once;
    static OsMesaApi api;
    static std::string loadError;
    std::call_once(once, [] {
        void* lib = nullptr;
        for (const char* name : {"libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"}) {
            lib = dlopen(name, RTLD_NOW | RTLD_LOCAL);
            if (lib) break;
        }
        if (!lib) {
            const char* why = dlerror();
            loadError = std::string("OSMesa: cannot load libOSMesa.so.8 (") + (why ? why : "not found") + ")";
            return;
        }
        loadSym(lib, "OSMesaCreateContextAttribs", api.createContextAttribs);
        loadSym(lib, "OSMesaDestroyContext", api.destroyContext);
        loadSym(lib, "OSMesaMakeCurrent", api.makeCurrent);
        loadSym(lib, "OSMesaGetCurrentContext", api.getCurrentContext);
        loadSym(lib, "OSMesaGetProcAddress", api.getProcAddress);
        if (!api.createContextAttribs || !api.destroyContext || !api.makeCurrent || !api.getCurrentContext ||
            !api.getProcAddress)
            loadError = "OSMesa: libOSMesa lacks OSMesaCreateContextAttribs or another required entry point";
    });
    if (!loadError.empty()) {
        error = loadError;
        return nullptr;
    }
    return &api;
}

class OsMesaContext final : public Context {
public:
    OsMesaContext(const OsMesaApi& api, OsMesaApi::Ctx ctx) : m_api(api), m_ctx(ctx) {}
    ~OsMesaContext() override {
        [[maybe_unused]] IgnoreDriverLeaks ignore;
        releaseIfCurrent();
        m_api.destroyContext(m_ctx);
    }
    const char* platformName() const override { return "OSMesa"; }
    Functions::GenericProc getProc(const char* name) override { return m_api.getProcAddress(name); }

protected:
    // The default framebuffer is never rendered to (all passes use FBOs): a 1x1 buffer suffices.
    bool bindNative() override {
        [[maybe_unused]] IgnoreDriverLeaks ignore;
        return m_api.makeCurrent(m_ctx, m_dummy, GL_UNSIGNED_BYTE, 1, 1) != 0;
    }
    void unbindNative() override {
        [[maybe_unused]] IgnoreDriverLeaks ignore;
        m_api.makeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
    }
    bool isNativeCurrent() const override { return m_api.getCurrentContext() == m_ctx; }

private:
    const OsMesaApi& m_api;
    OsMesaApi::Ctx m_ctx;
    alignas(16) unsigned char m_dummy[16] = {};
};

}  // namespace

std::unique_ptr<Context> createOsMesaContext(std::string& error) {
    const OsMesaApi* api = osMesaApi(error);
    if (!api) return nullptr;
    const int attribs[] = {kOsMesaFormat,
                           GL_RGBA,
                           kOsMesaDepthBits,
                           0,
                           kOsMesaStencilBits,
                           0,
                           kOsMesaAccumBits,
                           0,
                           kOsMesaProfile,
                           kOsMesaCoreProfile,
                           kOsMesaContextMajorVersion,
                           4,
                           kOsMesaContextMinorVersion,
                           5,
                           0};
    OsMesaApi::Ctx ctx = nullptr;
    {
        [[maybe_unused]] IgnoreDriverLeaks ignore;
        ctx = api->createContextAttribs(attribs, nullptr);
    }
    if (!ctx) {
        error = "OSMesa: cannot create an OpenGL 4.5 core context";
        return nullptr;
    }
    auto context = std::make_unique<OsMesaContext>(*api, ctx);
    if (!context->makeCurrent()) {
        error = "OSMesa: OSMesaMakeCurrent failed";
        return nullptr;
    }
    return context;
}

// ---------------------------------------------------------------------------------------------
// GLFW window context (created by the caller with a 4.5 core profile).
// ---------------------------------------------------------------------------------------------
namespace {

class GlfwContext final : public Context {
public:
    explicit GlfwContext(GLFWwindow* window) : m_window(window) {}
    ~GlfwContext() override { releaseIfCurrent(); }
    const char* platformName() const override { return "GLFW window"; }
    Functions::GenericProc getProc(const char* name) override { return glfwGetProcAddress(name); }
    bool swapBuffers() override {
        glfwSwapBuffers(m_window);
        return true;
    }
    bool framebufferSize(int& width, int& height) override {
        glfwGetFramebufferSize(m_window, &width, &height);
        return true;
    }
    void setSwapInterval(int interval) override { glfwSwapInterval(interval); }

protected:
    bool bindNative() override {
        glfwMakeContextCurrent(m_window);
        return glfwGetCurrentContext() == m_window;
    }
    void unbindNative() override { glfwMakeContextCurrent(nullptr); }
    bool isNativeCurrent() const override { return glfwGetCurrentContext() == m_window; }

private:
    GLFWwindow* m_window;
};

}  // namespace

std::unique_ptr<Context> createGlfwContext(void* glfwWindow, std::string& error) {
    auto* window = static_cast<GLFWwindow*>(glfwWindow);
    if (!window) {
        error = "GLFW: a windowed OpenGL device needs DeviceDesc::window (a GLFWwindow*)";
        return nullptr;
    }
    if (glfwGetWindowAttrib(window, GLFW_CLIENT_API) != GLFW_OPENGL_API) {
        error = "GLFW: the window has no OpenGL context (create it with GLFW_CLIENT_API = GLFW_OPENGL_API)";
        return nullptr;
    }
    const int major = glfwGetWindowAttrib(window, GLFW_CONTEXT_VERSION_MAJOR);
    const int minor = glfwGetWindowAttrib(window, GLFW_CONTEXT_VERSION_MINOR);
    if (major < 4 || (major == 4 && minor < 5)) {
        error = "GLFW: the window's OpenGL context is " + std::to_string(major) + "." +
                std::to_string(minor) + "; OpenGL 4.5 core is required";
        return nullptr;
    }
    if (glfwGetWindowAttrib(window, GLFW_OPENGL_PROFILE) != GLFW_OPENGL_CORE_PROFILE) {
        error = "GLFW: the window's OpenGL context must use GLFW_OPENGL_CORE_PROFILE";
        return nullptr;
    }
    auto context = std::make_unique<GlfwContext>(window);
    if (!context->makeCurrent()) {
        error = "GLFW: cannot make the window's OpenGL context current";
        return nullptr;
    }
    return context;
}

}  // namespace rhi::gl
