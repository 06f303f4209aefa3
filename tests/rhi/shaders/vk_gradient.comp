// Vulkan backend test: writes a gradient into mip `pc.mip` of a storage image, sampled back in the
// test through readTexture (per-mip storage views, GENERAL layout).
#version 450
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba8) uniform writeonly image2D target;
layout(push_constant) uniform Params {
    uint width;
    uint height;
    uint mip;
} pc;

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= pc.width || p.y >= pc.height) return;
    imageStore(target, ivec2(p), vec4(float(p.x) / 255.0, float(p.y) / 255.0, float(pc.mip) / 255.0, 1.0));
}
