// GPU evaluator of shape programs (engine/sdf/shape_program.h; record layout in docs/FORMATS.md,
// "Shape programs"). The same instruction set, stacks and rules as the double-precision CPU
// reference sdf::evaluateShapeProgram, in float; tests/renderer/shape_program_gpu_test.cpp checks
// the two against each other on both backends.
//
// Use: define the set and binding of the records buffer, then include this file; it declares the
// buffer itself (the block type name `ShapeRecords` is the name ShaderParams binds it by):
//
//     #define SHAPE_RECORDS_SET 2
//     #define SHAPE_RECORDS_BINDING 0
//     #include "shape_program.glsl"
//     //  -> layout(set = 2, binding = 0, std430) readonly buffer ShapeRecords {
//     //         ShapeInstruction shapeRecords[]; };
//     float d = evalShapeProgram(first, p);   // first = index of the program's header record
//
// Several programs may share the buffer (each one is its header followed by its instructions, as
// sdf::ShapeProgram::records). The program must have passed sdf::validateShapeProgram (the
// evaluator relies on its rules: operand counts, stack depths within ShapeProgramLimits' 16
// distances and 8 frames, finite parameters, unit quaternions, repetition cells).
//
// Precision. Parameters are the records' floats on both sides (the CPU reads the same floats into
// doubles), so float and double differ only by the rounding of the evaluation itself: the point
// transforms (p - t, the quaternion rotation, the division by the scale), the repetition cell and
// the shape formulas. That rounding is a few float ulps of the magnitudes involved — |p| and the
// translations, sizes, spacings and smooth radii met — not of the distance: measured up to 4.7 ulps
// (5.6e-7 * M, M = max(1, |p|, the program's bounds)). Near a surface ~1000 units from the program's
// origin that is ~3e-5, over the 1e-5 the issue-10 rule allows there. Repetition picks the cell with
// floor() in float: a point within a rounding error of a cell boundary may be evaluated in the
// neighbouring cell; both give a valid bound (PopRepeat bounds the other copies).
// So the returned distance is moved towards zero (never across it) by SHAPE_EVAL_MARGIN, 16 ulps of
// the largest magnitude met: |d| never exceeds the double-precision value (and so the exact
// distance) plus 1e-5 * max(1, |d|) — tests/renderer/shape_program_gpu_test.cpp, both backends.
// SHAPE_EVAL_NO_MARGIN (defined before the include) returns the raw float value instead.

#ifndef SHAPE_RECORDS_SET
#error "define SHAPE_RECORDS_SET and SHAPE_RECORDS_BINDING before including shape_program.glsl"
#endif

// One 64-byte record, the layout of sdf::ShapeInstruction: head.x = op, head.yzw = i[0..2].
struct ShapeInstruction {
    uvec4 head;
    vec4 a;
    vec4 b;
    vec4 c;
};

layout(set = SHAPE_RECORDS_SET, binding = SHAPE_RECORDS_BINDING, std430) readonly buffer ShapeRecords {
    ShapeInstruction shapeRecords[];
};

// Opcodes (sdf::ShapeOp).
const uint SHAPE_OP_SPHERE = 1u;
const uint SHAPE_OP_BOX = 2u;
const uint SHAPE_OP_ROUNDED_BOX = 3u;
const uint SHAPE_OP_CAPSULE = 4u;
const uint SHAPE_OP_CYLINDER = 5u;
const uint SHAPE_OP_TORUS = 6u;
const uint SHAPE_OP_CONE = 7u;
const uint SHAPE_OP_PLANE = 8u;
const uint SHAPE_OP_UNION = 16u;
const uint SHAPE_OP_SUBTRACT = 17u;
const uint SHAPE_OP_INTERSECT = 18u;
const uint SHAPE_OP_SMOOTH_UNION = 19u;
const uint SHAPE_OP_SMOOTH_SUBTRACT = 20u;
const uint SHAPE_OP_SMOOTH_INTERSECT = 21u;
const uint SHAPE_OP_PUSH_TRANSFORM = 32u;
const uint SHAPE_OP_PUSH_REPEAT = 33u;
const uint SHAPE_OP_POP_TRANSFORM = 34u;
const uint SHAPE_OP_POP_REPEAT = 35u;

// Fixed stacks: sdf::ShapeProgramLimits::maxDistanceStack and maxFrameStack (+ the root frame).
const int SHAPE_MAX_DISTANCES = 16;
const int SHAPE_MAX_FRAMES = 8;
// Stands for +infinity (no neighbouring copy; a program with no result, which validation excludes).
const float SHAPE_FAR = 3.0e38;

