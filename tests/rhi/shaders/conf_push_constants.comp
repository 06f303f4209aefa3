#version 450
// Conformance: copies a full 128-byte push-constant block into out[slot * 28 ...].
layout(local_size_x = 32) in;

layout(push_constant) uniform Push {
    uvec4 values[7];
    uvec4 slot;  // x: output slot
} pc;

layout(set = 0, binding = 0) writeonly buffer Out { uint words[]; };

void main() {
    uint i = gl_LocalInvocationID.x;
    if (i < 28u) words[pc.slot.x * 28u + i] = pc.values[i / 4u][i % 4u];
}
