// Conservative per-object distance (issue 10 acceptance): sdfObjectDistance of
// renderer/shaders/sdf_scene.glsl (variant SDF_FIELDS, through the test compute pass
// tests/renderer/shaders/sdf_object_eval.comp) at 100 000 random world points against the exact
// world distance computed in double, on both backends under validation.
//
// Objects (GpuSdfObject filled as SceneRenderer's fillSdfData does: worldToLocal = inverse(model),
// local bounds with the relative margin, boundsMin.w = smallestSingularValue(mat3(model)); fields'
// bounds are the mesh bounds +- one voxel):
//   shape programs
//     box TRS          a box under rotation + non-uniform scale: the world solid is the box with half
//                      extents S h, rotated (exact: the affine image of the box, a parallelepiped)
//     ellipsoid        a sphere under rotation + non-uniform scale (exact: Eberly's robust root
//                      solve for the distance to an ellipsoid, double)
//     union of boxes   two boxes with their own rotations / translations in the program, the whole
//                      under rotation + non-uniform scale: two parallelepipeds (exact outside: the
//                      minimum of both distances)
//     capsule, torus,  rotated + uniformly scaled (exact: scale * the local closed form)
//     box uniform
//   baked fields (AssetManager::bakeSdf, resolution 48, padding 2)
//     sphere (rotation + uniform scale), box and torus (rotation + non-uniform scale), the bunny
//     (data/meshes/bunny.ply, tools/fetch_meshes.sh; rotation + uniform scale). Exact: the closest-
//     point distance to the transformed triangles (sdf::TriangleBvh, double, the model as the GPU
//     has it), signed by the generalized winding number (sdf::WindingNumber), the baker's sign.
// Points (fixed seed, ~100 000 in all, the same share per object): 35 % uniform in the object's local
// bounds box enlarged by 10 % (inside and near outside), 35 % near the surface (shapes: the surface
// point found by bisection plus an offset of log-uniform length 1e-6 .. 1e-2; fields: area-uniform
// surface points plus up to three world voxels), 30 % far: log-uniform from 0.5 to 100 object sizes.
//
// Rules (tol = 1e-5 * max(1, |exact|); gpu = sdfObjectDistance(object, p, fieldSafety = 1)):
//   - outside (exact >= 0), every object:       gpu <= exact + tol            (the rule)
//   - inside, shapes:                            |gpu| <= |exact| + tol and gpu <= tol: the magnitude
//     is never overestimated and a point inside is never reported outside. For the union, |exact|
//     inside is max(depth in box A, depth in box B), a lower bound of the true depth (so the test is
//     at least as strict as the rule).
//   - inside, closed baked meshes: gpu <= tol (never reported outside); the magnitude may exceed
//     |exact| by design (fieldSafety subtracts the interpolation bound b_w = raw - gpu, raw =
//     sdfObjectDistance(.., 0)), but by no more than 2 b_w + 2^-10 |raw| + tol (|trilinear - f| <=
//     b + the storage rounding, sdf_field.glsl); under rotation + uniform scale the field's own
//     signed rule carries over exactly: gpu <= exact + tol at every point.
//   - open meshes (the sign is not defined everywhere): gpu <= |exact| + tol at every point.
//   - uniform scale + rotation (shapes): |gpu - exact| <= tol + scale * 2^-19 * mag (mag: the
//     largest of |p_local| and the shape's parameters; SHAPE_EVAL_MARGIN of shape_program.glsl):
//     sigma_min is the exact scale, so the distance is exact to float precision.
//   - sdfBoxDistance (the trace's culling bound) <= max(exact, 0) + tol; sdfObjectVoxel is 0 for
//     shapes and voxelSize * sigma_min for fields.
// Printed: how tight the distance is per object (mean of exact - gpu outside, relative to
// max(1, exact) and, for fields, in world voxels), the worst (gpu - exact) / tol, and coverage.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include <shaders/sdf_object_eval.h>

#include "engine/assets/asset_manager.h"
#include "engine/assets/mesh.h"
#include "engine/assets/primitives.h"
#include "engine/sdf/bvh.h"
#include "engine/sdf/distance.h"
#include "engine/sdf/psdf.h"
#include "engine/sdf/shape_program.h"
#include "engine/sdf/winding.h"
#include "renderer/core/gpu_cache.h"
#include "renderer/core/shader_params.h"
#include "renderer/features/sdf_atlas.h"
#include "renderer/features/sdf_scene.h"
#include "support/test_device.h"

