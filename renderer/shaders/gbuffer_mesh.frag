#version 450
#include "gbuffer_mesh_fs.glsl"
