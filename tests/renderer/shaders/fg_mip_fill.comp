// Frame-graph mip chain test: mip 0 texel (x, y) = x + width * y.
#version 450
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, r32f) uniform writeonly image2D dst;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(dst);
    if (any(greaterThanEqual(p, size))) return;
    imageStore(dst, p, vec4(float(p.x + size.x * p.y)));
}
