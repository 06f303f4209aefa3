// Acceptance tests of the SDF trace pass (issue 10; renderer/features/sdf_trace.h,
// renderer/shaders/sdf_trace.comp) on both backends under validation:
//   1. analytic depth and normals against an exact double-precision CPU ray cast of the shape
//      programs (sdf::evaluateShapeProgram), with rotated, uniformly and non-uniformly scaled
//      objects and CSG; no traced depth ever lies behind the exact first surface (thin plates
//      under every preset's over-relaxation included);
//   2. hybrid rendering: meshes and SDF objects occlude each other as two meshes would;
//   3. robustness: cameras inside or on surfaces, unusable transforms (skipped with one warning),
//      no SDF objects, 1000 instances of one program, more than 24 objects along one ray;
//   4. step counts (gbuffer.aux.y) within the step limits; over-relaxation saves steps;
//   5. velocity of a moving SDF object, and of static ones under a moving camera.
// Every criterion is asserted with its metric and threshold next to it; the measured numbers are
// printed. Depth agreement is relative (|a - b| / b), as in docs/ACCURACY.md. Image sizes are small
// (128x96 to 320x180, one frame each) so that software rasterizers run the suite in seconds.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/packing.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/assets/primitives.h"
#include "engine/core/log.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"
#include "engine/scene/scene.h"
#include "engine/sdf/shape_program.h"
#include "renderer/core/gbuffer_encoding.h"
#include "renderer/features/lighting_reference.h"
#include "renderer/features/sdf_scene.h"
#include "renderer/scene_renderer.h"
#include "support/log_capture.h"
#include "support/ref_camera.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using render::FrameDesc;
using render::SceneRenderer;
using sdf::ShapeNode;

constexpr float kFovY = 1.0471976f;  // 60 degrees
constexpr double kPi = 3.14159265358979323846;

// ---- scene building -------------------------------------------------------------------------------

// Rotation whose local -Z points along `dir` (camera convention).
glm::quat lookRotation(glm::vec3 dir, glm::vec3 up = {0, 1, 0}) {
    if (std::abs(glm::dot(glm::normalize(dir), glm::normalize(up))) > 0.999f) up = {0, 0, 1};
    return glm::quat_cast(glm::inverse(glm::lookAtRH(glm::vec3(0), dir, up)));
}

glm::quat euler(float xDeg, float yDeg, float zDeg) {
    return glm::quat(glm::radians(glm::vec3(xDeg, yDeg, zDeg)));
}

struct SdfScene {
    ecs::World world;
    assets::AssetManager assets;
    ecs::Entity camera;

    explicit SdfScene(glm::vec3 eye = {0, 0, 0}, glm::vec3 target = {0, 0, -1}, float nearPlane = 0.1f,
                      float farPlane = 100.0f) {
        camera = world.create();
        placeCamera(eye, target);
        ecs::Camera c;
        c.fovY = kFovY;
        c.nearPlane = nearPlane;
        c.farPlane = farPlane;
        world.add<ecs::Camera>(camera, c);
    }
    void placeCamera(glm::vec3 eye, glm::vec3 target, glm::vec3 up = {0, 1, 0}) {
        ecs::Transform* t = world.get<ecs::Transform>(camera);
        if (!t) t = world.add<ecs::Transform>(camera);
        t->position = eye;
        t->rotation = lookRotation(target - eye, up);
    }
    assets::AssetId program(const ShapeNode& root) {
        sdf::ShapeProgram p;
        std::string error;
        EXPECT_TRUE(sdf::compileShapeProgram(root, p, error)) << error;
        const std::string key = assets::AssetManager::shapeProgramKey(p);
        assets::AssetId id = assets.addShapeProgram(key, std::move(p), error);
        EXPECT_NE(id, 0u) << error;
        return id;
    }
    ecs::Entity transformed(glm::vec3 position, glm::quat rotation, glm::vec3 scale, const char* name) {
        ecs::Entity e = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = position;
        t->rotation = rotation;
        t->scale = scale;
        if (name) world.add<ecs::Name>(e, ecs::Name{name});
        return e;
    }
    ecs::Entity sdfObject(assets::AssetId program, glm::vec3 position, glm::quat rotation = {1, 0, 0, 0},
                          glm::vec3 scale = glm::vec3(1), const char* name = nullptr, uint32_t maxSteps = 0) {
        ecs::Entity e = transformed(position, rotation, scale, name);
        ecs::SdfRenderer sr;
        sr.sdf = program;
        sr.source = ecs::SdfSource::Shapes;
        sr.maxSteps = maxSteps;
        world.add<ecs::SdfRenderer>(e, sr);
        return e;
    }
    ecs::Entity sdfObject(const ShapeNode& root, glm::vec3 position, glm::quat rotation = {1, 0, 0, 0},
                          glm::vec3 scale = glm::vec3(1), const char* name = nullptr) {
        return sdfObject(program(root), position, rotation, scale, name);
    }
    ecs::Entity meshObject(const std::string& key, const assets::MeshData& mesh, glm::vec3 position,
                           glm::quat rotation = {1, 0, 0, 0}, glm::vec3 scale = glm::vec3(1)) {
        std::string error;
        assets::AssetId id = assets.addMesh(key, mesh, error);
        EXPECT_NE(id, 0u) << error;
        ecs::Entity e = transformed(position, rotation, scale, nullptr);
        ecs::MeshRenderer mr;
        mr.mesh = id;
        world.add<ecs::MeshRenderer>(e, mr);
        return e;
    }
    FrameDesc frame(uint32_t w, uint32_t h, scene::TraceQuality q = scene::TraceQuality::Medium,
                    bool aux = true) const {
        FrameDesc d;
        d.width = w;
        d.height = h;
        d.camera = camera;
        d.settings.quality = q;
        d.aux = aux;
        return d;
    }
    bool render(SceneRenderer& r, const FrameDesc& d, std::string& error) {
        ecs::updateTransforms(world);
        return r.render(world, assets, d, error);
    }
};

assets::MeshData sphereMesh(float r, uint32_t segments, uint32_t rings) {
    assets::MeshData m;
    std::string error;
    EXPECT_TRUE(assets::makeSphere(r, segments, rings, m, error)) << error;
    return m;
}
assets::MeshData boxMesh(glm::vec3 half) {
    assets::MeshData m;
    std::string error;
    EXPECT_TRUE(assets::makeBox(half, m, error)) << error;
    return m;
}

// ---- G-buffer readback ------------------------------------------------------------------------------

struct GBuffer {
    uint32_t w = 0, h = 0;
    std::vector<float> depth;
    std::vector<glm::vec2> normal, velocity, aux;  // aux: x entity index (-1 none), y steps
    size_t at(uint32_t x, uint32_t y) const { return size_t(y) * w + x; }
    bool hit(size_t i) const { return depth[i] > 0.0f; }
    int id(size_t i) const { return int(std::lround(aux[i].x)); }
};

std::vector<uint8_t> readRaw(SceneRenderer& r, const std::string& name, rhi::Format expected) {
    std::vector<uint8_t> texels;
    rhi::Format format{};
    std::string error;
    EXPECT_TRUE(r.readTarget(name, texels, format, error)) << name << ": " << error;
    EXPECT_EQ(format, expected) << name;
    return texels;
}

std::vector<glm::vec2> readHalf2(SceneRenderer& r, const std::string& name) {
    std::vector<uint8_t> texels = readRaw(r, name, rhi::Format::RG16_FLOAT);
    std::vector<glm::vec2> out(texels.size() / 4);
    for (size_t i = 0; i < out.size(); ++i) {
        uint16_t h[2];
        std::memcpy(h, &texels[i * 4], 4);
        out[i] = {glm::unpackHalf1x16(h[0]), glm::unpackHalf1x16(h[1])};
    }
    return out;
}

GBuffer readGBuffer(SceneRenderer& r, uint32_t w, uint32_t h, bool aux = true) {
    GBuffer g;
    g.w = w;
    g.h = h;
    std::vector<uint8_t> d = readRaw(r, "gbuffer.depth", rhi::Format::R32_FLOAT);
    g.depth.resize(d.size() / 4);
    std::memcpy(g.depth.data(), d.data(), g.depth.size() * 4);
    g.normal = readHalf2(r, "gbuffer.normal");
    g.velocity = readHalf2(r, "gbuffer.velocity");
    if (aux) {
        std::vector<uint8_t> a = readRaw(r, "gbuffer.aux", rhi::Format::RG32_FLOAT);
        g.aux.resize(a.size() / 8);
        std::memcpy(g.aux.data(), a.data(), g.aux.size() * 8);
    }
    EXPECT_EQ(g.depth.size(), size_t(w) * h);
    return g;
}

