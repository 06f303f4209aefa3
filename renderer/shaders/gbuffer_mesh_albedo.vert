#version 450
#include "gbuffer_mesh_vs.glsl"
