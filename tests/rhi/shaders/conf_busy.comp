#version 450
// Conformance: a dispatch that does a measurable amount of arithmetic (for timestamp tests).
layout(local_size_x = 64) in;

layout(set = 0, binding = 0) buffer Data { uint data[]; };

layout(push_constant) uniform Push { uint iterations; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint v = data[i] + i;
    for (uint k = 0u; k < pc.iterations; ++k) v = v * 1664525u + 1013904223u;
    data[i] = v;
}