// Renders one frame and reads its G-buffer back; prints the wall time of the two.
GBuffer renderAndRead(SdfScene& s, SceneRenderer& r, const FrameDesc& d, const char* what) {
    std::string error;
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_TRUE(s.render(r, d, error)) << error;
    GBuffer g = readGBuffer(r, d.width, d.height, d.aux);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::printf("  [%s] %ux%u frame + readback: %.0f ms\n", what, d.width, d.height, ms);
    return g;
}

std::vector<std::string> passNames(const SceneRenderer& r) {
    std::vector<std::string> names;
    for (const auto& p : r.lastFrameStats().passes) names.push_back(p.name);
    return names;
}

bool hasPass(const SceneRenderer& r, const std::string& name) {
    const auto names = passNames(r);
    return std::find(names.begin(), names.end(), name) != names.end();
}

// ---- the exact CPU ray cast ---------------------------------------------------------------------------

// The renderer's camera in double: RefCamera (tests/support/ref_camera.h).

// One traced object as the CPU sees it: the renderer's float world matrix in double.
struct RefObject {
    const sdf::ShapeProgram* program = nullptr;
    glm::dmat4 model{1.0}, inv{1.0};
    glm::dmat3 normalMatrix{1.0};  // inverse transpose of the model's 3x3 part
    double sigma = 1.0;            // smallest singular value: world distance >= sigma * local distance
    int entity = -1;

    double worldDistance(const glm::dvec3& p) const {
        return sigma * sdf::evaluateShapeProgram(*program, glm::dvec3(inv * glm::dvec4(p, 1.0)));
    }
    // The ray o + t d (d unit) against the program's local bounds box grown by `margin`.
    bool interval(const glm::dvec3& o, const glm::dvec3& d, double margin, double& t0, double& t1) const {
        const glm::dvec3 lo(inv * glm::dvec4(o, 1.0)), ld(glm::dmat3(inv) * d);
        t0 = -std::numeric_limits<double>::infinity();
        t1 = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a) {
            const double mn = program->bounds.min[a] - margin, mx = program->bounds.max[a] + margin;
            if (ld[a] == 0.0) {
                if (lo[a] < mn || lo[a] > mx) return false;
                continue;
            }
            double ta = (mn - lo[a]) / ld[a], tb = (mx - lo[a]) / ld[a];
            if (ta > tb) std::swap(ta, tb);
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
        }
        return t0 <= t1;
    }
    // Exact world normal: central differences of the local program with a tiny step, transformed by
    // the inverse transpose.
    glm::dvec3 normal(const glm::dvec3& p) const {
        const glm::dvec3 pl(inv * glm::dvec4(p, 1.0));
        const double hd = 1e-7 * std::max(1.0, glm::length(pl));
        glm::dvec3 g;
        for (int a = 0; a < 3; ++a) {
            glm::dvec3 e(0.0);
            e[a] = hd;
            g[a] = sdf::evaluateShapeProgram(*program, pl + e) - sdf::evaluateShapeProgram(*program, pl - e);
        }
        return glm::normalize(normalMatrix * g);
    }
};

// 1 / ||m^-1||_2 (power iteration on m^-T m^-1): world distance >= this times local distance.
double smallestSingularValue(const glm::dmat3& m) {
    const glm::dmat3 inv = glm::inverse(m), a = glm::transpose(inv) * inv;
    glm::dvec3 v(0.577, 0.579, 0.575);
    double lambda = 0;
    for (int k = 0; k < 200; ++k) {
        const glm::dvec3 u = a * v;
        lambda = glm::length(u);
        v = u / lambda;
    }
    return 1.0 / std::sqrt(lambda);
}

std::vector<RefObject> refObjects(const ecs::World& world, const assets::AssetManager& assets) {
    std::vector<RefObject> out;
    for (auto [e, sr, t] : world.view<ecs::SdfRenderer, ecs::Transform>()) {
        RefObject o;
        o.program = assets.shapeProgram(sr.sdf);
        if (!o.program) continue;
        o.model = glm::dmat4(t.worldMatrix);
        o.inv = glm::inverse(o.model);
        o.normalMatrix = glm::transpose(glm::inverse(glm::dmat3(o.model)));
        o.sigma = smallestSingularValue(glm::dmat3(o.model));
        o.entity = int(e.index);
        out.push_back(o);
    }
    return out;
}

struct RefHit {
    bool hit = false;
    bool undecided = false;  // the sphere trace did not settle (a ray tangent to a surface)
    double t = 0.0;          // along the unit ray
    int object = -1;         // index into the RefObject array
};

// Nearest root of one object's distance along o + t d in [a, b]: sphere tracing in double to
// 1e-10, then a sign change bracketed just behind the converged point and bisected.
RefHit traceObject(const RefObject& obj, const glm::dvec3& o, const glm::dvec3& d, double a, double b) {
    RefHit r;
    double t = a;
    auto f = [&](double tt) { return obj.worldDistance(o + d * tt); };
    double dist = f(t);
    if (dist <= 0.0) {  // the ray starts inside the solid: the GPU trace hits at once as well
        r.hit = true;
        r.t = t;
        return r;
    }
    int i = 0;
    for (; i < 1000000 && dist >= 1e-10; ++i) {
        t += dist;
        if (t > b) return r;
        dist = f(t);
    }
    if (dist >= 1e-10) {
        r.undecided = true;
        return r;
    }
    // Bracket the sign change behind t and bisect it (robust where the bound converges slowly).
    if (dist > 0.0) {
        for (double step = 1e-10; step < 1e-4; step *= 2.0) {
            if (f(t + step) <= 0.0) {
                double lo = t, hi = t + step;
                for (int k = 0; k < 80 && hi - lo > 1e-15 * hi; ++k) {
                    const double mid = 0.5 * (lo + hi);
                    (f(mid) > 0.0 ? lo : hi) = mid;
                }
                t = 0.5 * (lo + hi);
                break;
            }
        }
    }
    r.hit = t <= b;
    r.t = t;
    return r;
}

// The nearest surface of all objects along a camera ray (unit direction d), between the camera's
// near and far planes (linear depth).
RefHit traceScene(const std::vector<RefObject>& objects, const glm::dvec3& o, const glm::dvec3& d,
                  double tMin, double tMax) {
    RefHit best;
    double limit = tMax;
    for (size_t k = 0; k < objects.size(); ++k) {
        double t0, t1;
        if (!objects[k].interval(o, d, 1e-6, t0, t1)) continue;
        const double a = std::max(t0, tMin), b = std::min(t1, limit);
        if (a > b) continue;
        RefHit h = traceObject(objects[k], o, d, a, b);
        if (h.undecided) best.undecided = true;
        if (h.hit && h.t <= limit) {
            best.hit = true;
            best.t = h.t;
            best.object = int(k);
            limit = h.t;
        }
    }
    return best;
}

struct RefImage {
    std::vector<double> depth;       // linear depth, 0 = miss
    std::vector<glm::dvec3> normal;  // world normal where hit
    std::vector<int> entity;         // entity index, -1 = miss
    std::vector<uint8_t> undecided;  // excluded from every metric
};

// Runs `fn(y)` for every row on all cores.
template <typename Fn>
void parallelRows(uint32_t h, Fn fn) {
    const unsigned n = std::max(1u, std::min(8u, std::thread::hardware_concurrency()));
    std::vector<std::thread> threads;
    for (unsigned k = 0; k < n; ++k)
        threads.emplace_back([&, k] {
            for (uint32_t y = k; y < h; y += n) fn(y);
        });
    for (auto& t : threads) t.join();
}

