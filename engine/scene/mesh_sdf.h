// How rasterized meshes take part in the SDF passes (`--mesh-sdf`, the render block's "meshSdf"):
// - trace (for comparisons): every visible mesh is baked to a signed distance field
//   (AssetManager::bakeSdf) and drawn by the SDF path instead of the rasterizer;
// - occlusion (Wright's mesh distance fields): meshes stay rasterized and each gets a coarse baked
//   field that only the effects (shadows, AO) trace, so meshes cast onto and receive from SDF
//   objects and each other;
// - auto (the default): occlusion when the scene's settings turn effects on and meshes exist.
//
// Every front end (penumbra render and bench, the embedding example) resolves and applies the mode
// here, once, after its own setting overrides (auto looks at the effect settings):
//
//   if (!scene::applyMeshSdf(scene, assets, scene.settings.meshSdf, error)) { report(error); }
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "engine/assets/asset_manager.h"
#include "engine/scene/scene.h"

namespace penumbra::scene {

// MeshSdfMode is declared in scene.h (the render block's "meshSdf").
// "off" / "trace" / "occlusion" / "auto"; false (out unchanged) for anything else.
bool parseMeshSdfMode(std::string_view text, MeshSdfMode& out);
const char* toString(MeshSdfMode mode);

// Occlusion fields are coarse: they only feed soft shadows and AO, whose cones blur far more than a
// voxel, and they must bake fast (every mesh scene with a shadowed light gets them by default).
// Voxels along the longest axis of the padded grid when applyMeshSdf gets resolution 0.
inline constexpr uint32_t kOcclusionResolution = 64;

// True when the settings turn on an effect that meshes can occlude: shadows enabled and a light
// with castShadows, or an AO variant other than off.
bool meshOcclusionWanted(const Scene& scene);

// The mode `mode` stands for in this scene: Auto -> Occlusion when meshOcclusionWanted() and the
// scene has a visible MeshRenderer with a mesh, else Off; the other modes are returned as they are.
MeshSdfMode resolveMeshSdfMode(const Scene& scene, MeshSdfMode mode);

// Applies resolveMeshSdfMode(scene, mode):
//
// Off: does nothing.
//
// Trace: every entity with a visible MeshRenderer gets an SdfRenderer (source MeshBake, sdf = the
// mesh's baked field, the same material, visibility and castShadows; bakeMesh = the mesh's source
// file, if any; bakeResolution = `resolution`) and loses its MeshRenderer. `resolution` is voxels
// along the longest axis of the padded grid, 0 = automatic (medium quality). The scene's reference
// to the mesh is released (the material's stays, the SdfRenderer uses it). Atomic: false with
// `error` (naming the entity and the mesh) when a mesh cannot be baked or an entity already has an
// SdfRenderer; the scene and the asset manager's references are then unchanged.
//
// Occlusion: every visible MeshRenderer with castShadows keeps its MeshRenderer and gets an
// SdfRenderer with occluderOnly = true (source MeshBake, the mesh's baked field, the same
// material, visible, castShadows; `resolution` 0 = kOcclusionResolution). Entities that already
// have an SdfRenderer are skipped (their own SDF takes part in the effects; logged at debug level),
// and so are flat meshes (smallest bounds extent < 1 % of the largest: floors, sheets; a coarse field
// of a zero-thickness sheet would darken everything within a voxel of it),
// which also makes a second application a no-op. A mesh that cannot be baked is skipped with one
// warning naming the entity and the reason (the frame still renders; that mesh casts no SDF
// shadows): occlusion is on by default, so a degenerate mesh must not fail a scene that rasterizes.
//
// Both: each distinct mesh asset is baked once (and not at all when the asset manager has it in
// memory or in its disk cache); the scene holds one reference to the field per entity.
bool applyMeshSdf(Scene& scene, assets::AssetManager& assets, MeshSdfMode mode, std::string& error,
                  uint32_t resolution = 0);

}  // namespace penumbra::scene
