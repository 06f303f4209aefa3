#version 450
// Conformance: one step of a mip chain. Reads mip N (src) and writes mip N + 1 (dst) of the same
// r32ui image: each dst texel is the sum of its 2x2 source texels.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, r32ui) readonly uniform uimage2D src;
layout(set = 0, binding = 1, r32ui) writeonly uniform uimage2D dst;

layout(push_constant) uniform Push { uvec4 size; } pc;  // xy: dst size

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= int(pc.size.x) || p.y >= int(pc.size.y)) return;
    uint sum = imageLoad(src, 2 * p).x + imageLoad(src, 2 * p + ivec2(1, 0)).x +
               imageLoad(src, 2 * p + ivec2(0, 1)).x + imageLoad(src, 2 * p + ivec2(1, 1)).x;
    imageStore(dst, p, uvec4(sum));
}