RefImage referenceImage(const ecs::World& world, const assets::AssetManager& assets, ecs::Entity camera,
                        uint32_t w, uint32_t h) {
    const RefCamera cam(world, camera, w, h);
    const std::vector<RefObject> objects = refObjects(world, assets);
    RefImage img;
    img.depth.assign(size_t(w) * h, 0.0);
    img.normal.assign(size_t(w) * h, glm::dvec3(0.0));
    img.entity.assign(size_t(w) * h, -1);
    img.undecided.assign(size_t(w) * h, 0);
    parallelRows(h, [&](uint32_t y) {
        for (uint32_t x = 0; x < w; ++x) {
            const glm::dvec3 dir = cam.dir(x, y);
            const double len = glm::length(dir);
            const glm::dvec3 d = dir / len;
            const RefHit hit = traceScene(objects, cam.eye, d, cam.nearPlane * len, cam.farPlane * len);
            const size_t i = size_t(y) * w + x;
            img.undecided[i] = hit.undecided ? 1 : 0;
            if (!hit.hit) continue;
            img.depth[i] = hit.t / len;
            img.normal[i] = objects[size_t(hit.object)].normal(cam.eye + d * hit.t);
            img.entity[i] = objects[size_t(hit.object)].entity;
        }
    });
    return img;
}

RefImage referenceImage(const SdfScene& s, uint32_t w, uint32_t h) {
    return referenceImage(s.world, s.assets, s.camera, w, h);
}

double angleDeg(glm::dvec3 a, glm::dvec3 b) {
    return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b)) * 180.0 / kPi;
}

// Surfaces the trace went through: pixels where the traced depth lies behind the exact first
// surface (by more than `tolerance`, relative), and pixels the exact cast hits but the trace misses.
// Sphere tracing on distance bounds that never overestimate cannot step past a surface, and the
// hit epsilon only ever ends a ray early, so neither should happen except where a step limit runs out.
struct SeeThrough {
    uint64_t behind = 0, missed = 0;
    double maxBehind = 0;  // relative
};
SeeThrough seeThrough(const GBuffer& g, const RefImage& ref, double tolerance) {
    SeeThrough st;
    for (size_t i = 0; i < g.depth.size(); ++i) {
        if (ref.undecided[i] || ref.depth[i] <= 0) continue;
        if (!g.hit(i)) {
            ++st.missed;
            continue;
        }
        const double behind = (double(g.depth[i]) - ref.depth[i]) / ref.depth[i];
        st.maxBehind = std::max(st.maxBehind, behind);
        st.behind += behind > tolerance;
    }
    return st;
}

// Every pixel: finite depth, 0 or within [near, far]; finite normal and velocity; steps <= limit.
void expectSane(const GBuffer& g, float nearPlane, float farPlane, uint32_t stepLimit) {
    uint64_t bad = 0;
    for (size_t i = 0; i < g.depth.size(); ++i) {
        const float z = g.depth[i];
        const bool ok =
            std::isfinite(z) && (z == 0.0f || (z >= nearPlane * 0.999f && z <= farPlane * 1.001f)) &&
            std::isfinite(g.normal[i].x) && std::isfinite(g.normal[i].y) && std::isfinite(g.velocity[i].x) &&
            std::isfinite(g.velocity[i].y) && (g.aux.empty() || g.aux[i].y <= float(stepLimit));
        if (!ok && bad++ < 3)
            ADD_FAILURE() << "pixel " << i % g.w << "," << i / g.w << ": depth " << z << ", steps "
                          << (g.aux.empty() ? 0.0f : g.aux[i].y) << " (limit " << stepLimit << ")";
    }
    EXPECT_EQ(bad, 0u);
}

uint64_t hitCount(const GBuffer& g) {
    uint64_t n = 0;
    for (size_t i = 0; i < g.depth.size(); ++i) n += g.hit(i);
    return n;
}

class SdfTrace : public GpuTest {};

// ---- 1. analytic depth and normals --------------------------------------------------------------------

// Sphere, rotated box, rotated capsule, rotated and uniformly scaled torus, a plane floor and a box
// minus a sphere. The camera looks down on them; its far plane (12) ends the floor at a moderate
// angle, so the floor has a silhouette too (the sky above is background).
void buildShapesScene(SdfScene& s) {
    s.placeCamera({0, 3, 6.5f}, {0, 0.4f, 0});
    s.world.get<ecs::Camera>(s.camera)->farPlane = 12.0f;
    s.sdfObject(ShapeNode::sphere(0.7), {-2.0f, 0.7f, 0.0f}, {1, 0, 0, 0}, glm::vec3(1), "sphere");
    s.sdfObject(ShapeNode::box({0.5, 0.4, 0.6}), {0.0f, 0.9f, -1.2f}, euler(30, 20, 0), glm::vec3(1), "box");
    s.sdfObject(ShapeNode::capsule(0.3, 0.5), {2.0f, 0.9f, 0.3f}, euler(0, 0, 40), glm::vec3(1), "capsule");
    s.sdfObject(ShapeNode::torus(0.5, 0.15), {0.2f, 0.55f, 1.4f}, euler(60, 0, 0), glm::vec3(1.4f), "torus");
    s.sdfObject(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0}, {1, 0, 0, 0}, glm::vec3(1), "floor");
    s.sdfObject(
        ShapeNode::csg(sdf::CsgOp::Subtract, {ShapeNode::box({0.45, 0.45, 0.45}), ShapeNode::sphere(0.58)}),
        {-1.0f, 1.9f, 0.6f}, euler(15, -35, 0), glm::vec3(1), "carved");
}

// The analytic criteria for one traced frame against the exact ray cast, printed and
// asserted: depth within 1e-3 relative on >= 99.5 % of the pixels hit in both, silhouette mismatch
// (pixels hit in one only) <= 0.5 % of the pixels hit in either, mean normal angle error <= 0.5
// degrees; and no traced depth behind the exact first surface.
void expectMatchesExact(const SdfScene& s, const GBuffer& g, const RefImage& ref) {
    const uint32_t w = g.w, h = g.h;
    uint64_t both = 0, either = 0, onlyGpu = 0, onlyRef = 0, within = 0, undecided = 0, sameId = 0;
    double maxRel = 0, sumRel = 0, maxAbs = 0, sumAngle = 0, maxAngle = 0;
    uint32_t worstX = 0, worstY = 0;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const size_t i = g.at(x, y);
            if (ref.undecided[i]) {
                ++undecided;
                continue;
            }
            const bool gh = g.hit(i), rh = ref.depth[i] > 0.0;
            ASSERT_TRUE(std::isfinite(g.depth[i])) << x << "," << y;
            if (gh || rh) ++either;
            if (gh && !rh) ++onlyGpu;
            if (rh && !gh) ++onlyRef;
            if (!(gh && rh)) continue;
            ++both;
            const double abs = std::abs(double(g.depth[i]) - ref.depth[i]), rel = abs / ref.depth[i];
            if (rel > maxRel) {
                maxRel = rel;
                worstX = x;
                worstY = y;
            }
            sumRel += rel;
            maxAbs = std::max(maxAbs, abs);
            if (rel <= 1e-3) ++within;
            const double angle = angleDeg(glm::dvec3(render::octDecode(g.normal[i])), ref.normal[i]);
            sumAngle += angle;
            maxAngle = std::max(maxAngle, angle);
            if (g.id(i) == ref.entity[i]) ++sameId;
        }
    // The first pixels whose depth is off by more than 1e-3: the (conservative) distance of the
    // object the GPU hit at the GPU's point, in pixel footprints (a hit is a distance below
    // hitEpsilon footprints), and the cosine between the ray and the exact normal.
    {
        const RefCamera cam(s.world, s.camera, w, h);
        const std::vector<RefObject> objects = refObjects(s.world, s.assets);
        int listed = 0;
        for (size_t i = 0; i < g.depth.size() && listed < 6; ++i) {
            if (!g.hit(i) || ref.depth[i] <= 0 || std::abs(g.depth[i] - ref.depth[i]) <= 1e-3 * ref.depth[i])
                continue;
            ++listed;
            const glm::dvec3 dir = cam.dir(uint32_t(i % w), uint32_t(i / w));
            const glm::dvec3 p = cam.eye + dir * double(g.depth[i]);
            const double t = glm::length(dir) * double(g.depth[i]), footprint = 2.0 * cam.tanHalf / h * t;
            double dist = std::nan("");
            for (const RefObject& o : objects)
                if (o.entity == g.id(i)) dist = o.worldDistance(p);
            std::printf(
                "    px %zu,%zu: depth %.5f (entity %d, %.0f steps; its distance there %.3g = %.3g "
                "footprints) vs exact %.5f (entity %d, cos to the ray %.3f)\n",
                i % w, i / w, g.depth[i], g.id(i), g.aux[i].y, dist, dist / footprint, ref.depth[i],
                ref.entity[i], std::abs(glm::dot(ref.normal[i], glm::normalize(dir))));
        }
    }
    ASSERT_GT(both, uint64_t(w) * h / 10) << "the objects cover a good part of the image";
    const double fracWithin = double(within) / double(both);
    const double mismatch = double(onlyGpu + onlyRef) / double(either);
    const double meanAngle = sumAngle / double(both);
    const SeeThrough st = seeThrough(g, ref, 1e-4);
    std::printf(
        "  analytic depth: %llu px hit in both; |rel err| max %.3g (px %u,%u), mean %.3g; |abs err| max "
        "%.3g; "
        "within 1e-3 rel %.4f %%\n",
        (unsigned long long)both, maxRel, worstX, worstY, sumRel / double(both), maxAbs, 100.0 * fracWithin);
    std::printf(
        "  silhouette mismatch %.4f %% (%llu GPU only, %llu exact only, of %llu hit); ids agree on %.4f %%; "
        "%llu undecided px excluded\n",
        100.0 * mismatch, (unsigned long long)onlyGpu, (unsigned long long)onlyRef,
        (unsigned long long)either, 100.0 * double(sameId) / double(both), (unsigned long long)undecided);
    std::printf(
        "  normal angle error mean %.4f deg, max %.3f deg; %llu px behind the exact surface by > 1e-4 rel "
        "(max %.3g)\n",
        meanAngle, maxAngle, (unsigned long long)st.behind, st.maxBehind);
    EXPECT_GE(fracWithin, 0.995) << "depth within 1e-3 relative on >= 99.5 % of pixels hit in both";
    EXPECT_LE(mismatch, 0.005) << "silhouette mismatch <= 0.5 % of hit pixels";
    EXPECT_LE(meanAngle, 0.5) << "mean normal angle error <= 0.5 degrees";
    EXPECT_LE(undecided, uint64_t(w) * h / 1000) << "the CPU reference settles on nearly every pixel";
    EXPECT_EQ(st.behind, 0u) << "no traced depth behind the exact first surface (1e-4 relative)";
}

