#version 450
#define GBUFFER_ALBEDO 1
#include "deferred_lighting_fs.glsl"
