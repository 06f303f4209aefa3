// Test program for the GPU shape-program evaluator (renderer/shaders/shape_program.glsl): one
// invocation per point, each point naming the header record of its program in the shared records
// buffer. The SHAPE_EVAL_NO_MARGIN variant returns the raw float value (no conservative margin);
// SHAPE_PRIMITIVE evaluates one-instruction programs with evalShapePrimitive (the trace's
// SHAPE_PRIMITIVES shortcut) instead of the interpreter.
#version 450
#pragma penumbra_variants SHAPE_EVAL_NO_MARGIN SHAPE_PRIMITIVE
layout(local_size_x = 64) in;

#define SHAPE_RECORDS_SET 0
#define SHAPE_RECORDS_BINDING 0
#include "shape_program.glsl"

struct EvalPoint {
    vec3 p;        // program frame
    uint program;  // index of the program's header record in shapeRecords
};

layout(set = 0, binding = 1, std430) readonly buffer EvalPoints { EvalPoint points[]; };
layout(set = 0, binding = 2, std430) writeonly buffer EvalDistances { float distances[]; };

layout(push_constant) uniform EvalPush { uvec4 count; } pc;  // x: number of points

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count.x) return;
    EvalPoint e = points[i];
#ifdef SHAPE_PRIMITIVE
    distances[i] = evalShapePrimitive(e.program, e.p);
#else
    distances[i] = evalShapeProgram(e.program, e.p);
#endif
}
