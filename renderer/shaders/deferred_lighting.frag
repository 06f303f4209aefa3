#version 450
#include "deferred_lighting_fs.glsl"
