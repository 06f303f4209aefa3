// The rasterized mesh path (renderer/scene_renderer.h): G-buffer contents against analytic
// geometry, velocity, deferred lighting against the CPU reference, pass selection and errors,
// and Vulkan-vs-OpenGL parity. Every GPU test runs on both backends with validation on.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/packing.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"
#include "renderer/features/gpu_scene.h"
#include "renderer/features/lighting_reference.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using render::FrameDesc;
using render::SceneRenderer;
namespace ref = render::reference;

constexpr uint32_t kW = 96, kH = 64;
constexpr float kFovY = 1.0471976f;  // 60 degrees

// ---- scene building -----------------------------------------------------------------------------

// Quad in the local XY plane facing +Z, [-hx, hx] x [-hy, hy].
assets::MeshData makeQuad(float hx, float hy) {
    assets::MeshData m;
    m.positions = {{-hx, -hy, 0}, {hx, -hy, 0}, {hx, hy, 0}, {-hx, hy, 0}};
    m.normals.assign(4, glm::vec3(0, 0, 1));
    m.uvs = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
    m.indices = {0, 1, 2, 0, 2, 3};
    return m;
}

// UV sphere of radius r: `slices` around +Y, `stacks` from pole to pole; exact unit normals.
assets::MeshData makeUvSphere(float r, uint32_t slices, uint32_t stacks) {
    assets::MeshData m;
    const double pi = 3.14159265358979323846;
    for (uint32_t i = 0; i <= stacks; ++i) {
        double theta = pi * double(i) / stacks;
        for (uint32_t j = 0; j <= slices; ++j) {
            double phi = 2.0 * pi * double(j) / slices;
            glm::dvec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
            m.positions.push_back(glm::vec3(n * double(r)));
            m.normals.push_back(glm::vec3(n));
            m.uvs.push_back({float(j) / slices, float(i) / stacks});
        }
    }
    for (uint32_t i = 0; i < stacks; ++i) {
        for (uint32_t j = 0; j < slices; ++j) {
            uint32_t a = i * (slices + 1) + j, b = a + slices + 1;
            if (i != 0) m.indices.insert(m.indices.end(), {a, b, a + 1});
            if (i + 1 != stacks) m.indices.insert(m.indices.end(), {a + 1, b, b + 1});
        }
    }
    return m;
}

// `count` RGBA8 texels of one colour.
std::vector<uint8_t> solidTexels(size_t count, std::array<uint8_t, 4> rgba) {
    std::vector<uint8_t> out(count * 4);
    for (size_t i = 0; i < out.size(); ++i) out[i] = rgba[i % 4];
    return out;
}

// Rotation whose local -Z points along `dir` (camera / light convention).
glm::quat lookRotation(glm::vec3 dir, glm::vec3 up = {0, 1, 0}) {
    if (std::abs(glm::dot(glm::normalize(dir), glm::normalize(up))) > 0.999f) up = {0, 0, 1};
    return glm::quat_cast(glm::inverse(glm::lookAtRH(glm::vec3(0), dir, up)));
}

struct TestScene {
    ecs::World world;
    assets::AssetManager assets;
    ecs::Entity camera;

    TestScene(glm::vec3 eye = {0, 0, 0}, glm::vec3 target = {0, 0, -1}) { camera = addCamera(eye, target); }

    ecs::Entity addCamera(glm::vec3 eye, glm::vec3 target) {
        ecs::Entity e = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = eye;
        t->rotation = lookRotation(target - eye);
        ecs::Camera c;
        c.fovY = kFovY;
        c.nearPlane = 0.1f;
        c.farPlane = 200.0f;
        world.add<ecs::Camera>(e, c);
        return e;
    }
    assets::AssetId mesh(const std::string& key, assets::MeshData m) {
        std::string error;
        assets::AssetId id = assets.addMesh(key, std::move(m), error);
        EXPECT_NE(id, 0u) << error;
        return id;
    }
    assets::AssetId material(const std::string& key, const ecs::Material& m) {
        return assets.addMaterial(key, m);
    }
    ecs::Entity object(assets::AssetId mesh, assets::AssetId material, glm::vec3 position,
                       glm::quat rotation = {1, 0, 0, 0}, glm::vec3 scale = glm::vec3(1)) {
        ecs::Entity e = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = position;
        t->rotation = rotation;
        t->scale = scale;
        ecs::MeshRenderer mr;
        mr.mesh = mesh;
        mr.material = material;
        world.add<ecs::MeshRenderer>(e, mr);
        return e;
    }
    ecs::Entity directional(glm::vec3 travel, glm::vec3 color, float intensity) {
        ecs::Entity e = world.create();
        world.add<ecs::Transform>(e)->rotation = lookRotation(travel);
        ecs::Light l;
        l.type = ecs::LightType::Directional;
        l.color = color;
        l.intensity = intensity;
        world.add<ecs::Light>(e, l);
        return e;
    }
    ecs::Entity point(glm::vec3 position, glm::vec3 color, float intensity, float range,
                      ecs::LightType type = ecs::LightType::Point, float radius = 0.0f) {
        ecs::Entity e = world.create();
        world.add<ecs::Transform>(e)->position = position;
        ecs::Light l;
        l.type = type;
        l.color = color;
        l.intensity = intensity;
        l.range = range;
        l.radius = radius;
        world.add<ecs::Light>(e, l);
        return e;
    }
    FrameDesc frame(uint32_t w = kW, uint32_t h = kH) {
        FrameDesc d;
        d.width = w;
        d.height = h;
        d.camera = camera;
        return d;
    }
    bool render(SceneRenderer& r, const FrameDesc& d, std::string& error) {
        ecs::updateTransforms(world);
        return r.render(world, assets, d, error);
    }
};

// World-space ray through the centre of pixel (x, y) for a camera at the origin of `cam` (derived
// independently of the renderer: tan(fov / 2) and the aspect ratio; row 0 is the top). The
// returned ray has unit length along the view direction, so a point at linear depth t is eye + t*ray.
glm::dvec3 pixelRay(const ecs::Transform& cam, uint32_t x, uint32_t y, uint32_t w, uint32_t h) {
    double t = std::tan(double(kFovY) * 0.5), aspect = double(w) / double(h);
    double nx = (x + 0.5) / w * 2.0 - 1.0, ny = (y + 0.5) / h * 2.0 - 1.0;
    glm::dvec3 local(nx * t * aspect, -ny * t, -1.0);
    return glm::dmat3(glm::mat3_cast(cam.rotation)) * local;
}

