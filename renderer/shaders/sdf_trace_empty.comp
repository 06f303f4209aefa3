// sdf_trace_empty: the G-buffer's "nothing hit" values for the 8x8 tiles whose primary tile list is
// empty, in the sdf_trace pass of a frame without a mesh pass (renderer/features/sdf_trace.cpp).
// sdf_trace runs only over the tiles whose list is not empty (its tile dispatch); no ray of an empty
// tile crosses an object's box, so sdf_trace would write exactly these values there: depth, normal,
// material, velocity and albedo 0, aux (-1: background, 0 steps or evaluations). With a mesh pass
// the G-buffer already holds what such a pixel keeps (the mesh pass's values and aux (id, 0)), and
// this shader does not run.
// One workgroup per empty tile, from the indirect dispatch the culling wrote (sdf_tile_cull.comp).
#version 450
#pragma penumbra_variants ALBEDO AUX ALBEDO+AUX
layout(local_size_x = 8, local_size_y = 8) in;

#include "view.glsl"

layout(set = 2, binding = 0, r32f) uniform writeonly image2D gbufferDepthImage;
layout(set = 2, binding = 1, rg16f) uniform writeonly image2D gbufferNormalImage;
layout(set = 2, binding = 2, rgba8) uniform writeonly image2D gbufferMaterialImage;
layout(set = 2, binding = 3, rg16f) uniform writeonly image2D gbufferVelocityImage;
#ifdef ALBEDO
layout(set = 2, binding = 4, rgba8) uniform writeonly image2D gbufferAlbedoImage;
#endif
#ifdef AUX
layout(set = 2, binding = 5, rg32f) uniform writeonly image2D gbufferAuxImage;
#endif
// SdfTileLists::dispatch: the empty tiles' indices from empty.tiles.y on.
layout(set = 2, binding = 6, std430) readonly buffer SdfTileDispatch { uint sdfTileDispatch[]; };

layout(push_constant) uniform SdfTraceEmpty {
    uvec4 tiles;  // x tiles per row, y the first empty tile's index in sdfTileDispatch
} empty;

void main() {
    uint index = sdfTileDispatch[empty.tiles.y + gl_WorkGroupID.x];
    uvec2 tile = uvec2(index % empty.tiles.x, index / empty.tiles.x);
    ivec2 pixel = ivec2(tile * 8u + gl_LocalInvocationID.xy);
    if (pixel.x >= int(view.viewport.x) || pixel.y >= int(view.viewport.y)) return;
    imageStore(gbufferDepthImage, pixel, vec4(0.0));
    imageStore(gbufferNormalImage, pixel, vec4(0.0));
    imageStore(gbufferMaterialImage, pixel, vec4(0.0));
    imageStore(gbufferVelocityImage, pixel, vec4(0.0));
#ifdef ALBEDO
    imageStore(gbufferAlbedoImage, pixel, vec4(0.0));
#endif
#ifdef AUX
    imageStore(gbufferAuxImage, pixel, vec4(-1.0, 0.0, 0.0, 0.0));
#endif
}
