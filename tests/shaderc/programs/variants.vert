#version 450
// One source, several programs: the variants declared here and in variants.frag are compiled
// for both stages (a variant's vertex and fragment shader always belong together).
#pragma penumbra_variants FLIP_Y
#include "view.glsl"

layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec2 vUv;

void main() {
    vec4 clip = view.viewProj * vec4(inPosition, 1.0);
#ifdef FLIP_Y
    clip.y = -clip.y;
#endif
    vUv = inPosition.xy;
    gl_Position = clip;
}
