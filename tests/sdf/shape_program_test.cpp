// Shape programs (engine/sdf/shape_program.h): CPU distances against independent closed forms for
// every shape (inside, on and outside the surface, on rotated, translated and scaled nodes), CSG
// results against hand-computed values, the never-overestimate rule of every bound operation against
// brute-force nearest distances to the program's sampled zero set, bounds, repetition limits, and
// malformed programs refused with clear messages.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/sdf/shape_program.h"

namespace penumbra::sdf {
namespace {

ShapeProgram compile(const ShapeNode& n) {
    ShapeProgram p;
    std::string error;
    EXPECT_TRUE(compileShapeProgram(n, p, error)) << error;
    return p;
}

std::string compileError(const ShapeNode& n, const ShapeProgramLimits& limits = {}) {
    ShapeProgram p;
    std::string error;
    EXPECT_FALSE(compileShapeProgram(n, p, error, limits));
    return error;
}

// ---- independent closed forms ------------------------------------------------------------------------

// Signed distance to a closed 2D polygon (negative inside, even-odd rule).
double polygonDistance(glm::dvec2 p, const std::vector<glm::dvec2>& v) {
    double best = std::numeric_limits<double>::infinity();
    bool inside = false;
    for (size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
        const glm::dvec2 a = v[j], b = v[i];
        const glm::dvec2 e = b - a;
        if (glm::dot(e, e) == 0.0) continue;
        const double t = std::clamp(glm::dot(p - a, e) / glm::dot(e, e), 0.0, 1.0);
        best = std::min(best, glm::length(p - (a + t * e)));
        if ((a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x))
            inside = !inside;
    }
    return inside ? -best : best;
}

// Solids of revolution about Y: the distance is the 2D distance to the section through the axis
// and the point (a polygon symmetric about x = 0).
double revolvedDistance(glm::dvec3 p, const std::vector<glm::dvec2>& section) {
    return polygonDistance({std::sqrt(p.x * p.x + p.z * p.z), p.y}, section);
}

double boxReference(glm::dvec3 p, glm::dvec3 h) {
    const glm::dvec3 c = glm::clamp(p, -h, h);
    if (c != p) return glm::length(p - c);
    return -std::min({h.x - std::abs(p.x), h.y - std::abs(p.y), h.z - std::abs(p.z)});
}

double roundedBoxReference(glm::dvec3 p, glm::dvec3 h, double r) {
    const glm::dvec3 inner = h - glm::dvec3(r);
    const glm::dvec3 c = glm::clamp(p, -inner, inner);
    if (c != p) return glm::length(p - c) - r;
    return -std::min({h.x - std::abs(p.x), h.y - std::abs(p.y), h.z - std::abs(p.z)});
}

double referenceDistance(ShapeKind kind, glm::dvec4 q, glm::dvec3 p) {
    switch (kind) {
        case ShapeKind::Sphere:
            return glm::length(p) - q.x;
        case ShapeKind::Box:
            return boxReference(p, glm::dvec3(q));
        case ShapeKind::RoundedBox:
            return roundedBoxReference(p, glm::dvec3(q), q.w);
        case ShapeKind::Capsule: {
            const glm::dvec3 a(0, -q.y, 0), b(0, q.y, 0);
            const double t = std::clamp(glm::dot(p - a, b - a) / glm::dot(b - a, b - a), 0.0, 1.0);
            return glm::length(p - (a + t * (b - a))) - q.x;
        }
        case ShapeKind::Cylinder:
            return revolvedDistance(p, {{-q.x, -q.y}, {q.x, -q.y}, {q.x, q.y}, {-q.x, q.y}});
        case ShapeKind::Torus: {
            const double rho = std::sqrt(p.x * p.x + p.z * p.z);
            const glm::dvec3 nearest =
                rho > 0 ? glm::dvec3(p.x, 0, p.z) * (q.x / rho) : glm::dvec3(q.x, 0, 0);
            return glm::length(p - nearest) - q.y;
        }
        case ShapeKind::Cone:
            return revolvedDistance(p, {{-q.x, -q.z}, {q.x, -q.z}, {q.y, q.z}, {-q.y, q.z}});
        case ShapeKind::Plane:
            return glm::dot(p, glm::dvec3(q)) - q.w;
    }
    return 0;
}

struct ShapeCase {
    ShapeKind kind;
    glm::dvec4 params;  // float-exact values
};

const ShapeCase kShapes[] = {
    {ShapeKind::Sphere, {0.75, 0, 0, 0}},
    {ShapeKind::Box, {0.5, 1.0, 0.25, 0}},
    {ShapeKind::RoundedBox, {0.5, 1.0, 0.375, 0.125}},
    {ShapeKind::Capsule, {0.25, 0.75, 0, 0}},
    {ShapeKind::Cylinder, {0.5, 0.75, 0, 0}},
    {ShapeKind::Torus, {1.0, 0.25, 0, 0}},
    {ShapeKind::Cone, {0.75, 0.25, 0.5, 0}},
    {ShapeKind::Cone, {0.5, 0.0, 1.0, 0}},  // pointed
    {ShapeKind::Plane, {0.0, 1.0, 0.0, 0.25}},
};

ShapeNode leaf(const ShapeCase& c) {
    ShapeNode n;
    n.shape = c.kind;
    n.params = c.params;
    return n;
}

// Criterion: the program's distance equals the closed form within 1e-12 at 2000 random points per
// shape (about half inside) and within 1e-9 of zero at 200 surface points found by bisecting the
// closed form between an inside and an outside point.
TEST(ShapeProgram, EveryShapeMatchesItsClosedForm) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.6, 1.6);
    for (const ShapeCase& c : kShapes) {
        SCOPED_TRACE(shapeKindName(c.kind));
        const ShapeProgram program = compile(leaf(c));
        int inside = 0;
        for (int i = 0; i < 2000; ++i) {
            const glm::dvec3 p(u(rng), u(rng), u(rng));
            const double ref = referenceDistance(c.kind, c.params, p);
            inside += ref < 0;
            ASSERT_NEAR(evaluateShapeProgram(program, p), ref, 1e-12) << p.x << " " << p.y << " " << p.z;
        }
        EXPECT_GT(inside, 10);
        // Surface points: the origin side of every shape here is inside except the torus' hole.
        const glm::dvec3 in = c.kind == ShapeKind::Torus ? glm::dvec3(1, 0, 0) : glm::dvec3(0, -0.01, 0);
        ASSERT_LT(referenceDistance(c.kind, c.params, in), 0);
        for (int i = 0; i < 200; ++i) {
            glm::dvec3 out(u(rng), u(rng), u(rng));
            out = in + glm::normalize(out) * 4.0;
            if (referenceDistance(c.kind, c.params, out) <= 0) continue;
            glm::dvec3 lo = in, hi = out;
            for (int k = 0; k < 80; ++k) {
                const glm::dvec3 mid = 0.5 * (lo + hi);
                (referenceDistance(c.kind, c.params, mid) < 0 ? lo : hi) = mid;
            }
            EXPECT_NEAR(evaluateShapeProgram(program, lo), 0.0, 1e-9);
        }
    }
}

