// Shared helpers of the hard-case suite (tests/stability, CTest label `stability`; issue 11 item 4):
// small scenes built through the ECS, one frame rendered by the SceneRenderer on the backend under
// test (validation on), the G-buffer read back (depth, normal, aux = entity id and trace steps), an
// exact double-precision CPU ray cast of analytic primitives with the renderer's camera conventions
// (docs/ACCURACY.md "Camera and pixels"), and the per-case summary line printed for CI logs:
//   [ stability ] <case> <backend>: <measured numbers> (criterion ...)
// Header-only: the folder's executable is built from its *_test.cpp files.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/packing.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/core/log.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"
#include "engine/scene/scene.h"
#include "engine/sdf/shape_program.h"
#include "renderer/core/gbuffer_encoding.h"
#include "renderer/scene_renderer.h"
#include "support/log_capture.h"
#include "support/ref_camera.h"
#include "support/test_device.h"

namespace penumbra::test::stability {

using test::RefCamera;
using test::WarningCapture;

constexpr float kFovY = 1.0471976f;  // 60 degrees
constexpr double kInf = std::numeric_limits<double>::infinity();

inline const char* backendLabel(rhi::Backend b) { return b == rhi::Backend::Vulkan ? "vulkan" : "gl"; }

// One summary line per measurement, so a CI log shows every margin.
inline void summary(const char* caseName, rhi::Backend backend, const char* fmt, ...) {
    char text[1024];
    va_list args;
    va_start(args, fmt);
    std::vsnprintf(text, sizeof text, fmt, args);
    va_end(args);
    std::printf("[ stability ] %-26s %-6s %s\n", caseName, backendLabel(backend), text);
    std::fflush(stdout);
}

// Rotation whose local -Z points along `dir` (camera convention).
inline glm::quat lookRotation(glm::vec3 dir, glm::vec3 up = {0, 1, 0}) {
    if (std::abs(glm::dot(glm::normalize(dir), glm::normalize(up))) > 0.999f) up = {0, 0, 1};
    return glm::quat_cast(glm::inverse(glm::lookAtRH(glm::vec3(0), dir, up)));
}

// A World + AssetManager with one camera.
struct StabScene {
    ecs::World world;
    assets::AssetManager assets;
    ecs::Entity camera;

