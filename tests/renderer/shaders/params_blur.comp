// Test program for ShaderParams / GpuCache: a uniform block, a sampled texture and a storage image,
// each in its own set. Writes src * scale into dst.
#version 450
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, std140) uniform BlurParams {
    vec4 scale;
} params;
layout(set = 1, binding = 0) uniform sampler2D src;
layout(set = 1, binding = 1, rgba8) uniform writeonly image2D dst;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(dst)))) return;
    imageStore(dst, p, texelFetch(src, p, 0) * params.scale);
}