// Criterion: a node placed at translation t, rotation q and uniform scale s evaluates to
// s * d(q^-1 (p - t) / s) within 1e-5 (the record stores the transform in float).
TEST(ShapeProgram, TransformedNodesAreExact) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-3, 3);
    const glm::dvec3 t(0.5, -0.25, 1.0);
    const glm::dquat q = glm::normalize(glm::angleAxis(0.7, glm::normalize(glm::dvec3(1, 2, 3))));
    const double s = 1.5;
    for (const ShapeCase& c : kShapes) {
        SCOPED_TRACE(shapeKindName(c.kind));
        ShapeNode n = leaf(c);
        n.placed(t, q, s);
        const ShapeProgram program = compile(n);
        for (int i = 0; i < 1000; ++i) {
            const glm::dvec3 p(u(rng), u(rng), u(rng));
            const double ref = s * referenceDistance(c.kind, c.params, glm::conjugate(q) * (p - t) / s);
            ASSERT_NEAR(evaluateShapeProgram(program, p), ref, 1e-5);
        }
    }
    // Nested transforms compose: a CSG node placed inside a placed parent.
    ShapeNode inner =
        ShapeNode::csg(CsgOp::Union, {ShapeNode::sphere(0.5), ShapeNode::box({0.25, 0.25, 0.25})});
    inner.placed({1, 0, 0}, glm::angleAxis(glm::half_pi<double>(), glm::dvec3(0, 0, 1)), 2.0);
    ShapeNode outer = ShapeNode::csg(CsgOp::Union, {inner, ShapeNode::sphere(0.25).placed({0, 5, 0})});
    outer.placed({0, 0, 2}, {1, 0, 0, 0}, 0.5);
    const ShapeProgram program = compile(outer);
    // The sphere of `inner` is centred at 0.5 * (1, 0, 0) + (0, 0, 2) with radius 0.5 * 2 * 0.5.
    EXPECT_NEAR(evaluateShapeProgram(program, {0.5, 0.0, 2.0}), -0.5, 1e-6);
    EXPECT_NEAR(evaluateShapeProgram(program, {0.5, -3.0, 2.0}), 2.5, 1e-6);
}

