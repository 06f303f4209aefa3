// Scene names, the spin system, camera lookup, loading by extension (JSON scenes are read in
// scene_json.cpp) and glTF files as scenes with a default camera and light when they have none.
#include "engine/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/mesh_internal.h"
#include "engine/core/log.h"

namespace penumbra::scene {

const char* shadingModelName(ShadingModel m) {
    switch (m) {
        case ShadingModel::CookTorrance:
            return "cook-torrance";
        case ShadingModel::BlinnPhong:
            return "blinn-phong";
    }
    return "unknown";
}

const char* toneMapperName(ToneMapper t) {
    switch (t) {
        case ToneMapper::Clamp:
            return "clamp";
        case ToneMapper::Reinhard:
            return "reinhard";
        case ToneMapper::Aces:
            return "aces";
    }
    return "unknown";
}

bool parseShadingModel(std::string_view s, ShadingModel& out) {
    for (ShadingModel m : {ShadingModel::CookTorrance, ShadingModel::BlinnPhong}) {
        if (s == shadingModelName(m)) {
            out = m;
            return true;
        }
    }
    return false;
}

bool parseToneMapper(std::string_view s, ToneMapper& out) {
    for (ToneMapper t : {ToneMapper::Clamp, ToneMapper::Reinhard, ToneMapper::Aces}) {
        if (s == toneMapperName(t)) {
            out = t;
            return true;
        }
    }
    return false;
}

const char* toString(TraceQuality q) {
    switch (q) {
        case TraceQuality::Low:
            return "low";
        case TraceQuality::Medium:
            return "medium";
        case TraceQuality::High:
            return "high";
        case TraceQuality::Reference:
            return "reference";
    }
    return "medium";
}

bool parseTraceQuality(std::string_view text, TraceQuality& out) {
    for (TraceQuality q :
         {TraceQuality::Low, TraceQuality::Medium, TraceQuality::High, TraceQuality::Reference})
        if (text == toString(q)) {
            out = q;
            return true;
        }
    return false;
}

const char* toString(TraceMode mode) {
    switch (mode) {
        case TraceMode::Fullscreen:
            return "fullscreen";
        case TraceMode::Box:
            return "box";
        case TraceMode::Auto:
            return "auto";
    }
    return "fullscreen";
}

bool parseTraceMode(std::string_view text, TraceMode& out) {
    for (TraceMode m : {TraceMode::Fullscreen, TraceMode::Box, TraceMode::Auto})
        if (text == toString(m)) {
            out = m;
            return true;
        }
    return false;
}

TraceSettings tracePreset(TraceQuality quality) {
    TraceSettings s;  // medium
    switch (quality) {
        case TraceQuality::Low:
            s = {64, 0, 1.0f, 1.0f, 1.5f, 0.5f};
            break;
        case TraceQuality::Medium:
            break;
        case TraceQuality::High:
            s = {256, 24, 0.25f, 0.25f, 1.2f, 1.0f};
            break;
        case TraceQuality::Reference:
            s = {2048, 32, 0.01f, 0.05f, 1.0f, 1.0f};
            break;
    }
    return s;
}

TraceSettings RenderSettings::resolvedTrace() const {
    TraceSettings s = tracePreset(quality);
    if (trace.maxSteps) s.maxSteps = *trace.maxSteps;
    if (trace.refineSteps) s.refineSteps = *trace.refineSteps;
    if (trace.hitEpsilon) s.hitEpsilon = *trace.hitEpsilon;
    if (trace.normalEpsilon) s.normalEpsilon = *trace.normalEpsilon;
    if (trace.overRelaxation) s.overRelaxation = *trace.overRelaxation;
    if (trace.fieldSafety) s.fieldSafety = *trace.fieldSafety;
    return s;
}

void spinSystem(ecs::World& world, double dt) {
    world.view<ecs::Transform, const Spin>().each([dt](ecs::Transform& t, const Spin& s) {
        const float angle = float(double(s.radiansPerSecond) * dt);
        t.rotation = glm::normalize(glm::angleAxis(angle, s.axis) * t.rotation);
    });
}

ecs::Entity findCamera(const ecs::World& world, std::string_view name) {
    ecs::Entity best = ecs::kNullEntity;
    for (auto [e, cam] : world.view<ecs::Camera>()) {
        if (!name.empty()) {
            const ecs::Name* n = world.get<ecs::Name>(e);
            if (cam.name != name && !(n && n->value == name)) continue;
        }
        if (best.isNull() || e.index < best.index) best = e;
    }
    return best;
}

void unloadScene(Scene& scene, assets::AssetManager& assets) {
    for (assets::AssetId id : scene.assetRefs) {
        if (!assets.release(id)) {
            log::warn("scene {}: asset {:016x} was already released", scene.sourcePath, id);
        }
    }
    scene.assetRefs.clear();
    scene.world.clear();  // refused (and logged) only when called during a view iteration
    scene.settings = RenderSettings{};
    scene.sourcePath.clear();
}

namespace {

// A glTF scene without a camera or light gets a camera framing the world-space bounds of every
// mesh vertex and a directional light from above (docs/FORMATS.md, "glTF files as scenes").
void addGltfDefaults(Scene& scene, const assets::AssetManager& assets) {
    ecs::World& world = scene.world;
    ecs::updateTransforms(world);
    const bool needCamera = world.count<ecs::Camera>() == 0;
    const bool needLight = world.count<ecs::Light>() == 0;
    if (needCamera) {
        glm::vec3 lo(std::numeric_limits<float>::max());
        glm::vec3 hi(-std::numeric_limits<float>::max());
        for (auto [e, t, mr] : std::as_const(world).view<ecs::Transform, ecs::MeshRenderer>()) {
            const assets::MeshData* mesh = assets.mesh(mr.mesh);
            if (!mesh) continue;
            for (const glm::vec3& p : mesh->positions) {
                const glm::vec3 w(t.worldMatrix * glm::vec4(p, 1.0f));
                lo = glm::min(lo, w);
                hi = glm::max(hi, w);
            }
        }
        glm::vec3 centre(0.0f);
        float radius = 1.0f;
        if (lo.x <= hi.x) {
            centre = 0.5f * (lo + hi);
            radius = 0.5f * glm::length(hi - lo);
            if (!(radius > 0.0f) || !std::isfinite(radius)) radius = 1.0f;
        }
        ecs::Camera cam;
        cam.name = "default camera";
        // The bounding sphere fits the vertical field of view with 10% margin.
        const float distance = 1.1f * radius / std::sin(0.5f * cam.fovY);
        cam.nearPlane = 0.5f * (distance - radius);
        cam.farPlane = 2.0f * (distance + radius);
        const glm::vec3 direction = glm::normalize(glm::vec3(0.0f, 0.35f, 1.0f));
        ecs::Transform t;
        t.position = centre + direction * distance;
        t.rotation = glm::quatLookAtRH(-direction, glm::vec3(0.0f, 1.0f, 0.0f));
        const ecs::Entity e = world.create();
        world.add<ecs::Transform>(e, t);
        world.add<ecs::Name>(e, std::string("default camera"));
        world.add<ecs::Camera>(e, cam);
    }
    if (needLight) {
        ecs::Light light;
        light.type = ecs::LightType::Directional;
        light.intensity = 3.0f;
        ecs::Transform t;
        t.rotation =
            glm::quatLookAtRH(glm::normalize(glm::vec3(-0.3f, -1.0f, -0.5f)), glm::vec3(0.0f, 1.0f, 0.0f));
        const ecs::Entity e = world.create();
        world.add<ecs::Transform>(e, t);
        world.add<ecs::Name>(e, std::string("default light"));
        world.add<ecs::Light>(e, light);
    }
    ecs::updateTransforms(world);
}

bool loadGltfAsScene(const std::string& path, assets::AssetManager& assets, Scene& out, std::string& error,
                     const SceneLoadLimits& limits) {
    Scene local;
    local.sourcePath = path;
    if (!assets::loadGltfScene(path, local.world, assets, local.assetRefs, error, nullptr, ecs::kNullEntity,
                               limits.gltf)) {
        for (assets::AssetId id : local.assetRefs) assets.release(id);  // loadGltfScene leaves none
        return false;
    }
    addGltfDefaults(local, assets);
    out = std::move(local);
    return true;
}

}  // namespace

bool loadScene(const std::string& path, assets::AssetManager& assets, Scene& out, std::string& error,
               const SceneLoadLimits& limits) {
    const std::string ext = assets::detail::lowerExtension(path);
    if (ext == "json") return loadJsonScene(path, assets, out, error, limits);
    if (ext == "gltf" || ext == "glb") return loadGltfAsScene(path, assets, out, error, limits);
    error = fmt::format("{}: unknown scene file type '{}' (expected .json, .gltf or .glb)", path,
                        ext.empty() ? std::string("no extension") : std::string(".").append(ext));
    return false;
}

}  // namespace penumbra::scene