namespace {

namespace sdf = penumbra::sdf;
namespace assets = penumbra::assets;
namespace eval = penumbra::shaders::sdf_object_eval;
using penumbra::render::GpuCache;
using penumbra::render::GpuSdfField;
using penumbra::render::GpuSdfObject;
using penumbra::render::SdfAtlas;
using penumbra::render::ShaderParams;

static_assert(sizeof(eval::SdfObject) == sizeof(GpuSdfObject));
static_assert(offsetof(eval::SdfObject, boundsMin) == offsetof(GpuSdfObject, boundsMin));
static_assert(offsetof(eval::SdfObject, info) == offsetof(GpuSdfObject, info));
static_assert(sizeof(eval::SdfField) == sizeof(GpuSdfField));

constexpr size_t kTotalPoints = 100000;
constexpr double kPi = 3.14159265358979323846;

// ---- exact distances (double) ----------------------------------------------------------------------

// The affine image {A x + b : |x_i| <= h_i} of a box (a parallelepiped): signed distance to its
// boundary, as the distance to its 12 face triangles, negative inside.
struct AffineBox {
    glm::dmat3 a{1.0};
    glm::dvec3 b{0.0}, h{1.0};
    glm::dmat3 inv{1.0};
    glm::dvec3 corner(int i) const {
        return b + a * glm::dvec3(i & 1 ? h.x : -h.x, i & 2 ? h.y : -h.y, i & 4 ? h.z : -h.z);
    }
    double distance(const glm::dvec3& p) const {
        static const int faces[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                        {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
        double best = 1e300;
        for (const auto& f : faces) {
            const glm::dvec3 c0 = corner(f[0]), c1 = corner(f[1]), c2 = corner(f[2]), c3 = corner(f[3]);
            best = std::min({best, sdf::pointTriangleDistanceSquared(p, c0, c1, c2),
                             sdf::pointTriangleDistanceSquared(p, c0, c2, c3)});
        }
        const glm::dvec3 x = inv * (p - b);
        const bool inside = std::abs(x.x) < h.x && std::abs(x.y) < h.y && std::abs(x.z) < h.z;
        return inside ? -std::sqrt(best) : std::sqrt(best);
    }
};

AffineBox affineBox(const glm::dmat4& m, glm::dvec3 h) {
    AffineBox box;
    box.a = glm::dmat3(m);
    box.b = glm::dvec3(m[3]);
    box.h = h;
    box.inv = glm::inverse(box.a);
    return box;
}

// Eberly, "Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid" (2013): the
// robust bisection on the root of F(s); e0 >= e1 (>= e2), y_i >= 0.
double ellipseRoot(double r0, double z0, double z1, double g) {
    const double n0 = r0 * z0;
    double s0 = z1 - 1, s1 = g < 0 ? 0 : std::hypot(n0, z1) - 1, s = 0;
    for (int i = 0; i < 2200; ++i) {
        s = 0.5 * (s0 + s1);
        if (s == s0 || s == s1) break;
        const double ra = n0 / (s + r0), rb = z1 / (s + 1);
        g = ra * ra + rb * rb - 1;
        if (g > 0)
            s0 = s;
        else if (g < 0)
            s1 = s;
        else
            break;
    }
    return s;
}

double ellipseDistance(double e0, double e1, double y0, double y1) {
    if (y1 > 0) {
        if (y0 > 0) {
            const double z0 = y0 / e0, z1 = y1 / e1, g = z0 * z0 + z1 * z1 - 1;
            if (g == 0) return 0;
            const double r0 = (e0 / e1) * (e0 / e1), s = ellipseRoot(r0, z0, z1, g);
            const double x0 = r0 * y0 / (s + r0), x1 = y1 / (s + 1);
            return std::hypot(x0 - y0, x1 - y1);
        }
        return std::abs(y1 - e1);
    }
    const double numer0 = e0 * y0, denom0 = e0 * e0 - e1 * e1;
    if (numer0 < denom0) {
        const double xde0 = numer0 / denom0, x0 = e0 * xde0, x1 = e1 * std::sqrt(1 - xde0 * xde0);
        return std::hypot(x0 - y0, x1);
    }
    return std::abs(y0 - e0);
}

double ellipsoidRoot(double r0, double r1, double z0, double z1, double z2, double g) {
    const double n0 = r0 * z0, n1 = r1 * z1;
    double s0 = z2 - 1, s1 = g < 0 ? 0 : std::sqrt(n0 * n0 + n1 * n1 + z2 * z2) - 1, s = 0;
    for (int i = 0; i < 2200; ++i) {
        s = 0.5 * (s0 + s1);
        if (s == s0 || s == s1) break;
        const double ra = n0 / (s + r0), rb = n1 / (s + r1), rc = z2 / (s + 1);
        g = ra * ra + rb * rb + rc * rc - 1;
        if (g > 0)
            s0 = s;
        else if (g < 0)
            s1 = s;
        else
            break;
    }
    return s;
}

// Unsigned distance to the ellipsoid surface; e sorted e0 >= e1 >= e2 > 0, y >= 0 componentwise.
double ellipsoidDistanceSorted(const double e[3], const double y[3]) {
    if (y[2] > 0) {
        if (y[1] > 0) {
            if (y[0] > 0) {
                const double z0 = y[0] / e[0], z1 = y[1] / e[1], z2 = y[2] / e[2];
                const double g = z0 * z0 + z1 * z1 + z2 * z2 - 1;
                if (g == 0) return 0;
                const double r0 = (e[0] / e[2]) * (e[0] / e[2]), r1 = (e[1] / e[2]) * (e[1] / e[2]);
                const double s = ellipsoidRoot(r0, r1, z0, z1, z2, g);
                const glm::dvec3 x(r0 * y[0] / (s + r0), r1 * y[1] / (s + r1), y[2] / (s + 1));
                return glm::length(x - glm::dvec3(y[0], y[1], y[2]));
            }
            return ellipseDistance(e[1], e[2], y[1], y[2]);
        }
        if (y[0] > 0) return ellipseDistance(e[0], e[2], y[0], y[2]);
        return std::abs(y[2] - e[2]);
    }
    const double denom0 = e[0] * e[0] - e[2] * e[2], denom1 = e[1] * e[1] - e[2] * e[2];
    const double numer0 = e[0] * y[0], numer1 = e[1] * y[1];
    if (numer0 < denom0 && numer1 < denom1) {
        const double xde0 = numer0 / denom0, xde1 = numer1 / denom1;
        const double discr = 1 - xde0 * xde0 - xde1 * xde1;
        if (discr > 0) {
            const double x0 = e[0] * xde0, x1 = e[1] * xde1, x2 = e[2] * std::sqrt(discr);
            return std::sqrt((x0 - y[0]) * (x0 - y[0]) + (x1 - y[1]) * (x1 - y[1]) + x2 * x2);
        }
    }
    return ellipseDistance(e[0], e[1], y[0], y[1]);
}

// Signed distance from q (ellipsoid frame) to the ellipsoid of semi-axes `axes`.
double ellipsoidDistance(const glm::dvec3& axes, const glm::dvec3& q) {
    int order[3] = {0, 1, 2};
    std::sort(order, order + 3, [&](int i, int j) { return axes[i] > axes[j]; });
    double e[3], y[3];
    for (int k = 0; k < 3; ++k) {
        e[k] = axes[order[k]];
        y[k] = std::abs(q[order[k]]);
    }
    const double d = ellipsoidDistanceSorted(e, y);
    const glm::dvec3 z = q / axes;
    return glm::dot(z, z) < 1 ? -d : d;
}

double capsuleDistance(double r, double halfLength, glm::dvec3 p) {
    p.y -= std::clamp(p.y, -halfLength, halfLength);
    return glm::length(p) - r;
}

double torusDistance(double major, double minor, const glm::dvec3& p) {
    return std::hypot(std::hypot(p.x, p.z) - major, p.y) - minor;
}

// ---- objects ---------------------------------------------------------------------------------------

enum class Kind { Shapes, Field };
enum Group { Box, Near, Far };

struct MeshRef {  // a field's mesh in world space, for the exact distance
    std::vector<glm::dvec3> positions;
    std::vector<glm::uvec3> triangles;
    std::vector<double> areaPrefix;
    sdf::TriangleBvh bvh;
    std::unique_ptr<sdf::WindingNumber> winding;
};

struct Object {
    std::string name;
    Kind kind = Kind::Shapes;
    bool uniform = false;  // rotation + uniform scale (sigma_min exact)
    bool closed = true;    // fields: the sign is meaningful everywhere
    bool isUnion = false;
    double scale = 1;       // uniform objects: the scale
    double shapeMag = 0;    // largest shape parameter (SHAPE_EVAL_MARGIN)
    glm::dmat4 model{1.0};  // the float model, exactly, in double
    glm::dvec3 localLo{0}, localHi{0}, localInside{0};
    std::function<double(const glm::dvec3&)> exact;           // signed world distance
    std::function<double(const glm::dvec3&)> depthA, depthB;  // union: signed distances of the parts
    // Shapes
    sdf::ShapeProgram program;
    uint32_t firstRecord = 0;
    // Fields
    assets::AssetId field = 0;
    const sdf::PsdfAsset* asset = nullptr;
    std::unique_ptr<MeshRef> mesh;
    GpuSdfObject gpu{};
};

struct Sample {
    glm::vec3 p{0.0f};
    uint32_t object = 0;
    Group group = Box;
    double exact = 0;
    double unionDepth = 0;  // union, inside: max(depth A, depth B) (> 0)
};

struct Data {
    assets::AssetManager assets;
    std::vector<Object> objects;
    std::vector<Sample> samples;
    std::string error;
};

glm::dmat4 trs(glm::dvec3 t, glm::dquat r, glm::dvec3 s) {
    return glm::translate(glm::dmat4(1.0), t) * glm::mat4_cast(r) * glm::scale(glm::dmat4(1.0), s);
}

glm::dquat eulerDeg(double x, double y, double z) { return glm::dquat(glm::radians(glm::dvec3(x, y, z))); }

// The model as the GPU receives it (float), in double.
glm::dmat4 asFloat(const glm::dmat4& m) { return glm::dmat4(glm::mat4(m)); }

template <typename Fn>
void parallelFor(size_t n, Fn&& fn) {
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < threads; ++t)
        pool.emplace_back([&, t] {
            for (size_t i = n * t / threads; i < n * (t + 1) / threads; ++i) fn(i);
        });
    for (auto& th : pool) th.join();
}

// GpuSdfObject as renderer/scene_renderer.cpp fillSdfData fills it.
void fillGpu(Object& o, uint32_t slot, uint32_t index) {
    GpuSdfObject& g = o.gpu;
    g.model = glm::mat4(o.model);
    g.worldToLocal = glm::inverse(g.model);
    g.prevModel = g.model;
    glm::dvec3 lo, hi;
    if (o.kind == Kind::Shapes) {
        g.info = {uint32_t(penumbra::render::SdfKind::Shapes), o.firstRecord, 0u, index};
        lo = o.program.bounds.min;
        hi = o.program.bounds.max;
    } else {
        const sdf::PsdfHeader& h = o.asset->header;
        g.info = {uint32_t(penumbra::render::SdfKind::Field), slot, 0u, index};
        lo = h.boundsMin - h.voxelSize;
        hi = h.boundsMax + h.voxelSize;
    }
    const glm::dvec3 margin = 1e-4 * glm::max(glm::abs(lo), glm::abs(hi)) + 1e-6;
    for (int a = 0; a < 3; ++a) {
        g.boundsMin[a] = float(lo[a] - margin[a]);
        g.boundsMax[a] = float(hi[a] + margin[a]);
    }
    g.boundsMin.w = penumbra::render::smallestSingularValue(glm::mat3(g.model));
    g.params = glm::uvec4(0u);
}

bool addShape(Data& d, const std::string& name, const sdf::ShapeNode& root, const glm::dmat4& model,
              glm::dvec3 localInside, bool uniform, double scale, double shapeMag,
              std::function<double(const glm::dvec3&)> exact) {
    Object o;
    o.name = name;
    o.kind = Kind::Shapes;
    o.uniform = uniform;
    o.scale = scale;
    o.shapeMag = shapeMag;
    o.model = asFloat(model);
    o.localInside = localInside;
    o.exact = std::move(exact);
    std::string error;
    if (!sdf::compileShapeProgram(root, o.program, error)) {
        d.error = name + ": " + error;
        return false;
    }
    o.localLo = o.program.bounds.min;
    o.localHi = o.program.bounds.max;
    d.objects.push_back(std::move(o));
    return true;
}

bool addField(Data& d, const std::string& name, const assets::MeshData& mesh, const glm::dmat4& model,
              bool uniform) {
    Object o;
    o.name = name;
    o.kind = Kind::Field;
    o.uniform = uniform;
    o.model = asFloat(model);
    std::string error;
    const assets::AssetId meshId = d.assets.addMesh("test:" + name, mesh, error);
    if (!meshId) {
        d.error = name + ": " + error;
        return false;
    }
    sdf::BakeSettings settings;
    settings.resolution = 48;
    o.field = d.assets.bakeSdf(meshId, settings, error);
    o.asset = o.field ? d.assets.sdfField(o.field) : nullptr;
    if (!o.asset) {
        d.error = name + ": " + error;
        return false;
    }
    o.closed = (o.asset->header.flags & sdf::kPsdfFlagClosedManifold) != 0;
    o.localLo = o.asset->header.boundsMin;
    o.localHi = o.asset->header.boundsMax;
    auto ref = std::make_unique<MeshRef>();
    for (const glm::vec3& p : mesh.positions)
        ref->positions.push_back(glm::dvec3(o.model * glm::dvec4(p, 1.0)));
    double total = 0;
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
        const glm::uvec3 tri(mesh.indices[3 * t], mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]);
        ref->triangles.push_back(tri);
        const glm::dvec3 a = ref->positions[tri.x], b = ref->positions[tri.y], c = ref->positions[tri.z];
        total += 0.5 * glm::length(glm::cross(b - a, c - a));
        ref->areaPrefix.push_back(total);
    }
    ref->bvh.build(ref->positions, ref->triangles, 0);
    ref->winding = std::make_unique<sdf::WindingNumber>(ref->positions, ref->triangles);
    const MeshRef* m = ref.get();
    o.exact = [m](const glm::dvec3& p) {
        sdf::ClosestHit hit;
        m->bvh.closest(p, std::numeric_limits<double>::infinity(), hit);
        double w = m->winding->fast(p);
        if (std::abs(w - 0.5) < 0.25) w = m->winding->exact(p);
        return w > 0.5 ? -hit.distance : hit.distance;
    };
    o.mesh = std::move(ref);
    d.objects.push_back(std::move(o));
    return true;
}