// Criterion: CSG values equal the ones worked out by hand (1e-12).
TEST(ShapeProgram, CsgMatchesHandComputedValues) {
    const ShapeNode box = ShapeNode::box({1, 1, 1});
    const ShapeNode ball = ShapeNode::sphere(1.25);
    const ShapeProgram sub = compile(ShapeNode::csg(CsgOp::Subtract, {box, ball}));
    EXPECT_NEAR(evaluateShapeProgram(sub, {0, 0, 0}), 1.25, 1e-12);  // max(-1, 1.25)
    EXPECT_NEAR(evaluateShapeProgram(sub, {3, 0, 0}), 2.0, 1e-12);   // max(2, -1.75)
    EXPECT_NEAR(evaluateShapeProgram(sub, {0.95, 0.95, 0.95}), std::max(-0.05, 1.25 - std::sqrt(3 * 0.9025)),
                1e-12);
    const ShapeProgram uni =
        compile(ShapeNode::csg(CsgOp::Union, {box, ShapeNode::sphere(0.5).placed({3, 0, 0})}));
    EXPECT_NEAR(evaluateShapeProgram(uni, {2, 0, 0}), 0.5, 1e-12);  // min(1, 0.5)
    EXPECT_NEAR(evaluateShapeProgram(uni, {0, 0, 0}), -1.0, 1e-12);
    const ShapeProgram inter = compile(ShapeNode::csg(CsgOp::Intersect, {box, ball}));
    EXPECT_NEAR(evaluateShapeProgram(inter, {0, 0, 0}), -1.0, 1e-12);  // max(-1, -1.25)
    EXPECT_NEAR(evaluateShapeProgram(inter, {2, 0, 0}), 1.0, 1e-12);   // max(1, 0.75)
    // Three children fold from the left: (box - ball1) - ball2.
    const ShapeProgram fold =
        compile(ShapeNode::csg(CsgOp::Subtract, {box, ShapeNode::sphere(0.5).placed({1, 0, 0}),
                                                 ShapeNode::sphere(0.5).placed({-1, 0, 0})}));
    EXPECT_NEAR(evaluateShapeProgram(fold, {0.75, 0, 0}), 0.25, 1e-12);
    EXPECT_NEAR(evaluateShapeProgram(fold, {-0.75, 0, 0}), 0.25, 1e-12);
    EXPECT_NEAR(evaluateShapeProgram(fold, {0, 0, 0}), -0.5, 1e-12);
    // Smooth union of two unit spheres 2 apart, radius k = 1: at the midpoint both distances are 0
    // and the polynomial smooth minimum is 0 - k/4; far from the seam it is the hard union.
    const ShapeNode a = ShapeNode::sphere(1).placed({-1, 0, 0});
    const ShapeNode b = ShapeNode::sphere(1).placed({1, 0, 0});
    const ShapeProgram smooth = compile(ShapeNode::csg(CsgOp::Union, {a, b}, 1.0));
    EXPECT_NEAR(evaluateShapeProgram(smooth, {0, 0, 0}), -0.25, 1e-12);
    EXPECT_NEAR(evaluateShapeProgram(smooth, {-3, 0, 0}), 1.0, 1e-12);  // |a - b| = 2 >= k
    EXPECT_NEAR(smoothMin(0.3, 0.3, 0.4), 0.2, 1e-12);
    EXPECT_NEAR(smoothMax(0.3, 0.3, 0.4), 0.4, 1e-12);
    // A smooth radius scales with the node: the same union placed at scale 2 is twice as far.
    ShapeNode scaled = ShapeNode::csg(CsgOp::Union, {a, b}, 1.0);
    scaled.placed({0, 0, 0}, {1, 0, 0, 0}, 2.0);
    EXPECT_NEAR(evaluateShapeProgram(compile(scaled), {0, 0, 0}), -0.5, 1e-12);
}

// Criterion: a row of 5 spheres (radius 0.25, spacing 1 along x, centred) is exact at the copies,
// between them and beyond the last one (no copy past the count).
TEST(ShapeProgram, RepetitionIsBoundedByItsCount) {
    const ShapeProgram row = compile(ShapeNode::repeat(ShapeNode::sphere(0.25), {1, 0, 0}, {5, 1, 1}));
    EXPECT_NEAR(evaluateShapeProgram(row, {2, 0, 0}), -0.25, 1e-12);
    EXPECT_NEAR(evaluateShapeProgram(row, {-2, 0, 0}), -0.25, 1e-12);
    EXPECT_NEAR(evaluateShapeProgram(row, {1.5, 0, 0}), 0.25, 1e-12);
    EXPECT_NEAR(evaluateShapeProgram(row, {4, 0, 0}), 1.75, 1e-12);  // the last copy is at x = 2
    EXPECT_NEAR(evaluateShapeProgram(row, {0, 3, 0}), 2.75, 1e-12);
    EXPECT_EQ(row.bounds.min, glm::dvec3(-2.25, -0.25, -0.25));
    EXPECT_EQ(row.bounds.max, glm::dvec3(2.25, 0.25, 0.25));
    // An even count is centred too: copies at -0.5 and 0.5.
    const ShapeProgram pair = compile(ShapeNode::repeat(ShapeNode::sphere(0.25), {1, 0, 0}, {2, 1, 1}));
    EXPECT_NEAR(evaluateShapeProgram(pair, {0.5, 0, 0}), -0.25, 1e-12);
    EXPECT_NEAR(evaluateShapeProgram(pair, {-0.5, 0, 0}), -0.25, 1e-12);
    EXPECT_NEAR(evaluateShapeProgram(pair, {0, 0, 0}), 0.25, 1e-12);
}