TEST_P(SdfTrace, AnalyticDepthAndNormalsMatchExactRayCast) {
    constexpr uint32_t w = 256, h = 192;
    SdfScene s;
    buildShapesScene(s);
    SceneRenderer r(dev());
    const FrameDesc d = s.frame(w, h, scene::TraceQuality::Reference);
    const GBuffer g = renderAndRead(s, r, d, "reference quality");
    EXPECT_TRUE(hasPass(r, "sdf_trace"));
    EXPECT_EQ(r.lastFrameStats().sdfObjects, 6u);
    ecs::updateTransforms(s.world);
    const auto t0 = std::chrono::steady_clock::now();
    const RefImage ref = referenceImage(s, w, h);
    std::printf("  CPU exact ray cast: %.0f ms\n",
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    expectMatchesExact(s, g, ref);
}

// Non-uniform scale (conservative distances: sigma_min of the model) on a rotated ellipsoid, box and
// torus: the same criteria as uniform transforms. The flattened ellipsoid is seen at grazing angles
// over part of its outline, where a hit's depth error is its distance over the cosine to the ray.
TEST_P(SdfTrace, NonUniformScaleMatchesExactRayCast) {
    constexpr uint32_t w = 192, h = 144;
    SdfScene s({0.3f, 1.0f, 3.4f}, {0, 0, 0});
    s.sdfObject(ShapeNode::sphere(0.6), {-1.2f, 0.3f, 0.0f}, euler(0, 30, 20), {1.8f, 0.6f, 1.0f});
    s.sdfObject(ShapeNode::box({0.4, 0.4, 0.4}), {1.2f, 0.2f, 0.0f}, euler(20, 0, 30), {0.5f, 1.5f, 1.0f});
    s.sdfObject(ShapeNode::torus(0.5, 0.15), {0.0f, -0.5f, 0.8f}, euler(50, 10, 0), {1.2f, 2.0f, 0.8f});
    SceneRenderer r(dev());
    const GBuffer g = renderAndRead(s, r, s.frame(w, h, scene::TraceQuality::Reference), "non-uniform");
    EXPECT_EQ(r.lastFrameStats().sdfObjects, 3u);
    ecs::updateTransforms(s.world);
    expectMatchesExact(s, g, referenceImage(s, w, h));
}

// Over-relaxed presets on thin plates at many angles in front of a wall: no ray goes through a
// plate (a traced depth behind the exact first surface), for every preset's omega.
TEST_P(SdfTrace, OverRelaxedStepsNeverGoThroughThinPlates) {
    constexpr uint32_t w = 192, h = 144;
    SdfScene s({0.2f, 0.6f, 6.0f}, {0, 0, 0});
    s.sdfObject(ShapeNode::box({6, 6, 0.1}), {0, 0, -3});
    const assets::AssetId plate = s.program(ShapeNode::box({0.42, 0.42, 0.004}));
    for (int i = 0; i < 12; ++i) {
        const float yaw = -75.0f + 13.6f * float(i), pitch = -50.0f + 9.0f * float(i % 5);
        s.sdfObject(plate, {-1.8f + 1.2f * float(i % 4), -1.1f + 1.1f * float(i / 4), 0.3f * float(i % 3)},
                    euler(pitch, yaw, 0));
    }
    ecs::updateTransforms(s.world);
    const RefImage ref = referenceImage(s, w, h);
    SceneRenderer r(dev());
    for (auto q : {scene::TraceQuality::Low, scene::TraceQuality::Medium, scene::TraceQuality::High}) {
        const GBuffer g = renderAndRead(s, r, s.frame(w, h, q), scene::toString(q));
        const SeeThrough st = seeThrough(g, ref, 1e-4);
        uint64_t plates = 0;
        for (size_t i = 0; i < g.depth.size(); ++i) plates += ref.entity[i] > 1;
        std::printf(
            "  %s (omega %.2f): %llu px see a plate; %llu px behind the exact surface (> 1e-4 rel, max "
            "%.3g), %llu exact hits missed\n",
            scene::toString(q), scene::tracePreset(q).overRelaxation, (unsigned long long)plates,
            (unsigned long long)st.behind, st.maxBehind, (unsigned long long)st.missed);
        EXPECT_GT(plates, 2000u);
        EXPECT_EQ(st.behind, 0u)
            << "no ray through a plate (depth behind the exact surface by > 1e-4 relative)";
        EXPECT_EQ(st.missed, 0u) << "the wall behind covers the image: every pixel is hit";
    }
}

// ---- 2. hybrid: meshes and SDF objects ------------------------------------------------------------------

// Entities in the same order in both variants, so entity indices match: a sphere crossing a box and
// a box crossing a sphere; `sdf` makes the second of each pair an analytic SDF, else a mesh.
void buildHybridScene(SdfScene& s, bool sdf) {
    s.placeCamera({0.3f, 1.1f, 3.6f}, {0.2f, 0, 0});
    const glm::quat boxRot = euler(10, 25, 0), box2Rot = euler(30, 30, 15);
    s.meshObject("sphere-a", sphereMesh(0.8f, 256, 128), {-1.1f, 0.0f, 0.0f});
    if (sdf)
        s.sdfObject(ShapeNode::box({0.6, 0.6, 0.6}), {-0.5f, 0.1f, 0.2f}, boxRot);
    else
        s.meshObject("box-a", boxMesh(glm::vec3(0.6f)), {-0.5f, 0.1f, 0.2f}, boxRot);
    s.meshObject("box-b", boxMesh(glm::vec3(0.55f)), {1.0f, 0.0f, 0.0f}, box2Rot);
    if (sdf)
        s.sdfObject(ShapeNode::sphere(0.7), {1.5f, 0.2f, 0.3f});
    else
        s.meshObject("sphere-b", sphereMesh(0.7f, 256, 128), {1.5f, 0.2f, 0.3f});
}

TEST_P(SdfTrace, HybridNearestObjectMatchesAllMeshRendering) {
    constexpr uint32_t w = 256, h = 192;
    SdfScene hybrid, meshes;
    buildHybridScene(hybrid, true);
    buildHybridScene(meshes, false);
    SceneRenderer r(dev());
    const GBuffer b = renderAndRead(meshes, r, meshes.frame(w, h), "meshes only");
    EXPECT_FALSE(hasPass(r, "sdf_trace"));
    for (auto q : {scene::TraceQuality::Medium, scene::TraceQuality::Reference}) {
        const GBuffer a = renderAndRead(hybrid, r, hybrid.frame(w, h, q), "mesh + SDF");
        // The default acceleration (tile culling, no world cache): the culling passes, then the trace.
        EXPECT_EQ(passNames(r), (std::vector<std::string>{"scene_upload", "gbuffer_mesh", "sdf_upload",
                                                          "sdf_tile_cull_bounds", "sdf_tile_cull_clear",
                                                          "sdf_tile_cull_coarse", "sdf_tile_cull",
                                                          "sdf_trace", "lighting"}));
        uint64_t same = 0, hitAny = 0, objectVsObject = 0, objectVsBackground = 0;
        std::map<int, uint64_t> countA, countB;
        for (size_t i = 0; i < a.depth.size(); ++i) {
            const int ia = a.id(i), ib = b.id(i);
            ++countA[ia];
            ++countB[ib];
            same += ia == ib;
            hitAny += ia >= 0 || ib >= 0;
            if (ia != ib) ++(ia >= 0 && ib >= 0 ? objectVsObject : objectVsBackground);
        }
        const double frac = double(same) / double(a.depth.size());
        std::printf(
            "  %s: nearest object agrees on %.4f %% of all pixels (%.4f %% of the %llu covered in either); "
            "differing: %llu object vs object, %llu object vs background\n",
            scene::toString(q), 100.0 * frac,
            100.0 * (1.0 - double(objectVsObject + objectVsBackground) / double(hitAny)),
            (unsigned long long)hitAny, (unsigned long long)objectVsObject,
            (unsigned long long)objectVsBackground);
        for (auto [id, n] : countA)
            std::printf("    entity %d: %llu px (mesh + SDF), %llu px (meshes)\n", id, (unsigned long long)n,
                        (unsigned long long)countB[id]);
        EXPECT_GE(frac, 0.99) << "same nearest object on >= 99 % of pixels";
        expectSane(a, 0.1f, 100.0f, scene::tracePreset(q).maxSteps);
        // Every object is visible (the crossings are real, not one object hiding the other).
        for (int id = 1; id <= 4; ++id) EXPECT_GT(countA[id], 1000u) << "entity " << id;
    }
}

TEST_P(SdfTrace, HiddenObjectsStayHidden) {
    constexpr uint32_t w = 128, h = 96;
    SdfScene s({0, 0, 5}, {0, 0, 0});
    // Left: a mesh box in front of an SDF sphere that it covers entirely. Right: an SDF box in
    // front of a mesh sphere that it covers entirely.
    const ecs::Entity frontMesh = s.meshObject("front-box", boxMesh({0.8f, 0.8f, 0.1f}), {-1.0f, 0.0f, 0.0f});
    const ecs::Entity hiddenSdf = s.sdfObject(ShapeNode::sphere(0.5), {-1.3f, 0.0f, -2.0f});
    const ecs::Entity frontSdf = s.sdfObject(ShapeNode::box({0.8, 0.8, 0.1}), {1.0f, 0.0f, 0.0f});
    const ecs::Entity hiddenMesh =
        s.meshObject("hidden-sphere", sphereMesh(0.5f, 64, 32), {1.3f, 0.0f, -2.0f});
    SceneRenderer r(dev());
    const GBuffer g = renderAndRead(s, r, s.frame(w, h), "hidden");
    std::map<int, uint64_t> count;
    double maxDepthErr = 0;
    for (size_t i = 0; i < g.depth.size(); ++i) {
        ++count[g.id(i)];
        if (g.id(i) == int(frontMesh.index) || g.id(i) == int(frontSdf.index))
            maxDepthErr = std::max(maxDepthErr, std::abs(double(g.depth[i]) - 4.9) / 4.9);
    }
    std::printf(
        "  front mesh %llu px, front SDF %llu px, hidden SDF %llu px, hidden mesh %llu px; front depth "
        "max rel err %.3g\n",
        (unsigned long long)count[int(frontMesh.index)], (unsigned long long)count[int(frontSdf.index)],
        (unsigned long long)count[int(hiddenSdf.index)], (unsigned long long)count[int(hiddenMesh.index)],
        maxDepthErr);
    EXPECT_GT(count[int(frontMesh.index)], 500u);
    EXPECT_GT(count[int(frontSdf.index)], 500u);
    EXPECT_EQ(count[int(hiddenSdf.index)], 0u) << "an SDF behind a mesh is not visible";
    EXPECT_EQ(count[int(hiddenMesh.index)], 0u) << "a mesh behind an SDF is not visible";
    EXPECT_LE(maxDepthErr, 1e-3) << "front faces at linear depth 4.9 (relative error)";
    // Control: with the front objects hidden, the others show.
    s.world.get<ecs::MeshRenderer>(frontMesh)->visible = false;
    s.world.get<ecs::SdfRenderer>(frontSdf)->visible = false;
    const GBuffer c = renderAndRead(s, r, s.frame(w, h), "unhidden");
    uint64_t sdfPx = 0, meshPx = 0;
    for (size_t i = 0; i < c.depth.size(); ++i) {
        sdfPx += c.id(i) == int(hiddenSdf.index);
        meshPx += c.id(i) == int(hiddenMesh.index);
    }
    EXPECT_GT(sdfPx, 50u);
    EXPECT_GT(meshPx, 50u);
}

// ---- 3. robustness ---------------------------------------------------------------------------------------

TEST_P(SdfTrace, CameraInsideAnSdfObject) {
    SdfScene s({0, 0, 0}, {0, 0, -1});
    s.sdfObject(ShapeNode::sphere(3.0), {0, 0, 0});
    s.sdfObject(ShapeNode::box({0.5, 0.5, 0.5}), {0, 0, -2});
    SceneRenderer r(dev());
    for (auto q : {scene::TraceQuality::Medium, scene::TraceQuality::Reference}) {
        const FrameDesc d = s.frame(128, 96, q);
        const GBuffer g = renderAndRead(s, r, d, scene::toString(q));
        expectSane(g, 0.1f, 100.0f, scene::tracePreset(q).maxSteps);
        std::printf("  inside: %llu of %zu px hit\n", (unsigned long long)hitCount(g), g.depth.size());
    }
}

TEST_P(SdfTrace, CameraExactlyOnASurface) {
    SdfScene s({0, 0, 0}, {0, 0, -1});
    const ecs::Entity plane = s.sdfObject(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0});
    SceneRenderer r(dev());
    // On the plane y = 0: looking along it, and down into it.
    for (glm::vec3 target : {glm::vec3(0, 0, -1), glm::vec3(0, -1, -1), glm::vec3(0, 1, -0.2f)}) {
        s.placeCamera({0, 0, 0}, target);
        const GBuffer g = renderAndRead(s, r, s.frame(128, 96), "on a plane");
        expectSane(g, 0.1f, 100.0f, 128);
    }
    // On the surface of a unit sphere (a plane no more): looking into it, out of it, along it.
    s.world.get<ecs::SdfRenderer>(plane)->visible = false;
    s.sdfObject(ShapeNode::sphere(1.0), {0, 0, 0});
    for (glm::vec3 target : {glm::vec3(0, 0, 0), glm::vec3(0, 0, 2), glm::vec3(1, 0, 1)}) {
        s.placeCamera({0, 0, 1}, target);
        const GBuffer g = renderAndRead(s, r, s.frame(128, 96), "on a sphere");
        expectSane(g, 0.1f, 100.0f, 128);
    }
}