bool buildObjects(Data& d) {
    using sdf::ShapeNode;
    // Box under T R S (non-uniform).
    {
        const glm::dvec3 h(0.5, 0.3, 0.4);
        const glm::dmat4 m = trs({1.0, -2.0, 0.5}, eulerDeg(30, -50, 70), {2.0, 0.5, 1.3});
        const AffineBox box = affineBox(asFloat(m), h);
        if (!addShape(d, "box TRS", ShapeNode::box(h), m, glm::dvec3(0), false, 0, 0.5,
                      [box](const glm::dvec3& p) { return box.distance(p); }))
            return false;
    }
    // Sphere under T R S (non-uniform): an ellipsoid.
    {
        const double r = 0.6;
        const glm::dvec3 s(1.5, 0.7, 1.1), t(-0.7, 0.4, 2.0);
        const glm::dquat q = eulerDeg(-20, 35, 110);
        const glm::dmat4 m = trs(t, q, s);
        const glm::dmat3 rt = glm::transpose(glm::mat3_cast(q));
        if (!addShape(d, "ellipsoid", ShapeNode::sphere(r), m, glm::dvec3(0), false, 0, r,
                      [=](const glm::dvec3& p) { return ellipsoidDistance(r * s, rt * (p - t)); }))
            return false;
    }
    // Union of two boxes with their own transforms, under T R S (non-uniform).
    {
        const glm::dvec3 h1(0.4, 0.2, 0.3), h2(0.15, 0.5, 0.25);
        const glm::dvec3 t1(-0.3, 0.1, 0.0), t2(0.35, -0.2, 0.1);
        const glm::dquat q1 = eulerDeg(10, 20, 30), q2 = eulerDeg(-40, 5, 60);
        ShapeNode a = ShapeNode::box(h1), b = ShapeNode::box(h2);
        a.placed(t1, q1);
        b.placed(t2, q2);
        const ShapeNode root = ShapeNode::csg(sdf::CsgOp::Union, {a, b});
        const glm::dmat4 m = trs({0.2, 0.3, -1.5}, eulerDeg(15, 75, -25), {1.7, 0.6, 1.2});
        const glm::dmat4 mf = asFloat(m);
        const AffineBox boxA = affineBox(mf * trs(t1, q1, glm::dvec3(1)), h1);
        const AffineBox boxB = affineBox(mf * trs(t2, q2, glm::dvec3(1)), h2);
        if (!addShape(d, "union of boxes", root, m, t1, false, 0, 0.5, [boxA, boxB](const glm::dvec3& p) {
                return std::min(boxA.distance(p), boxB.distance(p));
            }))
            return false;
        d.objects.back().isUnion = true;
        d.objects.back().depthA = [boxA](const glm::dvec3& p) { return boxA.distance(p); };
        d.objects.back().depthB = [boxB](const glm::dvec3& p) { return boxB.distance(p); };
    }
    // Uniform scale + rotation: capsule, torus, box (exact = scale * local exact).
    {
        const double r = 0.25, hl = 0.5, s = 1.7;
        const glm::dvec3 t(0.5, 1.5, -0.5);
        const glm::dquat q = eulerDeg(50, -30, 15);
        const glm::dmat3 rt = glm::transpose(glm::mat3_cast(q));
        if (!addShape(d, "capsule uniform", ShapeNode::capsule(r, hl), trs(t, q, glm::dvec3(s)),
                      glm::dvec3(0), true, s, hl,
                      [=](const glm::dvec3& p) { return s * capsuleDistance(r, hl, rt * (p - t) / s); }))
            return false;
    }
    {
        const double major = 0.6, minor = 0.2, s = 0.8;
        const glm::dvec3 t(-1.2, -0.3, 0.9);
        const glm::dquat q = eulerDeg(-65, 20, 40);
        const glm::dmat3 rt = glm::transpose(glm::mat3_cast(q));
        if (!addShape(d, "torus uniform", ShapeNode::torus(major, minor), trs(t, q, glm::dvec3(s)),
                      glm::dvec3(major, 0, 0), true, s, major,
                      [=](const glm::dvec3& p) { return s * torusDistance(major, minor, rt * (p - t) / s); }))
            return false;
    }
    {
        const glm::dvec3 h(0.45, 0.2, 0.35);
        const double s = 2.5;
        const glm::dvec3 t(3.0, -1.0, 2.0);
        const glm::dquat q = eulerDeg(33, 66, -12);
        const glm::dmat3 rt = glm::transpose(glm::mat3_cast(q));
        if (!addShape(d, "box uniform", ShapeNode::box(h), trs(t, q, glm::dvec3(s)), glm::dvec3(0), true, s,
                      0.45, [=](const glm::dvec3& p) {
                          return s *
                                 sdf::shapeDistance(sdf::ShapeKind::Box, glm::dvec4(h, 0), rt * (p - t) / s);
                      }))
            return false;
    }
    // Baked fields.
    std::string error;
    assets::MeshData sphere, box, torus, bunny;
    if (!assets::makeSphere(0.5f, 48, 24, sphere, error) ||
        !assets::makeBox({0.4f, 0.25f, 0.3f}, box, error) ||
        !assets::makeTorus(0.5f, 0.2f, 48, 16, torus, error)) {
        d.error = error;
        return false;
    }
    const std::string bunnyPath = std::string(PENUMBRA_SOURCE_DIR) + "/data/meshes/bunny.ply";
    if (!std::filesystem::exists(bunnyPath)) {
        d.error = bunnyPath + " is missing: run tools/fetch_meshes.sh";
        return false;
    }
    if (!assets::loadMesh(bunnyPath, bunny, error)) {
        d.error = error;
        return false;
    }
    glm::dvec3 blo(1e300), bhi(-1e300);
    for (const glm::vec3& p : bunny.positions) {
        blo = glm::min(blo, glm::dvec3(p));
        bhi = glm::max(bhi, glm::dvec3(p));
    }
    const double bunnyScale = 2.0 / glm::length(bhi - blo);
    return addField(d, "field sphere uniform", sphere,
                    trs({0.3, -0.6, 1.1}, eulerDeg(25, 40, -70), glm::dvec3(1.6)), true) &&
           addField(d, "field box TRS", box, trs({-1.0, 0.7, 0.2}, eulerDeg(-35, 15, 55), {1.8, 0.6, 1.2}),
                    false) &&
           addField(d, "field torus TRS", torus,
                    trs({0.9, 0.2, -0.8}, eulerDeg(70, -20, 10), {0.7, 1.5, 1.1}), false) &&
           addField(d, "field bunny uniform", bunny,
                    trs({-0.5, -0.4, 0.6}, eulerDeg(-15, 120, 20), glm::dvec3(bunnyScale)), true);
}

