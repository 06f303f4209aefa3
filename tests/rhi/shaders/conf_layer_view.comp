#version 450
// Conformance: writes layer 0 of a storage view; the bind group views layers [1, 2) of an array,
// so the texels land in array layer 1.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, r32ui) writeonly uniform uimage2DArray dst;

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    imageStore(dst, ivec3(p, 0), uvec4(0xC0DE0000u | (p.y << 8) | p.x));
}
