// Per-frame scene data of the rasterized mesh path (renderer/passes/gpu_scene.h mirrors these
// layouts: std140 for the camera block, std430 for the storage buffers). Set 0 in every program.

// Camera and frame constants (binding 0).
layout(set = 0, binding = 0) uniform Frame {
    mat4 viewProj;      // world -> Vulkan clip space (y down, depth 0..1)
    mat4 prevViewProj;  // the previous frame's viewProj (velocity)
    vec4 position;      // xyz camera position
    vec4 forward;       // xyz unit view direction (linear depth = distance along it)
    vec4 rayRight;      // xyz camera right / proj[0][0]: ray = forward + ndc.x * rayRight + ndc.y * rayUp
    vec4 rayUp;         // xyz camera up / proj[1][1] (proj[1][1] < 0: NDC y = -1 is row 0)
    vec4 viewport;      // width, height, 1 / width, 1 / height
    vec4 ambient;       // rgb ambient radiance, w exposure
    vec4 background;    // rgb background radiance
    uvec4 params;       // x light count, y shading model, z tone mapper, w 1 = target encodes sRGB
} frame;

struct Material {
    vec4 baseColor;      // linear rgb, a alpha (unused)
    vec4 emissiveMetal;  // rgb emissive radiance, w metallic
    vec4 params;         // x roughness, y 1 when the material has a base-colour texture
};

struct Light {
    vec4 positionType;    // xyz world position, w type (0 directional, 1 point, 2 sphere)
    vec4 directionRange;  // xyz unit direction the light travels (directional), w range (<= 0: none)
    vec4 radianceRadius;  // rgb colour * intensity, w emitter radius (sphere lights)
};

struct Object {
    mat4 model;
    mat4 prevModel;     // the previous frame's model matrix (velocity)
    mat4 normalMatrix;  // inverse transpose of the model's upper 3x3 (columns 0..2)
    uvec4 info;         // x material index (this frame's material array)
};

const uint kShadingCookTorrance = 0u;
const uint kShadingBlinnPhong = 1u;
const uint kToneClamp = 0u;
const uint kToneReinhard = 1u;
const uint kToneAces = 2u;
