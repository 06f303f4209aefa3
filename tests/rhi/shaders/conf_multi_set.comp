#version 450
// Conformance: storage buffers in set 0 and a uniform buffer in set 1 used together.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0) readonly buffer In { float inData[]; };
layout(set = 0, binding = 1) writeonly buffer Out { float outData[]; };
layout(set = 1, binding = 0) uniform Params {
    vec4 scaleBias;  // x: scale, y: bias
    uvec4 range;     // x: first output element, y: count
} params;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= params.range.y) return;
    outData[params.range.x + i] = inData[i] * params.scaleBias.x + params.scaleBias.y;
}
