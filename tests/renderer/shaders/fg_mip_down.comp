// Frame-graph mip chain test: one step, mip N (a one-level sampled view) -> mip N + 1 (storage),
// each texel the mean of its 2x2 source texels.
#version 450
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0) uniform sampler2D src;
layout(set = 0, binding = 1, r32f) uniform writeonly image2D dst;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(dst)))) return;
    float sum = texelFetch(src, 2 * p, 0).x + texelFetch(src, 2 * p + ivec2(1, 0), 0).x +
                texelFetch(src, 2 * p + ivec2(0, 1), 0).x + texelFetch(src, 2 * p + ivec2(1, 1), 0).x;
    imageStore(dst, p, vec4(0.25 * sum));
}
