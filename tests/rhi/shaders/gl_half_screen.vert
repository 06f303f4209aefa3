// OpenGL backend test: a full-target triangle.
#version 450

void main() {
    vec2 p = vec2(float((gl_VertexIndex & 1) * 4 - 1), float((gl_VertexIndex >> 1) * 4 - 1));
    gl_Position = vec4(p, 0.5, 1.0);
}
