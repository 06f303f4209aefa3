// deferred_lighting, vertex stage: the full-screen triangle.
#version 450
#pragma penumbra_variants ALBEDO
#include "fullscreen.glsl"