// Pixel position (x right, y down, in pixels) of a world point.
glm::dvec2 projectToPixel(const ecs::Transform& cam, glm::dvec3 p, uint32_t w, uint32_t h) {
    glm::dvec3 local =
        glm::transpose(glm::dmat3(glm::mat3_cast(cam.rotation))) * (p - glm::dvec3(cam.position));
    double t = std::tan(double(kFovY) * 0.5), aspect = double(w) / double(h);
    double nx = local.x / (-local.z * t * aspect), ny = -local.y / (-local.z * t);
    return {(nx * 0.5 + 0.5) * w, (ny * 0.5 + 0.5) * h};
}

// ---- G-buffer readback ----------------------------------------------------------------------------

std::vector<float> readDepth(SceneRenderer& r) {
    std::vector<uint8_t> texels;
    rhi::Format format{};
    std::string error;
    EXPECT_TRUE(r.readTarget("gbuffer.depth", texels, format, error)) << error;
    EXPECT_EQ(format, rhi::Format::R32_FLOAT);
    std::vector<float> out(texels.size() / 4);
    std::memcpy(out.data(), texels.data(), out.size() * 4);
    return out;
}

std::vector<glm::vec2> readHalf2(SceneRenderer& r, const std::string& name) {
    std::vector<uint8_t> texels;
    rhi::Format format{};
    std::string error;
    EXPECT_TRUE(r.readTarget(name, texels, format, error)) << error;
    EXPECT_EQ(format, rhi::Format::RG16_FLOAT);
    std::vector<glm::vec2> out(texels.size() / 4);
    for (size_t i = 0; i < out.size(); ++i) {
        uint16_t h[2];
        std::memcpy(h, &texels[i * 4], 4);
        out[i] = {glm::unpackHalf1x16(h[0]), glm::unpackHalf1x16(h[1])};
    }
    return out;
}

std::vector<uint8_t> readRgba8(SceneRenderer& r, const std::string& name) {
    std::vector<uint8_t> texels;
    rhi::Format format{};
    std::string error;
    EXPECT_TRUE(r.readTarget(name, texels, format, error)) << error;
    return texels;
}

// Angle between two directions, well conditioned for tiny angles (atan2 of |cross| and dot).
double angleBetween(glm::dvec3 a, glm::dvec3 b) {
    return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

std::vector<glm::vec3> testDirections() {
    std::vector<glm::vec3> dirs;
    // Axes, poles, octant diagonals and edge midpoints (where the octahedral fold is).
    for (int x = -1; x <= 1; ++x)
        for (int y = -1; y <= 1; ++y)
            for (int z = -1; z <= 1; ++z)
                if (x || y || z) dirs.push_back(glm::normalize(glm::vec3(x, y, z)));
    // Near the poles and the z = 0 fold, both sides.
    for (float eps : {1e-7f, 1e-5f, 1e-3f}) {
        for (float sz : {1.0f, -1.0f}) {
            dirs.push_back(glm::normalize(glm::vec3(eps, -eps, sz)));
            dirs.push_back(glm::normalize(glm::vec3(1.0f, 0.5f, sz * eps)));
            dirs.push_back(glm::normalize(glm::vec3(-0.3f, -1.0f, sz * eps)));
        }
    }
    dirs.push_back(glm::vec3(0.0f, 0.0f, -0.0f) + glm::vec3(1, 0, 0));
    dirs.push_back(glm::vec3(0.0f, 1.0f, -0.0f));
    // A Fibonacci lattice: 200k nearly uniform directions.
    const uint32_t n = 200000;
    const double golden = 3.14159265358979323846 * (3.0 - std::sqrt(5.0));
    for (uint32_t i = 0; i < n; ++i) {
        double y = 1.0 - 2.0 * (i + 0.5) / n, r = std::sqrt(1.0 - y * y), phi = golden * i;
        dirs.push_back(
            glm::normalize(glm::vec3(float(r * std::cos(phi)), float(y), float(r * std::sin(phi)))));
    }
    return dirs;
}

// ---- 1. octahedral encoding (CPU) -----------------------------------------------------------------

TEST(OctahedralNormal, RoundTripFloatAndHalf) {
    double maxFloat = 0.0, maxHalf = 0.0, sumHalf = 0.0;
    const std::vector<glm::vec3> dirs = testDirections();
    for (const glm::vec3& n : dirs) {
        glm::vec2 e = render::octEncode(n);
        ASSERT_LE(std::abs(e.x) + std::abs(e.y), 2.0f + 1e-6f);
        ASSERT_LE(std::max(std::abs(e.x), std::abs(e.y)), 1.0f);
        maxFloat = std::max(maxFloat, angleBetween(n, render::octDecode(e)));
        // RG16_FLOAT storage: round each component to half precision (round to nearest).
        glm::vec2 q(glm::unpackHalf1x16(glm::packHalf1x16(e.x)), glm::unpackHalf1x16(glm::packHalf1x16(e.y)));
        double a = angleBetween(n, render::octDecode(q));
        maxHalf = std::max(maxHalf, a);
        sumHalf += a;
    }
    std::printf(
        "octahedral round trip over %zu directions: float max %.3g rad, RG16F max %.3g rad (%.4f deg), "
        "mean %.3g rad\n",
        dirs.size(), maxFloat, maxHalf, maxHalf * 57.29578, sumHalf / dirs.size());
    // Metric: max angle between n and decode(encode(n)) over the set; float threshold 1e-6 rad.
    EXPECT_LT(maxFloat, 1e-6);
    // Metric: the same after rounding the encoding to half floats (round to nearest). Half floats
    // have 11 significant bits (rounding error <= 2^-12 per component in [0.5, 1)), stretched by up
    // to ~3x where the octahedron folds; measured max 1.02e-3 rad (0.058 deg), mean 2.6e-4 rad.
    // Threshold 1.5e-3 rad.
    EXPECT_LT(maxHalf, 1.5e-3);
}

class SceneRendererTest : public GpuTest {};

// ---- 2. linear depth ----------------------------------------------------------------------------

TEST_P(SceneRendererTest, LinearDepthOfFacingQuad) {
    for (float d : {0.5f, 3.0f, 40.0f}) {
        TestScene s;
        // Large enough to cover the frame at distance d (half height d * tan 30 deg * margin).
        float half = d * 2.0f;
        s.object(s.mesh("quad", makeQuad(half, half)), 0, {0, 0, -d});
        SceneRenderer r(dev());
        std::string error;
        ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
        std::vector<float> depth = readDepth(r);
        ASSERT_EQ(depth.size(), size_t(kW) * kH);
        float maxErr = 0.0f;
        for (float v : depth) maxErr = std::max(maxErr, std::abs(v - d));
        std::printf("facing quad at d = %g: max |depth - d| = %.3g (%.3g relative)\n", d, maxErr, maxErr / d);
        // Metric: max over every pixel of |depth - d|; threshold 1e-4 * d (measured 0: the
        // interpolated view depth of a facing plane is constant).
        EXPECT_LT(maxErr, 1e-4f * d) << "d = " << d;
    }
}

TEST_P(SceneRendererTest, LinearDepthOfTiltedPlane) {
    TestScene s(glm::vec3(0.2f, 0.3f, 0.5f), glm::vec3(0.0f, 0.0f, -4.0f));
    // Plane through p0 tilted 35 degrees about X and 20 about Y, large enough to fill the frame.
    const glm::vec3 p0(0.1f, -0.2f, -4.0f);
    const glm::quat rot = glm::angleAxis(glm::radians(35.0f), glm::vec3(1, 0, 0)) *
                          glm::angleAxis(glm::radians(20.0f), glm::vec3(0, 1, 0));
    s.object(s.mesh("quad", makeQuad(30.0f, 30.0f)), 0, p0, rot);
    SceneRenderer r(dev());
    std::string error;
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    std::vector<float> depth = readDepth(r);
    ASSERT_EQ(depth.size(), size_t(kW) * kH);
    const ecs::Transform& cam = *s.world.get<ecs::Transform>(s.camera);
    const glm::dvec3 n = glm::dvec3(glm::mat3_cast(rot) * glm::vec3(0, 0, 1));
    double maxRel = 0.0;
    size_t covered = 0;
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            glm::dvec3 ray = pixelRay(cam, x, y, kW, kH);
            double denom = glm::dot(n, ray);
            double t = glm::dot(n, glm::dvec3(p0) - glm::dvec3(cam.position)) / denom;
            float got = depth[size_t(y) * kW + x];
            if (t <= 0.0 || t > 100.0) continue;
            ++covered;
            maxRel = std::max(maxRel, std::abs(double(got) - t) / t);
        }
    }
    std::printf("tilted plane: %zu pixels, max relative depth error %.3g\n", covered, maxRel);
    EXPECT_EQ(covered, size_t(kW) * kH) << "the plane should fill the frame";
    // Metric: max over pixels of |depth - t_analytic| / t_analytic, t from the exact ray-plane
    // intersection at the pixel centre; measured 9.5e-7 (both backends), threshold 1e-5.
    EXPECT_LT(maxRel, 1e-5);
}

