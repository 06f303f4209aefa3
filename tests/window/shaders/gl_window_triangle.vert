// OpenGL window test: one triangle per frame, offset by a push constant.
#version 450

layout(push_constant) uniform Push {
    vec4 color;
    float offset;
} pc;

void main() {
    const vec2 corners[3] = vec2[](vec2(-0.5, -0.5), vec2(0.5, -0.5), vec2(0.0, 0.5));
    gl_Position = vec4(corners[gl_VertexIndex] + vec2(pc.offset, 0.0), 0.5, 1.0);
}
