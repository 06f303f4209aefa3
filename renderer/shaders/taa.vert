// taa, vertex stage: the full-screen triangle.
#version 450
#include "fullscreen.glsl"
