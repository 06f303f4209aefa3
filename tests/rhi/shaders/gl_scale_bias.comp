// OpenGL backend test: dst[i] = src[i] * scale + bias (storage buffers in two sets + push constants).
#version 450
layout(local_size_x = 64) in;

layout(set = 0, binding = 0) readonly buffer Src { uint values[]; } src;
layout(set = 1, binding = 0) buffer Dst { uint values[]; } dst;

layout(push_constant) uniform Push {
    uint scale;
    uint bias;
    uint count;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < pc.count) dst.values[i] = src.values[i] * pc.scale + pc.bias;
}
