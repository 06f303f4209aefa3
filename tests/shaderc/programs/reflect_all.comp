#version 450
// One of every resource kind; shaderc_tests checks the reflection exactly.
#include "reflect_common.glsl"

layout(local_size_x = 8, local_size_y = 4, local_size_z = 1) in;

layout(set = 0, binding = 0) uniform Params {
    vec4 scale;
    uint count;
} params;

layout(set = 0, binding = 1) readonly buffer Input {
    float values[];
} inputData;

layout(set = 1, binding = 0) buffer Output {
    float values[];
} outputData;

layout(set = 1, binding = 2) uniform sampler3D volume;

layout(set = 2, binding = 0, rgba16f) uniform image2D target;

layout(push_constant) uniform Push {
    vec4 offset;
    uint frame;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= params.count) return;
    float v = scaleValue(inputData.values[i], params.scale.x) + texture(volume, vec3(0.5)).r;
    outputData.values[i] = v + pc.offset.x + float(pc.frame);
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    imageStore(target, p, imageLoad(target, p) + vec4(v));
}
