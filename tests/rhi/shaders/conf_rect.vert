#version 450
#include "conf_rect_vs.glsl"