// ---- 3. normals -----------------------------------------------------------------------------------

TEST_P(SceneRendererTest, SphereNormalsMatchAnalytic) {
    TestScene s;
    const glm::dvec3 c(0.0, 0.0, -3.0);
    const double radius = 1.0;
    s.object(s.mesh("sphere", makeUvSphere(float(radius), 256, 128)), 0, glm::vec3(c));
    SceneRenderer r(dev());
    std::string error;
    ASSERT_TRUE(s.render(r, s.frame(128, 96), error)) << error;
    std::vector<float> depth = readDepth(r);
    std::vector<glm::vec2> enc = readHalf2(r, "gbuffer.normal");
    ASSERT_EQ(enc.size(), size_t(128) * 96);
    const ecs::Transform& cam = *s.world.get<ecs::Transform>(s.camera);
    double sum = 0.0, maxErr = 0.0;
    size_t count = 0, interior = 0;
    double sumInterior = 0.0;
    for (uint32_t y = 0; y < 96; ++y) {
        for (uint32_t x = 0; x < 128; ++x) {
            if (depth[size_t(y) * 128 + x] <= 0.0f) continue;
            glm::dvec3 o = glm::dvec3(cam.position), d = glm::normalize(pixelRay(cam, x, y, 128, 96));
            glm::dvec3 oc = o - c;
            double b = glm::dot(oc, d), disc = b * b - (glm::dot(oc, oc) - radius * radius);
            if (disc < 0.0) continue;  // covered by the mesh's silhouette but missed by the ray
            glm::dvec3 p = o + d * (-b - std::sqrt(disc));
            glm::dvec3 analytic = (p - c) / radius;
            glm::dvec3 decoded = glm::dvec3(render::octDecode(enc[size_t(y) * 128 + x]));
            double a = angleBetween(analytic, decoded);
            sum += a;
            maxErr = std::max(maxErr, a);
            ++count;
            // Away from the silhouette (view angle < 60 deg) the tessellation error is smallest.
            if (glm::dot(-d, analytic) > 0.5) {
                sumInterior += a;
                ++interior;
            }
        }
    }
    ASSERT_GT(count, 1500u) << "the sphere should cover a large part of the frame";
    std::printf(
        "sphere normals (256x128 UV sphere): %zu px, mean %.3g rad, max %.3g rad, interior mean %.3g rad\n",
        count, sum / count, maxErr, sumInterior / interior);
    // Metric: mean (and max) angle between the decoded G-buffer normal and the analytic normal
    // (p - c) / r at the pixel ray's hit. Interpolated vertex normals of the 256x128 tessellation
    // (facets of 0.025 rad) deviate from the analytic normal at the hit point, plus the RG16F
    // quantisation (<= 1e-3 rad, test 1); measured mean 2.0e-4 rad, max 1.4e-3 rad on both
    // backends. Thresholds: mean < 5e-4 rad, max < 5e-3 rad.
    EXPECT_LT(sum / count, 5e-4);
    EXPECT_LT(maxErr, 5e-3);
}

// ---- 4. material index ------------------------------------------------------------------------------

TEST_P(SceneRendererTest, MaterialIndicesAndBackground) {
    TestScene s;
    auto quad = s.mesh("quad", makeQuad(0.5f, 0.5f));
    ecs::Material a, b;
    a.baseColor = {1, 0, 0, 1};
    b.baseColor = {0, 0, 1, 1};
    auto matA = s.material("a", a), matB = s.material("b", b);
    // Entity order decides the indices: the first drawn entity's material gets index 0.
    s.object(quad, matB, {-0.8f, 0, -3});  // left:  index 0
    s.object(quad, matA, {0.8f, 0, -3});   // right: index 1
    s.object(quad, matB, {0, 1.0f, -3});   // top:   matB again, index 0
    SceneRenderer r(dev());
    std::string error;
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    EXPECT_EQ(r.lastFrameStats().materials, 2u);
    std::vector<float> depth = readDepth(r);
    std::vector<uint8_t> mat = readRgba8(r, "gbuffer.material");
    ASSERT_EQ(mat.size(), size_t(kW) * kH * 4);
    const ecs::Transform& cam = *s.world.get<ecs::Transform>(s.camera);
    auto pixelOf = [&](glm::vec3 p) {
        glm::dvec2 px = projectToPixel(cam, glm::dvec3(p), kW, kH);
        return size_t(uint32_t(px.y)) * kW + uint32_t(px.x);
    };
    struct Probe {
        glm::vec3 p;
        int index;
    };
    for (Probe probe : {Probe{{-0.8f, 0, -3}, 0}, Probe{{0.8f, 0, -3}, 1}, Probe{{0, 1.0f, -3}, 0}}) {
        size_t i = pixelOf(probe.p);
        EXPECT_NEAR(depth[i], 3.0f, 3e-4f);
        EXPECT_EQ(int(mat[i * 4 + 0]), probe.index) << "at (" << probe.p.x << ", " << probe.p.y << ")";
        EXPECT_EQ(int(mat[i * 4 + 1]), 0) << "index high byte";
        EXPECT_EQ(int(mat[i * 4 + 2]), 0) << "SDF object slot (0: a mesh), low byte";
        EXPECT_EQ(int(mat[i * 4 + 3]), 0) << "SDF object slot, high byte";
    }
    // Background (bottom corners): nothing hit -> linear depth exactly 0.
    EXPECT_EQ(depth[size_t(kH - 1) * kW + 0], 0.0f);
    EXPECT_EQ(depth[size_t(kH - 1) * kW + kW - 1], 0.0f);
    size_t background = 0;
    for (float v : depth) background += v == 0.0f;
    EXPECT_GT(background, size_t(kW) * kH / 3);
}

