#version 450
// Parameter structs: every member type the generated C++ supports, std140 and std430 padding,
// nested structs, an array of structs, push constants and the shared View block (view.glsl).
// layout_test.cpp compares every generated offset with glslang's own reflection.
#include "view.glsl"

layout(local_size_x = 1) in;

struct Inner {
    vec3 direction;
    float weight;
    vec2 uv;
};

layout(set = 1, binding = 0) uniform Params {
    float scale;
    vec3 axis;
    vec2 extent;
    int count;
    uint mask;
    ivec2 cell;
    uvec3 dims;
    bool enabled;
    mat4 transform;
    mat3 rotation;
    mat2 basis;
    vec4 colors[3];
    Inner inners[2];
    Inner single;
    float tail;
} params;

layout(set = 1, binding = 1, std430) buffer Stats {
    vec2 range;
    float samples[4];
    Inner last;
    uint total;
} stats;

layout(set = 1, binding = 2, std430) readonly buffer Items {
    Inner items[];
};

// Used only as the element of a runtime-sized array: its C++ size is still the array stride.
struct Probe {
    vec3 position;
    float radius;
    vec2 uv;
};

layout(set = 1, binding = 3, std430) readonly buffer Probes {
    Probe probes[];
};

layout(push_constant) uniform Push {
    vec4 tint;
    uint frame;
} pc;

void main() {
    float v = params.scale + params.axis.x + params.extent.y + float(params.count + int(params.mask)) +
              float(params.cell.x) + float(params.dims.z) + (params.enabled ? 1.0 : 0.0) +
              params.transform[3].x + params.rotation[2].y + params.basis[1].x + params.colors[2].w +
              params.inners[1].weight + params.single.uv.x + params.tail + items[0].weight + probes[1].uv.y;
    stats.range = vec2(v, pc.tint.x) + view.viewport.zw;
    stats.samples[pc.frame % 4u] = v;
    stats.last = params.inners[0];
    stats.total = view.frameIndex;
}
