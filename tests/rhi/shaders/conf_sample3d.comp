#version 450
// Conformance: samples a 3D texture through a combined image sampler at points read from a
// storage buffer. Compute shaders have no derivatives, so the level is given explicitly (LOD 0 is
// what texture() means outside fragment shaders).
layout(local_size_x = 64) in;

layout(set = 0, binding = 0) uniform sampler3D volume;
layout(set = 0, binding = 1) readonly buffer Points { vec4 points[]; };
layout(set = 0, binding = 2) writeonly buffer Results { vec4 results[]; };

layout(push_constant) uniform Push { uint count; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    results[i] = textureLod(volume, points[i].xyz, 0.0);
}
