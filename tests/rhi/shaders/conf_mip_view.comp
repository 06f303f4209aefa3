#version 450
// Conformance: one step of a mip chain through a sampled view of one mip. `src` is a view of mip N
// only (its level 0, one level); each texel of `dst` (mip N + 1) is the sum of its 2x2 source
// texels, or -1 / -2 when the view's size / level count is not what a one-mip view has.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D src;
layout(set = 0, binding = 1, r32f) writeonly uniform image2D dst;

layout(push_constant) uniform Push { uvec4 size; } pc;  // xy: dst size

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.size.x) || p.y >= int(pc.size.y)) return;
    float sum = texelFetch(src, 2 * p, 0).x + texelFetch(src, 2 * p + ivec2(1, 0), 0).x +
                texelFetch(src, 2 * p + ivec2(0, 1), 0).x + texelFetch(src, 2 * p + ivec2(1, 1), 0).x;
    if (textureSize(src, 0) != 2 * ivec2(pc.size.xy)) sum = -1.0;
    if (textureQueryLevels(src) != 1) sum = -2.0;
    imageStore(dst, p, vec4(sum));
}