// A good sphere and a box named 'broken' with an unusable transform: two frames of a new renderer
// render, the box is skipped with exactly one warning naming it, the sphere is drawn.
void expectSkippedWithOneWarning(rhi::Device& device, glm::vec3 position, glm::vec3 scale) {
    WarningCapture capture;
    SceneRenderer r(device);
    SdfScene s({0, 0, 5}, {0, 0, 0});
    const ecs::Entity good = s.sdfObject(ShapeNode::sphere(0.8), {-1, 0, 0});
    const ecs::Entity broken =
        s.sdfObject(ShapeNode::box({0.5, 0.5, 0.5}), position, {1, 0, 0, 0}, scale, "broken");
    for (int frame = 0; frame < 2; ++frame) {
        const GBuffer g = renderAndRead(s, r, s.frame(128, 96), "skip");
        uint64_t goodPx = 0, brokenPx = 0;
        for (size_t i = 0; i < g.depth.size(); ++i) {
            goodPx += g.id(i) == int(good.index);
            brokenPx += g.id(i) == int(broken.index);
        }
        EXPECT_GT(goodPx, 500u) << "the other object still renders";
        EXPECT_EQ(brokenPx, 0u);
        EXPECT_EQ(r.lastFrameStats().sdfObjects, 1u);
        expectSane(g, 0.1f, 100.0f, 128);
    }
    EXPECT_EQ(capture.count("'broken'"), 1u) << "one warning naming the object over two frames";
    for (const std::string& w : capture.warnings) std::printf("  warning: %s\n", w.c_str());
}

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST_P(SdfTrace, ZeroScaleIsSkippedWithOneWarning) {
    expectSkippedWithOneWarning(dev(), {1, 0, 0}, glm::vec3(0.0f));
    expectSkippedWithOneWarning(dev(), {1, 0, 0}, {1.0f, 0.0f, 1.0f});
}
TEST_P(SdfTrace, NegativeScaleIsSkippedWithOneWarning) {
    expectSkippedWithOneWarning(dev(), {1, 0, 0}, glm::vec3(-1.0f));
    expectSkippedWithOneWarning(dev(), {1, 0, 0}, {1.0f, -1.0f, 1.0f});
}
TEST_P(SdfTrace, NaNScaleIsSkippedWithOneWarning) {
    expectSkippedWithOneWarning(dev(), {1, 0, 0}, glm::vec3(kNaN));
}
TEST_P(SdfTrace, NaNTranslationIsSkippedWithOneWarning) {
    expectSkippedWithOneWarning(dev(), {kNaN, 0, 0}, glm::vec3(1.0f));
}

