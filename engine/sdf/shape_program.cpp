#include "engine/sdf/shape_program.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include <fmt/format.h>
#include <glm/geometric.hpp>

namespace penumbra::sdf {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kUnitTolerance = 1e-5;  // |normal| and |quaternion| must be 1 within this
constexpr double kMinScale = 1e-6;

bool isShapeOp(uint32_t op) { return op >= uint32_t(ShapeOp::Sphere) && op <= uint32_t(ShapeOp::Plane); }
bool isBinaryOp(uint32_t op) {
    return op >= uint32_t(ShapeOp::Union) && op <= uint32_t(ShapeOp::SmoothIntersect);
}
bool isSmoothOp(uint32_t op) {
    return op >= uint32_t(ShapeOp::SmoothUnion) && op <= uint32_t(ShapeOp::SmoothIntersect);
}

ShapeKind kindOf(uint32_t op) { return ShapeKind(op - uint32_t(ShapeOp::Sphere)); }
uint32_t opOf(ShapeKind k) { return uint32_t(ShapeOp::Sphere) + uint32_t(k); }

bool finite4(const glm::vec4& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && std::isfinite(v.w);
}

// ---- parameter rules, shared by the compiler (node pointers) and the validator (record indices) --

// "" when the shape's parameters are valid.
std::string checkShapeParams(ShapeKind kind, const glm::dvec4& q, double maxMag) {
    auto length = [&](double v, std::string_view what, bool allowZero) -> std::string {
        if (!std::isfinite(v)) return fmt::format("{} is not a finite number", what);
        if (allowZero ? v < 0.0 : v <= 0.0) {
            return fmt::format("{} must be {} 0 (got {})", what, allowZero ? ">=" : ">", v);
        }
        if (v > maxMag) return fmt::format("{} {} exceeds the limit of {}", what, v, maxMag);
        return {};
    };
    std::string e;
    switch (kind) {
        case ShapeKind::Sphere:
            return length(q.x, "radius", false);
        case ShapeKind::Box:
            for (int k = 0; k < 3 && e.empty(); ++k) e = length(q[k], "halfExtents", false);
            return e;
        case ShapeKind::RoundedBox:
            for (int k = 0; k < 3 && e.empty(); ++k) e = length(q[k], "halfExtents", false);
            if (e.empty()) e = length(q.w, "rounding radius", true);
            if (e.empty() && q.w > std::min({q.x, q.y, q.z})) {
                e = fmt::format("rounding radius ({}) must not exceed the smallest half extent ({})", q.w,
                                std::min({q.x, q.y, q.z}));
            }
            return e;
        case ShapeKind::Capsule:
            e = length(q.x, "radius", false);
            return e.empty() ? length(q.y, "halfLength", true) : e;
        case ShapeKind::Cylinder:
            e = length(q.x, "radius", false);
            return e.empty() ? length(q.y, "halfHeight", false) : e;
        case ShapeKind::Torus:
            e = length(q.x, "majorRadius", false);
            if (e.empty()) e = length(q.y, "minorRadius", false);
            if (e.empty() && !(q.y < q.x)) {
                e = fmt::format("minorRadius ({}) must be smaller than majorRadius ({})", q.y, q.x);
            }
            return e;
        case ShapeKind::Cone:
            e = length(q.x, "bottomRadius", true);
            if (e.empty()) e = length(q.y, "topRadius", true);
            if (e.empty()) e = length(q.z, "halfHeight", false);
            if (e.empty() && !(q.x > 0.0 || q.y > 0.0)) e = "bottomRadius and topRadius are both 0";
            return e;
        case ShapeKind::Plane: {
            for (int k = 0; k < 4; ++k) {
                if (!std::isfinite(q[k])) return "the plane's normal and offset must be finite";
            }
            const double len = glm::length(glm::dvec3(q));
            if (std::abs(len - 1.0) > kUnitTolerance) {
                return fmt::format("the plane normal must have unit length (got length {})", len);
            }
            if (std::abs(q.w) > maxMag) return fmt::format("offset {} exceeds the limit of {}", q.w, maxMag);
            return {};
        }
    }
    return "unknown shape";
}

std::string checkTransform(const glm::dvec3& t, const glm::dquat& r, double s, double maxMag) {
    for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(t[k]) || std::abs(t[k]) > maxMag) {
            return fmt::format("translation component {} must be finite and within [-{}, {}]", t[k], maxMag,
                               maxMag);
        }
    }
    const double qlen = std::sqrt(r.w * r.w + r.x * r.x + r.y * r.y + r.z * r.z);
    if (!std::isfinite(qlen) || std::abs(qlen - 1.0) > kUnitTolerance) {
        return fmt::format("the rotation quaternion must have unit length (got length {})", qlen);
    }
    if (!std::isfinite(s) || s < kMinScale || s > maxMag) {
        return fmt::format("scale must be a finite number in [{}, {}] (got {})", kMinScale, maxMag, s);
    }
    return {};
}

