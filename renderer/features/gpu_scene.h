// CPU mirrors of the per-frame scene data in renderer/shaders/scene.glsl and view.glsl (std140
// uniform blocks, std430 storage-buffer elements). The View block's struct is the one shaderc
// generates (shaders/view.h); scene_upload.cpp checks these structs against the generated ones at
// compile time, so a layout change on either side fails the build.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>

#include <shaders/view.h>

namespace penumbra::render {

using GpuView = shaders::View;  // set 0, binding 0 of every program

struct GpuScene {
    glm::vec4 ambient;     // rgb ambient (the ground's with a sky ambient), w exposure
    glm::vec4 background;  // rgb background radiance
    glm::uvec4 params;     // x light count, y shading model, z tone mapper, w 1 = sRGB target
    glm::vec4 ambientSky;  // rgb ambient from straight up (= ambient when the scene sets no sky)
    glm::uvec4 effects;    // x shadow layers, y 1 = AO target, z 1 = thickness, w 1 = reflections
};
static_assert(sizeof(GpuScene) == 80);

struct GpuMaterial {
    glm::vec4 baseColor;
    glm::vec4 emissiveMetal;  // rgb emissive, w metallic
    glm::vec4 params;         // x roughness, y 1 when textured, z triplanar scale, w flags (kMaterial*)
    glm::vec4 subsurface;     // rgb subsurface colour * strength (0: none), w radius (scene units)
};
static_assert(sizeof(GpuMaterial) == 64);
// GpuMaterial::params.w bits (stored as a float holding a small integer).
inline constexpr uint32_t kMaterialReflections = 1u;    // traced reflection bounce
inline constexpr uint32_t kMaterialNormalTexture = 2u;  // has a normal map

struct GpuLight {
    glm::vec4 positionType;    // xyz position, w 0 directional / 1 point / 2 sphere
    glm::vec4 directionRange;  // xyz direction the light travels, w range
    glm::vec4 radianceRadius;  // rgb colour * intensity, w radius
    glm::vec4 shadow;          // x shadow layer (-1: unshadowed), y angular radius (directional, radians)
};
static_assert(sizeof(GpuLight) == 64);

struct GpuObject {
    glm::mat4 model;
    glm::mat4 prevModel;
    glm::mat4 normalMatrix;
    glm::uvec4 info;  // x material index
};
static_assert(sizeof(GpuObject) == 208);

// Interleaved vertex of the mesh vertex buffers (locations 0, 1, 2).
struct GpuVertex {
    float position[3];
    float normal[3];
    float uv[2];
};
static_assert(sizeof(GpuVertex) == 32);

// Everything the scene_upload pass writes this frame (the lights array holds at least one
// element so the buffer can always be bound; scene.params.x says how many are real).
struct SceneFrameData {
    GpuView view{};
    GpuScene scene{};
    std::vector<GpuMaterial> materials;
    std::vector<GpuLight> lights;
    std::vector<GpuObject> objects;
};

}  // namespace penumbra::render