TEST_P(SdfTrace, NoSdfObjects) {
    // Only a camera: the background, no SDF pass.
    SdfScene s;
    SceneRenderer r(dev());
    FrameDesc d = s.frame(64, 48);
    d.settings.background = {0.2f, 0.3f, 0.4f};
    std::string error;
    ASSERT_TRUE(s.render(r, d, error)) << error;
    EXPECT_FALSE(hasPass(r, "sdf_trace"));
    EXPECT_FALSE(hasPass(r, "sdf_upload"));
    EXPECT_EQ(r.lastFrameStats().sdfObjects, 0u);
    ImageRGBA8 img;
    ASSERT_TRUE(r.readPixels(img, error)) << error;
    const std::array<uint8_t, 3> bg =
        render::reference::displayEncode(d.settings.background, d.settings.exposure, d.settings.toneMapper);
    int maxDiff = 0;
    for (uint32_t y = 0; y < 48; ++y)
        for (uint32_t x = 0; x < 64; ++x)
            for (int c = 0; c < 3; ++c)
                maxDiff = std::max(maxDiff, std::abs(int(img.at(x, y)[c]) - int(bg[size_t(c)])));
    EXPECT_LE(maxDiff, 1) << "background everywhere";

    // Only meshes: no sdf_upload or sdf_trace pass.
    s.meshObject("sphere", sphereMesh(0.5f, 32, 16), {0, 0, -3});
    ASSERT_TRUE(s.render(r, d, error)) << error;
    EXPECT_EQ(passNames(r), (std::vector<std::string>{"scene_upload", "gbuffer_mesh", "lighting"}));
    EXPECT_EQ(r.lastFrameStats().sdfObjects, 0u);
}

TEST_P(SdfTrace, ThousandInstancesOfOneShapeProgram) {
    constexpr uint32_t w = 128, h = 96;
    SdfScene s({0, 0, 0}, {0, 0, -1});
    const assets::AssetId sphere = s.program(ShapeNode::sphere(0.04));
    // One instance first: the second frame sends the object records only (the program's records
    // are already on the GPU; renderer/features/sdf_scene.h SdfSceneStore).
    s.sdfObject(sphere, {-1.95f, -1.2f, -3.0f});
    SceneRenderer r(dev());
    renderAndRead(s, r, s.frame(w, h), "1 instance");
    for (int k = 1; k < 1000; ++k)
        s.sdfObject(sphere, {-1.95f + 0.1f * float(k % 40), -1.2f + 0.1f * float(k / 40), -3.0f});
    const GBuffer g = renderAndRead(s, r, s.frame(w, h), "1000 instances");
    const render::FrameStats& st = r.lastFrameStats();
    EXPECT_EQ(st.sdfObjects, 1000u);
    EXPECT_EQ(s.assets.count(assets::AssetKind::ShapeProgram), 1u);
    // Metric: bytes the frame's SDF upload sends. Threshold: exactly the 1000 object records (999
    // of 1000 changed: one full rewrite), no shape records.
    EXPECT_EQ(st.sdfUpload.uploadBytes, 1000u * sizeof(render::GpuSdfObject))
        << "the shared program's records are uploaded once";
    std::set<int> ids;
    for (size_t i = 0; i < g.depth.size(); ++i)
        if (g.id(i) >= 0) ids.insert(g.id(i));
    std::printf("  1000 instances: %llu px hit, %zu distinct objects seen, scene buffers %llu B\n",
                (unsigned long long)hitCount(g), ids.size(), (unsigned long long)st.memory.sceneBuffers);
    // Each sphere is 2.2 px across with its centre 2.8 px from its neighbours: every one covers a
    // pixel centre.
    EXPECT_EQ(ids.size(), 1000u);
    expectSane(g, 0.1f, 100.0f, 128);
}

// 30 square plates along the view axis, nearer ones smaller, so every plate shows as a ring and
// the central rays cross all 30 bounds boxes (the per-pixel list holds 24). Entities are created
// far to near: the nearest plates are the ones beyond the list.
constexpr int kPlates = 30;
glm::vec3 platePosition(int i) { return {0.0f, 0.0f, -(3.0f + 0.25f * float(i))}; }
double plateHalf(int i) { return 0.1 + 0.05 * i; }

void buildPlates(SdfScene& s, int drawn) {
    for (int i = kPlates - 1; i >= 0; --i) {
        if (i < drawn)
            s.sdfObject(ShapeNode::box({plateHalf(i), plateHalf(i), 0.02}), platePosition(i));
        else
            s.transformed(platePosition(i), {1, 0, 0, 0}, glm::vec3(1), nullptr);  // keeps indices aligned
    }
}

TEST_P(SdfTrace, MoreThan24ObjectsAlongARay) {
    constexpr uint32_t w = 192, h = 144;
    SdfScene all({0, 0, 0}, {0, 0, -1}), fewer({0, 0, 0}, {0, 0, -1});
    buildPlates(all, kPlates);
    buildPlates(fewer, 20);
    ecs::updateTransforms(all.world);
    // The central ray crosses every plate's box: the overflow path runs.
    {
        const RefCamera cam(all.world, all.camera, w, h);
        const glm::dvec3 d = glm::normalize(cam.dir(w / 2, h / 2));
        int crossed = 0;
        for (const RefObject& o : refObjects(all.world, all.assets)) {
            double t0, t1;
            crossed += o.interval(cam.eye, d, 0.0, t0, t1);
        }
        ASSERT_EQ(crossed, kPlates);
    }
    SceneRenderer r(dev());
    const GBuffer a = renderAndRead(all, r, all.frame(w, h), "30 plates");
    const GBuffer b = renderAndRead(fewer, r, fewer.frame(w, h), "20 plates");
    // Where the 20 nearest plates are hit, the 30-plate image is the same image.
    uint64_t covered = 0, sameId = 0, sameDepth = 0;
    double maxRel = 0;
    for (size_t i = 0; i < a.depth.size(); ++i) {
        if (!b.hit(i)) continue;
        ++covered;
        sameId += a.id(i) == b.id(i);
        const double rel = std::abs(double(a.depth[i]) - double(b.depth[i])) / double(b.depth[i]);
        maxRel = std::max(maxRel, rel);
        sameDepth += rel <= 1e-5;
    }
    // Everywhere: the nearest plate of the exact ray cast (CPU).
    const RefImage ref = referenceImage(all, w, h);
    uint64_t refAgree = 0, refHit = 0;
    double refMaxRel = 0;
    for (size_t i = 0; i < a.depth.size(); ++i) {
        if (ref.undecided[i]) continue;
        refAgree += a.id(i) == ref.entity[i];
        if (ref.depth[i] > 0 && a.hit(i)) {
            ++refHit;
            refMaxRel = std::max(refMaxRel, std::abs(double(a.depth[i]) - ref.depth[i]) / ref.depth[i]);
        }
    }
    std::printf(
        "  overflow: %llu px covered by the 20 nearest plates; same id on %.4f %%, depth within 1e-5 rel "
        "on %.4f %% (max rel diff %.3g); ids agree with the exact cast on %.4f %% of all pixels (depth max "
        "rel err %.3g)\n",
        (unsigned long long)covered, 100.0 * double(sameId) / double(covered),
        100.0 * double(sameDepth) / double(covered), maxRel,
        100.0 * double(refAgree) / double(a.depth.size()), refMaxRel);
    ASSERT_GT(covered, 1000u);
    EXPECT_GE(double(sameId) / double(covered), 0.999) << "same nearest plate on >= 99.9 % of covered pixels";
    EXPECT_GE(double(sameDepth) / double(covered), 0.999) << "same depth (1e-5 rel) on >= 99.9 % of them";
    EXPECT_GE(double(refAgree) / double(a.depth.size()), 0.99) << "nearest plate as the exact cast, >= 99 %";
    expectSane(a, 0.1f, 100.0f, 128);
}