// ---- 5. velocity ----------------------------------------------------------------------------------

TEST_P(SceneRendererTest, VelocityOfMovedAndStaticObjects) {
    TestScene s;
    auto quad = s.mesh("quad", makeQuad(0.4f, 0.4f));
    const glm::vec3 start(-0.9f, 0.1f, -5.0f), offset(0.35f, -0.2f, 0.0f), fixedPos(1.1f, 0.4f, -5.0f);
    ecs::Entity moving = s.object(quad, 0, start);
    s.object(quad, 0, fixedPos);
    SceneRenderer r(dev());
    std::string error;
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    // First frame: no history, every velocity is 0.
    for (glm::vec2 v : readHalf2(r, "gbuffer.velocity")) ASSERT_EQ(v, glm::vec2(0.0f));

    s.world.get<ecs::Transform>(moving)->position = start + offset;
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    std::vector<glm::vec2> vel = readHalf2(r, "gbuffer.velocity");
    const ecs::Transform& cam = *s.world.get<ecs::Transform>(s.camera);
    glm::dvec2 now = projectToPixel(cam, glm::dvec3(start + offset), kW, kH);
    glm::dvec2 before = projectToPixel(cam, glm::dvec3(start), kW, kH);
    glm::dvec2 expected = now - before;
    glm::vec2 got = vel[size_t(now.y) * kW + size_t(now.x)];
    std::printf("velocity: expected (%.4f, %.4f) px, got (%.4f, %.4f) px\n", expected.x, expected.y, got.x,
                got.y);
    // Metric: |velocity - projected offset| per component at the moved object's centre pixel;
    // threshold 0.05 px.
    EXPECT_NEAR(got.x, expected.x, 0.05);
    EXPECT_NEAR(got.y, expected.y, 0.05);
    EXPECT_GT(std::abs(expected.x), 2.0) << "the test offset should move several pixels";
    glm::dvec2 fixedPx = projectToPixel(cam, glm::dvec3(fixedPos), kW, kH);
    glm::vec2 still = vel[size_t(fixedPx.y) * kW + size_t(fixedPx.x)];
    // The static object (and the camera) did not move: exactly zero motion.
    EXPECT_EQ(still, glm::vec2(0.0f));
}

// ---- 6. lighting against the CPU reference ----------------------------------------------------------

struct LightingCase {
    TestScene scene;
    ecs::Material material;
    std::vector<ref::LightSample> lights;
};

// A quad facing the camera at depth 3 (covering the centre), the given material.
void addLitQuad(TestScene& s, const ecs::Material& m) {
    s.object(s.mesh("quad", makeQuad(0.6f, 0.6f)), s.material("lit", m), {0, 0, -3});
}

// The reference colour of the centre pixel of the lit-quad scene.
std::array<uint8_t, 3> referenceCentre(TestScene& s, const ecs::Material& m, const FrameDesc& d,
                                       std::optional<glm::vec3> baseColorOverride = {}) {
    ecs::updateTransforms(s.world);
    const ecs::Transform& cam = *s.world.get<ecs::Transform>(s.camera);
    const uint32_t x = d.width / 2, y = d.height / 2;
    glm::dvec3 ray = pixelRay(cam, x, y, d.width, d.height);
    ref::SurfaceSample surf;
    surf.position = glm::vec3(glm::dvec3(cam.position) + 3.0 * ray);
    surf.normal = {0, 0, 1};
    surf.baseColor = baseColorOverride ? *baseColorOverride : glm::vec3(m.baseColor);
    surf.metallic = m.metallic;
    surf.roughness = m.roughness;
    surf.emissive = m.emissive;
    std::vector<ref::LightSample> lights;
    for (auto [e, l, t] : s.world.view<const ecs::Light, const ecs::Transform>())
        lights.push_back(ref::makeLightSample(l, t));
    glm::vec3 radiance =
        ref::shadeSurface(d.settings.shading, d.settings.ambient, surf, cam.position, lights);
    return ref::displayEncode(radiance, d.settings.exposure, d.settings.toneMapper);
}

ecs::Material testMaterial() {
    ecs::Material m;
    m.baseColor = {0.8f, 0.35f, 0.2f, 1.0f};
    m.metallic = 0.3f;
    m.roughness = 0.4f;
    m.emissive = {0.02f, 0.01f, 0.0f};
    return m;
}

int maxChannelDiff(const uint8_t* px, const std::array<uint8_t, 3>& expected) {
    int m = 0;
    for (int c = 0; c < 3; ++c) m = std::max(m, std::abs(int(px[c]) - int(expected[size_t(c)])));
    return m;
}

