// CPU mirrors of the per-frame scene data in renderer/shaders/scene.glsl (std140 camera block,
// std430 storage-buffer elements). Change both together.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>

namespace penumbra::render {

struct GpuFrame {
    glm::mat4 viewProj;
    glm::mat4 prevViewProj;
    glm::vec4 position;
    glm::vec4 forward;
    glm::vec4 rayRight;    // camera right / proj[0][0]
    glm::vec4 rayUp;       // camera up / proj[1][1]
    glm::vec4 viewport;    // width, height, 1 / width, 1 / height
    glm::vec4 ambient;     // rgb ambient, w exposure
    glm::vec4 background;  // rgb background radiance
    glm::uvec4 params;     // x light count, y shading model, z tone mapper, w 1 = sRGB target
};
static_assert(sizeof(GpuFrame) == 2 * 64 + 8 * 16);

struct GpuMaterial {
    glm::vec4 baseColor;
    glm::vec4 emissiveMetal;  // rgb emissive, w metallic
    glm::vec4 params;         // x roughness, y 1 when textured
};
static_assert(sizeof(GpuMaterial) == 48);

struct GpuLight {
    glm::vec4 positionType;    // xyz position, w 0 directional / 1 point / 2 sphere
    glm::vec4 directionRange;  // xyz direction the light travels, w range
    glm::vec4 radianceRadius;  // rgb colour * intensity, w radius
};
static_assert(sizeof(GpuLight) == 48);

struct GpuObject {
    glm::mat4 model;
    glm::mat4 prevModel;
    glm::mat4 normalMatrix;
    glm::uvec4 info;  // x material index
};
static_assert(sizeof(GpuObject) == 208);

// Push constant of one gbuffer_mesh draw.
struct GpuDrawPush {
    glm::uvec4 object;  // x index into the objects buffer
};

// Interleaved vertex of the mesh vertex buffers (locations 0, 1, 2).
struct GpuVertex {
    float position[3];
    float normal[3];
    float uv[2];
};
static_assert(sizeof(GpuVertex) == 32);

// Everything the scene_upload pass writes this frame (the lights array holds at least one
// element so the buffer can always be bound; frame.params.x says how many are real).
struct SceneFrameData {
    GpuFrame frame{};
    std::vector<GpuMaterial> materials;
    std::vector<GpuLight> lights;
    std::vector<GpuObject> objects;
};

}  // namespace penumbra::render
