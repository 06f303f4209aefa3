#include "engine/scene/demo_scene.h"

#include <utility>

#include <glm/gtc/quaternion.hpp>

#include "engine/assets/primitives.h"
#include "engine/ecs/components.h"

namespace penumbra::scene {
namespace {

// Rotation by Euler angles in degrees, X first, then Y, then Z (the scene format's eulerDegrees).
glm::quat eulerDegrees(float x, float y, float z) {
    return glm::normalize(glm::angleAxis(glm::radians(z), glm::vec3(0, 0, 1)) *
                          glm::angleAxis(glm::radians(y), glm::vec3(0, 1, 0)) *
                          glm::angleAxis(glm::radians(x), glm::vec3(1, 0, 0)));
}

ecs::Material material(glm::vec3 baseColor, float roughness, float metallic = 0.0f) {
    ecs::Material m;
    m.baseColor = glm::vec4(baseColor, 1.0f);
    m.roughness = roughness;
    m.metallic = metallic;
    return m;
}

class DemoBuilder {
public:
    DemoBuilder(assets::AssetManager& assets, Scene& scene) : m_assets(assets), m_scene(scene) {}

    ecs::Entity entity(const char* name, glm::vec3 position, glm::quat rotation = glm::quat(1, 0, 0, 0)) {
        ecs::World& world = m_scene.world;
        ecs::Entity e = world.create();
        world.add<ecs::Name>(e)->value = name;
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = position;
        t->rotation = rotation;
        return e;
    }

    // An entity drawing the primitive `desc` with the material `m` (asset key "demo:<materialName>").
    bool mesh(const char* name, const assets::PrimitiveDesc& desc, const char* materialName,
              const ecs::Material& m, glm::vec3 position, glm::quat rotation, std::string& error) {
        assets::MeshData data;
        if (!assets::makePrimitive(desc, data, error)) return false;
        const assets::AssetId meshId = m_assets.addMesh(assets::primitiveKey(desc), std::move(data), error);
        if (!meshId) return false;
        m_scene.assetRefs.push_back(meshId);
        const assets::AssetId materialId = m_assets.addMaterial(std::string("demo:") + materialName, m);
        m_scene.assetRefs.push_back(materialId);
        ecs::Entity e = entity(name, position, rotation);
        m_scene.world.add<ecs::MeshRenderer>(e, ecs::MeshRenderer{meshId, materialId});
        return true;
    }

    void light(const char* name, const ecs::Light& light, glm::vec3 position, glm::quat rotation) {
        ecs::Entity e = entity(name, position, rotation);
        *m_scene.world.add<ecs::Light>(e) = light;
    }

private:
    assets::AssetManager& m_assets;
    Scene& m_scene;
};

bool buildInto(assets::AssetManager& assets, Scene& scene, std::string& error) {
    DemoBuilder b(assets, scene);
    using assets::PrimitiveShape;
    assets::PrimitiveDesc ground{.shape = PrimitiveShape::Plane, .halfSize = {20.0f, 20.0f}};
    assets::PrimitiveDesc sphere{
        .shape = PrimitiveShape::Sphere, .radius = 0.7f, .segments = 64, .rings = 32};
    assets::PrimitiveDesc box{.shape = PrimitiveShape::Box, .halfExtents = {0.55f, 0.55f, 0.55f}};
    assets::PrimitiveDesc torus{
        .shape = PrimitiveShape::Torus, .rings = 64, .majorRadius = 0.6f, .minorRadius = 0.22f, .sides = 32};
    assets::PrimitiveDesc cylinder{
        .shape = PrimitiveShape::Cylinder, .radius = 0.3f, .segments = 48, .halfHeight = 0.4f};
    const glm::quat none(1, 0, 0, 0);
    if (!b.mesh("ground", ground, "ground", material({0.4f, 0.4f, 0.4f}, 0.85f), {0, 0, 0}, none, error) ||
        !b.mesh("sphere", sphere, "red", material({0.85f, 0.12f, 0.1f}, 0.3f), {-2.2f, 0.7f, 0.2f}, none,
                error) ||
        !b.mesh("box", box, "blue", material({0.12f, 0.3f, 0.85f}, 0.5f), {-0.3f, 0.55f, -0.6f},
                eulerDegrees(0, 35, 0), error) ||
        !b.mesh("torus", torus, "gold", material({0.95f, 0.72f, 0.3f}, 0.3f, 1.0f), {1.9f, 0.85f, 0.0f},
                eulerDegrees(65, -20, 0), error) ||
        !b.mesh("cylinder", cylinder, "green", material({0.15f, 0.7f, 0.25f}, 0.4f), {0.7f, 0.4f, 1.4f}, none,
                error))
        return false;

    ecs::Light sun;
    sun.type = ecs::LightType::Directional;
    sun.color = {1.0f, 0.95f, 0.85f};
    sun.intensity = 2.0f;
    b.light("sun", sun, {0, 0, 0}, eulerDegrees(-50, 30, 0));
    ecs::Light warm;
    warm.color = {1.0f, 0.65f, 0.35f};
    warm.intensity = 6.0f;
    warm.range = 10.0f;
    b.light("warm lamp", warm, {2.8f, 2.0f, 2.2f}, none);
    ecs::Light cool;
    cool.color = {0.45f, 0.65f, 1.0f};
    cool.intensity = 6.0f;
    cool.range = 10.0f;
    b.light("cool lamp", cool, {-2.8f, 2.4f, 1.8f}, none);

    ecs::Entity camera = b.entity(kDemoCameraName, {0.0f, 2.2f, 6.5f}, eulerDegrees(-15, 0, 0));
    ecs::Camera* c = scene.world.add<ecs::Camera>(camera);
    c->name = kDemoCameraName;
    c->fovY = glm::radians(45.0f);
    c->nearPlane = 0.1f;
    c->farPlane = 50.0f;

    scene.settings.shading = ShadingModel::CookTorrance;
    scene.settings.toneMapper = ToneMapper::Aces;
    scene.settings.ambient = {0.03f, 0.03f, 0.04f};
    scene.settings.background = {0.04f, 0.06f, 0.12f};
    scene.settings.camera = kDemoCameraName;
    scene.sourcePath = "<built-in demo scene>";
    ecs::updateTransforms(scene.world);
    return true;
}

}  // namespace

bool buildDemoScene(assets::AssetManager& assets, Scene& out, std::string& error) {
    Scene built;
    if (!buildInto(assets, built, error)) {
        for (assets::AssetId id : built.assetRefs) assets.release(id);
        return false;
    }
    unloadScene(out, assets);
    out = std::move(built);
    return true;
}

}  // namespace penumbra::scene
