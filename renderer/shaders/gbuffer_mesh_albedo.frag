#version 450
#define GBUFFER_ALBEDO 1
#include "gbuffer_mesh_fs.glsl"