// ---- never overestimate ---------------------------------------------------------------------------

// Points on the program's zero set: every grid edge (spacing h) whose end values change sign is
// bisected to 1e-12.
std::vector<glm::dvec3> sampleSurface(const ShapeProgram& p, glm::dvec3 lo, glm::dvec3 hi, double h) {
    const glm::ivec3 n = glm::ivec3(glm::ceil((hi - lo) / h)) + 1;
    std::vector<double> v(size_t(n.x) * n.y * n.z);
    auto at = [&](int x, int y, int z) -> double& { return v[(size_t(z) * n.y + y) * n.x + x]; };
    auto pos = [&](int x, int y, int z) { return lo + h * glm::dvec3(x, y, z); };
    for (int z = 0; z < n.z; ++z)
        for (int y = 0; y < n.y; ++y)
            for (int x = 0; x < n.x; ++x) at(x, y, z) = evaluateShapeProgram(p, pos(x, y, z));
    std::vector<glm::dvec3> out;
    const glm::ivec3 steps[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int z = 0; z < n.z; ++z)
        for (int y = 0; y < n.y; ++y)
            for (int x = 0; x < n.x; ++x)
                for (const glm::ivec3& s : steps) {
                    const glm::ivec3 b(x + s.x, y + s.y, z + s.z);
                    if (b.x >= n.x || b.y >= n.y || b.z >= n.z) continue;
                    const double va = at(x, y, z), vb = at(b.x, b.y, b.z);
                    if ((va < 0) == (vb < 0)) continue;
                    glm::dvec3 in = pos(x, y, z), outside = pos(b.x, b.y, b.z);
                    if (va >= 0) std::swap(in, outside);
                    for (int k = 0; k < 45; ++k) {
                        const glm::dvec3 mid = 0.5 * (in + outside);
                        (evaluateShapeProgram(p, mid) < 0 ? in : outside) = mid;
                    }
                    out.push_back(0.5 * (in + outside));
                }
    return out;
}

struct BoundCase {
    const char* name;
    ShapeNode node;
    bool exactOutside;  // the distance must also match the sampled one (within the resolution)
};

// Criterion: at 600 random points around each program, |d| <= (distance to the nearest sampled
// surface point) + 1e-9. The sampled points lie on the true zero set, so the sampled distance is
// never below the true one, and a true overestimate larger than the sampling resolution h * sqrt(3)
// (h = 0.04) cannot hide. For the exact operations the values also agree with the sampled distance
// within h * sqrt(3) outside the solid (the sampling finds the surface).
TEST(ShapeProgram, BoundOperationsNeverOverestimate) {
    const ShapeNode box = ShapeNode::box({0.75, 0.5, 0.5});
    const ShapeNode ball = ShapeNode::sphere(0.625).placed({0.5, 0.25, 0});
    std::vector<BoundCase> cases = {
        {"union", ShapeNode::csg(CsgOp::Union, {box, ball}), true},
        {"subtract", ShapeNode::csg(CsgOp::Subtract, {box, ball}), false},
        {"intersect", ShapeNode::csg(CsgOp::Intersect, {box, ball}), false},
        {"smooth union", ShapeNode::csg(CsgOp::Union, {box, ball}, 0.5), false},
        {"smooth subtract", ShapeNode::csg(CsgOp::Subtract, {box, ball}, 0.5), false},
        {"smooth intersect", ShapeNode::csg(CsgOp::Intersect, {box, ball}, 0.5), false},
        // An off-centre child in its cell, repeated on two axes.
        {"repeat",
         ShapeNode::repeat(ShapeNode::sphere(0.2).placed({0.15, -0.1, 0}), {0.8, 0.8, 0}, {3, 2, 1}), false},
        {"rotated subtract",
         ShapeNode::csg(CsgOp::Subtract, {ShapeNode::torus(0.75, 0.25), ShapeNode::cylinder(0.625, 1.0)})
             .placed({0, 0, 0}, glm::angleAxis(0.6, glm::dvec3(1, 0, 0)), 1.25),
         false},
    };
    const double h = 0.04;
    for (const BoundCase& c : cases) {
        SCOPED_TRACE(c.name);
        const ShapeProgram p = compile(c.node);
        ASSERT_TRUE(p.bounds.finite());
        const glm::dvec3 lo = p.bounds.min - 0.3, hi = p.bounds.max + 0.3;
        const std::vector<glm::dvec3> surface = sampleSurface(p, lo, hi, h);
        ASSERT_GT(surface.size(), 100u);
        std::mt19937 rng(3);
        std::uniform_real_distribution<double> ux(lo.x - 0.5, hi.x + 0.5), uy(lo.y - 0.5, hi.y + 0.5),
            uz(lo.z - 0.5, hi.z + 0.5);
        int inside = 0;
        for (int i = 0; i < 600; ++i) {
            const glm::dvec3 x(ux(rng), uy(rng), uz(rng));
            double nearest = std::numeric_limits<double>::infinity();
            for (const glm::dvec3& s : surface) nearest = std::min(nearest, glm::length(x - s));
            const double d = evaluateShapeProgram(p, x);
            inside += d < 0;
            ASSERT_LE(std::abs(d), nearest + 1e-9) << x.x << " " << x.y << " " << x.z;
            if (c.exactOutside && d > 0) {
                ASSERT_GE(d, nearest - h * std::sqrt(3.0));
            }
        }
        EXPECT_GT(inside, 0);
    }
}

