// --mesh-sdf: meshes baked to fields, traced (trace) or used only by shadows and AO (occlusion);
// the auto mode's resolution (mesh_sdf.h).
#include "engine/scene/mesh_sdf.h"

#include <algorithm>
#include <unordered_map>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <glm/common.hpp>

#include "engine/core/log.h"
#include "engine/sdf/bake.h"

namespace penumbra::scene {

namespace {
constexpr const char* kMeshSdfModeNames[] = {"off", "trace", "occlusion", "auto"};
}

bool parseMeshSdfMode(std::string_view text, MeshSdfMode& out) {
    for (uint32_t i = 0; i < std::size(kMeshSdfModeNames); ++i)
        if (text == kMeshSdfModeNames[i]) {
            out = MeshSdfMode(i);
            return true;
        }
    return false;
}

const char* toString(MeshSdfMode mode) {
    return uint32_t(mode) < std::size(kMeshSdfModeNames) ? kMeshSdfModeNames[uint32_t(mode)] : "off";
}

bool meshOcclusionWanted(const Scene& scene) {
    if (scene.settings.ao.variant != AoVariant::Off) return true;
    if (!scene.settings.shadows.enabled) return false;
    for (auto [e, light] : scene.world.view<ecs::Light>())
        if (light.castShadows) return true;
    return false;
}

MeshSdfMode resolveMeshSdfMode(const Scene& scene, MeshSdfMode mode) {
    if (mode != MeshSdfMode::Auto) return mode;
    if (!meshOcclusionWanted(scene)) return MeshSdfMode::Off;
    for (auto [e, mr] : scene.world.view<ecs::MeshRenderer>())
        if (mr.visible && mr.mesh != 0) return MeshSdfMode::Occlusion;
    return MeshSdfMode::Off;
}

namespace {

std::string entityLabel(const ecs::World& world, ecs::Entity e) {
    if (const ecs::Name* name = world.get<ecs::Name>(e); name && !name->value.empty()) {
        return fmt::format("entity '{}'", name->value);
    }
    return fmt::format("entity #{}", e.index);
}

// The mesh entities the mode converts, in ascending entity index: visible MeshRenderers with a
// mesh (occlusion: only those that cast shadows and have no SdfRenderer of their own).
std::vector<ecs::Entity> meshEntities(const ecs::World& world, MeshSdfMode mode) {
    std::vector<ecs::Entity> entities;
    for (auto [e, mr] : world.view<ecs::MeshRenderer>()) {
        if (!mr.visible || mr.mesh == 0) continue;
        if (mode == MeshSdfMode::Occlusion && !mr.castShadows) continue;
        if (mode == MeshSdfMode::Occlusion && world.has<ecs::SdfRenderer>(e)) {
            log::debug(
                "--mesh-sdf occlusion: {} already has an sdf component; its mesh gets no occlusion field",
                entityLabel(world, e));
            continue;
        }
        entities.push_back(e);
    }
    std::sort(entities.begin(), entities.end(),
              [](ecs::Entity a, ecs::Entity b) { return a.index < b.index; });
    return entities;
}

struct Baked {
    assets::AssetId field = 0;
    std::string source;  // the mesh's file, if any
    bool referenceUsed = false;
};
using BakedMeshes = std::unordered_map<assets::AssetId, Baked>;  // mesh -> its field (one reference)

// A flat mesh (its bounds' smallest extent under 1 % of the largest: a floor plane, a sheet) gets no
// occlusion field: baked at the coarse occlusion resolution, a zero-thickness sheet's field is about
// a voxel thick, which darkens everything within a voxel of it (its conservative distance is
// lowered by the interpolation bound) and pushes the shadow rays of the points on it a voxel off
// the surface, past the objects standing on it. It cannot occlude anything on its lit side; it still
// receives shadows and AO.
bool isFlat(const assets::MeshData& mesh) {
    if (mesh.positions.empty()) return false;
    glm::vec3 lo = mesh.positions.front(), hi = lo;
    for (const glm::vec3& p : mesh.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    const glm::vec3 e = hi - lo;
    return std::min({e.x, e.y, e.z}) < 0.01f * std::max({e.x, e.y, e.z});
}

// Bakes each distinct mesh of `entities` once. Trace: the first failure releases every field baked
// so far and returns false with `error`. Occlusion: a failing mesh is warned about and its entities
// are removed from `entities`.
bool bakeMeshes(const ecs::World& world, assets::AssetManager& assets, MeshSdfMode mode, uint32_t resolution,
                std::vector<ecs::Entity>& entities, BakedMeshes& baked, std::string& error) {
    sdf::BakeSettings settings;
    settings.resolution = resolution;
    const char* modeName = toString(mode);
    std::vector<ecs::Entity> kept;
    std::unordered_map<assets::AssetId, bool> failed;  // occlusion: meshes that did not bake
    for (ecs::Entity e : entities) {
        if (mode == MeshSdfMode::Trace && world.has<ecs::SdfRenderer>(e)) {
            error = fmt::format("--mesh-sdf trace: {} has both a mesh and an sdf component",
                                entityLabel(world, e));
            return false;
        }
        const assets::AssetId mesh = world.get<ecs::MeshRenderer>(e)->mesh;
        if (mode == MeshSdfMode::Occlusion && assets.mesh(mesh) && isFlat(*assets.mesh(mesh))) {
            log::debug("--mesh-sdf occlusion: {} is flat: no occlusion field", entityLabel(world, e));
            continue;
        }
        if (!baked.count(mesh) && !failed.count(mesh)) {
            std::string why;
            assets::AssetId field = 0;
            if (!assets.mesh(mesh)) {
                why = fmt::format("mesh asset {:016x} is not loaded", mesh);
            } else {
                field = assets.bakeSdf(mesh, settings, why);
            }
            if (field != 0) {
                baked.emplace(mesh, Baked{field, assets.info(mesh)->sourcePath, false});
            } else if (mode == MeshSdfMode::Trace) {
                error = fmt::format("--mesh-sdf {}: {}: {}", modeName, entityLabel(world, e), why);
                return false;
            } else {
                log::warn("--mesh-sdf {}: {}: {}; the mesh casts no SDF shadows or AO", modeName,
                          entityLabel(world, e), why);
                failed.emplace(mesh, true);
            }
        }
        if (baked.count(mesh)) kept.push_back(e);
    }
    entities = std::move(kept);
    return true;
}

// Gives entity `e` the SdfRenderer of its mesh's field (trace: instead of its MeshRenderer).
void attachField(Scene& scene, assets::AssetManager& assets, MeshSdfMode mode, uint32_t resolution,
                 ecs::Entity e, Baked& b) {
    ecs::World& world = scene.world;
    const ecs::MeshRenderer mr = *world.get<ecs::MeshRenderer>(e);
    // One field reference per entity: the first takes the one bakeSdf returned.
    if (b.referenceUsed) assets.retain(b.field);
    b.referenceUsed = true;
    scene.assetRefs.push_back(b.field);
    ecs::SdfRenderer sr;
    sr.sdf = b.field;
    sr.material = mr.material;
    sr.visible = mr.visible;
    sr.castShadows = mr.castShadows;
    sr.source = ecs::SdfSource::MeshBake;
    sr.bakeMesh = b.source;
    sr.bakeResolution = resolution;
    sr.occluderOnly = mode == MeshSdfMode::Occlusion;
    world.add<ecs::SdfRenderer>(e, std::move(sr));
    if (mode != MeshSdfMode::Trace) return;
    world.remove<ecs::MeshRenderer>(e);
    // The scene no longer uses the mesh: drop the reference it held for this entity.
    if (auto it = std::find(scene.assetRefs.begin(), scene.assetRefs.end(), mr.mesh);
        it != scene.assetRefs.end()) {
        scene.assetRefs.erase(it);
        assets.release(mr.mesh);
    }
}

}  // namespace

bool applyMeshSdf(Scene& scene, assets::AssetManager& assets, MeshSdfMode mode, std::string& error,
                  uint32_t resolution) {
    mode = resolveMeshSdfMode(scene, mode);
    if (mode == MeshSdfMode::Off) return true;
    if (mode == MeshSdfMode::Occlusion && resolution == 0) resolution = kOcclusionResolution;
    std::vector<ecs::Entity> entities = meshEntities(scene.world, mode);
    // Bake first (each distinct mesh once), change the scene only when every bake worked.
    BakedMeshes baked;
    if (!bakeMeshes(scene.world, assets, mode, resolution, entities, baked, error)) {
        for (const auto& [mesh, b] : baked) assets.release(b.field);
        return false;
    }
    for (ecs::Entity e : entities)
        attachField(scene, assets, mode, resolution, e,
                    baked.at(scene.world.get<ecs::MeshRenderer>(e)->mesh));
    log::debug("--mesh-sdf {}: {} mesh entities got {} baked fields", toString(mode), entities.size(),
               baked.size());
    return true;
}

}  // namespace penumbra::scene
