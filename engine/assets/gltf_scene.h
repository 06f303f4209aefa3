// glTF 2.0 (.gltf / .glb) as a scene: nodes become entities with Transform (hierarchy kept through
// Transform::parent) and Name; each triangle primitive becomes a MeshRenderer (the first on the
// node's entity, further ones on child entities named "<node>#prim<i>"); PBR metallic-roughness
// materials (factors, emissive, textures) become material assets; perspective cameras become
// Camera components; KHR_lights_punctual directional and point lights become Light components
// (spot lights are imported as point lights with a warning). Uses the same validation as
// loadGltfMesh() (GLB container, JSON depth, URIs confined to the file's folder, overflow-safe
// accessor and bufferView ranges, node graph without cycles or shared children).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/world.h"

namespace penumbra::assets {

struct GltfSceneStats {
    size_t nodes = 0;
    size_t meshPrimitives = 0;
    size_t materials = 0;
    size_t textures = 0;
    size_t cameras = 0;
    size_t lights = 0;
};

// Light::range given to KHR_lights_punctual lights without a range (glTF: infinite). Large enough
// to never fade inside a scene, small enough that its square is still a finite float.
inline constexpr float kGltfInfiniteLightRange = 1.0e18f;

// Camera::farPlane = znear * this for perspective cameras without zfar (glTF: infinite), the
// far/near ratio of the Camera component's defaults (0.1 .. 1000).
inline constexpr float kGltfDefaultFarOverNear = 10000.0f;

struct GltfSceneLimits {
    MeshLoadLimits mesh;
    TextureLoadLimits texture;
    size_t maxNodes = 1u << 20;
    size_t maxMaterials = 1u << 16;
};

// Instantiates the default scene (else scene 0, else every root node) into `world`, under
// `parent` when given (its Transform becomes the parent of the glTF roots). Every asset reference
// the new components hold is appended to `acquired` (one reference each, owned by the caller), as
// is one reference per texture the imported materials refer to.
// Atomic: on failure returns false with one message naming the file, the element (e.g.
// "nodes[4].children[1]") and the reason, and leaves `world`, `assets` and `acquired` as they were.
bool loadGltfScene(const std::string& path, ecs::World& world, AssetManager& assets,
                   std::vector<AssetId>& acquired, std::string& error, GltfSceneStats* stats = nullptr,
                   ecs::Entity parent = ecs::kNullEntity, const GltfSceneLimits& limits = {});

}  // namespace penumbra::assets
