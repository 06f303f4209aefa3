#version 450
// Conformance: samples one 2D texture through five samplers (filter / address-mode combinations)
// at the same coordinates; result[i * 5 + k] is the red channel through sampler k.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0) uniform sampler2D nearestClamp;
layout(set = 0, binding = 1) uniform sampler2D linearClamp;
layout(set = 0, binding = 2) uniform sampler2D nearestRepeat;
layout(set = 0, binding = 3) uniform sampler2D linearRepeat;
layout(set = 0, binding = 4) uniform sampler2D linearMirrored;
layout(set = 0, binding = 5) readonly buffer Coords { vec4 coords[]; };
layout(set = 0, binding = 6) writeonly buffer Results { float results[]; };

layout(push_constant) uniform Push { uint count; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    vec2 uv = coords[i].xy;
    results[i * 5u + 0u] = textureLod(nearestClamp, uv, 0.0).r;
    results[i * 5u + 1u] = textureLod(linearClamp, uv, 0.0).r;
    results[i * 5u + 2u] = textureLod(nearestRepeat, uv, 0.0).r;
    results[i * 5u + 3u] = textureLod(linearRepeat, uv, 0.0).r;
    results[i * 5u + 4u] = textureLod(linearMirrored, uv, 0.0).r;
}
