#version 450
// Conformance: writes a pattern identifying (mip, x, y) into one mip level of an r32ui image.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, r32ui) writeonly uniform uimage2D level;

layout(push_constant) uniform Push { uvec4 info; } pc;  // x: mip, yz: level size

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.info.y || p.y >= pc.info.z) return;
    imageStore(level, ivec2(p), uvec4((pc.info.x << 24) | (p.y << 12) | p.x));
}