// ---- 4. step counts -------------------------------------------------------------------------------------

TEST_P(SdfTrace, StepCountsStayWithinTheLimits) {
    constexpr uint32_t w = 128, h = 96;
    SdfScene s({0, 0.5f, 5}, {0, 0, 0});
    // Left: a sphere and a capsule with the frame's limit; right: a torus with its own, higher limit.
    s.sdfObject(ShapeNode::sphere(0.6), {-1.2f, 0.0f, 0.0f});
    s.sdfObject(ShapeNode::capsule(0.2, 0.5), {-1.2f, 0.0f, 1.0f}, euler(0, 0, 70));
    const ecs::Entity raised = s.sdfObject(s.program(ShapeNode::torus(0.5, 0.2)), {1.3f, 0.0f, 0.0f},
                                           euler(70, 0, 0), glm::vec3(1), nullptr, 40);
    SceneRenderer r(dev());
    ecs::updateTransforms(s.world);
    const RefCamera cam(s.world, s.camera, w, h);
    RefObject raisedRef;
    for (const RefObject& o : refObjects(s.world, s.assets))
        if (o.entity == int(raised.index)) raisedRef = o;
    ASSERT_NE(raisedRef.program, nullptr);

    // Every preset, then an override of 8 steps that many rays exhaust.
    struct Case {
        scene::TraceQuality q;
        std::optional<uint32_t> maxSteps;
    };
    for (const Case& c : {Case{scene::TraceQuality::Low, {}}, Case{scene::TraceQuality::Medium, {}},
                          Case{scene::TraceQuality::High, {}}, Case{scene::TraceQuality::Reference, {}},
                          Case{scene::TraceQuality::Medium, 8u}}) {
        FrameDesc d = s.frame(w, h, c.q);
        d.settings.trace.maxSteps = c.maxSteps;
        const uint32_t limit = d.settings.resolvedTrace().maxSteps;
        const GBuffer g = renderAndRead(s, r, d, scene::toString(c.q));
        uint64_t traced = 0, zeroSteps = 0, over = 0, atLimit = 0;
        double sum = 0, maxSteps = 0;
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) {
                const size_t i = g.at(x, y);
                const float steps = g.aux[i].y;
                // A ray crossing the raised object's bounds (grown a little) may take up to 40.
                double t0, t1;
                const bool crossesRaised =
                    raisedRef.interval(cam.eye, glm::normalize(cam.dir(x, y)), 1e-3, t0, t1) && t1 > 0;
                const uint32_t pixelLimit = crossesRaised ? std::max(limit, 40u) : limit;
                over += steps > float(pixelLimit) || steps < 0.0f || steps != std::floor(steps);
                atLimit += steps == float(pixelLimit);
                maxSteps = std::max(maxSteps, double(steps));
                if (!g.hit(i)) continue;
                ++traced;
                sum += steps;
                zeroSteps += steps <= 0.0f;
            }
        std::printf(
            "  %s (limit %u, torus 40): %llu traced px, mean steps %.2f, max %.0f, %llu px at their limit, "
            "%llu traced px with 0 steps\n",
            scene::toString(c.q), limit, (unsigned long long)traced, sum / double(traced), maxSteps,
            (unsigned long long)atLimit, (unsigned long long)zeroSteps);
        EXPECT_GT(traced, 500u);
        EXPECT_EQ(over, 0u) << "steps <= the step limit of the preset (40 for rays crossing the torus)";
        // A ray that hits at its first distance evaluation (e.g. where it enters an object's bounds
        // box within the hit epsilon of the surface) has still taken that step.
        EXPECT_EQ(zeroSteps, 0u) << "steps > 0 on traced pixels";
        if (c.maxSteps) {
            EXPECT_GT(atLimit, 0u) << "an 8-step limit is reached";
        }
    }
}

