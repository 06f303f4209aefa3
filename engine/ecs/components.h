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

// An object drawn from a signed-distance-field asset.
struct SdfRenderer {
    AssetId sdf = 0;
    AssetId material = 0;
    bool visible = true;
    bool castShadows = true;
};

enum class SdfShape : uint8_t { Sphere, Box, Plane, Capsule, Torus };
enum class CsgOp : uint8_t { Union, Subtract, Intersect };

// An analytic SDF shape in the entity's local space. `op` says how it combines with the shapes
// before it in the same object: result = op(previous, this), blended over `smoothness` units
// (0 = hard edge).
struct SdfPrimitive {
    SdfShape shape = SdfShape::Sphere;
    // Sphere:  x = radius
    // Box:     xyz = half extents, w = edge rounding radius (inside the half extents)
    // Plane:   xyz = unit normal, w = offset along it (surface: dot(p, n) = w, outside on the n side)
    // Capsule: x = radius, y = half length of the core segment along local Y
    // Torus:   x = major radius (ring in the local XZ plane), y = minor (tube) radius
    glm::vec4 params{0.5f, 0.0f, 0.0f, 0.0f};
    CsgOp op = CsgOp::Union;
    float smoothness = 0.0f;

    static SdfPrimitive sphere(float radius);
    static SdfPrimitive box(glm::vec3 halfExtents, float rounding = 0.0f);
    static SdfPrimitive plane(glm::vec3 normal, float offset);
    static SdfPrimitive capsule(float radius, float halfLength);
    static SdfPrimitive torus(float majorRadius, float minorRadius);

    // Signed distance from a local-space point (negative inside). Exact for every shape.
    float distance(glm::vec3 p) const;
};

// Combines the accumulated distance `a` with a shape's distance `b` (smooth when smoothness > 0;
// the smooth variants never exceed the hard union and never fall below the hard intersection).
float csgCombine(CsgOp op, float a, float b, float smoothness);

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
