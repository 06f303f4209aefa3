// Included by reflect_all.comp: proves #include works in programs built by penumbra_add_shader_dir.
#ifndef REFLECT_COMMON_GLSL
#define REFLECT_COMMON_GLSL

float scaleValue(float x, float s) { return x * s; }

#endif
