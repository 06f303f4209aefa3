#include "engine/engine.h"

#include <filesystem>

#include <fmt/format.h>

#include "engine/core/log.h"

namespace penumbra {

std::unique_ptr<Engine> Engine::create(const EngineDesc& desc, std::string& error) {
    std::unique_ptr<Engine> engine(new Engine());
    engine->m_desc = desc;
    assets::AssetManagerDesc assetDesc;
    assetDesc.cacheDir = desc.cacheDir;
    assetDesc.meshLimits = desc.sceneLimits.gltf.mesh;
    assetDesc.textureLimits = desc.sceneLimits.gltf.texture;
    engine->m_assets = std::make_unique<assets::AssetManager>(assetDesc);
    engine->m_plugins = std::make_unique<plugin::PluginHost>(&engine->m_schedule);
    engine->m_schedule.add("spin", scene::spinSystem);
    if (desc.loadStaticPlugins) engine->m_plugins->loadStaticPlugins();
    if (!desc.pluginDir.empty()) {
        std::error_code ec;
        if (!std::filesystem::is_directory(desc.pluginDir, ec)) {
            error = fmt::format("{}: plugin directory does not exist or is not a directory", desc.pluginDir);
            return nullptr;
        }
        engine->m_plugins->loadDirectory(desc.pluginDir);
    }
    engine->bridgeImporters();
    std::string loopError;
    engine->m_loop.configure({engine->m_scene.settings.fixedDt, 16}, loopError);
    return engine;
}

Engine::~Engine() {
    scene::unloadScene(m_scene, *m_assets);
    // Plugins go before the schedule and the asset manager they registered into.
    m_plugins.reset();
}

void Engine::bridgeImporters() {
    plugin::PluginHost* host = m_plugins.get();
    for (const std::string& ext : host->meshImporterExtensions()) {
        m_assets->setMeshImporter(ext, [host](const std::string& path, assets::MeshData& out,
                                              std::string& err) { return host->importMesh(path, out, err); });
    }
}

bool Engine::loadScene(const std::string& path, std::string& error) {
    scene::Scene loaded;
    if (!scene::loadScene(path, *m_assets, loaded, error, m_desc.sceneLimits)) return false;
    std::string loopError;
    if (!m_loop.configure({loaded.settings.fixedDt, m_loop.desc().maxStepsPerFrame}, loopError)) {
        error = fmt::format("{}: {}", path, loopError);
        scene::unloadScene(loaded, *m_assets);
        return false;
    }
    scene::unloadScene(m_scene, *m_assets);
    m_scene = std::move(loaded);
    m_loop.reset();
    ecs::updateTransforms(m_scene.world);
    return true;
}

void Engine::unloadScene() {
    scene::unloadScene(m_scene, *m_assets);
    m_scene = scene::Scene{};
    m_loop.reset();
}

app::FrameTime Engine::update(double frameSeconds) {
    app::FrameTime t = m_loop.advance(frameSeconds, [this](double dt) { m_schedule.run(m_scene.world, dt); });
    ecs::updateTransforms(m_scene.world);
    return t;
}

bool Engine::updateOffline(double frameSeconds, app::FrameTime& out, std::string& error) {
    if (!m_loop.advanceOffline(
            frameSeconds, [this](double dt) { m_schedule.run(m_scene.world, dt); }, out, error))
        return false;
    ecs::updateTransforms(m_scene.world);
    return true;
}

}  // namespace penumbra