TEST_P(SceneRendererTest, DirectionalLightMatchesReferenceForEveryModelAndToneMapper) {
    TestScene s;
    const ecs::Material m = testMaterial();
    addLitQuad(s, m);
    s.directional(glm::normalize(glm::vec3(-0.3f, -0.45f, -1.0f)), {1.0f, 0.95f, 0.9f}, 2.2f);
    SceneRenderer r(dev());
    int worst = 0;
    std::vector<std::array<uint8_t, 3>> seen;  // GPU centre pixels, one per combination
    for (auto shading : {scene::ShadingModel::CookTorrance, scene::ShadingModel::BlinnPhong}) {
        for (auto mapper : {scene::ToneMapper::Clamp, scene::ToneMapper::Reinhard, scene::ToneMapper::Aces}) {
            FrameDesc d = s.frame();
            d.settings.shading = shading;
            d.settings.toneMapper = mapper;
            d.settings.exposure = 1.3f;
            d.settings.ambient = {0.05f, 0.05f, 0.06f};
            std::string error;
            ASSERT_TRUE(s.render(r, d, error)) << error;
            ImageRGBA8 img;
            ASSERT_TRUE(r.readPixels(img, error)) << error;
            std::array<uint8_t, 3> expected = referenceCentre(s, m, d);
            const uint8_t* px = img.at(kW / 2, kH / 2);
            int diff = maxChannelDiff(px, expected);
            worst = std::max(worst, diff);
            // Metric: max per-channel |GPU - CPU reference| at the centre pixel (8-bit sRGB);
            // threshold 2/255.
            EXPECT_LE(diff, 2) << scene::shadingModelName(shading) << " + " << scene::toneMapperName(mapper)
                               << ": GPU (" << int(px[0]) << ", " << int(px[1]) << ", " << int(px[2])
                               << ") reference (" << int(expected[0]) << ", " << int(expected[1]) << ", "
                               << int(expected[2]) << ")";
            EXPECT_EQ(px[3], 255);
            seen.push_back({px[0], px[1], px[2]});
        }
    }
    // Each shading model and tone mapper changes the result (the settings reach the shader).
    for (size_t i = 0; i < seen.size(); ++i)
        for (size_t j = i + 1; j < seen.size(); ++j) EXPECT_NE(seen[i], seen[j]) << i << " vs " << j;
    std::printf("directional light, 2 models x 3 tone mappers: max centre-pixel difference %d/255\n", worst);
}

TEST_P(SceneRendererTest, PointAndSphereLightsMatchReference) {
    for (auto type : {ecs::LightType::Point, ecs::LightType::Sphere}) {
        TestScene s;
        ecs::Material m = testMaterial();
        m.metallic = 0.0f;
        m.roughness = 0.6f;
        addLitQuad(s, m);
        // 1.2 units in front of the quad, off-centre: d ~ 1.27 to the centre pixel, range 4.
        s.point({0.3f, 0.25f, -1.8f}, {0.9f, 0.9f, 1.0f}, 3.0f, 4.0f, type, 0.2f);
        SceneRenderer r(dev());
        for (auto shading : {scene::ShadingModel::CookTorrance, scene::ShadingModel::BlinnPhong}) {
            FrameDesc d = s.frame();
            d.settings.shading = shading;
            d.settings.toneMapper = scene::ToneMapper::Reinhard;
            std::string error;
            ASSERT_TRUE(s.render(r, d, error)) << error;
            ImageRGBA8 img;
            ASSERT_TRUE(r.readPixels(img, error)) << error;
            std::array<uint8_t, 3> expected = referenceCentre(s, m, d);
            const uint8_t* px = img.at(kW / 2, kH / 2);
            const int diff = maxChannelDiff(px, expected);
            std::printf("%s light, %s: centre-pixel difference %d/255\n",
                        type == ecs::LightType::Point ? "point" : "sphere", scene::shadingModelName(shading),
                        diff);
            // Metric: max per-channel |GPU - reference| at the centre pixel; threshold 2/255.
            EXPECT_LE(diff, 2) << (type == ecs::LightType::Point ? "point" : "sphere") << " light, "
                               << scene::shadingModelName(shading) << ": GPU (" << int(px[0]) << ", "
                               << int(px[1]) << ", " << int(px[2]) << ") reference (" << int(expected[0])
                               << ", " << int(expected[1]) << ", " << int(expected[2]) << ")";
            EXPECT_GT(int(px[0]), int(expected[0]) / 2 + 20) << "the light should contribute";
        }
    }
}

TEST_P(SceneRendererTest, NoLightsShowsAmbientAndBackground) {
    TestScene s;
    ecs::Material m = testMaterial();
    addLitQuad(s, m);
    SceneRenderer r(dev());
    FrameDesc d = s.frame();
    d.settings.ambient = {0.4f, 0.5f, 0.6f};
    d.settings.background = {0.1f, 0.2f, 0.7f};
    d.settings.toneMapper = scene::ToneMapper::Aces;
    d.settings.exposure = 1.5f;
    std::string error;
    ASSERT_TRUE(s.render(r, d, error)) << error;
    EXPECT_EQ(r.lastFrameStats().lights, 0u);
    ImageRGBA8 img;
    ASSERT_TRUE(r.readPixels(img, error)) << error;
    // Ambient only: ambient * baseColor * AO(1) + emissive.
    std::array<uint8_t, 3> ambient = ref::displayEncode(
        d.settings.ambient * glm::vec3(m.baseColor) + m.emissive, d.settings.exposure, d.settings.toneMapper);
    const uint8_t* px = img.at(kW / 2, kH / 2);
    // Metric: max per-channel |GPU - reference| (8-bit sRGB); threshold 2/255 (centre pixel).
    EXPECT_LE(maxChannelDiff(px, ambient), 2);
    EXPECT_LE(maxChannelDiff(px, referenceCentre(s, m, d)), 2);
    // Background through the same exposure + tone map + sRGB; threshold 1/255 (corner pixel).
    std::array<uint8_t, 3> bg =
        ref::displayEncode(d.settings.background, d.settings.exposure, d.settings.toneMapper);
    EXPECT_LE(maxChannelDiff(img.at(0, 0), bg), 1);
}

TEST_P(SceneRendererTest, BaseColorTextureFillsAlbedoTarget) {
    TestScene s;
    assets::TextureData tex;
    tex.width = tex.height = 2;
    tex.srgb = true;
    tex.rgba8 = solidTexels(4, {188, 120, 60, 255});
    std::string error;
    assets::AssetId texId = s.assets.addTexture("tex", tex, error);
    ASSERT_NE(texId, 0u) << error;
    ecs::Material m = testMaterial();
    m.baseColorTexture = texId;
    addLitQuad(s, m);
    s.directional(glm::normalize(glm::vec3(0.2f, -0.3f, -1.0f)), glm::vec3(1.0f), 1.8f);
    SceneRenderer r(dev());
    FrameDesc d = s.frame();
    d.settings.toneMapper = scene::ToneMapper::Reinhard;
    ASSERT_TRUE(s.render(r, d, error)) << error;
    EXPECT_GT(r.lastFrameStats().memory.textures, 0u);
    std::vector<uint8_t> albedo = readRgba8(r, "gbuffer.albedo");
    ASSERT_EQ(albedo.size(), size_t(kW) * kH * 4);
    auto srgbToLinear = [](float c) {
        return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
    };
    glm::vec3 texLinear(srgbToLinear(188 / 255.0f), srgbToLinear(120 / 255.0f), srgbToLinear(60 / 255.0f));
    glm::vec3 expectedAlbedo = glm::vec3(m.baseColor) * texLinear;
    const size_t centre = (size_t(kH / 2) * kW + kW / 2) * 4;
    for (int c = 0; c < 3; ++c) {
        int enc = int(std::lround(ref::srgbEncode(expectedAlbedo[c]) * 255.0f));
        // Metric: |stored sRGB byte - encoded base colour x texture|; threshold 1/255.
        EXPECT_NEAR(int(albedo[centre + size_t(c)]), enc, 1) << "channel " << c;
    }
    ImageRGBA8 img;
    ASSERT_TRUE(r.readPixels(img, error)) << error;
    std::array<uint8_t, 3> expected = referenceCentre(s, m, d, expectedAlbedo);
    // Metric: max per-channel |GPU - reference|; threshold 3/255 (the albedo target's 8-bit sRGB
    // quantisation adds up to half a step before shading).
    const int diff = maxChannelDiff(img.at(kW / 2, kH / 2), expected);
    std::printf("textured material: centre-pixel difference %d/255\n", diff);
    EXPECT_LE(diff, 3);

    // Without textured materials there is no albedo target.
    ecs::Material plain = testMaterial();
    TestScene s2;
    addLitQuad(s2, plain);
    ASSERT_TRUE(s2.render(r, s2.frame(), error)) << error;
    std::vector<uint8_t> texels;
    rhi::Format format{};
    EXPECT_FALSE(r.readTarget("gbuffer.albedo", texels, format, error));
    EXPECT_NE(error.find("not part of the last frame"), std::string::npos) << error;
}

