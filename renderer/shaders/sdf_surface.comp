// sdf_surface: the textures of one material on the SDF pixels that show it
// (renderer/features/sdf_surface.h). One dispatch per textured material of the frame's SDF objects;
// one invocation per pixel:
//  1. pixels whose G-buffer material is another one, or that belong to no SDF object (meshes,
//     background: gbuffer.material b,a = 0), are left alone;
//  2. the world position is rebuilt from the linear depth (effects.glsl) and taken to the object's
//     local space with its worldToLocal matrix, the world normal with the model's transpose: every
//     texture lookup is in object space, so textures move and turn with the object (no swimming);
//  3. triplanar projection: the local position times Material.params.z (triplanarScale, repeats per
//     object unit) gives three planar coordinates, along X (z, y), along Y (x, z) and along Z (x, y),
//     each read with the image's top towards the second axis (u = a * s, v = -b * s); the three
//     samples are blended by |n_local|^4 (sharpness 4), normalised: a face at 30 degrees from an axis
//     still takes 70 % of its weight from its own projection, and an axis-aligned face exactly one;
//  4. ALBEDO: albedo = baseColor factor * the blended (linear) base-colour texture;
//  5. NORMAL_MAP: the three tangent-space normals (x along +a, y along +b, z out of the face, each
//     t = texel * 2 - 1) are each combined with the local normal by the whiteout blend
//     (t.xy + n_ab, |t.z| n_axis), swizzled back to object axes and blended with the same weights;
//     the result goes back to world space with the normal matrix (transpose of worldToLocal's 3x3).
//     A flat map (0.5, 0.5, 1) keeps the normal; on an axis-aligned face the blend is exact.
#version 450
#pragma penumbra_variants ALBEDO NORMAL_MAP ALBEDO+NORMAL_MAP
layout(local_size_x = 8, local_size_y = 8) in;

#include "scene.glsl"
#include "gbuffer.glsl"
#include "effects.glsl"

#define SDF_SCENE_SET 2
#define SDF_OBJECTS_BINDING 6
#define SHAPE_RECORDS_BINDING 7
#include "sdf_scene.glsl"

SCENE_MATERIALS;

layout(set = 2, binding = 0, r32f) uniform readonly image2D gbufferDepthImage;
layout(set = 2, binding = 1, rg16f) uniform image2D gbufferNormalImage;
layout(set = 2, binding = 2, rgba8) uniform readonly image2D gbufferMaterialImage;
#ifdef ALBEDO
layout(set = 2, binding = 3, rgba8) uniform writeonly image2D gbufferAlbedoImage;
layout(set = 3, binding = 0) uniform sampler2D baseColorTexture;
#endif
#ifdef NORMAL_MAP
layout(set = 3, binding = 1) uniform sampler2D normalTexture;
#endif

layout(push_constant) uniform SdfSurface {
    uvec4 params;  // x the material index this dispatch textures, y traced SDF objects
} surface;

const float kSharpness = 4.0;

// Blend weights of the X, Y and Z projections for local normal n (they sum to 1).
vec3 triplanarWeights(vec3 n) {
    vec3 w = pow(abs(n), vec3(kSharpness));
    return w / max(w.x + w.y + w.z, 1e-20);
}

// The three planar texture coordinates of local position pl (scale s): along X, Y, Z.
void triplanarCoords(vec3 pl, float s, out vec2 uvX, out vec2 uvY, out vec2 uvZ) {
    uvX = vec2(pl.z, -pl.y) * s;
    uvY = vec2(pl.x, -pl.z) * s;
    uvZ = vec2(pl.x, -pl.y) * s;
}

#ifdef NORMAL_MAP
vec3 tangentNormal(vec2 uv) { return textureLod(normalTexture, uv, 0.0).xyz * 2.0 - 1.0; }

// Whiteout-blended triplanar normal mapping in object space (step 5 above).
vec3 triplanarNormal(vec3 n, vec3 w, vec2 uvX, vec2 uvY, vec2 uvZ) {
    vec3 tx = tangentNormal(uvX), ty = tangentNormal(uvY), tz = tangentNormal(uvZ);
    // Projection X: tangent axes (+z, +y), face axis x; Y: (+x, +z), y; Z: (+x, +y), z.
    vec3 bx = vec3(tx.xy + n.zy, abs(tx.z) * n.x);
    vec3 by = vec3(ty.xy + n.xz, abs(ty.z) * n.y);
    vec3 bz = vec3(tz.xy + n.xy, abs(tz.z) * n.z);
    vec3 blended = bx.zyx * w.x + by.xzy * w.y + bz.xyz * w.z;
    return dot(blended, blended) > 1e-12 ? normalize(blended) : n;
}
#endif

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (pixel.x >= int(view.viewport.x) || pixel.y >= int(view.viewport.y)) return;
    vec4 packed = imageLoad(gbufferMaterialImage, pixel);
    uint object1 = unpackMaterialObject(packed);
    if (object1 == 0u || object1 > surface.params.y || unpackMaterialIndex(packed) != surface.params.x) return;
    uint obj = object1 - 1u;
    float depth = imageLoad(gbufferDepthImage, pixel).r;
    if (depth <= 0.0) return;

    Material m = materials[surface.params.x];
    vec3 pl = sdfToLocal(obj, effectsWorldPosition(pixel, depth));
    vec3 nWorld = octDecode(imageLoad(gbufferNormalImage, pixel).rg);
    vec3 nLocal = normalize(transpose(mat3(sdfObjects[obj].model)) * nWorld);
    vec3 w = triplanarWeights(nLocal);
    vec2 uvX, uvY, uvZ;
    triplanarCoords(pl, m.params.z, uvX, uvY, uvZ);
#ifdef ALBEDO
    vec3 tex = w.x * textureLod(baseColorTexture, uvX, 0.0).rgb + w.y * textureLod(baseColorTexture, uvY, 0.0).rgb +
               w.z * textureLod(baseColorTexture, uvZ, 0.0).rgb;
    imageStore(gbufferAlbedoImage, pixel, packAlbedo(m.baseColor.rgb * tex));
#endif
#ifdef NORMAL_MAP
    vec3 mapped = triplanarNormal(nLocal, w, uvX, uvY, uvZ);
    vec3 n = normalize(transpose(mat3(sdfObjects[obj].worldToLocal)) * mapped);
    if (!any(isnan(n))) imageStore(gbufferNormalImage, pixel, vec4(octEncode(n), 0.0, 0.0));
#endif
}