void addSamples(Data& d, uint32_t index, size_t count, std::mt19937_64& rng) {
    const Object& o = d.objects[index];
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> n(0.0, 1.0);
    auto direction = [&] { return glm::normalize(glm::dvec3(n(rng), n(rng), n(rng))); };
    auto world = [&](const glm::dvec3& l) { return glm::dvec3(o.model * glm::dvec4(l, 1.0)); };
    const glm::dvec3 lc = 0.5 * (o.localLo + o.localHi), lsize = o.localHi - o.localLo;
    double radius = 0;  // world radius of the local bounds box about its centre
    for (int c = 0; c < 8; ++c) {
        const glm::dvec3 corner(c & 1 ? o.localHi.x : o.localLo.x, c & 2 ? o.localHi.y : o.localLo.y,
                                c & 4 ? o.localHi.z : o.localLo.z);
        radius = std::max(radius, glm::length(world(corner) - world(lc)));
    }
    const double worldVoxel =
        o.kind == Kind::Field ? o.asset->header.voxelSize * glm::length(glm::dvec3(o.model[0])) : 0;
    const size_t first = d.samples.size();
    for (size_t i = 0; i < count; ++i) {
        Sample s;
        s.object = index;
        const double share = double(i) / double(count);
        glm::dvec3 x;
        if (share < 0.35) {
            s.group = Box;
            x = world(lc + (glm::dvec3(u(rng), u(rng), u(rng)) - 0.5) * lsize * 1.1);
        } else if (share < 0.7) {
            s.group = Near;
            if (o.kind == Kind::Field) {
                const MeshRef& m = *o.mesh;
                const size_t t = std::min(size_t(std::lower_bound(m.areaPrefix.begin(), m.areaPrefix.end(),
                                                                  u(rng) * m.areaPrefix.back()) -
                                                 m.areaPrefix.begin()),
                                          m.triangles.size() - 1);
                double b1 = u(rng), b2 = u(rng);
                if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
                const glm::dvec3 a = m.positions[m.triangles[t].x], b = m.positions[m.triangles[t].y],
                                 c = m.positions[m.triangles[t].z];
                x = a + b1 * (b - a) + b2 * (c - a) + direction() * (u(rng) * 3.0 * worldVoxel);
            } else {
                // Bisection between a point inside and one outside the bounds, then a small offset.
                glm::dvec3 in = world(o.localInside), out = world(lc) + direction() * (2.5 * radius);
                for (int k = 0; k < 80; ++k) {
                    const glm::dvec3 mid = 0.5 * (in + out);
                    (o.exact(mid) < 0 ? in : out) = mid;
                }
                x = 0.5 * (in + out) + direction() * std::pow(10.0, -6.0 + 4.0 * u(rng));
            }
        } else {
            s.group = Far;
            x = world(lc) + direction() * (radius * std::pow(200.0, u(rng)));  // 0.5 .. 100 sizes
        }
        s.p = glm::vec3(x);
        d.samples.push_back(s);
    }
    parallelFor(count, [&](size_t k) {
        Sample& s = d.samples[first + k];
        const glm::dvec3 p(s.p);
        s.exact = o.exact(p);
        if (o.isUnion && s.exact < 0) s.unionDepth = std::max(-o.depthA(p), -o.depthB(p));
    });
}

