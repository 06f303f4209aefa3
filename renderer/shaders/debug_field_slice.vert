// debug_field_slice, vertex stage: the full-screen triangle.
#version 450
#pragma penumbra_variants SDF_FIELDS
#include "fullscreen.glsl"
