// Vulkan backend test: dst[i] = src[i] * 2 + add for i < count (storage-buffer round trip with
// push constants).
#version 450
layout(local_size_x = 64) in;

layout(set = 0, binding = 0) readonly buffer Src { uint src[]; };
layout(set = 0, binding = 1) buffer Dst { uint dst[]; };
layout(push_constant) uniform Params {
    uint count;
    uint add;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < pc.count) dst[i] = src[i] * 2u + pc.add;
}