    explicit StabScene(glm::vec3 eye = {0, 0, 0}, glm::vec3 target = {0, 0, -1}, float nearPlane = 0.1f,
                       float farPlane = 100.0f, assets::AssetManagerDesc desc = {})
        : assets(std::move(desc)) {
        camera = world.create();
        world.add<ecs::Transform>(camera);
        placeCamera(eye, target);
        ecs::Camera c;
        c.fovY = kFovY;
        c.nearPlane = nearPlane;
        c.farPlane = farPlane;
        world.add<ecs::Camera>(camera, c);
    }
    void placeCamera(glm::vec3 eye, glm::vec3 target, glm::vec3 up = {0, 1, 0}) {
        ecs::Transform* t = world.get<ecs::Transform>(camera);
        t->position = eye;
        t->rotation = lookRotation(target - eye, up);
    }
    assets::AssetId program(const sdf::ShapeNode& root) {
        sdf::ShapeProgram p;
        std::string error;
        EXPECT_TRUE(sdf::compileShapeProgram(root, p, error)) << error;
        const std::string key = assets::AssetManager::shapeProgramKey(p);
        const assets::AssetId id = assets.addShapeProgram(key, std::move(p), error);
        EXPECT_NE(id, 0u) << error;
        return id;
    }
    ecs::Entity placed(glm::vec3 position, glm::quat rotation, glm::vec3 scale, const char* name) {
        const ecs::Entity e = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = position;
        t->rotation = rotation;
        t->scale = scale;
        if (name) world.add<ecs::Name>(e, ecs::Name{name});
        return e;
    }
    ecs::Entity sdfAsset(assets::AssetId id, ecs::SdfSource source, glm::vec3 position,
                         glm::quat rotation = {1, 0, 0, 0}, glm::vec3 scale = glm::vec3(1),
                         const char* name = nullptr, assets::AssetId material = 0) {
        const ecs::Entity e = placed(position, rotation, scale, name);
        ecs::SdfRenderer sr;
        sr.sdf = id;
        sr.source = source;
        sr.material = material;
        world.add<ecs::SdfRenderer>(e, sr);
        return e;
    }
    ecs::Entity shape(const sdf::ShapeNode& root, glm::vec3 position, glm::quat rotation = {1, 0, 0, 0},
                      glm::vec3 scale = glm::vec3(1), const char* name = nullptr,
                      assets::AssetId material = 0) {
        return sdfAsset(program(root), ecs::SdfSource::Shapes, position, rotation, scale, name, material);
    }
    ecs::Entity field(assets::AssetId fieldId, glm::vec3 position, glm::quat rotation = {1, 0, 0, 0},
                      glm::vec3 scale = glm::vec3(1), const char* name = nullptr) {
        return sdfAsset(fieldId, ecs::SdfSource::Field, position, rotation, scale, name);
    }
    ecs::Entity mesh(assets::AssetId meshId, glm::vec3 position, glm::quat rotation = {1, 0, 0, 0},
                     glm::vec3 scale = glm::vec3(1)) {
        const ecs::Entity e = placed(position, rotation, scale, nullptr);
        ecs::MeshRenderer mr;
        mr.mesh = meshId;
        world.add<ecs::MeshRenderer>(e, mr);
        return e;
    }
    render::FrameDesc frame(uint32_t w, uint32_t h,
                            scene::TraceQuality q = scene::TraceQuality::Medium) const {
        render::FrameDesc d;
        d.width = w;
        d.height = h;
        d.camera = camera;
        d.settings.quality = q;
        d.aux = true;
        return d;
    }
};

// ---- G-buffer readback ---------------------------------------------------------------------------

struct GBuffer {
    uint32_t w = 0, h = 0;
    std::vector<float> depth;       // linear view depth, 0 = nothing hit
    std::vector<glm::vec3> normal;  // decoded world normal (zero where nothing was hit)
    std::vector<glm::vec2> aux;     // x entity index (-1 none), y sphere-trace steps
    size_t at(uint32_t x, uint32_t y) const { return size_t(y) * w + x; }
    bool hit(size_t i) const { return depth[i] > 0.0f; }
    int id(size_t i) const { return int(std::lround(aux[i].x)); }
    size_t size() const { return depth.size(); }
};

inline std::vector<uint8_t> readRaw(render::SceneRenderer& r, const std::string& name, rhi::Format expected) {
    std::vector<uint8_t> texels;
    rhi::Format format{};
    std::string error;
    EXPECT_TRUE(r.readTarget(name, texels, format, error)) << name << ": " << error;
    EXPECT_EQ(format, expected) << name;
    return texels;
}

// Renders one frame (transforms updated first) and reads the G-buffer back. False (test failure
// added) when the frame fails.
inline bool renderAndRead(StabScene& s, render::SceneRenderer& r, const render::FrameDesc& d, GBuffer& g) {
    ecs::updateTransforms(s.world);
    std::string error;
    if (!r.render(s.world, s.assets, d, error)) {
        ADD_FAILURE() << "render failed: " << error;
        return false;
    }
    g = {};
    g.w = d.width;
    g.h = d.height;
    const size_t n = size_t(d.width) * d.height;
    std::vector<uint8_t> raw = readRaw(r, "gbuffer.depth", rhi::Format::R32_FLOAT);
    if (raw.size() != n * 4) return false;
    g.depth.resize(n);
    std::memcpy(g.depth.data(), raw.data(), n * 4);
    raw = readRaw(r, "gbuffer.normal", rhi::Format::RG16_FLOAT);
    if (raw.size() != n * 4) return false;
    g.normal.resize(n);
    for (size_t i = 0; i < n; ++i) {
        uint16_t hh[2];
        std::memcpy(hh, &raw[i * 4], 4);
        const glm::vec2 e(glm::unpackHalf1x16(hh[0]), glm::unpackHalf1x16(hh[1]));
        g.normal[i] = g.depth[i] > 0.0f ? render::octDecode(e) : glm::vec3(0.0f);
        if (!std::isfinite(e.x) || !std::isfinite(e.y)) g.normal[i] = glm::vec3(std::nanf(""));
    }
    raw = readRaw(r, "gbuffer.aux", rhi::Format::RG32_FLOAT);
    if (raw.size() != n * 8) return false;
    g.aux.resize(n);
    std::memcpy(g.aux.data(), raw.data(), n * 8);
    return true;
}

// Non-finite values anywhere in depth, normal (hit pixels) or aux; depth outside {0} u [near, far].
struct Sanity {
    size_t nonFinite = 0, outOfRange = 0;
    bool ok() const { return nonFinite == 0 && outOfRange == 0; }
};
inline Sanity checkSanity(const GBuffer& g, float nearPlane, float farPlane) {
    Sanity s;
    for (size_t i = 0; i < g.size(); ++i) {
        const float d = g.depth[i];
        if (!std::isfinite(d) || !std::isfinite(g.aux[i].x) || !std::isfinite(g.aux[i].y) ||
            (d > 0.0f && !(std::isfinite(g.normal[i].x) && std::isfinite(g.normal[i].y) &&
                           std::isfinite(g.normal[i].z)))) {
            ++s.nonFinite;
            continue;
        }
        if (d != 0.0f && (d < nearPlane * (1 - 1e-5f) || d > farPlane * (1 + 1e-5f))) ++s.outOfRange;
    }
    return s;
}

// The renderer's camera in double: RefCamera (tests/support/ref_camera.h); the ray parameter of its
// dir() is the linear view depth.

// ---- exact intersections (double) --------------------------------------------------------------------
// All take the unnormalised camera ray o + s d (d's forward component 1), return the smallest root
// s >= sMin (kInf when none) and its outward unit normal.

struct Hit {
    double s = kInf;
    glm::dvec3 n{0.0};
    int id = -1;
};

inline Hit raySphere(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& c, double r, double sMin) {
    Hit h;
    const glm::dvec3 oc = o - c;
    const double a = glm::dot(d, d), b = glm::dot(oc, d), cc = glm::dot(oc, oc) - r * r;
    const double disc = b * b - a * cc;
    if (disc < 0) return h;
    const double sq = std::sqrt(disc);
    // Numerically stable roots.
    const double q = b >= 0 ? -(b + sq) : -(b - sq);
    double s0 = q / a, s1 = q != 0 ? cc / q : s0;
    if (s0 > s1) std::swap(s0, s1);
    const double s = s0 >= sMin ? s0 : (s1 >= sMin ? s1 : kInf);
    if (s == kInf) return h;
    h.s = s;
    h.n = glm::normalize(o + d * s - c);
    return h;
}

// Plane dot(p, n) = offset (n unit), two-sided.
inline Hit rayPlane(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& n, double offset,
                    double sMin) {
    Hit h;
    const double dn = glm::dot(d, n);
    if (dn == 0) return h;
    const double s = (offset - glm::dot(o, n)) / dn;
    if (s >= sMin) {
        h.s = s;
        h.n = dn < 0 ? n : -n;
    }
    return h;
}

// Axis-aligned box (centre c, half extents e): the entry point (or the exit when o is inside).
inline Hit rayBox(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& c, const glm::dvec3& e,
                  double sMin) {
    Hit h;
    double t0 = -kInf, t1 = kInf;
    int a0 = -1, a1 = -1;
    for (int a = 0; a < 3; ++a) {
        const double lo = c[a] - e[a] - o[a], hi = c[a] + e[a] - o[a];
        if (d[a] == 0) {
            if (lo > 0 || hi < 0) return h;
            continue;
        }
        double ta = lo / d[a], tb = hi / d[a];
        if (ta > tb) std::swap(ta, tb);
        if (ta > t0) t0 = ta, a0 = a;
        if (tb < t1) t1 = tb, a1 = a;
    }
    if (t0 > t1) return h;
    if (t0 >= sMin && a0 >= 0) {
        h.s = t0;
        h.n[a0] = d[a0] > 0 ? -1.0 : 1.0;
    } else if (t1 >= sMin && a1 >= 0) {
        h.s = t1;
        h.n[a1] = d[a1] > 0 ? 1.0 : -1.0;
    }
    return h;
}

// Relative depth error |a - b| / b.
inline double relErr(double a, double b) { return std::abs(a - b) / std::abs(b); }

// Quantile (nearest rank) of a copy of v; 0 for an empty vector.
inline double quantile(std::vector<double> v, double q) {
    if (v.empty()) return 0.0;
    const size_t k = std::min(v.size() - 1, size_t(std::ceil(q * double(v.size()))) - (q > 0 ? 1 : 0));
    std::nth_element(v.begin(), v.begin() + long(k), v.end());
    return v[k];
}

// Wall time of a scope in ms.
struct Stopwatch {
    std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
    double ms() const {
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }
};

}  // namespace penumbra::test::stability