Data& data() {
    static Data d;
    static const bool built = [] {
        if (!buildObjects(d)) return false;
        std::mt19937_64 rng(20261211);
        const size_t per = (kTotalPoints + d.objects.size() - 1) / d.objects.size();
        for (uint32_t i = 0; i < d.objects.size(); ++i) addSamples(d, i, per, rng);
        return true;
    }();
    (void)built;
    return d;
}

// ---- the references are what they claim -------------------------------------------------------------

TEST(SdfObjectDistanceReference, EllipsoidAndBoxDistancesMatchBruteForce) {
    // The ellipsoid distance against the minimum over a dense surface sampling (an upper bound that
    // converges to the distance): exact <= brute + 1e-12 and brute - exact <= 2e-3 (the sampling's
    // resolution) at 300 points inside and outside.
    const glm::dvec3 axes(0.9, 0.42, 0.66);
    std::vector<glm::dvec3> surface;
    for (int i = 0; i <= 400; ++i)
        for (int j = 0; j < 800; ++j) {
            const double th = kPi * i / 400, ph = 2 * kPi * j / 800;
            surface.push_back(
                axes * glm::dvec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)));
        }
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    double worst = 0;
    for (int k = 0; k < 300; ++k) {
        const glm::dvec3 p(u(rng), u(rng), u(rng));
        double brute = 1e300;
        for (const glm::dvec3& s : surface) brute = std::min(brute, glm::length(p - s));
        const double e = ellipsoidDistance(axes, p);
        EXPECT_LE(std::abs(e), brute + 1e-12) << p.x << " " << p.y << " " << p.z;
        EXPECT_LE(brute - std::abs(e), 2e-3) << p.x << " " << p.y << " " << p.z;
        EXPECT_EQ(e < 0, glm::dot(p / axes, p / axes) < 1);
        worst = std::max(worst, brute - std::abs(e));
    }
    std::printf("[ sdf object ] ellipsoid reference: max (brute force - exact) %.2e over 300 points\n",
                worst);
    // The parallelepiped distance of a rotated, scaled box against the closed form in the box frame.
    const glm::dquat q = eulerDeg(30, -50, 70);
    const glm::dvec3 s(2.0, 0.5, 1.3), h(0.5, 0.3, 0.4), t(1.0, -2.0, 0.5);
    const AffineBox box = affineBox(trs(t, q, s), h);
    const glm::dmat3 rt = glm::transpose(glm::mat3_cast(q));
    for (int k = 0; k < 1000; ++k) {
        const glm::dvec3 p = t + glm::dvec3(u(rng), u(rng), u(rng)) * 1.5;
        const double closed = sdf::shapeDistance(sdf::ShapeKind::Box, glm::dvec4(s * h, 0), rt * (p - t));
        EXPECT_NEAR(box.distance(p), closed, 1e-12);
    }
}

