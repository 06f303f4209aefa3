#version 450
// Conformance: writes dispatch arguments (x, y, z) at word offset `groups.w` of a buffer.
layout(local_size_x = 1) in;

layout(set = 0, binding = 0) writeonly buffer Args { uint args[]; };

layout(push_constant) uniform Push { uvec4 groups; } pc;

void main() {
    args[pc.groups.w + 0u] = pc.groups.x;
    args[pc.groups.w + 1u] = pc.groups.y;
    args[pc.groups.w + 2u] = pc.groups.z;
}
