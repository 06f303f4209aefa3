#version 450
// Conformance: b[i] = a[i] * 3 + texel(i), reading a storage buffer and sampling a texture.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0) readonly buffer A { uint a[]; };
layout(set = 0, binding = 1) uniform sampler2D texels;
layout(set = 0, binding = 2) writeonly buffer B { uint b[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    ivec2 size = textureSize(texels, 0);
    uint x = i % uint(size.x);
    uint y = (i / uint(size.x)) % uint(size.y);
    vec2 uv = (vec2(x, y) + 0.5) / vec2(size);
    b[i] = a[i] * 3u + uint(textureLod(texels, uv, 0.0).r);
}
