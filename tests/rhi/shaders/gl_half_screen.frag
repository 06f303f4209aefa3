// OpenGL backend test: the push-constant colour on rows with y < split, black elsewhere.
#version 450

layout(push_constant) uniform Push {
    vec4 color;
    float split;
} pc;

layout(location = 0) out vec4 outColor;

void main() {
    outColor = gl_FragCoord.y < pc.split ? pc.color : vec4(0.0, 0.0, 0.0, 1.0);
}
