// penumbra::Renderer — the embedding API's renderer half: a graphics device plus the scene
// renderer module, drawing a penumbra::Engine's scene offscreen or into a GLFW window.
//
//   auto renderer = penumbra::Renderer::create(*engine, {.backend = rhi::Backend::Vulkan}, error);
//   engine->update(1.0 / 60.0);
//   renderer->renderFrame(*engine, error);        // offscreen at the scene's (or desc's) size
//   penumbra::ImageRGBA8 image;
//   renderer->readPixels(image, error);           // 8-bit sRGB RGBA, row 0 = top
//   for (auto& pass : renderer->stats().passes) ...   // per-pass GPU / CPU milliseconds
//
// The renderer module is a plugin: it registers itself (static plugin "penumbra.renderer") with a
// factory of kind "renderer" named "deferred"; create() instantiates the renderer through the
// engine's plugin registry, so an engine built without it, or with the plugin unloaded, gets a
// clear error instead of a renderer.
#pragma once

#include <memory>
#include <string>

#include "engine/engine.h"
#include "engine/image/image.h"
#include "renderer/scene_renderer.h"
#include "rhi/device.h"

namespace penumbra {

inline constexpr const char* kRendererPluginName = "penumbra.renderer";
inline constexpr const char* kRendererFactoryKind = "renderer";
inline constexpr const char* kDeferredRendererName = "deferred";
// The factory signature registered under (kRendererFactoryKind, kDeferredRendererName).
using SceneRendererFactoryFn = std::unique_ptr<render::SceneRenderer>(rhi::Device& device);

// Routes a device's messages into the engine log (engine/core/log.h) at the matching severity.
rhi::LogCallback engineLogCallback();

struct RendererDesc {
    rhi::Backend backend = rhi::Backend::Auto;
    bool validation = false;  // RHI validation + Vulkan layers / GL debug output
    void* window = nullptr;   // GLFWwindow*: present there instead of rendering offscreen
    bool vsync = true;
    // Output size; 0 = the scene's render settings (offscreen) or the window's size.
    uint32_t width = 0;
    uint32_t height = 0;
    // Show a G-buffer channel instead of the lit image (`penumbra render --debug-view`).
    render::DebugView debugView = render::DebugView::None;
    bool aux = false;  // also write gbuffer.aux (entity index, trace steps): --aov ids / steps
};

class Renderer {
public:
    // Creates the device and the renderer module (through the engine's plugin registry). Null with
    // `error` when no device of the backend can be created or the renderer plugin is not loaded.
    static std::unique_ptr<Renderer> create(Engine& engine, const RendererDesc& desc, std::string& error);
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    // Renders the engine's scene through the camera called `camera` (empty: the scene settings'
    // camera, else the first camera). Windowed: also presents.
    bool renderFrame(Engine& engine, std::string& error, const std::string& camera = {});

    // The last offscreen frame as 8-bit sRGB RGBA (row 0 = top).
    bool readPixels(ImageRGBA8& out, std::string& error);
    // The last frame's statistics (waits for its GPU timings if they have not arrived yet).
    const render::FrameStats& stats() const;
    // Pass timings of every frame that arrived since the last call (no waiting; `wait`: all).
    std::vector<fg::FrameTimings> takeTimings(bool wait = false);
    std::string frameGraphviz() const;

    // Output size for the next frames (windowed: also resizes the swapchain).
    void resize(uint32_t width, uint32_t height);

    rhi::Device& device() { return *m_device; }
    render::SceneRenderer& sceneRenderer() { return *m_renderer; }
    // Validation errors reported by the device so far (0 without validation).
    uint64_t validationErrors() const;

private:
    Renderer() = default;

    RendererDesc m_desc;
    std::unique_ptr<rhi::Device> m_device;
    std::unique_ptr<render::SceneRenderer> m_renderer;
};

}  // namespace penumbra
