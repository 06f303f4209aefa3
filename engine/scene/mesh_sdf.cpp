// --mesh-sdf: meshes baked to fields and traced (mesh_sdf.h).
#include "engine/scene/mesh_sdf.h"

#include <algorithm>
#include <unordered_map>
#include <utility>
#include <vector>

#include <fmt/format.h>

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

namespace {

std::string entityLabel(const ecs::World& world, ecs::Entity e) {
    if (const ecs::Name* name = world.get<ecs::Name>(e); name && !name->value.empty()) {
        return fmt::format("entity '{}'", name->value);
    }
    return fmt::format("entity #{}", e.index);
}

}  // namespace

bool applyMeshSdf(Scene& scene, assets::AssetManager& assets, MeshSdfMode mode, std::string& error,
                  uint32_t resolution) {
    if (mode == MeshSdfMode::Off) return true;
    ecs::World& world = scene.world;

    std::vector<ecs::Entity> entities;
    for (auto [e, mr] : std::as_const(world).view<ecs::MeshRenderer>()) {
        if (mr.visible && mr.mesh != 0) entities.push_back(e);
    }
    std::sort(entities.begin(), entities.end(),
              [](ecs::Entity a, ecs::Entity b) { return a.index < b.index; });

    // Bake first (each distinct mesh once), change the scene only when every bake worked.
    sdf::BakeSettings settings;
    settings.resolution = resolution;
    struct Baked {
        assets::AssetId field = 0;
        std::string source;  // the mesh's file, if any
        bool referenceUsed = false;
    };
    std::unordered_map<assets::AssetId, Baked> baked;  // mesh -> its field (one reference)
    auto releaseAll = [&] {
        for (const auto& [mesh, b] : baked) assets.release(b.field);
    };
    for (ecs::Entity e : entities) {
        if (world.has<ecs::SdfRenderer>(e)) {
            releaseAll();
            error = fmt::format("--mesh-sdf trace: {} has both a mesh and an sdf component",
                                entityLabel(world, e));
            return false;
        }
        const assets::AssetId mesh = world.get<ecs::MeshRenderer>(e)->mesh;
        if (baked.count(mesh)) continue;
        std::string why;
        assets::AssetId field = 0;
        if (!assets.mesh(mesh)) {
            why = fmt::format("mesh asset {:016x} is not loaded", mesh);
        } else {
            field = assets.bakeSdf(mesh, settings, why);
        }
        if (field == 0) {
            releaseAll();
            error = fmt::format("--mesh-sdf trace: {}: {}", entityLabel(world, e), why);
            return false;
        }
        baked.emplace(mesh, Baked{field, assets.info(mesh)->sourcePath, false});
    }

    for (ecs::Entity e : entities) {
        const ecs::MeshRenderer mr = *world.get<ecs::MeshRenderer>(e);
        Baked& b = baked.at(mr.mesh);
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
        world.remove<ecs::MeshRenderer>(e);
        world.add<ecs::SdfRenderer>(e, std::move(sr));
        // The scene no longer uses the mesh: drop the reference it held for this entity.
        if (auto it = std::find(scene.assetRefs.begin(), scene.assetRefs.end(), mr.mesh);
            it != scene.assetRefs.end()) {
            scene.assetRefs.erase(it);
            assets.release(mr.mesh);
        }
    }
    log::debug("--mesh-sdf trace: {} mesh entities traced as {} baked fields", entities.size(), baked.size());
    return true;
}

}  // namespace penumbra::scene
