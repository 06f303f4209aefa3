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

// ---- shadows (renderer/features/sdf_shadow.h) ---------------------------------------------------------

// A directional light toward the unit vector `toLight` (it travels along -toLight); angular radius 0
// gives a binary (hard) shadow. Layers of effects.shadow follow the shadowed lights' entity order.
inline ecs::Entity directionalLight(StabScene& s, const glm::dvec3& toLight, float angularRadius) {
    const ecs::Entity e = s.world.create();
    s.world.add<ecs::Transform>(e)->rotation = lookRotation(-glm::vec3(toLight));
    ecs::Light l;
    l.type = ecs::LightType::Directional;
    l.angularRadius = angularRadius;
    s.world.add<ecs::Light>(e, l);
    return e;
}
// The unit direction toward a directional light as the renderer uploads it (transforms updated).
inline glm::dvec3 towardLight(const StabScene& s, ecs::Entity light) {
    return -glm::normalize(glm::dvec3(s.world.get<ecs::Transform>(light)->worldForward()));
}

// effects.shadow (R8_UNORM, layer k at columns [k w, (k + 1) w)) read after a frame rendered with
// ShadowSettings::resolutionScale 1.
struct ShadowStrip {
    uint32_t w = 0, h = 0, layers = 0;
    std::vector<uint8_t> texels;
    double at(uint32_t layer, uint32_t x, uint32_t y) const {
        return texels[size_t(y) * w * layers + size_t(layer) * w + x] / 255.0;
    }
};
inline bool readShadow(render::SceneRenderer& r, uint32_t w, uint32_t h, uint32_t layers, ShadowStrip& out) {
    out = {w, h, layers, readRaw(r, "effects.shadow", rhi::Format::R8_UNORM)};
    EXPECT_EQ(out.texels.size(), size_t(w) * h * layers) << "effects.shadow";
    return out.texels.size() == size_t(w) * h * layers;
}

// Signed distance from p to the axis-aligned box (centre c, half extents e).
inline double boxDistance(const glm::dvec3& p, const glm::dvec3& c, const glm::dvec3& e) {
    const glm::dvec3 q = glm::abs(p - c) - e;
    return glm::length(glm::max(q, glm::dvec3(0.0))) + std::min(std::max(q.x, std::max(q.y, q.z)), 0.0);
}
// Signed clearance of the segment o + t l, t in [t0, t1], from that box: the minimum of its signed
// distance along the segment (> 0: the segment misses the box by that much; < 0: it enters it). A
// convex set's signed distance is convex along a line, so a ternary search finds the minimum.
inline double segmentBoxClearance(const glm::dvec3& o, const glm::dvec3& l, double t0, double t1,
                                  const glm::dvec3& c, const glm::dvec3& e) {
    double a = t0, b = t1;
    for (int i = 0; i < 200 && b - a > 1e-12 * (1.0 + std::abs(b)); ++i) {
        const double m1 = a + (b - a) / 3.0, m2 = b - (b - a) / 3.0;
        if (boxDistance(o + m1 * l, c, e) < boxDistance(o + m2 * l, c, e))
            b = m2;
        else
            a = m1;
    }
    return std::min({boxDistance(o + 0.5 * (a + b) * l, c, e), boxDistance(o + t0 * l, c, e),
                     boxDistance(o + t1 * l, c, e)});
}

// A pixel traced at the near plane: its ray started inside a solid (the point is not on the receiver's
// surface, and a shadow ray from inside a solid is rightly blocked), so shadow comparisons skip it.
inline bool nearPlaneHit(const GBuffer& g, const RefCamera& cam, size_t i) {
    return double(g.depth[i]) <= cam.nearPlane * (1.0 + 1e-4);
}

// Light leaking through a thin wall: a box (local half extents `half`, placed by the rigid matrix
// `wallModel`) between a directional light (toward `toLight`, angular radius `angularRadius`) and the
// receiver pixels (entity `receiverId`) on the camera side. The light ray from the traced point p
// crosses the wall's mid-plane at t: "umbra" when the crossing lies inside the wall's outline by more
// than (t tan(angularRadius) + 2 pixel footprints at p) / cos(incidence) (the whole light disc is
// hidden: exact visibility 0), "lit" when outside it by more than that or when the ray leaves away
// from the wall (exact visibility 1); the band between is not counted, nor receivers whose ray meets
// the wall within 4 pixel footprints (the pass starts its rays 2 footprints + a bias off the surface),
// nor pixels traced at the near plane (nearPlaneHit).
struct WallShadowStats {
    size_t umbra = 0, umbraOver = 0;  // umbra pixels; those with visibility > 0.5
    size_t lit = 0, litDark = 0;      // lit pixels; those with visibility < 0.5
    double umbraMean = 0, umbraMax = 0, litMean = 0;
};
inline WallShadowStats wallShadow(const GBuffer& g, const RefCamera& cam, int receiverId,
                                  const glm::dmat4& wallModel, const glm::dvec3& half,
                                  const ShadowStrip& strip, uint32_t layer, const glm::dvec3& toLight,
                                  double angularRadius) {
    WallShadowStats st;
    const glm::dmat4 inv = glm::inverse(wallModel);
    const glm::dvec3 ll = glm::dmat3(inv) * toLight;
    for (uint32_t y = 0; y < g.h; ++y)
        for (uint32_t x = 0; x < g.w; ++x) {
            const size_t i = g.at(x, y);
            if (!g.hit(i) || g.id(i) != receiverId || nearPlaneHit(g, cam, i)) continue;
            const glm::dvec3 d = cam.dir(x, y);
            const glm::dvec3 p = cam.eye + d * double(g.depth[i]);
            const double pixelSize = cam.footprint() * double(g.depth[i]) * glm::length(d);
            const glm::dvec3 lo(inv * glm::dvec4(p, 1.0));
            const double v = strip.at(layer, x, y);
            const double t = std::abs(ll.z) > 1e-9 ? -lo.z / ll.z : -1.0;
            bool lit = t <= 0.0, umbra = false;
            if (!lit) {
                if (t < 4.0 * pixelSize) continue;
                const glm::dvec3 q = lo + t * ll;
                const double r = (t * std::tan(angularRadius) + 2.0 * pixelSize) / std::abs(ll.z);
                const double inner = std::min(half.x - std::abs(q.x), half.y - std::abs(q.y));
                const double outside = glm::length(glm::max(
                    glm::dvec2(std::abs(q.x), std::abs(q.y)) - glm::dvec2(half.x, half.y), glm::dvec2(0.0)));
                umbra = inner > r;
                lit = outside > r;
            }
            if (umbra) {
                ++st.umbra;
                st.umbraOver += v > 0.5;
                st.umbraMean += v;
                st.umbraMax = std::max(st.umbraMax, v);
            } else if (lit) {
                ++st.lit;
                st.litDark += v < 0.5;
                st.litMean += v;
            }
        }
    if (st.umbra) st.umbraMean /= double(st.umbra);
    if (st.lit) st.litMean /= double(st.lit);
    return st;
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
