#include "renderer/renderer.h"

#include <fmt/format.h>

#include "engine/core/log.h"
#include "engine/plugin/plugin_host.h"

namespace penumbra {
namespace {

// The renderer module as a built-in plugin: it provides the deferred scene renderer as a factory.
class RendererPlugin final : public plugin::IPlugin {
public:
    const char* name() const override { return kRendererPluginName; }
    const char* version() const override { return "0.1.0"; }
    bool onLoad(plugin::PluginContext& context) override {
        return context.registerFactory<SceneRendererFactoryFn>(
            kRendererFactoryKind, kDeferredRendererName,
            [](rhi::Device& device) { return std::make_unique<render::SceneRenderer>(device); });
    }
};

}  // namespace

PENUMBRA_STATIC_PLUGIN(RendererPlugin, "penumbra.renderer")

rhi::LogCallback engineLogCallback() {
    return [](rhi::LogSeverity s, std::string_view msg) {
        using log::Severity;
        log::write(s == rhi::LogSeverity::Error     ? Severity::Error
                   : s == rhi::LogSeverity::Warning ? Severity::Warning
                   : s == rhi::LogSeverity::Info    ? Severity::Info
                                                    : Severity::Debug,
                   msg);
    };
}

std::unique_ptr<Renderer> Renderer::create(Engine& engine, const RendererDesc& desc, std::string& error) {
    const auto* factory = engine.plugins().factories().find<SceneRendererFactoryFn>(kRendererFactoryKind,
                                                                                    kDeferredRendererName);
    if (!factory) {
        error = fmt::format("no '{}' renderer registered: the renderer plugin '{}' is not loaded",
                            kDeferredRendererName, kRendererPluginName);
        return nullptr;
    }
    std::unique_ptr<Renderer> r(new Renderer());
    r->m_desc = desc;
    rhi::DeviceDesc deviceDesc;
    deviceDesc.backend = desc.backend;
    deviceDesc.validation = desc.validation;
    deviceDesc.headless = desc.window == nullptr;
    deviceDesc.window = desc.window;
    deviceDesc.vsync = desc.vsync;
    deviceDesc.log = engineLogCallback();
    r->m_device = rhi::createDevice(deviceDesc);
    if (!r->m_device) {
        error = fmt::format("no usable graphics device for backend '{}'", rhi::toString(desc.backend));
        return nullptr;
    }
    r->m_renderer = (*factory)(*r->m_device);
    if (!r->m_renderer) {
        error = "the renderer factory returned no renderer";
        return nullptr;
    }
    return r;
}

Renderer::~Renderer() {
    m_renderer.reset();
    if (m_device) m_device->waitIdle();
}

bool Renderer::renderFrame(Engine& engine, std::string& error, const std::string& camera) {
    const scene::RenderSettings& settings = engine.settings();
    const std::string& cameraName = camera.empty() ? settings.camera : camera;
    ecs::Entity cam = scene::findCamera(engine.world(), cameraName);
    if (cam == ecs::kNullEntity) {
        error = cameraName.empty() ? std::string("the scene has no camera")
                                   : fmt::format("the scene has no camera named '{}'", cameraName);
        return false;
    }
    render::FrameDesc frame;
    frame.camera = cam;
    frame.settings = settings;
    frame.width = m_desc.width ? m_desc.width : settings.width;
    frame.height = m_desc.height ? m_desc.height : settings.height;
    frame.debugView = m_desc.debugView;
    frame.aux = m_desc.aux;
    if (m_desc.window) {
        rhi::TextureHandle backbuffer = m_device->acquireBackbuffer();
        const rhi::TextureDesc* bd = m_device->describe(backbuffer);
        if (!bd) {
            error = "could not acquire the window's backbuffer";
            return false;
        }
        frame.width = bd->width;
        frame.height = bd->height;
        frame.target = backbuffer;
        frame.targetAccess = rhi::Access::None;
        frame.targetFinalAccess = rhi::Access::Present;
        if (!m_renderer->render(engine.world(), engine.assets(), frame, error)) return false;
        if (!m_device->present()) {
            error = "present failed";
            return false;
        }
        return true;
    }
    return m_renderer->render(engine.world(), engine.assets(), frame, error);
}

bool Renderer::readPixels(ImageRGBA8& out, std::string& error) { return m_renderer->readPixels(out, error); }
const render::FrameStats& Renderer::stats() const { return m_renderer->lastFrameStats(); }
std::vector<fg::FrameTimings> Renderer::takeTimings(bool wait) { return m_renderer->takeTimings(wait); }
std::string Renderer::frameGraphviz() const { return m_renderer->lastFrameGraphviz(); }
uint64_t Renderer::validationErrors() const { return rhi::validationErrorCount(*m_device); }

void Renderer::resize(uint32_t width, uint32_t height) {
    m_desc.width = width;
    m_desc.height = height;
    if (m_desc.window) m_device->resizeBackbuffer(width, height);
}

}  // namespace penumbra