std::string checkRepeat(const glm::dvec3& spacing, const glm::uvec3& count,
                        const ShapeProgramLimits& limits) {
    uint64_t copies = 1;
    for (int k = 0; k < 3; ++k) {
        if (count[k] < 1 || count[k] > limits.maxRepeatCount) {
            return fmt::format("count {} is out of range [1, {}]", count[k], limits.maxRepeatCount);
        }
        copies *= count[k];
        if (!std::isfinite(spacing[k]) || spacing[k] < 0.0 || spacing[k] > limits.maxMagnitude) {
            return fmt::format("spacing {} must be finite and within [0, {}]", spacing[k],
                               limits.maxMagnitude);
        }
        if (count[k] > 1 && !(spacing[k] > 0.0)) {
            return fmt::format("spacing must be > 0 on an axis with more than one copy (axis {})", "xyz"[k]);
        }
    }
    if (copies > limits.maxRepeatCopies) {
        return fmt::format("{} copies exceed the limit of {}", copies, limits.maxRepeatCopies);
    }
    return {};
}

std::string checkSmooth(double k, double maxMag) {
    if (!std::isfinite(k) || !(k > 0.0) || k > maxMag) {
        return fmt::format("the smooth radius must be a finite number in (0, {}] (got {})", maxMag, k);
    }
    return {};
}

// ---- bounds ---------------------------------------------------------------------------------------

ShapeBounds shapeBounds(ShapeKind kind, const glm::dvec4& q) {
    auto sym = [](glm::dvec3 h) { return ShapeBounds{-h, h}; };
    switch (kind) {
        case ShapeKind::Sphere:
            return sym(glm::dvec3(q.x));
        case ShapeKind::Box:
        case ShapeKind::RoundedBox:
            return sym(glm::dvec3(q));
        case ShapeKind::Capsule:
            return sym({q.x, q.y + q.x, q.x});
        case ShapeKind::Cylinder:
            return sym({q.x, q.y, q.x});
        case ShapeKind::Torus:
            return sym({q.x + q.y, q.y, q.x + q.y});
        case ShapeKind::Cone: {
            const double r = std::max(q.x, q.y);
            return sym({r, q.z, r});
        }
        case ShapeKind::Plane: {
            ShapeBounds b{glm::dvec3(-kInf), glm::dvec3(kInf)};
            // An axis-aligned plane bounds one side of one axis (the solid is dot(p, n) <= w).
            for (int k = 0; k < 3; ++k) {
                const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
                if (q[k1] != 0.0 || q[k2] != 0.0) continue;
                if (q[k] > 0.0) b.max[k] = q.w / q[k];
                if (q[k] < 0.0) b.min[k] = q.w / q[k];
            }
            return b;
        }
    }
    return {glm::dvec3(-kInf), glm::dvec3(kInf)};
}

ShapeBounds enclose(const ShapeBounds& a, const ShapeBounds& b) {
    return {glm::min(a.min, b.min), glm::max(a.max, b.max)};
}

double volume(const ShapeBounds& b) {
    const glm::dvec3 e = b.max - b.min;
    return e.x * e.y * e.z;  // +inf when unbounded
}

// The box of op(a, b): the solid lies inside, and the value of op is at least the distance to the
// box outside it (FORMATS.md, "Bounds"), given that both inputs have these properties.
ShapeBounds combineBounds(uint32_t op, const ShapeBounds& a, const ShapeBounds& b, double k) {
    switch (ShapeOp(op)) {
        case ShapeOp::Union:
            return enclose(a, b);
        case ShapeOp::SmoothUnion: {
            ShapeBounds e = enclose(a, b);
            e.min -= glm::dvec3(0.25 * k);
            e.max += glm::dvec3(0.25 * k);
            return e;
        }
        case ShapeOp::Subtract:
        case ShapeOp::SmoothSubtract:
            return a;
        case ShapeOp::Intersect:
        case ShapeOp::SmoothIntersect:
            return volume(b) < volume(a) ? b : a;
        default:
            return a;
    }
}

glm::dvec3 rotate(const glm::dquat& q, const glm::dvec3& v) { return q * v; }

ShapeBounds transformBounds(const ShapeBounds& b, const glm::dvec3& t, const glm::dquat& r, double s) {
    if (!b.finite()) {
        if (r == glm::dquat(1.0, 0.0, 0.0, 0.0)) return {b.min * s + t, b.max * s + t};
        return {glm::dvec3(-kInf), glm::dvec3(kInf)};
    }
    ShapeBounds out{glm::dvec3(kInf), glm::dvec3(-kInf)};
    for (int c = 0; c < 8; ++c) {
        const glm::dvec3 corner((c & 1) ? b.max.x : b.min.x, (c & 2) ? b.max.y : b.min.y,
                                (c & 4) ? b.max.z : b.min.z);
        const glm::dvec3 w = t + rotate(r, corner * s);
        out.min = glm::min(out.min, w);
        out.max = glm::max(out.max, w);
    }
    // Rotation rounding: widen by a relative epsilon so the box stays conservative.
    const glm::dvec3 pad = (glm::abs(out.min) + glm::abs(out.max)) * 1e-12;
    return {out.min - pad, out.max + pad};
}

