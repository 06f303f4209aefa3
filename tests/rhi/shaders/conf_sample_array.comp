#version 450
// Conformance: samples a 2D array texture at (u, v, layer) coordinates read from a storage buffer.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0) uniform sampler2DArray layers;
layout(set = 0, binding = 1) readonly buffer Coords { vec4 coords[]; };
layout(set = 0, binding = 2) writeonly buffer Results { vec4 results[]; };

layout(push_constant) uniform Push { uint count; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    results[i] = textureLod(layers, coords[i].xyz, 0.0);
}