// ---- the GPU evaluation ------------------------------------------------------------------------------

class SdfObjectDistanceGpu : public penumbra::test::GpuTest {
protected:
    std::vector<glm::vec4> evaluate(Data& d, SdfAtlas& atlas) {
        std::vector<std::pair<assets::AssetId, const sdf::PsdfAsset*>> list;
        for (const Object& o : d.objects)
            if (o.kind == Kind::Field) list.push_back({o.field, o.asset});
        std::string error;
        if (!atlas.update(list, error)) {
            ADD_FAILURE() << error;
            return {};
        }
        std::vector<sdf::ShapeInstruction> records;
        std::vector<GpuSdfObject> objects;
        for (uint32_t i = 0; i < d.objects.size(); ++i) {
            Object& o = d.objects[i];
            if (o.kind == Kind::Shapes) {
                o.firstRecord = uint32_t(records.size());
                records.insert(records.end(), o.program.records.begin(), o.program.records.end());
            }
            fillGpu(o, o.kind == Kind::Field ? atlas.slotOf(o.field) : 0u, i);
            objects.push_back(o.gpu);
        }
        std::vector<eval::ObjectPoint> points(d.samples.size());
        for (size_t i = 0; i < points.size(); ++i) {
            points[i].p = d.samples[i].p;
            points[i].object = d.samples[i].object;
        }
        const rhi::ShaderDesc& cs = eval::compute();
        rhi::BufferDesc bd;
        bd.usage = rhi::BufferUsage::Storage;
        auto make = [&](const char* name, uint64_t size, const void* init) {
            bd.size = size;
            bd.debugName = name;
            return dev().createBuffer(bd, init);
        };
        const rhi::BufferHandle objectBuffer =
            make("sdf objects", objects.size() * sizeof(GpuSdfObject), objects.data());
        const rhi::BufferHandle recordBuffer =
            make("shape records", records.size() * sizeof(sdf::ShapeInstruction), records.data());
        const rhi::BufferHandle fieldBuffer =
            make("sdf fields", atlas.fields().size() * sizeof(GpuSdfField), atlas.fields().data());
        const rhi::BufferHandle pointBuffer =
            make("points", points.size() * sizeof(points[0]), points.data());
        bd.usage = rhi::BufferUsage::Storage | rhi::BufferUsage::CopySrc;
        const rhi::BufferHandle outBuffer = make("results", points.size() * sizeof(glm::vec4), nullptr);
        std::vector<glm::vec4> out;
        GpuCache cache(dev());
        const rhi::PipelineHandle pipeline = cache.computePipeline(cs);
        const rhi::SamplerHandle sampler = cache.sampler(rhi::SamplerDesc{});  // linear, clamp-to-edge
        if (pipeline.isValid() && sampler.isValid() && objectBuffer.isValid() && recordBuffer.isValid() &&
            fieldBuffer.isValid() && pointBuffer.isValid() && outBuffer.isValid()) {
            rhi::CommandList& cmd = dev().beginCommandList("sdf object eval");
            cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("SdfObjects", objectBuffer)
                .set("ShapeRecords", recordBuffer)
                .set("SdfFields", fieldBuffer)
                .set("sdfAtlas", atlas.texture(), sampler)
                .set("ObjectPoints", pointBuffer)
                .set("ObjectResults", outBuffer);
            const bool bound = params.bind(cmd, cache, pipeline);
            EXPECT_TRUE(bound) << params.error();
            eval::PushConstants push;
            push.count = glm::uvec4(uint32_t(points.size()), 0, 0, 0);
            cmd.pushConstants(&push, sizeof(push));
            if (bound) penumbra::render::dispatchOver(cmd, cs, uint32_t(points.size()), 1);
            cmd.barrier(rhi::Barrier::buf(outBuffer, rhi::Access::ShaderWrite, rhi::Access::HostRead));
            dev().waitForSubmission(dev().submit(cmd));
            out.resize(points.size());
            if (!bound || !dev().readBuffer(outBuffer, 0, out.size() * sizeof(glm::vec4), out.data()))
                out.clear();
        } else {
            ADD_FAILURE() << "could not create the pipeline, the sampler or the buffers";
        }
        dev().waitIdle();
        for (rhi::BufferHandle b : {objectBuffer, recordBuffer, fieldBuffer, pointBuffer, outBuffer})
            dev().destroy(b);
        return out;
    }
};