// Signed distance of one shape (sdf::shapeDistance) at p in its own frame.
float shapeDistance(uint op, vec4 q, vec3 p) {
    if (op == SHAPE_OP_SPHERE) return length(p) - q.x;
    if (op == SHAPE_OP_BOX || op == SHAPE_OP_ROUNDED_BOX) {
        float r = op == SHAPE_OP_ROUNDED_BOX ? q.w : 0.0;
        vec3 d = abs(p) - (q.xyz - vec3(r));
        return length(max(d, vec3(0.0))) + min(max(d.x, max(d.y, d.z)), 0.0) - r;
    }
    if (op == SHAPE_OP_CAPSULE) {
        vec3 d = p;
        d.y -= clamp(d.y, -q.y, q.y);
        return length(d) - q.x;
    }
    if (op == SHAPE_OP_CYLINDER) {
        vec2 d = vec2(length(p.xz) - q.x, abs(p.y) - q.y);
        return min(max(d.x, d.y), 0.0) + length(max(d, vec2(0.0)));
    }
    if (op == SHAPE_OP_TORUS) {
        vec2 d = vec2(length(p.xz) - q.x, p.y);
        return length(d) - q.y;
    }
    if (op == SHAPE_OP_CONE) {
        // Capped cone along Y: radius r1 = q.x at y = -h, r2 = q.y at y = +h, h = q.z.
        float r1 = q.x, r2 = q.y, h = q.z;
        vec2 w = vec2(length(p.xz), p.y);
        vec2 k1 = vec2(r2, h);
        vec2 k2 = vec2(r2 - r1, 2.0 * h);
        vec2 ca = vec2(w.x - min(w.x, w.y < 0.0 ? r1 : r2), abs(w.y) - h);
        vec2 cb = w - k1 + k2 * clamp(dot(k1 - w, k2) / dot(k2, k2), 0.0, 1.0);
        float s = (cb.x < 0.0 && ca.y < 0.0) ? -1.0 : 1.0;
        return s * sqrt(min(dot(ca, ca), dot(cb, cb)));
    }
    // SHAPE_OP_PLANE: xyz unit normal, w offset.
    return dot(p, q.xyz) - q.w;
}

// Polynomial smooth minimum / maximum (sdf::smoothMin / smoothMax), radius k > 0.
float shapeSmoothMin(float a, float b, float k) {
    float h = clamp(0.5 + 0.5 * (b - a) / k, 0.0, 1.0);
    return b + (a - b) * h - k * h * (1.0 - h);
}
float shapeSmoothMax(float a, float b, float k) { return -shapeSmoothMin(-a, -b, k); }

// The conjugate of the unit quaternion q (xyz, w) applied to v: the inverse rotation, with glm's
// formula (the one the CPU reference uses).
vec3 shapeInverseRotate(vec4 q, vec3 v) {
    vec3 u = -q.xyz;
    vec3 uv = cross(u, v);
    vec3 uuv = cross(u, uv);
    return v + (uv * q.w + uuv) * 2.0;
}

// Repetition: the point relative to its cell's copy (xyz) and the cell index (id).
vec3 shapeRepeatCell(vec3 p, vec3 spacing, uvec3 count, out ivec3 id) {
    vec3 local = p;
    id = ivec3(0);
    for (int k = 0; k < 3; ++k) {
        if (count[k] < 2u) continue;
        float off = 0.5 * float(count[k] - 1u);
        float c = clamp(floor(p[k] / spacing[k] + off + 0.5), 0.0, float(count[k] - 1u));
        id[k] = int(c);
        local[k] = p[k] - spacing[k] * (c - off);
    }
    return local;
}

float shapeInterval(float x, float lo, float hi) { return max(max(lo - x, x - hi), 0.0); }

// Lower bound of the distance to every copy other than the cell's own (repeat node units), from
// the child's bounds [lo, hi] (FORMATS.md, PopRepeat).
float shapeOtherCopiesBound(vec3 local, ivec3 id, vec3 spacing, uvec3 count, vec3 lo, vec3 hi) {
    vec3 own, next, best;
    for (int k = 0; k < 3; ++k) {
        own[k] = shapeInterval(local[k], lo[k], hi[k]);
        next[k] = SHAPE_FAR;  // no neighbouring copy on this axis
        if (count[k] > 1u) {
            if (id[k] > 0)
                next[k] = min(next[k], shapeInterval(local[k], lo[k] - spacing[k], hi[k] - spacing[k]));
            if (id[k] < int(count[k]) - 1)
                next[k] = min(next[k], shapeInterval(local[k], lo[k] + spacing[k], hi[k] + spacing[k]));
        }
        best[k] = min(own[k], next[k]);
    }
    float g2 = SHAPE_FAR;
    for (int a = 0; a < 3; ++a) {
        if (next[a] >= SHAPE_FAR) continue;
        float sum = next[a] * next[a];
        for (int k = 0; k < 3; ++k) {
            if (k != a) sum += best[k] * best[k];
        }
        g2 = min(g2, sum);
    }
    return sqrt(g2);
}

// Float rounding margin (program-frame units) taken off |d|: 2^-19 (16 float ulps) of `mag`, the
// largest of |p| (root frame) and the translations, shape parameters, spacings and smooth radii met,
// each in root units. The measured rounding stays below 5 ulps of that (shape_program_gpu_test).
#define SHAPE_EVAL_MARGIN(mag) (1.9073486328125e-6 * (mag))

