// Analytic SDF shapes as data: a tree of shapes, CSG operations and domain repetition (ShapeNode)
// is compiled into a flat, versioned instruction program (ShapeProgram) that a shader evaluates with
// two small stacks. The layout of the records is documented in docs/FORMATS.md ("Shape programs"),
// precisely enough to write the GLSL evaluator from it; evaluateShapeProgram() is the double-
// precision CPU reference of that evaluator.
//
//   sdf::ShapeNode root = sdf::ShapeNode::csg(sdf::CsgOp::Subtract,
//       {sdf::ShapeNode::box({1, 1, 1}), sdf::ShapeNode::sphere(1.2)});
//   sdf::ShapeProgram program;
//   std::string error;
//   if (!sdf::compileShapeProgram(root, program, error)) report(error);
//   double d = sdf::evaluateShapeProgram(program, {0.5, 2.0, 0.0});
//
// Distance rules (each checked by tests/sdf/shape_program_test.cpp):
//  - every shape is an exact signed distance; transforms (translation, rotation, uniform scale)
//    keep exactness; hard union is exact outside the solid (inside, |d| is never overestimated);
//  - subtraction, intersection, the smooth operations and repetition return bounds: |d| never
//    exceeds the distance to the surface the program describes (its zero set).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace penumbra::sdf {

// Version of the record layout (the header record's first integer).
inline constexpr uint32_t kShapeProgramVersion = 1;

// Opcodes (ShapeInstruction::op). Values are part of the format.
enum class ShapeOp : uint32_t {
    Header = 0,  // first record only
    // Shapes push one distance.
    Sphere = 1,
    Box = 2,
    RoundedBox = 3,
    Capsule = 4,
    Cylinder = 5,
    Torus = 6,
    Cone = 7,
    Plane = 8,
    // Binary operations pop b, pop a, push op(a, b).
    Union = 16,
    Subtract = 17,  // a minus b
    Intersect = 18,
    SmoothUnion = 19,
    SmoothSubtract = 20,
    SmoothIntersect = 21,
    // Frames: push a new evaluation point derived from the current one; pop restores it.
    PushTransform = 32,
    PushRepeat = 33,
    PopTransform = 34,
    PopRepeat = 35,  // also folds in the bound of the copies not evaluated (FORMATS.md)
};

// One 64-byte record: std430-compatible (uvec4, vec4, vec4, vec4; array stride 64).
struct ShapeInstruction {
    uint32_t op = 0;
    std::array<uint32_t, 3> i{0, 0, 0};
    glm::vec4 a{0.0f};
    glm::vec4 b{0.0f};
    glm::vec4 c{0.0f};
};
static_assert(sizeof(ShapeInstruction) == 64, "the GPU record is 64 bytes");

// Axis-aligned box; unbounded axes hold -inf / +inf.
struct ShapeBounds {
    glm::dvec3 min{0.0};
    glm::dvec3 max{0.0};
    bool finite() const;
};

// A compiled program: records[0] is the header (see FORMATS.md), then the instructions.
struct ShapeProgram {
    std::vector<ShapeInstruction> records;
    ShapeBounds bounds;             // the solid (d <= 0) lies inside; also in the header
    uint32_t maxDistanceStack = 0;  // deepest distance stack the program needs
    uint32_t maxFrameStack = 0;     // deepest frame stack (pushed frames, the root not counted)
    uint32_t instructionCount() const { return records.empty() ? 0 : uint32_t(records.size() - 1); }
};

struct ShapeProgramLimits {
    uint32_t maxInstructions = 1024;  // header not counted
    uint32_t maxDistanceStack = 16;   // a GLSL evaluator's fixed array size
    uint32_t maxFrameStack = 8;
    uint32_t maxRepeatCount = 1024;      // copies per axis
    uint64_t maxRepeatCopies = 1 << 20;  // copies of one repetition in all
    double maxMagnitude = 1.0e6;         // |any length parameter, translation| in scene units
};

// ---- the tree the builder compiles -----------------------------------------------------------------

enum class ShapeKind : uint8_t { Sphere, Box, RoundedBox, Capsule, Cylinder, Torus, Cone, Plane };
enum class CsgOp : uint8_t { Union, Subtract, Intersect };