// ---- 7. passes, resources and errors ----------------------------------------------------------------

std::vector<std::string> passNames(const SceneRenderer& r) {
    std::vector<std::string> names;
    for (const auto& p : r.lastFrameStats().passes) names.push_back(p.name);
    return names;
}

TEST_P(SceneRendererTest, PassesFollowTheScene) {
    TestScene s;
    s.point({0, 1, 0}, glm::vec3(1), 1.0f, 5.0f);  // lights alone need no geometry pass
    SceneRenderer r(dev());
    FrameDesc d = s.frame();
    d.settings.background = {0.2f, 0.3f, 0.4f};
    std::string error;
    ASSERT_TRUE(s.render(r, d, error)) << error;
    EXPECT_EQ(passNames(r), (std::vector<std::string>{"lighting"}));
    EXPECT_EQ(r.lastFrameGraphviz().find("gbuffer_mesh"), std::string::npos);
    EXPECT_EQ(r.lastFrameStats().memory.meshBuffers, 0u);
    EXPECT_EQ(r.lastFrameStats().memory.sceneBuffers, 0u);
    EXPECT_EQ(r.lastFrameStats().memory.renderTargets, uint64_t(kW) * kH * 4) << "only the output";
    ImageRGBA8 img;
    ASSERT_TRUE(r.readPixels(img, error)) << error;
    std::array<uint8_t, 3> bg =
        ref::displayEncode(d.settings.background, d.settings.exposure, d.settings.toneMapper);
    for (uint32_t y = 0; y < kH; y += 7)
        for (uint32_t x = 0; x < kW; x += 5) ASSERT_LE(maxChannelDiff(img.at(x, y), bg), 1);
    std::vector<uint8_t> texels;
    rhi::Format format{};
    EXPECT_FALSE(r.readTarget("gbuffer.depth", texels, format, error));

    // With a mesh: the three passes, in order, each timed; resources sized to the scene.
    auto quad = s.mesh("quad", makeQuad(0.5f, 0.5f));
    s.object(quad, 0, {0, 0, -3});
    s.object(quad, 0, {1, 0, -3});
    ASSERT_TRUE(s.render(r, d, error)) << error;
    EXPECT_EQ(passNames(r), (std::vector<std::string>{"scene_upload", "gbuffer_mesh", "lighting"}));
    for (const auto& p : r.lastFrameStats().passes) EXPECT_GE(p.gpuMs, 0.0) << p.name;
    const render::FrameStats& st = r.lastFrameStats();
    EXPECT_EQ(st.drawCalls, 2u);
    EXPECT_EQ(st.triangles, 4u);
    EXPECT_EQ(st.lights, 1u);
    EXPECT_EQ(st.materials, 1u);
    EXPECT_EQ(st.memory.meshBuffers, 4u * sizeof(render::GpuVertex) + 6u * 4u)
        << "one copy of the shared mesh";
    EXPECT_EQ(st.memory.sceneBuffers, sizeof(render::GpuView) + sizeof(render::GpuScene) +
                                          1 * sizeof(render::GpuMaterial) + 1 * sizeof(render::GpuLight) +
                                          2 * sizeof(render::GpuObject));
    EXPECT_EQ(st.memory.textures, 0u) << "no material has a texture";
    // Output + depth, normal, material, velocity (4 bytes per pixel each) + D32 depth; no albedo.
    EXPECT_EQ(st.memory.renderTargets, uint64_t(kW) * kH * 4 * 6);
    EXPECT_NE(r.lastFrameGraphviz().find("gbuffer_mesh"), std::string::npos);
    EXPECT_EQ(r.lastFrameGraphviz().find("gbuffer.albedo"), std::string::npos);

    // No lights: the lights buffer still holds one (unused) element.
    for (auto [e, l] : s.world.view<ecs::Light>()) s.world.destroy(e);
    ASSERT_TRUE(s.render(r, d, error)) << error;
    EXPECT_EQ(r.lastFrameStats().lights, 0u);
    EXPECT_EQ(r.lastFrameStats().memory.sceneBuffers,
              sizeof(render::GpuView) + sizeof(render::GpuScene) + sizeof(render::GpuMaterial) +
                  sizeof(render::GpuLight) + 2 * sizeof(render::GpuObject));
}

TEST_P(SceneRendererTest, ErrorsAreReportedAndTheRendererStaysUsable) {
    TestScene s;
    auto quad = s.mesh("quad", makeQuad(0.5f, 0.5f));
    s.object(quad, 0, {0, 0, -3});
    SceneRenderer r(dev());
    std::string error;

    FrameDesc noCamera = s.frame();
    noCamera.camera = ecs::kNullEntity;
    EXPECT_FALSE(s.render(r, noCamera, error));
    EXPECT_NE(error.find("no camera"), std::string::npos) << error;
    FrameDesc notACamera = s.frame();
    notACamera.camera = s.world.create();
    EXPECT_FALSE(s.render(r, notACamera, error));
    EXPECT_NE(error.find("no camera"), std::string::npos) << error;

    ecs::Entity broken = s.object(0x1234567, 0, {0, 0, -2});
    EXPECT_FALSE(s.render(r, s.frame(), error));
    EXPECT_NE(error.find("mesh asset 0000000001234567 is not loaded"), std::string::npos) << error;
    s.world.get<ecs::MeshRenderer>(broken)->mesh = quad;
    s.world.get<ecs::MeshRenderer>(broken)->material = 0x777;
    EXPECT_FALSE(s.render(r, s.frame(), error));
    EXPECT_NE(error.find("material asset 0000000000000777 is not loaded"), std::string::npos) << error;
    s.world.destroy(broken);

    FrameDesc zero = s.frame(0, 10);
    EXPECT_FALSE(s.render(r, zero, error));
    EXPECT_NE(error.find("frame size"), std::string::npos) << error;

    ImageRGBA8 img;
    EXPECT_FALSE(r.readPixels(img, error)) << "no frame succeeded yet";
    EXPECT_TRUE(s.render(r, s.frame(), error)) << error;
    EXPECT_TRUE(r.readPixels(img, error)) << error;
    std::vector<uint8_t> texels;
    rhi::Format format{};
    EXPECT_FALSE(r.readTarget("gbuffer.nothing", texels, format, error));
    EXPECT_NE(error.find("unknown target"), std::string::npos) << error;
}

