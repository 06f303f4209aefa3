// Feature "sdf_surface": textures on SDF objects (issue 12 item 6). The compute pass "sdf_surface"
// runs after sdf_trace and, for each textured material that an SDF object of the frame uses, makes
// one dispatch binding that material's base-colour and normal textures (the compute trace cannot
// bind every material's textures: no bindless on the software backends). Each dispatch touches the
// SDF pixels of its material (gbuffer.material r,g = the material, b,a = the SDF object + 1):
//   - the pixel's world position (from its linear depth) and normal go to the object's local space,
//     so the texturing is fixed to the object: textures do not swim when it moves or turns;
//   - triplanar projection with Material.params.z (triplanarScale) repeats per object unit, blend
//     weights |n_local|^4 (renderer/shaders/sdf_surface.comp has the exact convention);
//   - albedo = baseColor factor x texture (gbuffer.albedo), and with a normal map the whiteout-
//     blended object-space normal, back in world space, replaces gbuffer.normal.
// Lighting (Blinn-Phong or Cook-Torrance) is the deferred lighting pass shared with meshes.
#pragma once

#include <cstdint>
#include <vector>

#include "renderer/features/frame_context.h"

namespace penumbra::render {

// A textured material of the frame's SDF objects with its textures imported into the graph.
struct SdfSurfaceMaterial {
    uint32_t material = 0;     // index in the frame's material array
    fg::TextureRef baseColor;  // invalid: no base-colour texture (albedo stays the factor)
    fg::TextureRef normal;     // invalid: no normal map (gbuffer.normal stays the traced one)
};

// Adds the pass (nothing when `materials` is empty). Reads SceneBuffers (view, materials),
// SdfSceneBuffers (objects) and the GBuffer's depth and material; writes its normal (normal maps)
// and albedo (base-colour textures; the GBuffer must have one then).
void addSdfSurface(FrameContext& fc, std::vector<SdfSurfaceMaterial> materials);

}  // namespace penumbra::render