// Criterion: the fields are 1-Lipschitz (|d(x) - d(y)| <= |x - y| + 1e-12 for 20000 random pairs
// up to 0.5 apart), the property that makes a bound never overestimate the distance to its own zero
// set — for every operation, and for a repetition of a child centred in its cell.
TEST(ShapeProgram, FieldsAreOneLipschitz) {
    const ShapeNode box = ShapeNode::box({0.75, 0.5, 0.5});
    const ShapeNode ball = ShapeNode::sphere(0.625).placed({0.5, 0.25, 0});
    const std::vector<ShapeNode> programs = {
        ShapeNode::csg(CsgOp::Union, {box, ball}),
        ShapeNode::csg(CsgOp::Subtract, {box, ball}),
        ShapeNode::csg(CsgOp::Intersect, {box, ball}),
        ShapeNode::csg(CsgOp::Union, {box, ball}, 0.5),
        ShapeNode::csg(CsgOp::Subtract, {box, ball}, 0.5),
        ShapeNode::csg(CsgOp::Intersect, {box, ball}, 0.5),
        ShapeNode::repeat(ShapeNode::torus(0.25, 0.0625), {0.75, 0, 0.75}, {4, 1, 3}),
        ShapeNode::csg(
            CsgOp::Union,
            {ShapeNode::repeat(ShapeNode::sphere(0.25), {1, 0, 0}, {5, 1, 1}), ShapeNode::cone(0.5, 0, 1)},
            0.25)
            .placed({0.25, 0, 0}, glm::angleAxis(0.3, glm::dvec3(0, 1, 0)), 1.5),
    };
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> u(-3, 3), v(-0.5, 0.5);
    for (size_t i = 0; i < programs.size(); ++i) {
        SCOPED_TRACE(i);
        const ShapeProgram p = compile(programs[i]);
        for (int k = 0; k < 20000; ++k) {
            const glm::dvec3 x(u(rng), u(rng), u(rng));
            const glm::dvec3 y = x + glm::dvec3(v(rng), v(rng), v(rng));
            ASSERT_LE(std::abs(evaluateShapeProgram(p, x) - evaluateShapeProgram(p, y)),
                      glm::length(x - y) + 1e-12);
        }
    }
}

