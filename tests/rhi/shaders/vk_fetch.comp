// Vulkan backend test: copies two texels of a sampled texture into a storage buffer (used to
// sample a texture whose state maps to the GENERAL layout).
#version 450
layout(local_size_x = 1) in;

layout(set = 0, binding = 0) uniform sampler2D tex;
layout(set = 0, binding = 1) buffer Out { vec4 texels[]; };

void main() {
    texels[0] = texelFetch(tex, ivec2(0, 0), 0);
    texels[1] = texelFetch(tex, ivec2(1, 0), 0);
}
