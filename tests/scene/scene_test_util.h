// Helpers shared by the scene tests.
#pragma once

#include <string>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>

#include "assets/assets_test_util.h"
#include "engine/assets/asset_manager.h"
#include "engine/scene/scene.h"

namespace penumbra::test {

// Parses `text` as a scene named "test.json" with relative paths against `baseDir`.
inline bool parseScene(const std::string& text, assets::AssetManager& assets, scene::Scene& out,
                       std::string& error, const std::string& baseDir = PENUMBRA_SOURCE_DIR,
                       const scene::SceneLoadLimits& limits = {}) {
    return scene::parseJsonScene(text, "test.json", baseDir, assets, out, error, limits);
}

inline ecs::Entity entityNamed(const ecs::World& world, const std::string& name) {
    ecs::Entity found = ecs::kNullEntity;
    for (auto [e, n] : world.view<ecs::Name>()) {
        if (n.value == name) found = e;
    }
    return found;
}

// The camera's view-projection (Vulkan clip space, depth 0..1) for an image of the given aspect.
inline glm::mat4 viewProjection(const ecs::World& world, ecs::Entity camera, float aspect) {
    const ecs::Transform* t = world.get<ecs::Transform>(camera);
    const ecs::Camera* c = world.get<ecs::Camera>(camera);
    return glm::perspectiveRH_ZO(c->fovY, aspect, c->nearPlane, c->farPlane) * glm::inverse(t->worldMatrix);
}

// True when the world-space point lies inside the camera's view frustum (between near and far).
inline bool inView(const glm::mat4& viewProj, glm::vec3 p) {
    const glm::vec4 clip = viewProj * glm::vec4(p, 1.0f);
    if (!(clip.w > 0.0f)) return false;
    const glm::vec3 ndc = glm::vec3(clip) / clip.w;
    return ndc.x >= -1.0f && ndc.x <= 1.0f && ndc.y >= -1.0f && ndc.y <= 1.0f && ndc.z >= 0.0f &&
           ndc.z <= 1.0f;
}

// World-space bounds of an entity's mesh (every vertex through its world matrix).
inline void worldBounds(const ecs::World& world, const assets::AssetManager& assets, ecs::Entity e,
                        glm::vec3& lo, glm::vec3& hi) {
    lo = glm::vec3(1e30f);
    hi = glm::vec3(-1e30f);
    const ecs::Transform* t = world.get<ecs::Transform>(e);
    const ecs::MeshRenderer* mr = world.get<ecs::MeshRenderer>(e);
    if (!t || !mr) return;
    const assets::MeshData* mesh = assets.mesh(mr->mesh);
    if (!mesh) return;
    for (const glm::vec3& p : mesh->positions) {
        const glm::vec3 w(t->worldMatrix * glm::vec4(p, 1.0f));
        lo = glm::min(lo, w);
        hi = glm::max(hi, w);
    }
}

// World bounds of an SdfRenderer's field (its source mesh bounds, the 8 corners transformed).
inline void sdfWorldBounds(const ecs::World& world, const assets::AssetManager& assets, ecs::Entity e,
                           glm::vec3& lo, glm::vec3& hi) {
    lo = glm::vec3(1e30f);
    hi = glm::vec3(-1e30f);
    const ecs::Transform* t = world.get<ecs::Transform>(e);
    const ecs::SdfRenderer* sr = world.get<ecs::SdfRenderer>(e);
    if (!t || !sr) return;
    const sdf::PsdfAsset* field = assets.sdfField(sr->sdf);
    if (!field) return;
    for (int c = 0; c < 8; ++c) {
        const glm::dvec3& a = field->header.boundsMin;
        const glm::dvec3& b = field->header.boundsMax;
        const glm::vec3 p((c & 1) ? b.x : a.x, (c & 2) ? b.y : a.y, (c & 4) ? b.z : a.z);
        const glm::vec3 w(t->worldMatrix * glm::vec4(p, 1.0f));
        lo = glm::min(lo, w);
        hi = glm::max(hi, w);
    }
}

}  // namespace penumbra::test