// Criterion: the solid lies inside the program's bounds and the distance is at least the distance
// to the bounds outside them (the rule the GPU uses to skip objects), at 4000 points per program.
TEST(ShapeProgram, BoundsContainTheSolid) {
    const ShapeNode a =
        ShapeNode::box({1.0, 0.125, 0.125}).placed({0, 0, 0}, glm::angleAxis(0.4, glm::dvec3(0, 0, 1)));
    const ShapeNode b = ShapeNode::capsule(0.25, 1.0).placed({0.5, 0, 0});
    const std::vector<ShapeNode> programs = {
        ShapeNode::csg(CsgOp::Union, {a, b}, 0.75),
        ShapeNode::csg(CsgOp::Intersect, {a, b}),
        ShapeNode::csg(CsgOp::Subtract, {a, b}, 0.25),
        ShapeNode::csg(CsgOp::Intersect, {a, b}, 0.5),
        ShapeNode::cone(0.5, 0.125, 0.75).placed({1, 2, 3}, glm::angleAxis(1.0, glm::dvec3(0, 1, 0)), 0.5),
        ShapeNode::repeat(ShapeNode::torus(0.25, 0.0625), {0.75, 0, 0.75}, {4, 1, 3}),
    };
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-4, 4);
    for (size_t i = 0; i < programs.size(); ++i) {
        SCOPED_TRACE(i);
        const ShapeProgram p = compile(programs[i]);
        ASSERT_TRUE(p.bounds.finite());
        int outside = 0;
        for (int k = 0; k < 4000; ++k) {
            const glm::dvec3 x(u(rng), u(rng), u(rng));
            const glm::dvec3 c = glm::clamp(x, p.bounds.min, p.bounds.max);
            if (c == x) continue;  // inside the bounds: no claim
            outside++;
            ASSERT_GE(evaluateShapeProgram(p, x), glm::length(x - c) - 1e-9);
        }
        EXPECT_GT(outside, 3000);
        // The header carries the same bounds, rounded outwards to float.
        const ShapeInstruction& hdr = p.records[0];
        EXPECT_EQ(hdr.op, uint32_t(ShapeOp::Header));
        EXPECT_EQ(hdr.i[0], kShapeProgramVersion);
        EXPECT_EQ(hdr.i[1], p.instructionCount());
        for (int k = 0; k < 3; ++k) {
            EXPECT_LE(double(hdr.a[k]), p.bounds.min[k]);
            EXPECT_GE(double(hdr.b[k]), p.bounds.max[k]);
        }
    }
    // An axis-aligned plane bounds one side; an oblique one nothing.
    const ShapeProgram floor = compile(ShapeNode::plane({0, 1, 0}, 0.5));
    EXPECT_EQ(floor.bounds.max.y, 0.5);
    EXPECT_TRUE(std::isinf(floor.bounds.min.y) && std::isinf(floor.bounds.max.x));
    EXPECT_FALSE(compile(ShapeNode::plane({1, 1, 0}, 0)).bounds.finite());
}

TEST(ShapeProgram, RecordLayoutAndStacks) {
    ShapeNode n = ShapeNode::csg(CsgOp::Subtract, {ShapeNode::box({1, 1, 1}), ShapeNode::sphere(1.25)});
    n.placed({1, 2, 3});
    const ShapeProgram p = compile(n);
    ASSERT_EQ(p.records.size(), 6u);  // header, push, box, sphere, subtract, pop
    EXPECT_EQ(p.records[1].op, uint32_t(ShapeOp::PushTransform));
    EXPECT_EQ(p.records[1].a, glm::vec4(1, 2, 3, 1));
    EXPECT_EQ(p.records[1].b, glm::vec4(0, 0, 0, 1));  // quaternion x, y, z, w
    EXPECT_EQ(p.records[2].op, uint32_t(ShapeOp::Box));
    EXPECT_EQ(p.records[3].op, uint32_t(ShapeOp::Sphere));
    EXPECT_EQ(p.records[4].op, uint32_t(ShapeOp::Subtract));
    EXPECT_EQ(p.records[5].op, uint32_t(ShapeOp::PopTransform));
    EXPECT_EQ(p.maxDistanceStack, 2u);
    EXPECT_EQ(p.maxFrameStack, 1u);
    EXPECT_EQ(p.records[0].i[2], 2u | (1u << 16));
    std::string error;
    EXPECT_TRUE(validateShapeProgram(p.records, error)) << error;
}

// ---- malformed -------------------------------------------------------------------------------------

TEST(ShapeProgram, BadTreesAreRefusedWithTheNode) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(compileError(ShapeNode::sphere(nan)), "sphere: radius is not a finite number");
    EXPECT_EQ(compileError(ShapeNode::csg(CsgOp::Union, {ShapeNode::sphere(1), ShapeNode::box({1, -1, 1})})),
              "/children/1: box: halfExtents must be > 0 (got -1)");
    EXPECT_EQ(compileError(ShapeNode::torus(1, 1)),
              "torus: minorRadius (1) must be smaller than majorRadius (1)");
    EXPECT_EQ(compileError(ShapeNode::roundedBox({1, 0.5, 1}, 0.75)),
              "roundedBox: rounding radius (0.75) must not exceed the smallest half extent (0.5)");
    EXPECT_EQ(compileError(ShapeNode::cone(0, 0, 1)), "cone: bottomRadius and topRadius are both 0");
    EXPECT_EQ(compileError(ShapeNode::plane({0, 0, 0}, 1)), "the plane normal must be non-zero");
    EXPECT_EQ(compileError(ShapeNode::sphere(2e6)), "sphere: radius 2000000 exceeds the limit of 1000000");
    EXPECT_EQ(compileError(ShapeNode::csg(CsgOp::Union, {ShapeNode::sphere(1)})),
              "a union needs at least two children (got 1)");
    EXPECT_EQ(compileError(ShapeNode::csg(CsgOp::Union, {ShapeNode::sphere(1), ShapeNode::sphere(1)}, nan)),
              "/smoothRadius: the smooth radius must be a finite number in (0, 1000000] (got nan)");
    ShapeNode badScale = ShapeNode::sphere(1);
    badScale.placed({0, 0, 0}, {1, 0, 0, 0}, 0.0);
    EXPECT_EQ(compileError(badScale),
              "/transform: scale must be a finite number in [1e-06, 1000000] (got 0)");
    ShapeNode badMove = ShapeNode::sphere(1);
    badMove.placed({nan, 0, 0});
    EXPECT_EQ(compileError(badMove).substr(0, 40), "/transform: translation component nan mu");
}