ShapeBounds repeatBounds(const ShapeBounds& child, const glm::dvec3& spacing, const glm::uvec3& count) {
    ShapeBounds out = child;
    for (int k = 0; k < 3; ++k) {
        const double half = 0.5 * double(count[k] - 1) * spacing[k];
        out.min[k] -= half;
        out.max[k] += half;
    }
    return out;
}

// "" when the child's box lies strictly inside its cell on every axis with more than one copy.
std::string checkRepeatCell(const ShapeBounds& child, const glm::dvec3& spacing, const glm::uvec3& count) {
    for (int k = 0; k < 3; ++k) {
        if (count[k] < 2) continue;
        const double half = 0.5 * spacing[k];
        if (!(child.min[k] > -half) || !(child.max[k] < half)) {
            return fmt::format(
                "the repeated shape's bounds on {} ([{}, {}]) must lie strictly inside its cell ({}, {}) "
                "(spacing {}): copies may not touch or overlap",
                "xyz"[k], child.min[k], child.max[k], -half, half, spacing[k]);
        }
    }
    return {};
}

// Outward rounding to float; infinities become -FLT_MAX / FLT_MAX (records hold finite numbers only).
float roundDown(double v) {
    if (v < -double(std::numeric_limits<float>::max())) return -std::numeric_limits<float>::max();
    float f = float(v);
    if (double(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
    return f;
}
float roundUp(double v) {
    if (v > double(std::numeric_limits<float>::max())) return std::numeric_limits<float>::max();
    float f = float(v);
    if (double(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
    return f;
}

glm::dvec4 d4(const glm::vec4& v) { return glm::dvec4(v); }

// The float values a record holds, read back through memory. The compiler derives bounds from
// exactly what the records hold, because the validator recomputes them from the records; computed
// in registers, GCC 12 at -O2/-O3 produced the unrounded double values here (a repetition's spacing,
// a transform's translation), so nested or transformed repetitions were refused by their own check.
glm::dvec4 storedValues(const glm::vec4& v) {
    volatile float f[4] = {v.x, v.y, v.z, v.w};
    return glm::dvec4(double(f[0]), double(f[1]), double(f[2]), double(f[3]));
}

// ---- repetition: cell selection and the bound of the copies not evaluated ---------------------------

struct RepeatCell {
    glm::dvec3 local;  // the point relative to its cell's copy
    glm::ivec3 id;     // cell index per axis, 0 .. count - 1
};

RepeatCell repeatCell(const glm::dvec3& p, const glm::dvec3& spacing, const glm::uvec3& count) {
    RepeatCell c;
    for (int k = 0; k < 3; ++k) {
        if (count[k] < 2) {
            c.id[k] = 0;
            c.local[k] = p[k];
            continue;
        }
        const double off = 0.5 * double(count[k] - 1);
        const double id = std::clamp(std::floor(p[k] / spacing[k] + off + 0.5), 0.0, double(count[k] - 1));
        c.id[k] = int(id);
        c.local[k] = p[k] - spacing[k] * (id - off);
    }
    return c;
}

double interval(double x, double lo, double hi) { return std::max({lo - x, x - hi, 0.0}); }

// Lower bound of the distance from the point to every copy other than its own cell's (in the
// repeat node's units): the nearest of the neighbouring copies' boxes, per axis.
double otherCopiesBound(const RepeatCell& c, const glm::dvec3& spacing, const glm::uvec3& count,
                        const ShapeBounds& child) {
    double own[3], next[3], best[3];
    for (int k = 0; k < 3; ++k) {
        own[k] = interval(c.local[k], child.min[k], child.max[k]);
        next[k] = kInf;
        if (count[k] > 1) {
            if (c.id[k] > 0) {
                next[k] = std::min(
                    next[k], interval(c.local[k], child.min[k] - spacing[k], child.max[k] - spacing[k]));
            }
            if (c.id[k] < int(count[k]) - 1) {
                next[k] = std::min(
                    next[k], interval(c.local[k], child.min[k] + spacing[k], child.max[k] + spacing[k]));
            }
        }
        best[k] = std::min(own[k], next[k]);
    }
    double g2 = kInf;
    for (int a = 0; a < 3; ++a) {
        if (next[a] == kInf) continue;
        double sum = next[a] * next[a];
        for (int k = 0; k < 3; ++k) {
            if (k != a) sum += best[k] * best[k];
        }
        g2 = std::min(g2, sum);
    }
    return std::sqrt(g2);
}

// ---- the compiler ------------------------------------------------------------------------------

class Compiler {
public:
    Compiler(const ShapeProgramLimits& limits, std::string& error) : m_limits(limits), m_error(error) {}

    std::vector<ShapeInstruction> records;
    std::vector<std::string> origins;  // the node pointer that emitted each record (header: "")

    bool emit(const ShapeNode& n, const std::string& ptr, int depth, ShapeBounds& bounds) {
        if (depth > int(m_limits.maxDistanceStack) + int(m_limits.maxFrameStack) + 64) {
            return fail(ptr, "the shape tree is nested too deeply");
        }
        const ShapeTransform& tf = n.transform;
        const bool placed = !tf.identity();
        glm::dquat r = tf.rotation;
        ShapeInstruction pushedTransform;  // the PushTransform record, when placed
        if (placed) {
            if (std::string e = checkTransform(tf.translation, r, tf.scale, m_limits.maxMagnitude);
                !e.empty()) {
                return fail(ptr + "/transform", e);
            }
            r = glm::normalize(r);
            ShapeInstruction ins;
            ins.op = uint32_t(ShapeOp::PushTransform);
            ins.a = glm::vec4(glm::vec3(tf.translation), float(tf.scale));
            ins.b = glm::vec4(float(r.x), float(r.y), float(r.z), float(r.w));
            if (!push(ins, ptr)) return false;
            pushedTransform = ins;
        }
        ShapeBounds local;
        switch (n.type) {
            case ShapeNode::Type::Shape: {
                glm::dvec4 q = n.params;
                if (n.shape == ShapeKind::Plane) {
                    const double len = glm::length(glm::dvec3(q));
                    if (!std::isfinite(len) || len < 1e-12)
                        return fail(ptr, "the plane normal must be non-zero");
                    q = glm::dvec4(glm::dvec3(q) / len, q.w);
                }
                ShapeInstruction ins;
                ins.op = opOf(n.shape);
                ins.a = glm::vec4(q);
                if (std::string e = checkShapeParams(n.shape, d4(ins.a), m_limits.maxMagnitude); !e.empty()) {
                    return fail(ptr, fmt::format("{}: {}", shapeKindName(n.shape), e));
                }
                if (!n.children.empty()) return fail(ptr, "a shape has no children");
                local = shapeBounds(n.shape, d4(ins.a));
                if (!push(ins, ptr)) return false;
                break;
            }
            case ShapeNode::Type::Csg: {
                if (n.children.size() < 2) {
                    return fail(ptr, fmt::format("a {} needs at least two children (got {})", csgOpName(n.op),
                                                 n.children.size()));
                }
                const bool smooth = n.smoothRadius != 0.0;
                if (smooth) {
                    if (std::string e = checkSmooth(n.smoothRadius, m_limits.maxMagnitude); !e.empty()) {
                        return fail(ptr + "/smoothRadius", e);
                    }
                }
                const uint32_t op =
                    (smooth ? uint32_t(ShapeOp::SmoothUnion) : uint32_t(ShapeOp::Union)) + uint32_t(n.op);
                const float k = smooth ? float(n.smoothRadius) : 0.0f;
                for (size_t c = 0; c < n.children.size(); ++c) {
                    ShapeBounds cb;
                    if (!emit(n.children[c], fmt::format("{}/children/{}", ptr, c), depth + 1, cb))
                        return false;
                    if (c == 0) {
                        local = cb;
                        continue;
                    }
                    ShapeInstruction ins;
                    ins.op = op;
                    ins.a.x = k;
                    local = combineBounds(op, local, cb, double(k));
                    if (!push(ins, ptr)) return false;
                }
                break;
            }
            case ShapeNode::Type::Repeat: {
                if (n.children.size() != 1) {
                    return fail(
                        ptr, fmt::format("a repetition has exactly one child (got {})", n.children.size()));
                }
                ShapeInstruction ins;
                ins.op = uint32_t(ShapeOp::PushRepeat);
                ins.i = {n.count.x, n.count.y, n.count.z};
                ins.a = glm::vec4(glm::vec3(n.spacing), 0.0f);
                const glm::dvec3 spacing(storedValues(ins.a));
                if (std::string e = checkRepeat(spacing, n.count, m_limits); !e.empty()) return fail(ptr, e);
                if (!push(ins, ptr)) return false;
                ShapeBounds cb;
                if (!emit(n.children[0], ptr + "/children/0", depth + 1, cb)) return false;
                ins.op = uint32_t(ShapeOp::PopRepeat);
                ins.b = glm::vec4(roundDown(cb.min.x), roundDown(cb.min.y), roundDown(cb.min.z), 0.0f);
                ins.c = glm::vec4(roundUp(cb.max.x), roundUp(cb.max.y), roundUp(cb.max.z), 0.0f);
                const ShapeBounds stored{glm::dvec3(glm::vec3(ins.b)), glm::dvec3(glm::vec3(ins.c))};
                if (std::string e = checkRepeatCell(stored, spacing, n.count); !e.empty())
                    return fail(ptr, e);
                local = repeatBounds(cb, spacing, n.count);
                if (!push(ins, ptr)) return false;
                break;
            }
        }
        bounds = local;
        if (placed) {
            ShapeInstruction ins;
            ins.op = uint32_t(ShapeOp::PopTransform);
            if (!push(ins, ptr)) return false;
            const glm::dvec4 t = storedValues(pushedTransform.a);
            const glm::dvec4 q = storedValues(pushedTransform.b);
            bounds = transformBounds(local, glm::dvec3(t), glm::dquat(q.w, q.x, q.y, q.z), t.w);
        }
        return true;
    }

private:
    bool push(const ShapeInstruction& ins, const std::string& ptr) {
        if (records.size() - 1 >= m_limits.maxInstructions) {  // the header is not counted
            return fail(ptr,
                        fmt::format("the program needs more than {} instructions", m_limits.maxInstructions));
        }
        records.push_back(ins);
        origins.push_back(ptr);
        return true;
    }
    bool fail(const std::string& ptr, const std::string& reason) {
        m_error = ptr.empty() ? reason : fmt::format("{}: {}", ptr, reason);
        return false;
    }

    const ShapeProgramLimits& m_limits;
    std::string& m_error;
};

// ---- the validator -------------------------------------------------------------------------------

struct Analysis {
    ShapeBounds bounds;
    uint32_t maxDistanceStack = 0;
    uint32_t maxFrameStack = 0;
};

// On failure `error` is "record N: reason"; failedRecord / failedReason hold N and the reason alone.
bool analyse(const std::vector<ShapeInstruction>& records, bool checkHeader, const ShapeProgramLimits& limits,
             Analysis& out, std::string& error, size_t& failedRecord, std::string& failedReason) {
    auto fail = [&](size_t i, const std::string& reason) {
        error = fmt::format("record {}: {}", i, reason);
        failedRecord = i;
        failedReason = reason;
        return false;
    };
    if (records.empty()) {
        error = failedReason = "an empty program (no header record)";
        return false;
    }
    const ShapeInstruction& h = records[0];
    if (h.op != uint32_t(ShapeOp::Header))
        return fail(0, fmt::format("expected the header (op 0), got op {}", h.op));
    if (checkHeader) {
        if (h.i[0] != kShapeProgramVersion) {
            return fail(0, fmt::format("unsupported shape program version {} (expected {})", h.i[0],
                                       kShapeProgramVersion));
        }
        if (h.i[1] != records.size() - 1) {
            return fail(0, fmt::format("the header counts {} instructions, the program has {}", h.i[1],
                                       records.size() - 1));
        }
    }
    if (records.size() - 1 > limits.maxInstructions) {
        return fail(0, fmt::format("{} instructions exceed the limit of {}", records.size() - 1,
                                   limits.maxInstructions));
    }
    if (records.size() < 2) return fail(0, "the program has no instructions");

    struct Frame {
        uint32_t op;
        size_t index;
        size_t height;  // distance stack height when pushed
    };
    std::vector<ShapeBounds> stack;
    std::vector<Frame> frames;
    const double maxMag = limits.maxMagnitude;
    for (size_t i = 1; i < records.size(); ++i) {
        const ShapeInstruction& r = records[i];
        if (!finite4(r.a) || !finite4(r.b) || !finite4(r.c))
            return fail(i, "a parameter is not a finite number");
        if (isShapeOp(r.op)) {
            const ShapeKind kind = kindOf(r.op);
            if (std::string e = checkShapeParams(kind, d4(r.a), maxMag); !e.empty()) {
                return fail(i, fmt::format("{}: {}", shapeKindName(kind), e));
            }
            stack.push_back(shapeBounds(kind, d4(r.a)));
        } else if (isBinaryOp(r.op)) {
            if (stack.size() < 2 || (!frames.empty() && stack.size() < frames.back().height + 2)) {
                return fail(i, "a binary operation needs two operands");
            }
            if (isSmoothOp(r.op)) {
                if (std::string e = checkSmooth(r.a.x, maxMag); !e.empty()) return fail(i, e);
            }
            const ShapeBounds b = stack.back();
            stack.pop_back();
            stack.back() = combineBounds(r.op, stack.back(), b, double(r.a.x));
        } else if (r.op == uint32_t(ShapeOp::PushTransform)) {
            const glm::dquat q(r.b.w, r.b.x, r.b.y, r.b.z);
            if (std::string e = checkTransform(glm::dvec3(glm::vec3(r.a)), q, r.a.w, maxMag); !e.empty()) {
                return fail(i, e);
            }
            frames.push_back({r.op, i, stack.size()});
        } else if (r.op == uint32_t(ShapeOp::PushRepeat)) {
            const glm::uvec3 count(r.i[0], r.i[1], r.i[2]);
            if (std::string e = checkRepeat(glm::dvec3(glm::vec3(r.a)), count, limits); !e.empty())
                return fail(i, e);
            frames.push_back({r.op, i, stack.size()});
        } else if (r.op == uint32_t(ShapeOp::PopTransform) || r.op == uint32_t(ShapeOp::PopRepeat)) {
            const uint32_t pushOp = r.op == uint32_t(ShapeOp::PopTransform) ? uint32_t(ShapeOp::PushTransform)
                                                                            : uint32_t(ShapeOp::PushRepeat);
            if (frames.empty() || frames.back().op != pushOp) {
                return fail(i, fmt::format("op {} does not close a matching op {}", r.op, pushOp));
            }
            if (stack.size() != frames.back().height + 1) {
                return fail(i, fmt::format("a frame must produce exactly one distance (got {})",
                                           stack.size() - frames.back().height));
            }
            const ShapeInstruction& p = records[frames.back().index];
            if (r.op == uint32_t(ShapeOp::PopTransform)) {
                const glm::dquat q(p.b.w, p.b.x, p.b.y, p.b.z);
                stack.back() = transformBounds(stack.back(), glm::dvec3(glm::vec3(p.a)), q, double(p.a.w));
            } else {
                if (r.i != p.i || r.a != p.a) return fail(i, "the repetition's pop differs from its push");
                const glm::uvec3 count(r.i[0], r.i[1], r.i[2]);
                const glm::dvec3 spacing(glm::vec3(r.a));
                const ShapeBounds stored{glm::dvec3(glm::vec3(r.b)), glm::dvec3(glm::vec3(r.c))};
                const ShapeBounds& child = stack.back();
                const double fmax = double(std::numeric_limits<float>::max());
                for (int k = 0; k < 3; ++k) {
                    const bool minOk = stored.min[k] <= child.min[k] || stored.min[k] == -fmax;
                    const bool maxOk = stored.max[k] >= child.max[k] || stored.max[k] == fmax;
                    if (!minOk || !maxOk) {
                        return fail(i, "the stored child bounds do not contain the repeated shape");
                    }
                }
                if (std::string e = checkRepeatCell(stored, spacing, count); !e.empty()) return fail(i, e);
                stack.back() = repeatBounds(child, spacing, count);
            }
            frames.pop_back();
        } else {
            return fail(i, fmt::format("unknown opcode {}", r.op));
        }
        out.maxDistanceStack = std::max(out.maxDistanceStack, uint32_t(stack.size()));
        out.maxFrameStack = std::max(out.maxFrameStack, uint32_t(frames.size()));
        if (stack.size() > limits.maxDistanceStack) {
            return fail(i,
                        fmt::format("the program needs a distance stack deeper than {} (every operand that "
                                    "waits for a later sibling takes a slot; put the deepest child first)",
                                    limits.maxDistanceStack));
        }
        if (frames.size() > limits.maxFrameStack) {
            return fail(i, fmt::format("the program nests frames deeper than {}", limits.maxFrameStack));
        }
    }
    if (!frames.empty())
        return fail(records.size() - 1, fmt::format("{} frame(s) not closed", frames.size()));
    if (stack.size() != 1) {
        return fail(records.size() - 1,
                    fmt::format("the program leaves {} distances (expected 1)", stack.size()));
    }
    out.bounds = stack.back();
    return true;
}

}  // namespace

// ---- names ---------------------------------------------------------------------------------------

namespace {
constexpr std::pair<ShapeKind, const char*> kShapeNames[] = {
    {ShapeKind::Sphere, "sphere"},   {ShapeKind::Box, "box"},           {ShapeKind::RoundedBox, "roundedBox"},
    {ShapeKind::Capsule, "capsule"}, {ShapeKind::Cylinder, "cylinder"}, {ShapeKind::Torus, "torus"},
    {ShapeKind::Cone, "cone"},       {ShapeKind::Plane, "plane"},
};
constexpr std::pair<CsgOp, const char*> kCsgNames[] = {
    {CsgOp::Union, "union"}, {CsgOp::Subtract, "subtract"}, {CsgOp::Intersect, "intersect"}};
}  // namespace

const char* shapeKindName(ShapeKind k) {
    for (const auto& [kind, name] : kShapeNames) {
        if (kind == k) return name;
    }
    return "unknown";
}
bool parseShapeKind(std::string_view s, ShapeKind& out) {
    for (const auto& [kind, name] : kShapeNames) {
        if (s == name) {
            out = kind;
            return true;
        }
    }
    return false;
}
const char* csgOpName(CsgOp op) {
    for (const auto& [o, name] : kCsgNames) {
        if (o == op) return name;
    }
    return "unknown";
}
bool parseCsgOp(std::string_view s, CsgOp& out) {
    for (const auto& [o, name] : kCsgNames) {
        if (s == name) {
            out = o;
            return true;
        }
    }
    return false;
}

// ---- small types ---------------------------------------------------------------------------------

bool ShapeBounds::finite() const {
    for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(min[k]) || !std::isfinite(max[k])) return false;
    }
    return true;
}

bool ShapeTransform::identity() const {
    return translation == glm::dvec3(0.0) && rotation == glm::dquat(1.0, 0.0, 0.0, 0.0) && scale == 1.0;
}

namespace {
ShapeNode shapeNode(ShapeKind kind, glm::dvec4 params) {
    ShapeNode n;
    n.type = ShapeNode::Type::Shape;
    n.shape = kind;
    n.params = params;
    return n;
}
}  // namespace

ShapeNode ShapeNode::sphere(double radius) { return shapeNode(ShapeKind::Sphere, {radius, 0, 0, 0}); }
ShapeNode ShapeNode::box(glm::dvec3 h) { return shapeNode(ShapeKind::Box, {h, 0}); }
ShapeNode ShapeNode::roundedBox(glm::dvec3 h, double r) { return shapeNode(ShapeKind::RoundedBox, {h, r}); }
ShapeNode ShapeNode::capsule(double r, double h) { return shapeNode(ShapeKind::Capsule, {r, h, 0, 0}); }
ShapeNode ShapeNode::cylinder(double r, double h) { return shapeNode(ShapeKind::Cylinder, {r, h, 0, 0}); }
ShapeNode ShapeNode::torus(double R, double r) { return shapeNode(ShapeKind::Torus, {R, r, 0, 0}); }
ShapeNode ShapeNode::cone(double r1, double r2, double h) {
    return shapeNode(ShapeKind::Cone, {r1, r2, h, 0});
}
ShapeNode ShapeNode::plane(glm::dvec3 n, double offset) { return shapeNode(ShapeKind::Plane, {n, offset}); }

ShapeNode ShapeNode::csg(CsgOp op, std::vector<ShapeNode> children, double smoothRadius) {
    ShapeNode n;
    n.type = Type::Csg;
    n.op = op;
    n.smoothRadius = smoothRadius;
    n.children = std::move(children);
    return n;
}

ShapeNode ShapeNode::repeat(ShapeNode child, glm::dvec3 spacing, glm::uvec3 count) {
    ShapeNode n;
    n.type = Type::Repeat;
    n.spacing = spacing;
    n.count = count;
    n.children.push_back(std::move(child));
    return n;
}

ShapeNode& ShapeNode::placed(glm::dvec3 translation, glm::dquat rotation, double scale) {
    transform.translation = translation;
    transform.rotation = rotation;
    transform.scale = scale;
    return *this;
}

// ---- compile / validate / evaluate -------------------------------------------------------------------

bool compileShapeProgram(const ShapeNode& root, ShapeProgram& out, std::string& error,
                         const ShapeProgramLimits& limits) {
    Compiler compiler(limits, error);
    compiler.records.emplace_back();  // the header, filled below
    compiler.origins.emplace_back();
    ShapeBounds bounds;
    if (!compiler.emit(root, "", 0, bounds)) return false;
    ShapeProgram program;
    program.records = std::move(compiler.records);
    Analysis analysis;
    size_t failedRecord = 0;
    std::string failedReason;
    if (!analyse(program.records, false, limits, analysis, error, failedRecord, failedReason)) {
        // Name the tree node that emitted the record rather than the record.
        const std::string& node =
            failedRecord < compiler.origins.size() ? compiler.origins[failedRecord] : "";
        error = node.empty() ? failedReason : fmt::format("{}: {}", node, failedReason);
        return false;
    }
    program.bounds = analysis.bounds;
    program.maxDistanceStack = analysis.maxDistanceStack;
    program.maxFrameStack = analysis.maxFrameStack;
    ShapeInstruction& h = program.records[0];
    h.op = uint32_t(ShapeOp::Header);
    h.i = {kShapeProgramVersion, program.instructionCount(),
           program.maxDistanceStack | (program.maxFrameStack << 16)};
    h.a = glm::vec4(roundDown(analysis.bounds.min.x), roundDown(analysis.bounds.min.y),
                    roundDown(analysis.bounds.min.z), 0.0f);
    h.b = glm::vec4(roundUp(analysis.bounds.max.x), roundUp(analysis.bounds.max.y),
                    roundUp(analysis.bounds.max.z), 0.0f);
    out = std::move(program);
    return true;
}

bool validateShapeProgram(const std::vector<ShapeInstruction>& records, std::string& error,
                          const ShapeProgramLimits& limits) {
    Analysis analysis;
    size_t failedRecord = 0;
    std::string failedReason;
    if (!analyse(records, true, limits, analysis, error, failedRecord, failedReason)) return false;
    const ShapeInstruction& h = records[0];
    if (h.i[2] != (analysis.maxDistanceStack | (analysis.maxFrameStack << 16))) {
        error =
            fmt::format("record 0: the header's stack depths ({}, {}) differ from the program's ({}, {})",
                        h.i[2] & 0xffffu, h.i[2] >> 16, analysis.maxDistanceStack, analysis.maxFrameStack);
        return false;
    }
    const float fmax = std::numeric_limits<float>::max();
    for (int k = 0; k < 3; ++k) {
        const bool minOk = h.a[k] == -fmax || double(h.a[k]) <= analysis.bounds.min[k];
        const bool maxOk = h.b[k] == fmax || double(h.b[k]) >= analysis.bounds.max[k];
        if (!minOk || !maxOk) {
            error = "record 0: the header's bounds do not contain the program's bounds";
            return false;
        }
    }
    return true;
}

double shapeDistance(ShapeKind kind, const glm::dvec4& q, const glm::dvec3& p) {
    switch (kind) {
        case ShapeKind::Sphere:
            return glm::length(p) - q.x;
        case ShapeKind::Box:
        case ShapeKind::RoundedBox: {
            const double r = kind == ShapeKind::RoundedBox ? q.w : 0.0;
            const glm::dvec3 d = glm::abs(p) - (glm::dvec3(q) - glm::dvec3(r));
            return glm::length(glm::max(d, glm::dvec3(0.0))) + std::min(std::max({d.x, d.y, d.z}), 0.0) - r;
        }
        case ShapeKind::Capsule: {
            glm::dvec3 d = p;
            d.y -= std::clamp(d.y, -q.y, q.y);
            return glm::length(d) - q.x;
        }
        case ShapeKind::Cylinder: {
            const glm::dvec2 d(std::sqrt(p.x * p.x + p.z * p.z) - q.x, std::abs(p.y) - q.y);
            return std::min(std::max(d.x, d.y), 0.0) + glm::length(glm::max(d, glm::dvec2(0.0)));
        }
        case ShapeKind::Torus: {
            const glm::dvec2 d(std::sqrt(p.x * p.x + p.z * p.z) - q.x, p.y);
            return glm::length(d) - q.y;
        }
        case ShapeKind::Cone: {
            // Capped cone along Y: radius r1 at y = -h, r2 at y = +h.
            const double r1 = q.x, r2 = q.y, h = q.z;
            const glm::dvec2 w(std::sqrt(p.x * p.x + p.z * p.z), p.y);
            const glm::dvec2 k1(r2, h);
            const glm::dvec2 k2(r2 - r1, 2.0 * h);
            const glm::dvec2 ca(w.x - std::min(w.x, w.y < 0.0 ? r1 : r2), std::abs(w.y) - h);
            const glm::dvec2 cb = w - k1 + k2 * std::clamp(glm::dot(k1 - w, k2) / glm::dot(k2, k2), 0.0, 1.0);
            const double s = (cb.x < 0.0 && ca.y < 0.0) ? -1.0 : 1.0;
            return s * std::sqrt(std::min(glm::dot(ca, ca), glm::dot(cb, cb)));
        }
        case ShapeKind::Plane:
            return glm::dot(p, glm::dvec3(q)) - q.w;
    }
    return kInf;
}

double smoothMin(double a, double b, double k) {
    const double h = std::clamp(0.5 + 0.5 * (b - a) / k, 0.0, 1.0);
    return b + (a - b) * h - k * h * (1.0 - h);
}

double smoothMax(double a, double b, double k) { return -smoothMin(-a, -b, k); }

double evaluateShapeProgram(const ShapeProgram& program, const glm::dvec3& point) {
    struct Frame {
        glm::dvec3 p;
        double scale;
    };
    // The stacks live on the C++ stack for programs within the default limits (16 distances, 8
    // frames: every program the scene format compiles); larger limits fall back to the heap. The
    // reference renderer calls this millions of times per image.
    std::array<Frame, 9> frameBuffer;
    std::array<double, 16> stackBuffer;
    std::vector<Frame> frameHeap;
    std::vector<double> stackHeap;
    Frame* frames = frameBuffer.data();
    double* stack = stackBuffer.data();
    if (program.maxFrameStack + 1 > frameBuffer.size()) {
        frameHeap.resize(program.maxFrameStack + 1);
        frames = frameHeap.data();
    }
    if (program.maxDistanceStack > stackBuffer.size()) {
        stackHeap.resize(program.maxDistanceStack);
        stack = stackHeap.data();
    }
    size_t fp = 0, sp = 0;
    frames[0] = {point, 1.0};
    const std::vector<ShapeInstruction>& rec = program.records;
    for (size_t i = 1; i < rec.size(); ++i) {
        const ShapeInstruction& r = rec[i];
        const Frame& f = frames[fp];
        if (isShapeOp(r.op)) {
            stack[sp++] = shapeDistance(kindOf(r.op), d4(r.a), f.p) * f.scale;
            continue;
        }
        if (isBinaryOp(r.op)) {
            const double b = stack[--sp];
            const double a = stack[sp - 1];
            const double k = double(r.a.x) * f.scale;
            double v = a;
            switch (ShapeOp(r.op)) {
                case ShapeOp::Union:
                    v = std::min(a, b);
                    break;
                case ShapeOp::Subtract:
                    v = std::max(a, -b);
                    break;
                case ShapeOp::Intersect:
                    v = std::max(a, b);
                    break;
                case ShapeOp::SmoothUnion:
                    v = smoothMin(a, b, k);
                    break;
                case ShapeOp::SmoothSubtract:
                    v = smoothMax(a, -b, k);
                    break;
                case ShapeOp::SmoothIntersect:
                    v = smoothMax(a, b, k);
                    break;
                default:
                    break;
            }
            stack[sp - 1] = v;
            continue;
        }
        switch (ShapeOp(r.op)) {
            case ShapeOp::PushTransform: {
                const glm::dquat q(r.b.w, r.b.x, r.b.y, r.b.z);
                const double s = r.a.w;
                frames[fp + 1] = {glm::conjugate(q) * (f.p - glm::dvec3(glm::vec3(r.a))) / s, f.scale * s};
                ++fp;
                break;
            }
            case ShapeOp::PushRepeat: {
                const RepeatCell c = repeatCell(f.p, glm::dvec3(glm::vec3(r.a)), {r.i[0], r.i[1], r.i[2]});
                frames[fp + 1] = {c.local, f.scale};
                ++fp;
                break;
            }
            case ShapeOp::PopTransform:
                --fp;
                break;
            case ShapeOp::PopRepeat: {
                --fp;
                const Frame& parent = frames[fp];
                const glm::uvec3 count(r.i[0], r.i[1], r.i[2]);
                const glm::dvec3 spacing(glm::vec3(r.a));
                const RepeatCell c = repeatCell(parent.p, spacing, count);
                const ShapeBounds child{glm::dvec3(glm::vec3(r.b)), glm::dvec3(glm::vec3(r.c))};
                const double g = otherCopiesBound(c, spacing, count, child) * parent.scale;
                stack[sp - 1] = std::min(stack[sp - 1], g);
                break;
            }
            default:
                break;
        }
    }
    return sp > 0 ? stack[sp - 1] : kInf;
}

}  // namespace penumbra::sdf
