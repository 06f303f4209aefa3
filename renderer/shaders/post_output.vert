// post_output, vertex stage: the full-screen triangle.
#version 450
#pragma penumbra_variants MOTION_BLUR
#include "fullscreen.glsl"
