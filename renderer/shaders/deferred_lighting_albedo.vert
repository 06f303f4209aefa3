#version 450
#include "fullscreen.glsl"
