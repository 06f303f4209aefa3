// motion_blur_tiles: the largest motion (pixels, jitter removed) of each TILE x TILE block of
// gbuffer.velocity, one invocation per tile (renderer/features/post_output.h).
#version 450
layout(local_size_x = 8, local_size_y = 8) in;
#include "view.glsl"

layout(set = 2, binding = 0) uniform sampler2D gbufferVelocity;
layout(set = 2, binding = 1, rg16f) uniform writeonly image2D velocityTilesImage;

layout(push_constant) uniform MotionBlurTiles {
    uvec4 params;  // x tile size, y, z tiles
} tiles;

void main() {
    ivec2 tile = ivec2(gl_GlobalInvocationID.xy);
    if (tile.x >= int(tiles.params.y) || tile.y >= int(tiles.params.z)) return;
    int n = int(tiles.params.x);
    ivec2 size = ivec2(view.viewport.xy);
    vec2 best = vec2(0.0);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            ivec2 q = min(tile * n + ivec2(x, y), size - 1);
            vec2 v = texelFetch(gbufferVelocity, q, 0).rg + view.jitter.xy - view.jitter.zw;
            if (dot(v, v) > dot(best, best)) best = v;
        }
    imageStore(velocityTilesImage, tile, vec4(best, 0.0, 0.0));
}
