// Vertex shader body for a full-screen triangle; uv (0,0) is image row 0.
layout(location = 0) out vec2 vUv;

void main() {
    vec2 uv = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
    vUv = uv;
    gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
