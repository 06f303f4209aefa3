#version 450
// Resource arrays take `count` consecutive OpenGL binding points; readonly images do not write.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0) uniform sampler2D layersOfTextures[3];
layout(set = 0, binding = 1) uniform sampler2DArray atlas;
layout(set = 1, binding = 0, r32f) uniform readonly image3D density;
layout(set = 1, binding = 1, r32ui) uniform writeonly uimage2D counts;
layout(set = 1, binding = 2, rgba8) uniform writeonly image2DArray colors;
layout(set = 2, binding = 0) buffer Result {
    vec4 values[];
} result;

void main() {
    uint i = gl_GlobalInvocationID.x;
    vec4 sum = texture(atlas, vec3(0.5, 0.5, 1.0));
    for (int t = 0; t < 3; ++t) sum += textureLod(layersOfTextures[t], vec2(0.5), 0.0);
    sum += imageLoad(density, ivec3(i, 0, 0));
    imageStore(counts, ivec2(i, 0), uvec4(1u));
    imageStore(colors, ivec3(i, 0, 0), sum);
    result.values[i] = sum;
}