const char* shapeKindName(ShapeKind k);  // "sphere", "box", "roundedBox", ...
bool parseShapeKind(std::string_view s, ShapeKind& out);
const char* csgOpName(CsgOp op);  // "union", "subtract", "intersect"
bool parseCsgOp(std::string_view s, CsgOp& out);

// Node placement in its parent's frame: p_parent = translation + rotation * (scale * p_node).
struct ShapeTransform {
    glm::dvec3 translation{0.0};
    glm::dquat rotation{1.0, 0.0, 0.0, 0.0};  // w, x, y, z; unit
    double scale = 1.0;                       // uniform, > 0
    bool identity() const;
};

struct ShapeNode {
    enum class Type : uint8_t { Shape, Csg, Repeat };
    Type type = Type::Shape;
    ShapeTransform transform;

    // Shape parameters (all lengths in the node's frame):
    //  Sphere:     x = radius
    //  Box:        xyz = half extents
    //  RoundedBox: xyz = half extents (the rounding lies inside them), w = rounding radius
    //  Capsule:    x = radius, y = half length of the core segment along Y
    //  Cylinder:   x = radius, y = half height along Y (capped)
    //  Torus:      x = major radius (ring in the XZ plane), y = minor radius
    //  Cone:       x = radius at y = -h, y = radius at y = +h (0: a point), z = half height h
    //  Plane:      xyz = unit normal, w = offset (surface dot(p, n) = w; solid on the -n side)
    ShapeKind shape = ShapeKind::Sphere;
    glm::dvec4 params{0.0};

    // Csg: children folded from the left, op(op(c0, c1), c2) ...; at least two children.
    CsgOp op = CsgOp::Union;
    double smoothRadius = 0.0;  // > 0: the smooth variant blending over this radius (node units)

    // Repeat: one child, copies centred on the node origin, `count` per axis, `spacing` apart.
    glm::dvec3 spacing{0.0};
    glm::uvec3 count{1, 1, 1};

    std::vector<ShapeNode> children;

    static ShapeNode sphere(double radius);
    static ShapeNode box(glm::dvec3 halfExtents);
    static ShapeNode roundedBox(glm::dvec3 halfExtents, double radius);
    static ShapeNode capsule(double radius, double halfLength);
    static ShapeNode cylinder(double radius, double halfHeight);
    static ShapeNode torus(double majorRadius, double minorRadius);
    static ShapeNode cone(double bottomRadius, double topRadius, double halfHeight);
    static ShapeNode plane(glm::dvec3 normal, double offset);
    static ShapeNode csg(CsgOp op, std::vector<ShapeNode> children, double smoothRadius = 0.0);
    static ShapeNode repeat(ShapeNode child, glm::dvec3 spacing, glm::uvec3 count);
    ShapeNode& placed(glm::dvec3 translation, glm::dquat rotation = {1, 0, 0, 0}, double scale = 1.0);
};

// Compiles and validates a tree. On failure `out` is unchanged and `error` names the node as a
// JSON pointer relative to the root ("" for the root, "/children/1" ...) and the reason.
bool compileShapeProgram(const ShapeNode& root, ShapeProgram& out, std::string& error,
                         const ShapeProgramLimits& limits = {});

// Checks a record array as a GPU upload would receive it (header, version, opcodes, operand
// counts, stack depths, finite and in-range parameters, unit quaternions, repetition cells). The
// GPU evaluator may assume every rule checked here. `error` names the record index.
bool validateShapeProgram(const std::vector<ShapeInstruction>& records, std::string& error,
                          const ShapeProgramLimits& limits = {});

// Signed distance of a valid program at point p (program frame), in double precision.
double evaluateShapeProgram(const ShapeProgram& program, const glm::dvec3& p);

// The exact signed distance of one shape at p in its own frame (the CPU reference of each opcode).
double shapeDistance(ShapeKind kind, const glm::dvec4& params, const glm::dvec3& p);

// The polynomial smooth minimum / maximum used by the smooth operations (radius k > 0).
double smoothMin(double a, double b, double k);
double smoothMax(double a, double b, double k);

}  // namespace penumbra::sdf