// 300 distinct materials in one frame (issue 8, item 5: the G-buffer index was 8-bit and the frame
// failed with "more than 255 materials"). 300 small quads in a 20 x 15 grid, quad i with material i
// (entity order = index order) of a unique base colour; ambient 1, no lights, Clamp tone mapping, so
// a pixel shows exactly its material's base colour. Criteria at every quad's centre pixel: the
// G-buffer holds index i (low byte r, high byte g) and the output colour equals the display encoding
// of material i's base colour within 1/255 per channel (a wrong index shows another material's
// colour, at least 16/255 away). Indices 256 .. 299 exercise the high byte.
TEST_P(SceneRendererTest, ThreeHundredMaterialsInOneFrame) {
    constexpr int kCols = 20, kRows = 15, kCount = kCols * kRows;
    constexpr uint32_t kWidth = 320, kHeight = 240;
    TestScene s;
    auto quad = s.mesh("quad", makeQuad(0.07f, 0.07f));
    std::vector<glm::vec3> colours, positions;
    for (int i = 0; i < kCount; ++i) {
        ecs::Material m;
        m.baseColor = {float(i & 15) / 15.0f, float(i >> 4) / 18.0f, 0.25f, 1.0f};
        m.metallic = 0.0f;
        colours.push_back(glm::vec3(m.baseColor));
        positions.push_back({(float(i % kCols) - 9.5f) * 0.2f, (float(i / kCols) - 7.0f) * 0.2f, -3.0f});
        s.object(quad, s.material("m" + std::to_string(i), m), positions.back());
    }
    SceneRenderer r(dev());
    FrameDesc d = s.frame(kWidth, kHeight);
    d.settings.ambient = glm::vec3(1.0f);
    d.settings.background = glm::vec3(0.0f);
    d.settings.toneMapper = scene::ToneMapper::Clamp;
    d.settings.exposure = 1.0f;
    std::string error;
    ASSERT_TRUE(s.render(r, d, error)) << error;
    EXPECT_EQ(r.lastFrameStats().materials, uint32_t(kCount));
    std::vector<uint8_t> mat = readRgba8(r, "gbuffer.material");
    ASSERT_EQ(mat.size(), size_t(kWidth) * kHeight * 4);
    ImageRGBA8 img;
    ASSERT_TRUE(r.readPixels(img, error)) << error;
    const ecs::Transform& cam = *s.world.get<ecs::Transform>(s.camera);
    int wrongIndex = 0, wrongColour = 0;
    for (int i = 0; i < kCount; ++i) {
        glm::dvec2 px = projectToPixel(cam, glm::dvec3(positions[size_t(i)]), kWidth, kHeight);
        const uint32_t x = uint32_t(px.x), y = uint32_t(px.y);
        const size_t at = (size_t(y) * kWidth + x) * 4;
        const int index = int(mat[at]) | int(mat[at + 1]) << 8;
        if (index != i) ++wrongIndex;
        EXPECT_EQ(index, i) << "G-buffer index at quad " << i;
        EXPECT_EQ(int(mat[at + 2]), 0) << "SDF object slot (0: a mesh), low byte";
        EXPECT_EQ(int(mat[at + 3]), 0) << "SDF object slot, high byte";
        const std::array<uint8_t, 3> expected =
            ref::displayEncode(colours[size_t(i)], d.settings.exposure, d.settings.toneMapper);
        const int diff = maxChannelDiff(img.at(x, y), expected);
        if (diff > 1) ++wrongColour;
        EXPECT_LE(diff, 1) << "colour of quad " << i << " (material " << i << ")";
    }
    EXPECT_EQ(wrongIndex, 0);
    EXPECT_EQ(wrongColour, 0);
}

// The per-frame limit is now the 16-bit index: 65536 materials (the scene format's limit). One more
// (65536 material assets plus the default material) is refused before any GPU work, with a message
// that says why, and the renderer stays usable.
TEST_P(SceneRendererTest, MoreThan65536MaterialsIsAClearError) {
    TestScene s;
    auto quad = s.mesh("quad", makeQuad(0.01f, 0.01f));
    for (int i = 0; i < 65536; ++i) {
        ecs::Material m;
        m.roughness = 0.5f + float(i) * 1e-6f;
        s.object(quad, s.material("m" + std::to_string(i), m), {0, 0, -3});
    }
    s.object(quad, 0, {0.1f, 0, -3});  // the default material: number 65537
    SceneRenderer r(dev());
    std::string error;
    EXPECT_FALSE(s.render(r, s.frame(), error));
    EXPECT_NE(error.find("more than 65536 materials in one frame (65537 used"), std::string::npos) << error;
    TestScene small;
    small.object(small.mesh("big_quad", makeQuad(0.5f, 0.5f)), 0, {0, 0, -3});
    EXPECT_TRUE(small.render(r, small.frame(), error)) << error;
}