// The margin of a distance d evaluated with magnitude mag (the program's last step).
float shapeApplyMargin(float d, float mag) {
#ifdef SHAPE_EVAL_NO_MARGIN
    return d;  // the raw float evaluation (tests measure its rounding error)
#else
    // Conservative: move towards zero by the rounding margin (never across it).
    float margin = SHAPE_EVAL_MARGIN(mag);
    return d > 0.0 ? max(d - margin, 0.0) : min(d + margin, 0.0);
#endif
}

// evalShapeProgram for a program of one shape instruction (sdfShapePrimitivesOnly on the C++
// side): the same arithmetic without the interpreter's loop, stacks and frames, so the same value.
float evalShapePrimitive(uint first, vec3 point) {
    ShapeInstruction r = shapeRecords[first + 1u];
    float mag = max(abs(point.x), max(abs(point.y), abs(point.z)));
    mag = max(mag, max(max(abs(r.a.x), abs(r.a.y)), max(abs(r.a.z), abs(r.a.w))));
    return shapeApplyMargin(shapeDistance(r.head.x, r.a, point), mag);
}

float evalShapeProgram(uint first, vec3 point) {
    // The current frame (p, s) and the top distance live in registers; the arrays hold what lies
    // below them (frames 0 .. fp - 1, distances 0 .. sp - 2). Where instructions share work it is
    // done once for all of them (a GPU that runs every branch of a SIMD group pays for each one):
    // one array access per kind, one repetition cell, one (smooth) minimum.
    vec3 framePoint[SHAPE_MAX_FRAMES];
    float frameScale[SHAPE_MAX_FRAMES];
    float stack[SHAPE_MAX_DISTANCES];
    int fp = 0;
    int sp = 0;
    vec3 p = point;
    float s = 1.0;
    float top = SHAPE_FAR;
    float mag = max(abs(point.x), max(abs(point.y), abs(point.z)));
    uint count = shapeRecords[first].head.z;  // header: i = (version, instructions, stacks)
    for (uint i = first + 1u; i <= first + count; ++i) {
        ShapeInstruction r = shapeRecords[i];
        uint op = r.head.x;
        if (op >= SHAPE_OP_SPHERE && op <= SHAPE_OP_PLANE) {
            if (sp > 0) stack[sp - 1] = top;
            top = shapeDistance(op, r.a, p) * s;
            sp += 1;
            // Rounding of the shape formula happens at the size of its parameters (frame units).
            mag = max(mag, max(max(abs(r.a.x), abs(r.a.y)), max(abs(r.a.z), abs(r.a.w))) * s);
        } else if (op >= SHAPE_OP_UNION && op <= SHAPE_OP_SMOOTH_INTERSECT) {
            // a (below) op b (top); the maxima are negated minima: max(a, b) = -min(-a, -b),
            // max(a, -b) = -min(-a, b), and sdf::smoothMax likewise (exact: negation is).
            sp -= 1;
            float a = stack[sp - 1];
            bool isMax = op == SHAPE_OP_SUBTRACT || op == SHAPE_OP_INTERSECT ||
                         op == SHAPE_OP_SMOOTH_SUBTRACT || op == SHAPE_OP_SMOOTH_INTERSECT;
            bool subtract = op == SHAPE_OP_SUBTRACT || op == SHAPE_OP_SMOOTH_SUBTRACT;
            float x = isMax ? -a : a;
            float y = isMax != subtract ? -top : top;
            float m = op >= SHAPE_OP_SMOOTH_UNION ? shapeSmoothMin(x, y, r.a.x * s) : min(x, y);
            top = isMax ? -m : m;
        } else if (op >= SHAPE_OP_PUSH_TRANSFORM && op <= SHAPE_OP_POP_REPEAT) {
            bool push = op == SHAPE_OP_PUSH_TRANSFORM || op == SHAPE_OP_PUSH_REPEAT;
            if (push) {
                framePoint[fp] = p;
                frameScale[fp] = s;
                fp += 1;
            } else {
                fp -= 1;
                p = framePoint[fp];
                s = frameScale[fp];
            }
            // PushRepeat enters the cell of the current point, PopRepeat bounds the other copies
            // around the cell of the restored one.
            ivec3 id;
            vec3 local = shapeRepeatCell(p, r.a.xyz, r.head.yzw, id);
            if (op == SHAPE_OP_PUSH_TRANSFORM) {
                mag = max(mag, max(abs(r.a.x), max(abs(r.a.y), abs(r.a.z))) * s);
                p = shapeInverseRotate(r.b, p - r.a.xyz) / r.a.w;
                s = s * r.a.w;
            } else if (op == SHAPE_OP_PUSH_REPEAT) {
                mag = max(mag, max(r.a.x, max(r.a.y, r.a.z)) * s);
                p = local;
            } else if (op == SHAPE_OP_POP_REPEAT) {
                float g = shapeOtherCopiesBound(local, id, r.a.xyz, r.head.yzw, r.b.xyz, r.c.xyz);
                top = min(top, g * s);
            }
        }
    }
    return shapeApplyMargin(sp > 0 ? top : SHAPE_FAR, mag);
}
