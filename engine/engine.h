// penumbra::Engine — the embedding API's engine half: one object that owns the asset manager, the
// loaded scene (its World and render settings), the plugin host with its registries, the update
// schedule and the app loop. It knows nothing about graphics; penumbra::Renderer
// (renderer/renderer.h) draws an Engine's scene.
//
//   std::string error;
//   auto engine = penumbra::Engine::create({}, error);
//   if (!engine || !engine->loadScene("scenes/default.json", error)) { ... }
//   // or build a World in code: engine->world().create(), add<Transform>(), ...
//   engine->update(1.0 / 60.0);   // real time: fixed-step systems, then transforms
//   engine->updateOffline(0.1, t, error);  // offline: exactly 0.1 s more simulated time
//
// Schedule: every fixed step runs the systems in schedule() (by default "spin" = scene::spinSystem;
// plugins add theirs through PluginContext::addSystem); after the frame's steps, world transforms
// are recomputed once. Mesh importers registered by plugins are available to scene loading.
#pragma once

#include <memory>
#include <string>

#include "engine/app/app_loop.h"
#include "engine/assets/asset_manager.h"
#include "engine/ecs/schedule.h"
#include "engine/plugin/plugin_host.h"
#include "engine/scene/scene.h"

namespace penumbra {

struct EngineDesc {
    std::string cacheDir;           // processed-asset cache; empty = no disk cache
    std::string pluginDir;          // shared-library plugins (*.so) to load; empty = none
    bool loadStaticPlugins = true;  // built-in plugins (the renderer module among them)
    scene::SceneLoadLimits sceneLimits;
};

class Engine {
public:
    // Null with `error` when a plugin directory is given but unusable. A plugin that fails to load
    // is logged and skipped (its neighbours still load).
    static std::unique_ptr<Engine> create(const EngineDesc& desc, std::string& error);
    ~Engine();
    Engine(const Engine&) = delete;
    Engine& operator=(const Engine&) = delete;

    // Replaces the current scene by the file's (.json, .gltf, .glb). On failure the current scene
    // is kept and `error` says why. Configures the loop's fixed step from the scene settings.
    bool loadScene(const std::string& path, std::string& error);
    // Releases the current scene's assets and starts an empty one (default settings).
    void unloadScene();

    // Real time: runs the fixed steps that fit in the measured `frameSeconds` (app::AppLoop::advance,
    // with its catch-up cap), then updates transforms.
    app::FrameTime update(double frameSeconds);
    // Offline: advances by exactly `frameSeconds` (app::AppLoop::advanceOffline: the frame is split
    // into equal steps no longer than the scene's fixedDt, nothing is dropped, and after k calls
    // with the same S from time 0 the simulated time is exactly k * S), then updates transforms.
    // False with `error` for an invalid frame time (nothing changes).
    bool updateOffline(double frameSeconds, app::FrameTime& out, std::string& error);

    scene::Scene& scene() { return m_scene; }
    const scene::Scene& scene() const { return m_scene; }
    ecs::World& world() { return m_scene.world; }
    const ecs::World& world() const { return m_scene.world; }
    scene::RenderSettings& settings() { return m_scene.settings; }
    assets::AssetManager& assets() { return *m_assets; }
    const assets::AssetManager& assets() const { return *m_assets; }
    plugin::PluginHost& plugins() { return *m_plugins; }
    ecs::Schedule& schedule() { return m_schedule; }
    app::AppLoop& loop() { return m_loop; }

private:
    Engine() = default;
    void bridgeImporters();

    EngineDesc m_desc;
    ecs::Schedule m_schedule;  // declared before the host: the host removes systems on unload
    std::unique_ptr<assets::AssetManager> m_assets;
    std::unique_ptr<plugin::PluginHost> m_plugins;
    scene::Scene m_scene;
    app::AppLoop m_loop;
};

}  // namespace penumbra
