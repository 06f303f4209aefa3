// Native OpenGL contexts behind the GL backend: EGL surfaceless (headless, preferred), OSMesa
// (headless fallback, libOSMesa loaded with dlopen) and a GLFW window's context (windowed).
//
// Several devices (and so several contexts, possibly of different platforms) may live in one
// process. A context remembers, per thread, which one of ours is current; makeCurrent() re-binds
// only when another context (or none) is current, releasing the previous one first so EGL (via
// libglvnd) and OSMesa (via libglapi) never both believe they own the thread's dispatch table.
#pragma once

#include <memory>
#include <string>

#include "rhi/opengl/gl_functions.h"

namespace rhi::gl {

class Context {
public:
    virtual ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    // "EGL surfaceless", "OSMesa" or "GLFW window" (DeviceInfo::platform).
    virtual const char* platformName() const = 0;
    // Resolves a GL entry point; the context must be current.
    virtual Functions::GenericProc getProc(const char* name) = 0;
    // Makes this context current on the calling thread (no-op when it already is).
    bool makeCurrent();

    // Windowed contexts only.
    virtual bool swapBuffers() { return false; }
    virtual bool framebufferSize(int& width, int& height) {
        width = height = 0;
        return false;
    }
    virtual void setSwapInterval(int /*interval*/) {}

protected:
    Context() = default;
    virtual bool bindNative() = 0;
    virtual void unbindNative() = 0;
    virtual bool isNativeCurrent() const = 0;
    // Derived destructors call this first, while their native objects still exist.
    void releaseIfCurrent();
};

// Each returns null and sets `error` when the context cannot be created.
std::unique_ptr<Context> createEglSurfacelessContext(bool debug, std::string& error);
std::unique_ptr<Context> createOsMesaContext(std::string& error);
std::unique_ptr<Context> createGlfwContext(void* glfwWindow, std::string& error);

}  // namespace rhi::gl