TEST(ShapeProgram, RepetitionLimits) {
    const ShapeNode s = ShapeNode::sphere(0.25);
    EXPECT_EQ(compileError(ShapeNode::repeat(s, {1, 0, 0}, {1025, 1, 1})),
              "count 1025 is out of range [1, 1024]");
    EXPECT_EQ(compileError(ShapeNode::repeat(s, {1, 0, 0}, {0, 1, 1})), "count 0 is out of range [1, 1024]");
    EXPECT_EQ(compileError(ShapeNode::repeat(s, {1, 1, 1}, {1024, 1024, 2})),
              "2097152 copies exceed the limit of 1048576");
    EXPECT_EQ(compileError(ShapeNode::repeat(s, {0, 0, 0}, {3, 1, 1})),
              "spacing must be > 0 on an axis with more than one copy (axis x)");
    EXPECT_EQ(compileError(ShapeNode::repeat(ShapeNode::sphere(0.5), {1, 0, 0}, {3, 1, 1})),
              "the repeated shape's bounds on x ([-0.5, 0.5]) must lie strictly inside its cell (-0.5, 0.5) "
              "(spacing 1): copies may not touch or overlap");
    EXPECT_EQ(
        compileError(ShapeNode::repeat(ShapeNode::plane({0, 1, 0}, 0), {1, 0, 0}, {3, 1, 1})).substr(0, 35),
        "the repeated shape's bounds on x ([");
    // A count of 1 on an axis needs no spacing and leaves that axis unbounded-friendly.
    const ShapeProgram column =
        compile(ShapeNode::repeat(ShapeNode::plane({1, 0, 0}, 0), {0, 0, 0}, {1, 1, 1}));
    EXPECT_NEAR(evaluateShapeProgram(column, {2, 0, 0}), 2.0, 1e-12);
    EXPECT_FALSE(column.bounds.finite());  // unbounded axes: +-FLT_MAX in the records
    std::string error;
    EXPECT_TRUE(validateShapeProgram(column.records, error)) << error;
    EXPECT_EQ(column.records[0].a.y, -std::numeric_limits<float>::max());
    // Repetitions nest (a grid of rows).
    const ShapeProgram grid =
        compile(ShapeNode::repeat(ShapeNode::repeat(s, {1, 0, 0}, {3, 1, 1}), {0, 0, 4}, {1, 1, 2}));
    EXPECT_NEAR(evaluateShapeProgram(grid, {1, 0, 2}), -0.25, 1e-12);
    EXPECT_NEAR(evaluateShapeProgram(grid, {-1, 0, -2}), -0.25, 1e-12);
}

TEST(ShapeProgram, TooDeepOrTooLongIsRefused) {
    // Right-nested unions: each level keeps one more operand waiting on the stack.
    ShapeNode n = ShapeNode::sphere(1);
    for (int i = 0; i < 20; ++i) n = ShapeNode::csg(CsgOp::Union, {ShapeNode::sphere(1), n});
    const std::string error = compileError(n);
    EXPECT_NE(error.find("the program needs a distance stack deeper than 16"), std::string::npos) << error;
    // The same depth on the left needs two slots.
    ShapeNode left = ShapeNode::sphere(1);
    for (int i = 0; i < 20; ++i) left = ShapeNode::csg(CsgOp::Union, {left, ShapeNode::sphere(1)});
    EXPECT_EQ(compile(left).maxDistanceStack, 2u);
    ShapeProgramLimits small;
    small.maxInstructions = 10;
    EXPECT_EQ(compileError(left, small).substr(0, 40), "/children/0/children/0/children/0/childr");
    // Frames nest at most 8 deep.
    ShapeNode framed = ShapeNode::sphere(1);
    for (int i = 0; i < 9; ++i) {
        framed = ShapeNode::csg(CsgOp::Union, {framed, ShapeNode::sphere(1)});
        framed.placed({0.5, 0, 0});
    }
    // The error names the node whose transform opens the ninth frame, not a record index.
    const std::string frameError = compileError(framed);
    EXPECT_EQ(
        frameError.rfind("/children/0/children/0/children/0/children/0/children/0/children/0/children/0/"
                         "children/0: the program nests frames deeper than 8",
                         0),
        0u)
        << frameError;
}

