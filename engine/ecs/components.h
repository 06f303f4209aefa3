// The engine's components. Conventions: right-handed, +Y up, cameras and lights look along their
// local -Z (as in glTF); lengths in scene units; colours linear RGB; angles in radians.
// Asset ids refer to the asset manager; 0 means "none".
#pragma once

#include <cstdint>
#include <string>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "engine/ecs/entity.h"

namespace penumbra::ecs {

class World;

using AssetId = uint64_t;

// Placement relative to the parent entity (or the world when parent is null, stale or has no
// Transform). worldMatrix is computed by updateTransforms().
struct Transform {
    glm::vec3 position{0.0f};
    glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};  // w, x, y, z
    glm::vec3 scale{1.0f};
    Entity parent = kNullEntity;
    glm::mat4 worldMatrix{1.0f};  // output of updateTransforms(): parent world * local

    // translate(position) * rotate(rotation) * scale(scale)
    glm::mat4 localMatrix() const;
    glm::vec3 worldPosition() const { return glm::vec3(worldMatrix[3]); }
    // The local -Z axis in world space (view / light direction), normalised.
    glm::vec3 worldForward() const;
};

// An optional human-readable name (scene files, glTF node names, --camera NAME).
struct Name {
    std::string value;
};

// A perspective camera at its Transform, looking along local -Z with +Y up.
struct Camera {
    float fovY = 1.0471976f;  // vertical field of view (60 degrees)
    float nearPlane = 0.1f;
    float farPlane = 1000.0f;
    std::string name;
};

// A triangle mesh drawn by the rasterized path.
struct MeshRenderer {
    AssetId mesh = 0;
    AssetId material = 0;
    bool visible = true;
    bool castShadows = true;
};

// Where an SDF object's field comes from.
enum class SdfSource : uint8_t {
    None,      // nothing to draw
    Shapes,    // `sdf` is a shape-program asset (analytic shapes, CSG, repetition; AssetKind::ShapeProgram)
    Field,     // `sdf` is a .psdf field asset (AssetKind::SdfField)
    MeshBake,  // `bakeMesh` is baked to a field when the scene loads (AssetManager::bakeSdf, cached), at
               // `bakeResolution`
};

// An object drawn from a signed distance field, placed by the entity's Transform (translation,
// rotation and uniform scale keep distances exact; the renderer makes non-uniform scale
// conservative). Many entities may share one `sdf` asset (instancing).
struct SdfRenderer {
    AssetId sdf = 0;  // the ShapeProgram or SdfField asset (MeshBake: the baked field); 0 = nothing to draw
    AssetId material = 0;
    bool visible = true;
    bool castShadows = true;
    SdfSource source = SdfSource::None;
    std::string bakeMesh{};       // MeshBake: the mesh file (path resolved by the scene loader)
    uint32_t bakeResolution = 0;  // MeshBake: voxels along the longest axis; 0 = automatic (FORMATS.md)
    uint32_t maxSteps = 0;        // sphere-tracing step limit for this object; 0 = the renderer's setting
    bool occluderOnly = false;    // the baked field of a rasterized mesh (--mesh-sdf occlusion): not
                                  // traced, used only by shadows and AO (engine/scene/mesh_sdf.h)
};

const char* sdfSourceName(SdfSource s);  // "none", "shapes", "field", "mesh"

enum class LightType : uint8_t { Directional, Point, Sphere };

// Direction (directional lights) is the Transform's worldForward(); position is its worldPosition().
struct Light {
    LightType type = LightType::Point;
    glm::vec3 color{1.0f};
    float intensity = 1.0f;
    float range = 10.0f;         // point/sphere: distance at which the light fades to zero
    float radius = 0.0f;         // sphere: emitter radius, sets the soft-shadow penumbra (0 = hard)
    float angularRadius = 0.0f;  // directional: angular radius of the source (soft shadows; 0 = hard)
    bool castShadows = true;
};

// PBR metallic-roughness material (glTF 2.0 model).
struct Material {
    glm::vec4 baseColor{1.0f};  // linear RGB + alpha
    float metallic = 0.0f;
    float roughness = 0.5f;
    glm::vec3 emissive{0.0f};
    AssetId baseColorTexture = 0;
    AssetId metallicRoughnessTexture = 0;  // G = roughness, B = metallic (glTF)
    AssetId normalTexture = 0;
    AssetId occlusionTexture = 0;
    AssetId emissiveTexture = 0;
    // SDF objects (renderer/features/effects.h): textures are applied triplanar in object space,
    // `triplanarScale` repeats per object unit.
    float triplanarScale = 1.0f;
    // Subsurface translucency: > 0 makes the thickness pass trace through the object here; the
    // lighting adds strength * subsurfaceColor * exp(-thickness / subsurfaceRadius) * light.
    float subsurface = 0.0f;
    glm::vec3 subsurfaceColor{1.0f};
    float subsurfaceRadius = 0.1f;  // scene units
    bool reflections = false;       // one traced, shaded reflection bounce (below the roughness cut-off)
};

// ---- hierarchy ----------------------------------------------------------------------------------

struct TransformUpdateStats {
    size_t updated = 0;       // transforms whose worldMatrix was written
    size_t cyclesBroken = 0;  // parent cycles found (each reported and cut at one link)
};

// Computes every Transform's worldMatrix, parents before children, for hierarchies of any depth
// (no recursion). A parent cycle is reported through the log and broken by clearing the parent of
// the entity whose link closes it; that entity becomes a root. Call outside view iteration.
TransformUpdateStats updateTransforms(World& world);

// The same, with the system signature, for a Schedule.
void transformSystem(World& world, double dt);

// Sets child's parent (null = root) after checking that both have a Transform and that the link
// would not create a cycle. False (logged) otherwise; the hierarchy is then unchanged.
bool setParent(World& world, Entity child, Entity parent);

}  // namespace penumbra::ecs
