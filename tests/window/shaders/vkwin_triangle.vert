// Vulkan window test: one triangle around the centre of the backbuffer, no vertex buffers.
#version 450
layout(push_constant) uniform Params {
    vec4 color;
} pc;

void main() {
    const vec2 corners[3] = vec2[](vec2(-0.5, -0.5), vec2(0.5, -0.5), vec2(0.0, 0.5));
    gl_Position = vec4(corners[gl_VertexIndex], 0.0, 1.0);
}
