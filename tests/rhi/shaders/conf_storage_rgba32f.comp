#version 450
// Conformance: writes a deterministic pattern to an rgba32f storage image and to a storage buffer.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) writeonly uniform image2D image;
layout(set = 0, binding = 1) writeonly buffer Words { uint words[]; };

layout(push_constant) uniform Push { uvec4 size; } pc;  // xy: image size

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.size.x || p.y >= pc.size.y) return;
    imageStore(image, ivec2(p), vec4(float(p.x), float(p.y), float(p.x) * 0.25, -float(p.y) * 0.5 - 1.0));
    words[p.y * pc.size.x + p.x] = (p.x * 2654435761u) ^ (p.y << 16) ^ 0xA5A5A5A5u;
}