// scenes/shapes.json at 320x180 with over-relaxation (the preset's omega, or `omega` when set) and
// with omega = 1: the same image (depth within 1e-3 relative on >= 99 % of the pixels hit in both)
// in no more steps per pixel.
void compareOverRelaxation(rhi::Device& device, std::optional<scene::TraceQuality> quality,
                           std::optional<float> omegaOverride) {
    constexpr uint32_t w = 320, h = 180;
    assets::AssetManager assets;
    scene::Scene sc;
    std::string error;
    ASSERT_TRUE(scene::loadScene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/shapes.json", assets, sc, error))
        << error;
    const ecs::Entity cam = scene::findCamera(sc.world, sc.settings.camera);
    ASSERT_FALSE(cam.isNull());
    ecs::updateTransforms(sc.world);
    if (quality) sc.settings.quality = *quality;
    SceneRenderer r(device);
    auto frame = [&](float omega, const char* what) {
        FrameDesc d;
        d.width = w;
        d.height = h;
        d.camera = cam;
        d.settings = sc.settings;
        d.settings.trace.overRelaxation = omega;
        d.aux = true;
        const auto t0 = std::chrono::steady_clock::now();
        EXPECT_TRUE(r.render(sc.world, assets, d, error)) << error;
        GBuffer g = readGBuffer(r, w, h);
        std::printf("  [%s] %ux%u: %.0f ms\n", what, w, h,
                    std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        return g;
    };
    const float omega = omegaOverride ? *omegaOverride : sc.settings.resolvedTrace().overRelaxation;
    std::printf("  quality %s, omega %.2f\n", scene::toString(sc.settings.quality), omega);
    ASSERT_GT(omega, 1.0f) << "the scene's preset over-relaxes";
    const GBuffer a = frame(omega, "over-relaxed");
    const GBuffer b = frame(1.0f, "omega 1");
    // Two traces agree to the preset's accuracy: a hit lands within hitEpsilon / 10 footprints of
    // the surface (sdf_trace.comp), 1e-3 of the depth or better at reference quality (0.01
    // footprints); medium (0.5 footprints) is ~1e-3 of the depth head-on and more at grazing angles,
    // so 1e-2 there.
    const double tol = sc.settings.quality == scene::TraceQuality::Reference ? 1e-3 : 1e-2;
    uint64_t both = 0, within = 0, onlyOne = 0;
    double stepsA = 0, stepsB = 0, hitStepsA = 0, hitStepsB = 0, maxRel = 0;
    for (size_t i = 0; i < a.depth.size(); ++i) {
        stepsA += a.aux[i].y;
        stepsB += b.aux[i].y;
        if (a.hit(i) != b.hit(i)) ++onlyOne;
        if (!(a.hit(i) && b.hit(i))) continue;
        ++both;
        hitStepsA += a.aux[i].y;
        hitStepsB += b.aux[i].y;
        const double rel = std::abs(double(a.depth[i]) - double(b.depth[i])) / double(b.depth[i]);
        maxRel = std::max(maxRel, rel);
        within += rel <= tol;
    }
    const double n = double(a.depth.size());
    std::printf(
        "  omega %.2f vs 1: mean steps per pixel %.3f vs %.3f (ratio %.3f); per pixel hit in both %.3f vs "
        "%.3f (ratio %.3f); depth within the tolerance on %.4f %% of %llu px hit in both (max rel diff "
        "%.3g); "
        "%llu px "
        "hit in one only\n",
        omega, stepsA / n, stepsB / n, stepsA / stepsB, hitStepsA / double(both), hitStepsB / double(both),
        hitStepsA / hitStepsB, 100.0 * double(within) / double(both), (unsigned long long)both, maxRel,
        (unsigned long long)onlyOne);
    // Diagnostics: each image against the exact ray cast (which one departs, and by how much).
    const RefImage ref = referenceImage(sc.world, assets, cam, w, h);
    for (const GBuffer* g : {&a, &b}) {
        uint64_t n1 = 0, within1 = 0, within3 = 0, otherId = 0;
        double maxErr = 0;
        for (size_t i = 0; i < g->depth.size(); ++i) {
            if (!g->hit(i) || ref.depth[i] <= 0 || ref.undecided[i]) continue;
            ++n1;
            const double rel = std::abs(double(g->depth[i]) - ref.depth[i]) / ref.depth[i];
            within1 += rel <= 1e-3;
            within3 += rel <= 3e-3;
            otherId += g->id(i) != ref.entity[i];
            maxErr = std::max(maxErr, rel);
        }
        const SeeThrough st = seeThrough(*g, ref, 1e-4);
        std::printf(
            "    %s vs exact: within 1e-3 rel %.4f %%, within 3e-3 rel %.4f %%, max rel err %.3g, other "
            "object on %llu px; %llu px behind the exact surface (> 1e-4 rel, max %.3g), %llu exact hits "
            "missed\n",
            g == &a ? "over-relaxed" : "omega 1", 100.0 * double(within1) / double(n1),
            100.0 * double(within3) / double(n1), maxErr, (unsigned long long)otherId,
            (unsigned long long)st.behind, st.maxBehind, (unsigned long long)st.missed);
    }
    int listed = 0;
    for (size_t i = 0; i < a.depth.size() && listed < 8; ++i) {
        if (!(a.hit(i) && b.hit(i))) continue;
        const double rel = std::abs(double(a.depth[i]) - double(b.depth[i])) / double(b.depth[i]);
        if (rel < 0.05) continue;
        ++listed;
        std::printf(
            "    px %zu,%zu: depth %.5f (id %d, %.0f steps) vs %.5f (id %d, %.0f steps); exact %.5f (id "
            "%d)\n",
            i % w, i / w, a.depth[i], a.id(i), a.aux[i].y, b.depth[i], b.id(i), b.aux[i].y, ref.depth[i],
            ref.entity[i]);
    }
    EXPECT_GE(double(within) / double(both), 0.99)
        << "depth within " << tol << " relative on >= 99 % of pixels hit in both";
    EXPECT_LE(stepsA, stepsB) << "over-relaxation does not add steps per pixel";
}

// The scene's own settings (medium preset: omega 1.3, hit epsilon 0.5 footprints).
TEST_P(SdfTrace, OverRelaxationSavesStepsOnTheShapesScene) { compareOverRelaxation(dev(), {}, {}); }
// The reference preset (hit epsilon 0.01 footprints) with omega 1.3 against its own omega 1.
TEST_P(SdfTrace, OverRelaxationSavesStepsAtReferenceQuality) {
    compareOverRelaxation(dev(), scene::TraceQuality::Reference, 1.3f);
}

// ---- 5. velocity
// -------------------------------------------------------------------------------------------

TEST_P(SdfTrace, VelocityOfAMovingSdfObject) {
    constexpr uint32_t w = 160, h = 120;
    SdfScene s({0, 1, 5}, {0, 0, 0});
    const ecs::Entity mover =
        s.sdfObject(ShapeNode::box({0.6, 0.4, 0.5}), {-0.3f, 0.0f, 0.0f}, euler(10, 20, 0));
    const ecs::Entity still = s.sdfObject(ShapeNode::sphere(0.4), {1.4f, 0.0f, -0.5f});
    SceneRenderer r(dev());
    const GBuffer g1 = renderAndRead(s, r, s.frame(w, h), "frame 1");
    ecs::updateTransforms(s.world);
    const glm::dmat4 model1(s.world.get<ecs::Transform>(mover)->worldMatrix);
    ecs::Transform* t = s.world.get<ecs::Transform>(mover);
    t->position += glm::vec3(0.25f, 0.1f, -0.15f);
    t->rotation = euler(10, 28, 3);
    const GBuffer g2 = renderAndRead(s, r, s.frame(w, h), "frame 2");
    ecs::updateTransforms(s.world);
    const glm::dmat4 model2(s.world.get<ecs::Transform>(mover)->worldMatrix);
    const RefCamera cam(s.world, s.camera, w, h);  // the camera did not move

    uint64_t covered = 0, over = 0, stillPx = 0;
    double maxErr = 0, sumErr = 0, sumMotion = 0, maxStill = 0;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const size_t i = g2.at(x, y);
            if (g2.id(i) == int(still.index)) {
                ++stillPx;
                maxStill = std::max(maxStill, double(glm::length(g2.velocity[i])));
            }
            if (g2.id(i) != int(mover.index) || g1.id(i) != int(mover.index)) continue;
            ++covered;
            // The surface point under this pixel, back to where it was a frame ago.
            const glm::dvec3 p = cam.eye + cam.dir(x, y) * double(g2.depth[i]);
            const glm::dvec3 prev(model1 * glm::inverse(model2) * glm::dvec4(p, 1.0));
            const glm::dvec2 expected = glm::dvec2(x + 0.5, y + 0.5) - cam.project(prev);
            const double err = glm::length(glm::dvec2(g2.velocity[i]) - expected);
            maxErr = std::max(maxErr, err);
            sumErr += err;
            sumMotion += glm::length(expected);
            over += err > 0.5;
        }
    std::printf(
        "  velocity: %llu px covered in both frames, mean motion %.2f px, error max %.4f px, mean %.4f px; "
        "static sphere max |v| %.4f px\n",
        (unsigned long long)covered, sumMotion / double(covered), maxErr, sumErr / double(covered), maxStill);
    ASSERT_GT(covered, 300u);
    EXPECT_GT(sumMotion / double(covered), 3.0) << "the object moved several pixels";
    EXPECT_EQ(over, 0u)
        << "velocity within 0.5 px of the screen motion on every pixel covered in both frames";
    EXPECT_GT(stillPx, 100u);
    EXPECT_LE(maxStill, 0.01) << "a static object has no motion";

    // Frame 3: the objects stay, the camera moves; the motion is the reprojection through the
    // previous camera, for pixels on an SDF object in both frames.
    s.placeCamera({0.6f, 1.3f, 4.6f}, {0.1f, 0.0f, 0.0f});
    const GBuffer g3 = renderAndRead(s, r, s.frame(w, h), "frame 3, camera moved");
    ecs::updateTransforms(s.world);
    const RefCamera cam3(s.world, s.camera, w, h);
    uint64_t covered3 = 0, over3 = 0;
    double maxErr3 = 0, sumMotion3 = 0;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const size_t i = g3.at(x, y);
            if (g3.id(i) < 0 || g2.id(i) < 0) continue;
            ++covered3;
            const glm::dvec3 p = cam3.eye + cam3.dir(x, y) * double(g3.depth[i]);
            const glm::dvec2 expected = glm::dvec2(x + 0.5, y + 0.5) - cam.project(p);
            const double err = glm::length(glm::dvec2(g3.velocity[i]) - expected);
            maxErr3 = std::max(maxErr3, err);
            sumMotion3 += glm::length(expected);
            over3 += err > 0.5;
        }
    std::printf(
        "  camera motion: %llu px on an object in both frames, mean motion %.2f px, error max %.4f px\n",
        (unsigned long long)covered3, sumMotion3 / double(covered3), maxErr3);
    ASSERT_GT(covered3, 300u);
    EXPECT_GT(sumMotion3 / double(covered3), 2.0) << "the camera moved a few pixels' worth";
    EXPECT_EQ(over3, 0u) << "velocity within 0.5 px of the reprojection through the previous camera";
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfTrace, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test
