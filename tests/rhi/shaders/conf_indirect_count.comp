#version 450
// Conformance: every invocation counts itself and marks its linear index (for indirect dispatch).
layout(local_size_x = 4, local_size_y = 2) in;

layout(set = 0, binding = 0) buffer Counter {
    uint invocations;
    uint hits[];
};

void main() {
    atomicAdd(invocations, 1u);
    uvec3 n = gl_NumWorkGroups * gl_WorkGroupSize;
    uvec3 g = gl_GlobalInvocationID;
    uint index = g.x + n.x * (g.y + n.y * g.z);
    hits[index] = index + 1u;
}