TEST_P(SdfObjectDistanceGpu, NeverExceedsTheExactDistance) {
    const auto t0 = std::chrono::steady_clock::now();
    Data& d = data();
    ASSERT_TRUE(d.error.empty()) << d.error;
    ASSERT_GE(d.samples.size(), kTotalPoints);
    const auto t1 = std::chrono::steady_clock::now();
    SdfAtlas atlas(dev());
    const std::vector<glm::vec4> gpu = evaluate(d, atlas);
    ASSERT_EQ(gpu.size(), d.samples.size());

    struct Stats {
        size_t points = 0, inside = 0, outside = 0, near = 0, groups[3] = {};
        size_t insideOver = 0;  // inside, |gpu| > |exact| + tol (fields: allowed up to 2 b_w + ...)
        double sumGap = 0, sumGapVoxel = 0;  // outside: (exact - gpu) / max(1, exact); in world voxels
        size_t nearOutside = 0;              // outside, group Near
        double sumNearGap = 0;               // of those: exact - gpu (world units)
        double worstOutside = -1e30;         // max (gpu - exact) / tol outside
        double worstInside = -1e30;          // max (|gpu| - |exact|) / tol inside
        double worstUniform = 0;             // max |gpu - exact| / (tol + margin), uniform shapes
        double worstInsideExcessVoxel = 0;   // fields: max (|gpu| - |exact|) inside, world voxels
    };
    std::vector<Stats> stats(d.objects.size());
    size_t failures = 0;
    auto fail = [&](const Sample& s, size_t i, const std::string& what, const glm::vec4& g) {
        if (++failures <= 16)
            ADD_FAILURE() << d.objects[s.object].name << " point " << i << " (" << s.p.x << ", " << s.p.y
                          << ", " << s.p.z << ") group " << s.group << ": " << what << "; exact " << s.exact
                          << " gpu " << g.x << " raw " << g.y << " voxel " << g.z << " box " << g.w;
    };
    for (size_t i = 0; i < d.samples.size(); ++i) {
        const Sample& s = d.samples[i];
        const Object& o = d.objects[s.object];
        Stats& st = stats[s.object];
        const glm::vec4 g = gpu[i];
        const double v = g.x, raw = g.y, ex = s.exact;
        const double tol = 1e-5 * std::max(1.0, std::abs(ex));
        const double sigma = o.gpu.boundsMin.w;
        const double worldVoxel = o.kind == Kind::Field ? o.asset->header.voxelSize * sigma : 0;
        ++st.points;
        ++st.groups[s.group];
        st.near += std::abs(ex) < (o.kind == Kind::Field ? 3 * worldVoxel : 1e-2);
        if (!std::isfinite(v) || !std::isfinite(raw)) {
            fail(s, i, "not finite", g);
            continue;
        }
        // The culling bound and the voxel size.
        if (!(g.w <= std::max(ex, 0.0) + tol)) fail(s, i, "sdfBoxDistance exceeds the exact distance", g);
        if (o.kind == Kind::Shapes ? g.z != 0.0f : !(std::abs(g.z - worldVoxel) <= 1e-6 * worldVoxel))
            fail(s, i, "sdfObjectVoxel is not voxelSize * sigma_min (0 for shapes)", g);
        if (ex >= 0) {
            // Outside: gpu <= exact + 1e-5 max(1, |exact|).
            ++st.outside;
            st.worstOutside = std::max(st.worstOutside, (v - ex) / tol);
            st.sumGap += (ex - v) / std::max(1.0, ex);
            if (o.kind == Kind::Field) st.sumGapVoxel += (ex - v) / worldVoxel;
            if (s.group == Near) {
                ++st.nearOutside;
                st.sumNearGap += ex - v;
            }
            if (!(v <= ex + tol)) fail(s, i, "outside: exceeds the exact distance", g);
        } else {
            ++st.inside;
            if (o.kind == Kind::Shapes) {
                // Inside: |gpu| <= |exact| + tol, never reported outside (union: |exact| = max depth).
                const double depth = o.isUnion ? s.unionDepth : -ex;
                st.worstInside = std::max(st.worstInside, (std::abs(v) - depth) / tol);
                st.insideOver += std::abs(v) > depth + tol;
                if (!(std::abs(v) <= depth + tol)) fail(s, i, "inside: magnitude exceeds the exact depth", g);
                if (!(v <= tol)) fail(s, i, "inside: reported outside", g);
            } else if (o.closed) {
                // Inside a closed baked mesh: never reported outside; the magnitude is over the exact
                // depth by at most 2 b_w + 2^-10 |raw| (+ tol).
                st.worstInside = std::max(st.worstInside, (std::abs(v) + ex) / tol);
                st.insideOver += std::abs(v) > -ex + tol;
                st.worstInsideExcessVoxel =
                    std::max(st.worstInsideExcessVoxel, (std::abs(v) + ex) / worldVoxel);
                if (!(v <= tol)) fail(s, i, "inside a closed mesh: reported outside", g);
                const double allowed = -ex + 2 * (raw - v) + std::ldexp(std::abs(raw), -10) + tol;
                if (!(std::abs(v) <= allowed))
                    fail(s, i, "inside: magnitude over exact + 2 b_w + storage", g);
            }
        }
        if (o.kind == Kind::Field) {
            if (!(v <= std::abs(ex) + tol)) fail(s, i, "exceeds the unsigned exact distance", g);
            if (o.uniform && o.closed && !(v <= ex + tol))
                fail(s, i, "uniform scale: exceeds the exact signed distance", g);
        }
        if (o.kind == Kind::Shapes && o.uniform) {
            // Exact to float precision: |gpu - exact| <= tol + scale * SHAPE_EVAL_MARGIN(mag).
            const glm::dvec3 pl = glm::dvec3(glm::inverse(o.model) * glm::dvec4(glm::dvec3(s.p), 1.0));
            const double mag = std::max({std::abs(pl.x), std::abs(pl.y), std::abs(pl.z), o.shapeMag});
            const double bound = tol + o.scale * std::ldexp(mag, -19);
            st.worstUniform = std::max(st.worstUniform, std::abs(v - ex) / bound);
            if (!(std::abs(v - ex) <= bound)) fail(s, i, "uniform scale: not exact to float precision", g);
        }
    }
    EXPECT_EQ(failures, 0u);
    const auto t2 = std::chrono::steady_clock::now();
    auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
    for (size_t k = 0; k < d.objects.size(); ++k) {
        const Stats& st = stats[k];
        const Object& o = d.objects[k];
        const double n = double(std::max<size_t>(st.outside, 1));
        std::printf(
            "[ sdf object ] %-20s sigma_min %.6f%s: %zu points (%zu box, %zu near, %zu far), %zu inside, "
            "%zu near the surface\n",
            o.name.c_str(), double(o.gpu.boundsMin.w), o.kind == Kind::Field && !o.closed ? " (open)" : "",
            st.points, st.groups[Box], st.groups[Near], st.groups[Far], st.inside, st.near);
        std::printf("[ sdf object ]   outside: mean (exact - gpu) / max(1, exact) %.3e", st.sumGap / n);
        if (o.kind == Kind::Field) std::printf(", mean exact - gpu %.3f world voxel", st.sumGapVoxel / n);
        std::printf("; max (gpu - exact) / tol %.3f\n", st.worstOutside);
        const double nearGap = st.sumNearGap / double(std::max<size_t>(st.nearOutside, 1));
        std::printf("[ sdf object ]   near the surface, outside: mean exact - gpu %.3e", nearGap);
        if (o.kind == Kind::Field)
            std::printf(" = %.3f world voxel",
                        nearGap / (o.asset->header.voxelSize * double(o.gpu.boundsMin.w)));
        std::printf(" (%zu points)\n", st.nearOutside);
        if (st.inside)
            std::printf(
                "[ sdf object ]   inside: max (|gpu| - |exact|) / tol %.3g, |gpu| > |exact| + tol at %zu "
                "points%s\n",
                st.worstInside, st.insideOver,
                o.kind == Kind::Field
                    ? (" (max " + std::to_string(st.worstInsideExcessVoxel) + " world voxel)").c_str()
                    : "");
        if (o.kind == Kind::Shapes && o.uniform)
            std::printf("[ sdf object ]   uniform: max |gpu - exact| / (tol + margin) %.3f\n",
                        st.worstUniform);
        // Coverage: every group, both sides of the surface, points near it.
        EXPECT_GT(st.groups[Box], st.points / 4) << o.name;
        EXPECT_GT(st.groups[Near], st.points / 4) << o.name;
        EXPECT_GT(st.groups[Far], st.points / 5) << o.name;
        EXPECT_GT(st.inside, st.points / 10) << o.name;
        EXPECT_GT(st.near, st.points / 5) << o.name;
    }
    std::printf("[ sdf object ] setup (bakes, exact distances) %.0f ms, GPU + checks %.0f ms\n", ms(t0, t1),
                ms(t1, t2));
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfObjectDistanceGpu, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
