// debug_view, fragment stage: shows one G-buffer channel instead of the lit image
// (renderer/features/debug_view.h describes the views). Background pixels (depth 0) are black for
// normals, depth and albedo; steps and ids decide by gbuffer.aux.
//   mode 0 normals  world normal * 0.5 + 0.5
//   mode 1 depth    linear depth / depthRange, white = near, black = far or nothing hit
//   mode 2 albedo   base colour (variant ALBEDO: the albedo target, else the material's colour)
//   mode 3 steps    trace steps / step limit through the heat ramp (variant AUX)
//   mode 4 ids      hash colour of the entity index, black for -1 (variant AUX)
//   mode 6 ao          ambient occlusion, grey (effects.ao r)                       (variant EFFECTS)
//   mode 7 shadow      visibility of the first shadowed light, grey (effects.shadow layer 0)
//   mode 8 bentnormal  bent normal * 0.5 + 0.5 (effects.ao gba)
//   mode 9 thickness   t / (t + r), t the thickness (effects.thickness, scene units), r the material's
//                      subsurfaceRadius: 0 black (none), t = r mid grey, thick white
//   mode 10 tiles      the primary tile list length n of the pixel's 8x8 tile (variant TILES:
//                      sdf_tiles.glsl) through the steps ramp at log2(1 + n) / log2(1 + N), N the
//                      traced objects (mode.z); 0 black, the "all objects" fallback magenta
// The effect views bind the effect's target as effectTexture (variant EFFECTS); without it (the
// effect did not run) they show what lighting uses then: AO and shadow 1, the shading normal,
// thickness 0. Tiles without lists (no traced SDF object) are black.
#version 450
#pragma penumbra_variants ALBEDO AUX ALBEDO+AUX EFFECTS TILES
#include "scene.glsl"
#include "gbuffer.glsl"
#include "brdf.glsl"

SCENE_CONSTANTS;
SCENE_MATERIALS;

layout(set = 2, binding = 0) uniform sampler2D gbufferDepth;
layout(set = 2, binding = 1) uniform sampler2D gbufferNormal;
layout(set = 2, binding = 2) uniform sampler2D gbufferMaterial;
#ifdef ALBEDO
layout(set = 2, binding = 3) uniform sampler2D gbufferAlbedo;
#endif
#ifdef AUX
layout(set = 2, binding = 4) uniform sampler2D gbufferAux;
#endif
#ifdef EFFECTS
layout(set = 2, binding = 5) uniform sampler2D effectTexture;
#endif
#ifdef TILES
#define SDF_TILES_SET 2
#define SDF_TILE_RANGES_BINDING 6
#define SDF_TILE_INDICES_BINDING 7
#include "sdf_tiles.glsl"
#endif

layout(push_constant) uniform DebugView {
    uvec4 mode;        // x mode (see above), y tiles per row, z traced objects (tiles)
    vec4 depthRange;   // x linear depth shown as black, y step limit (the heat map's top)
} debugView;

layout(location = 0) in vec2 vUv;
layout(location = 0) out vec4 outColor;

// The steps heat ramp: s = steps / limit through black, blue, cyan, green, yellow, red (s >= 1).
vec3 heat(float s) {
    const vec3 stops[6] = vec3[6](vec3(0.0), vec3(0.0, 0.0, 1.0), vec3(0.0, 1.0, 1.0), vec3(0.0, 1.0, 0.0),
                                  vec3(1.0, 1.0, 0.0), vec3(1.0, 0.0, 0.0));
    const float at[6] = float[6](0.0, 0.125, 0.25, 0.5, 0.75, 1.0);
    s = clamp(s, 0.0, 1.0);
    for (int i = 1; i < 6; ++i)
        if (s <= at[i]) return mix(stops[i - 1], stops[i], (s - at[i - 1]) / (at[i] - at[i - 1]));
    return stops[5];
}

// PCG (O'Neill) output hash of the entity index: the same colour for an index everywhere.
vec3 idColour(uint id) {
    uint state = id * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    uint h = (word >> 22u) ^ word;
    return 0.2 + 0.8 * vec3(float(h & 255u), float((h >> 8u) & 255u), float((h >> 16u) & 255u)) / 255.0;
}

// Modes 6..9 on a surface pixel (see above).
vec3 effectView(uint mode, ivec2 pixel) {
    vec3 normal = octDecode(texelFetch(gbufferNormal, pixel, 0).rg);
#ifdef EFFECTS
    vec4 e = texelFetch(effectTexture, pixel, 0);
    if (mode == 6u || mode == 7u) return vec3(e.r);
    if (mode == 8u) {
        vec3 bent = e.gba * 2.0 - 1.0;
        return (dot(bent, bent) > 1e-6 ? normalize(bent) : normal) * 0.5 + 0.5;
    }
    float radius = max(materials[unpackMaterialIndex(texelFetch(gbufferMaterial, pixel, 0))].subsurface.w, 1e-6);
    return vec3(max(e.r, 0.0) / (max(e.r, 0.0) + radius));
#else
    return mode == 8u ? normal * 0.5 + 0.5 : vec3(mode == 9u ? 0.0 : 1.0);
#endif
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(gbufferDepth, pixel, 0).r;
    uint mode = debugView.mode.x;
    vec3 value = vec3(0.0);
    if (mode == 10u) {
#ifdef TILES
        uint n = sdfTileRanges[sdfTileIndex(pixel, debugView.mode.y)].y;
        if (n == 0xffffffffu) {
            value = vec3(1.0, 0.0, 1.0);
        } else if (n > 0u) {
            value = heat(log2(1.0 + float(n)) / log2(1.0 + float(max(debugView.mode.z, 1u))));
        }
#endif
    } else if (mode >= 6u) {
        if (depth > 0.0) value = effectView(mode, pixel);
    } else if (mode >= 3u) {
#ifdef AUX
        vec2 aux = texelFetch(gbufferAux, pixel, 0).rg;
        if (mode == 3u) {
            value = aux.y > 0.0 ? heat(aux.y / debugView.depthRange.y) : vec3(0.0);
        } else if (aux.x >= 0.0) {
            value = idColour(uint(aux.x + 0.5));
        }
#endif
    } else if (depth > 0.0) {
        if (mode == 0u) {
            value = octDecode(texelFetch(gbufferNormal, pixel, 0).rg) * 0.5 + 0.5;
        } else if (mode == 1u) {
            value = vec3(1.0 - clamp(depth / debugView.depthRange.x, 0.0, 1.0));
        } else {
#ifdef ALBEDO
            value = unpackAlbedo(texelFetch(gbufferAlbedo, pixel, 0));
#else
            value = materials[unpackMaterialIndex(texelFetch(gbufferMaterial, pixel, 0))].baseColor.rgb;
#endif
        }
    }
    // Normals, depth, steps and ids are display values already; albedo is linear colour.
    vec3 encoded = mode == 2u ? srgbEncode(value) : value;
    outColor = vec4(scene.params.w != 0u && mode == 2u ? value : encoded, 1.0);
}
