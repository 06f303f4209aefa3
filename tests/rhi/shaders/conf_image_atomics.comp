#version 450
// Conformance: image atomics on r32ui storage images. Invocation i adds 1 to texel i % 16 (of a
// 4x4 image) of `counts` and takes the maximum of i there in `maxima`.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0, r32ui) uniform uimage2D counts;
layout(set = 0, binding = 1, r32ui) uniform uimage2D maxima;

layout(push_constant) uniform Push { uvec4 info; } pc;  // x: invocation count

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.info.x) return;
    ivec2 p = ivec2(i % 4u, (i / 4u) % 4u);
    imageAtomicAdd(counts, p, 1u);
    imageAtomicMax(maxima, p, i);
}