TEST_P(SceneRendererTest, ExternalTargetResizeAndAssetCollection) {
    TestScene s;
    auto quad = s.mesh("quad", makeQuad(0.5f, 0.5f));
    ecs::Entity obj = s.object(quad, 0, {0, 0, -3});
    s.directional({0, 0, -1}, glm::vec3(1), 1.0f);
    SceneRenderer r(dev());
    std::string error;
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    ImageRGBA8 own;
    ASSERT_TRUE(r.readPixels(own, error)) << error;

    // The same frame into a caller's texture, left in CopySrc.
    rhi::TextureDesc td;
    td.format = rhi::Format::RGBA8_UNORM;
    td.width = kW;
    td.height = kH;
    td.usage = rhi::TextureUsage::ColorTarget | rhi::TextureUsage::CopySrc;
    td.debugName = "test.external";
    rhi::TextureHandle target = dev().createTexture(td);
    ASSERT_TRUE(target.isValid());
    FrameDesc d = s.frame();
    d.target = target;
    d.targetAccess = rhi::Access::None;
    d.targetFinalAccess = rhi::Access::CopySrc;
    ASSERT_TRUE(s.render(r, d, error)) << error;
    std::vector<uint8_t> texels;
    ASSERT_TRUE(dev().readTexture(target, {}, rhi::Access::CopySrc, texels));
    EXPECT_EQ(texels, own.pixels) << "external target and own output must match";
    ImageRGBA8 none;
    EXPECT_FALSE(r.readPixels(none, error)) << "readPixels reads only the renderer's own output";
    // A target of the wrong size is refused.
    FrameDesc wrong = s.frame(kW + 1, kH);
    wrong.target = target;
    EXPECT_FALSE(s.render(r, wrong, error));
    dev().destroy(target);

    // Resize: targets follow the frame size.
    ASSERT_TRUE(s.render(r, s.frame(128, 96), error)) << error;
    ImageRGBA8 big;
    ASSERT_TRUE(r.readPixels(big, error)) << error;
    EXPECT_EQ(big.width, 128u);
    EXPECT_EQ(big.height, 96u);
    EXPECT_EQ(readDepth(r).size(), size_t(128) * 96);

    // collectAssets drops the GPU copy of a released mesh.
    EXPECT_GT(r.lastFrameStats().memory.meshBuffers, 0u);
    s.world.destroy(obj);
    EXPECT_TRUE(s.assets.release(quad));
    r.collectAssets(s.assets);
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    EXPECT_EQ(r.lastFrameStats().memory.meshBuffers, 0u);
}

INSTANTIATE_TEST_SUITE_P(Backends, SceneRendererTest, testing::ValuesIn(gpuBackends()), backendName);

// ---- 8. Vulkan vs OpenGL parity -------------------------------------------------------------------

// A small multi-object scene: floor, a sphere, a rotated box-like quad pair, a textured quad,
// directional + point + sphere lights.
ImageRGBA8 renderParityScene(rhi::Device& device, std::string& error) {
    TestScene s(glm::vec3(0.5f, 1.4f, 3.2f), glm::vec3(0.0f, 0.2f, -1.0f));
    auto floor = s.mesh("floor", makeQuad(4.0f, 4.0f));
    auto sphere = s.mesh("sphere", makeUvSphere(0.6f, 48, 24));
    auto panel = s.mesh("panel", makeQuad(0.5f, 0.7f));
    assets::TextureData tex;
    tex.width = tex.height = 8;
    tex.rgba8 = solidTexels(64, {40, 60, 160, 255});
    const uint8_t on[4] = {230, 200, 90, 255};
    for (uint32_t y = 0; y < 8; ++y)
        for (uint32_t x = 0; x < 8; ++x)
            if (((x / 2) + (y / 2)) % 2 == 0) std::memcpy(&tex.rgba8[(y * 8 + x) * 4], on, 4);
    assets::AssetId texId = s.assets.addTexture("checker", tex, error);
    ecs::Material floorM, sphereM, metalM, texM;
    floorM.baseColor = {0.6f, 0.6f, 0.55f, 1};
    floorM.roughness = 0.8f;
    sphereM.baseColor = {0.8f, 0.15f, 0.1f, 1};
    sphereM.roughness = 0.3f;
    metalM.baseColor = {0.9f, 0.75f, 0.4f, 1};
    metalM.metallic = 1.0f;
    metalM.roughness = 0.25f;
    texM.baseColorTexture = texId;
    texM.emissive = {0.05f, 0.02f, 0.0f};
    s.object(floor, s.material("floor", floorM), {0, -0.6f, -1.0f},
             glm::angleAxis(glm::radians(-90.0f), glm::vec3(1, 0, 0)));
    s.object(sphere, s.material("sphere", sphereM), {-0.7f, 0.0f, -1.2f});
    s.object(panel, s.material("metal", metalM), {0.9f, 0.1f, -1.5f},
             glm::angleAxis(glm::radians(-35.0f), glm::vec3(0, 1, 0)));
    s.object(panel, s.material("textured", texM), {0.2f, 0.1f, -2.4f},
             glm::angleAxis(glm::radians(20.0f), glm::vec3(0, 1, 0)));
    s.directional(glm::normalize(glm::vec3(-0.4f, -1.0f, -0.5f)), {1.0f, 0.95f, 0.85f}, 2.0f);
    s.point({0.3f, 0.8f, -0.3f}, {0.4f, 0.6f, 1.0f}, 2.5f, 5.0f);
    s.point({-1.2f, 0.6f, -0.4f}, {1.0f, 0.5f, 0.3f}, 1.5f, 4.0f, ecs::LightType::Sphere, 0.15f);
    SceneRenderer r(device);
    FrameDesc d = s.frame(128, 96);
    d.settings.background = {0.05f, 0.07f, 0.12f};
    ImageRGBA8 img;
    if (!s.render(r, d, error) || !r.readPixels(img, error)) return {};
    device.waitIdle();
    return img;
}

TEST(SceneRendererParity, VulkanMatchesOpenGL) {
    BackendPair pair;
    ASSERT_TRUE(pair.ready());
    auto& vkDevice = pair.vk;
    auto& glDevice = pair.gl;
    std::string errVk, errGl;
    ImageRGBA8 vk = renderParityScene(*vkDevice, errVk);
    ImageRGBA8 gl = renderParityScene(*glDevice, errGl);
    ASSERT_FALSE(vk.empty()) << errVk;
    ASSERT_FALSE(gl.empty()) << errGl;
    pair.expectNoErrors();
    // Rule (support/golden.h, shared/design.md): per-channel |delta| <= 5/255 for all but 0.1 % of
    // pixels and no pixel over 64/255.
    ImageDiff d = compareImages(vk, gl);
    std::printf("Vulkan vs OpenGL mesh scene (128x96): %s\n", d.summary().c_str());
    RecordProperty("max_delta", d.maxDelta);
    RecordProperty("mean_delta", std::to_string(d.meanDelta));
    if (!d.pass) {
        std::filesystem::create_directories(goldenOutDir("parity"));
        writePng(goldenOutDir("parity") + "/scene_mesh.vulkan.png", vk);
        writePng(goldenOutDir("parity") + "/scene_mesh.gl.png", gl);
        writePng(goldenOutDir("parity") + "/scene_mesh.diff.png", d.diffImage);
    }
    EXPECT_TRUE(d.pass) << d.summary();
    // The frame is not trivially empty: the lit objects cover much of it.
    size_t lit = 0;
    for (size_t i = 0; i < vk.pixels.size(); i += 4)
        lit += vk.pixels[i] + vk.pixels[i + 1] + vk.pixels[i + 2] > 90;
    EXPECT_GT(lit, vk.pixels.size() / 4 / 3);
}

}  // namespace
}  // namespace penumbra::test
