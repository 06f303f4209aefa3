// Tracing meshes as SDFs ("--mesh-sdf trace", for comparisons): every visible mesh of a scene is
// baked to a signed distance field (AssetManager::bakeSdf) and drawn by the SDF path instead of
// the rasterizer.
//
//   if (!scene::applyMeshSdf(scene, assets, scene::MeshSdfMode::Trace, error)) { report(error); }
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

// Off: does nothing. Trace: every entity with a visible MeshRenderer gets an SdfRenderer (source
// MeshBake, sdf = the mesh's baked field, the same material, visibility and castShadows; bakeMesh
// = the mesh's source file, if any; bakeResolution = `resolution`) and loses its MeshRenderer.
// `resolution` is voxels along the longest axis of the padded grid, 0 = automatic (medium
// quality). Each distinct mesh asset is baked once (and not at all when the asset manager has it
// in memory or in its disk cache). The scene holds one reference to the field per entity; the
// reference it held for the mesh is released (the material's stays, the SdfRenderer uses it).
// Invisible MeshRenderers and those without a mesh are left as they are.
//
// Atomic: false with `error` (naming the entity and the mesh) when a mesh cannot be baked or an
// entity already has an SdfRenderer; the scene and the asset manager's references are then
// unchanged.
bool applyMeshSdf(Scene& scene, assets::AssetManager& assets, MeshSdfMode mode, std::string& error,
                  uint32_t resolution = 0);

}  // namespace penumbra::scene
