#version 450
// Conformance: writes an rgba8 storage image and read-modify-writes an r32ui storage image.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba8) writeonly uniform image2D colors;
layout(set = 0, binding = 1, r32ui) uniform uimage2D counters;

layout(push_constant) uniform Push { uvec4 size; } pc;  // xy: image size

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.size.x || p.y >= pc.size.y) return;
    imageStore(colors, ivec2(p), vec4(float(p.x) / 255.0, float(p.y) / 255.0, float(p.x + p.y) / 255.0, 1.0));
    uint previous = imageLoad(counters, ivec2(p)).x;
    imageStore(counters, ivec2(p), uvec4(previous * 3u + (p.x << 8) + p.y + 0x10000000u));
}
