// OpenGL backend test: writes (x, y, layer, 1) / 255 into every texel of a storage image array.
#version 450
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba8) uniform writeonly image2DArray dst;

void main() {
    ivec3 p = ivec3(gl_GlobalInvocationID);
    ivec3 size = imageSize(dst);
    if (any(greaterThanEqual(p, size))) return;
    imageStore(dst, p, vec4(float(p.x), float(p.y), float(p.z), 255.0) / 255.0);
}