TEST(ShapeProgram, MalformedRecordsAreRefused) {
    const ShapeProgram good =
        compile(ShapeNode::csg(CsgOp::Union,
                               {ShapeNode::sphere(1).placed({1, 0, 0}),
                                ShapeNode::repeat(ShapeNode::sphere(0.25), {1, 0, 0}, {3, 1, 1})},
                               0.25));
    std::string error;
    ASSERT_TRUE(validateShapeProgram(good.records, error)) << error;
    auto refused = [&](auto mutate) {
        std::vector<ShapeInstruction> r = good.records;
        mutate(r);
        std::string e;
        EXPECT_FALSE(validateShapeProgram(r, e));
        return e;
    };
    EXPECT_EQ(refused([](auto& r) { r[2].op = 99; }), "record 2: unknown opcode 99");
    EXPECT_EQ(refused([](auto& r) { r[2].a.x = std::numeric_limits<float>::quiet_NaN(); }),
              "record 2: a parameter is not a finite number");
    EXPECT_EQ(refused([](auto& r) { r[0].i[0] = 2; }),
              "record 0: unsupported shape program version 2 (expected 1)");
    EXPECT_EQ(refused([](auto& r) { r[0].i[1] = 3; }),
              "record 0: the header counts 3 instructions, the program has 7");
    EXPECT_EQ(refused([](auto& r) { r[1].b = glm::vec4(1, 1, 0, 0); }),
              "record 1: the rotation quaternion must have unit length (got length 1.4142135623730951)");
    EXPECT_EQ(refused([](auto& r) {
                  r.erase(r.begin() + 2);
                  r[0].i[1] = 6;
              }),
              "record 2: a frame must produce exactly one distance (got 0)");
    EXPECT_EQ(refused([](auto& r) {
                  r.erase(r.begin() + 1, r.begin() + 4);
                  r[0].i[1] = 4;
              }),
              "record 4: a binary operation needs two operands");
    EXPECT_EQ(refused([](auto& r) {
                  r.erase(r.begin() + 3);
                  r[0].i[1] = 6;
              }),
              "record 6: 1 frame(s) not closed");
    EXPECT_EQ(refused([](auto& r) { r[6].b.x = -0.1f; }).substr(0, 44),
              "record 6: the stored child bounds do not con");
    EXPECT_EQ(refused([](auto& r) { r[7].a.x = 0.0f; }),
              "record 7: the smooth radius must be a finite number in (0, 1000000] (got 0)");
    EXPECT_EQ(refused([](auto& r) { r[0].a.x = 0.0f; }),
              "record 0: the header's bounds do not contain the program's bounds");
    EXPECT_EQ(refused([](auto& r) {
                  r.resize(1);
                  r[0].i[1] = 0;
              }),
              "record 0: the program has no instructions");
    EXPECT_EQ(refused([](auto& r) {
                  r.pop_back();
                  r[0].i[1] = 6;
              }),
              "record 6: the program leaves 2 distances (expected 1)");
}

// Regression (Release builds): nested repetitions and a repetition of a rotated and translated
// child were refused by the compiler's own validation ("the stored child bounds do not contain the
// repeated shape"): the compiler derived the bounds from unrounded spacings and translations while
// the validator recomputes them from the float records. Both programs compile and validate now.
TEST(ShapeProgram, NestedAndRotatedRepetitionsCompile) {
    const ShapeNode nested = ShapeNode::repeat(
        ShapeNode::repeat(ShapeNode::box({0.1, 0.1, 0.1}), {0.3, 0, 0}, {3, 1, 1}), {0, 0, 1}, {1, 1, 4});
    ShapeNode rotatedChild = ShapeNode::capsule(0.15, 0.2);
    rotatedChild.placed({0, 0.1, 0}, glm::angleAxis(0.7, glm::normalize(glm::dvec3(1, 2, 3))));
    const ShapeNode rotated = ShapeNode::repeat(rotatedChild, {1, 0, 1.2}, {1, 1, 1});
    for (const ShapeNode* root : {&nested, &rotated}) {
        ShapeProgram program;
        std::string error;
        ASSERT_TRUE(compileShapeProgram(*root, program, error)) << error;
        ASSERT_TRUE(validateShapeProgram(program.records, error)) << error;
    }
    // The nested grid: boxes of half size 0.1 (0.1f in the records) at x in {-0.3, 0, 0.3} and
    // z in {-1.5, -0.5, 0.5, 1.5}. On the top face of the corner box the distance is that of the
    // float half size (1e-12); straight above it, never above the exact distance.
    ShapeProgram program;
    std::string error;
    ASSERT_TRUE(compileShapeProgram(nested, program, error)) << error;
    const double half = double(0.1f);
    EXPECT_NEAR(evaluateShapeProgram(program, {0.3, 0.1, 1.5}), 0.1 - half, 1e-12);
    const double above = evaluateShapeProgram(program, {0.3, 0.5, 1.5});
    EXPECT_GT(above, 0.0);
    EXPECT_LE(above, 0.5 - half + 1e-12);
}

}  // namespace
}  // namespace penumbra::sdf
