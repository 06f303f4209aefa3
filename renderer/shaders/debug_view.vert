// debug_view, vertex stage: the full-screen triangle.
#version 450
#pragma penumbra_variants ALBEDO AUX ALBEDO+AUX
#include "fullscreen.glsl"
