// Per-frame scene data shared by every program (renderer/features/gpu_scene.h holds the C++ side,
// checked against shaderc's generated structs). Set 0 is the shared per-view block (view.glsl);
// set 1 is the scene, with one layout in every program (a program declares the bindings it uses):
//   set 1, binding 0  uniform Scene            ambient, background, light count, shading, tone map (SCENE_CONSTANTS)
//   set 1, binding 1  readonly buffer Objects  Object[]   (SCENE_OBJECTS)
//   set 1, binding 2  readonly buffer Materials Material[] (SCENE_MATERIALS)
//   set 1, binding 3  readonly buffer Lights   Light[]    (SCENE_LIGHTS)
// Set 2 holds a pass's own inputs, set 3 per-material resources.
#include "view.glsl"

struct Material {
    vec4 baseColor;      // linear rgb, a alpha (unused)
    vec4 emissiveMetal;  // rgb emissive radiance, w metallic
    vec4 params;         // x roughness, y 1 when the material has a base-colour texture,
                         // z triplanar scale (SDF objects), w flags (MATERIAL_*)
    vec4 subsurface;     // rgb subsurface colour * strength (0: none), w radius (scene units)
};
const uint MATERIAL_REFLECTIONS = 1u;    // traced reflection bounce
const uint MATERIAL_NORMAL_TEXTURE = 2u;  // has a normal map
uint materialFlags(Material m) { return uint(m.params.w + 0.5); }

struct Light {
    vec4 positionType;    // xyz world position, w type (0 directional, 1 point, 2 sphere)
    vec4 directionRange;  // xyz unit direction the light travels (directional), w range (<= 0: none)
    vec4 radianceRadius;  // rgb colour * intensity, w emitter radius (sphere lights)
    vec4 shadow;          // x shadow layer in the effects.shadow strip (-1: unshadowed),
                          // y angular radius in radians (directional lights)
};

struct Object {
    mat4 model;
    mat4 prevModel;     // the previous frame's model matrix (velocity)
    mat4 normalMatrix;  // inverse transpose of the model's upper 3x3 (columns 0..2)
    uvec4 info;         // x material index (this frame's material array)
};

// The scene's bindings: a program writes e.g. `SCENE_CONSTANTS;` for each one it uses (a declared
// binding is part of the program's reflection and must be bound, used or not).
#define SCENE_CONSTANTS                                                                         \
    layout(set = 1, binding = 0, std140) uniform Scene {                                        \
        vec4 ambient;    /* rgb ambient radiance (from below with a sky), w exposure */         \
        vec4 background; /* rgb background radiance */                                         \
        uvec4 params;    /* x lights, y shading model, z tone mapper, w 1 = write linear (sRGB target, post) */ \
        vec4 ambientSky; /* rgb ambient radiance from straight up */                            \
        uvec4 effects;   /* x shadow layers, y AO target, z thickness, w reflections (1 = on) */ \
    }                                                                                           \
    scene
#define SCENE_OBJECTS layout(set = 1, binding = 1, std430) readonly buffer Objects { Object objects[]; }
#define SCENE_MATERIALS layout(set = 1, binding = 2, std430) readonly buffer Materials { Material materials[]; }
#define SCENE_LIGHTS layout(set = 1, binding = 3, std430) readonly buffer Lights { Light lights[]; }

const uint kShadingCookTorrance = 0u;
const uint kShadingBlinnPhong = 1u;
const uint kToneClamp = 0u;
const uint kToneReinhard = 1u;
const uint kToneAces = 2u;
