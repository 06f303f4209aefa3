// Acceptance tests of the SDF ambient occlusion pass (issue 12 item 2; renderer/features/sdf_ao.h,
// renderer/shaders/sdf_ao.comp) on both backends under validation:
//   1. AO against the closed form: a unit sphere resting on a plane; at a plane point at distance x
//      from the contact point the cosine-weighted, unbounded AO is 1 - r^3 / (x^2 + r^2)^(3/2)
//      (the sphere subtends a cap of solid-angle factor (r/D)^2 whose centre is at elevation
//      sin = r/D, D = sqrt(x^2 + r^2)); mean and max |AO - closed form| over the plane pixels per
//      variant and trace quality, printed as a table; multi-ray at "reference" quality (exact binary
//      visibility, 1024 rays) with an unbounded distance must be within 0.02 on average;
//   2. bent normal: near the sphere it tilts away from it; on an open plane it is the normal;
//   3. strength 0 gives AO 1; an occluder beyond maxDistance does not occlude;
//   4. a golden image per backend of a small lit scene with cones AO, and Vulkan / OpenGL parity.
// The AO target is read back at full resolution (resolutionScale 1: the pass writes effects.ao).
// Images are small (128x96, 160x90) so that the software rasterizers run the suite in seconds.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"
#include "engine/engine.h"
#include "engine/scene/scene.h"
#include "engine/sdf/shape_program.h"
#include "renderer/core/gbuffer_encoding.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/ref_camera.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using render::FrameDesc;
using render::SceneRenderer;
using scene::AoVariant;
using scene::TraceQuality;
using sdf::ShapeNode;

constexpr uint32_t kW = 128, kH = 96;

// ---- scene --------------------------------------------------------------------------------------

// A plane y = 0 and (optionally) a sphere of radius `radius` whose centre is at height `centreY`
// above the origin; the camera looks down on both from the side.
struct AoScene {
    ecs::World world;
    assets::AssetManager assets;
    ecs::Entity camera, plane, sphere;

    AoScene(bool withSphere, float radius = 1.0f, float centreY = 1.0f) {
        camera = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(camera);
        t->position = {2.5f, 5.5f, 5.0f};
        t->rotation = glm::quat_cast(
            glm::inverse(glm::lookAtRH(glm::vec3(0), glm::vec3(-2.5f, -5.5f, -5.0f), glm::vec3(0, 1, 0))));
        ecs::Camera c;
        c.fovY = 1.0471976f;  // 60 degrees
        c.nearPlane = 0.1f;
        c.farPlane = 60.0f;
        world.add<ecs::Camera>(camera, c);
        plane = object(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0});
        if (withSphere) sphere = object(ShapeNode::sphere(radius), {0, centreY, 0});
    }
    ecs::Entity object(const ShapeNode& root, glm::vec3 position) {
        sdf::ShapeProgram p;
        std::string error;
        EXPECT_TRUE(sdf::compileShapeProgram(root, p, error)) << error;
        const std::string key = assets::AssetManager::shapeProgramKey(p);
        const assets::AssetId id = assets.addShapeProgram(key, std::move(p), error);
        EXPECT_NE(id, 0u) << error;
        ecs::Entity e = world.create();
        world.add<ecs::Transform>(e)->position = position;
        ecs::SdfRenderer sr;
        sr.sdf = id;
        sr.source = ecs::SdfSource::Shapes;
        world.add<ecs::SdfRenderer>(e, sr);
        return e;
    }
};

struct AoParams {
    AoVariant variant = AoVariant::Cones;
    TraceQuality quality = TraceQuality::Medium;
    float maxDistance = 2.0f;
    float strength = 1.0f;
    uint32_t rays = 0;
};

// One AO frame read back: per pixel AO, bent normal and the entity the trace hit (-1: none).
struct AoImage {
    std::vector<float> ao;
    std::vector<glm::vec3> bent;
    std::vector<int> id;
};

AoImage renderAo(rhi::Device& device, AoScene& s, const AoParams& p) {
    SceneRenderer r(device);
    FrameDesc d;
    d.width = kW;
    d.height = kH;
    d.camera = s.camera;
    d.aux = true;
    d.settings.quality = p.quality;
    d.settings.ao.variant = p.variant;
    d.settings.ao.maxDistance = p.maxDistance;
    d.settings.ao.strength = p.strength;
    d.settings.ao.resolutionScale = 1.0f;
    d.settings.ao.rays = p.rays;
    ecs::updateTransforms(s.world);
    std::string error;
    AoImage out;
    EXPECT_TRUE(r.render(s.world, s.assets, d, error)) << error;
    std::vector<uint8_t> texels, aux;
    rhi::Format format{};
    EXPECT_TRUE(r.readTarget("effects.ao", texels, format, error)) << error;
    EXPECT_EQ(format, rhi::Format::RGBA8_UNORM);
    EXPECT_TRUE(r.readTarget("gbuffer.aux", aux, format, error)) << error;
    if (texels.size() != size_t(kW) * kH * 4 || aux.size() != size_t(kW) * kH * 8) {
        ADD_FAILURE() << "readback sizes";
        return out;
    }
    for (size_t i = 0; i < size_t(kW) * kH; ++i) {
        out.ao.push_back(texels[i * 4] / 255.0f);
        out.bent.push_back(
            glm::vec3(texels[i * 4 + 1], texels[i * 4 + 2], texels[i * 4 + 3]) / 255.0f * 2.0f - 1.0f);
        float entity;
        std::memcpy(&entity, &aux[i * 8], 4);
        out.id.push_back(int(std::lround(entity)));
    }
    return out;
}

// The plane point seen through pixel i (exact ray / plane intersection in double).
glm::dvec3 planePoint(const AoScene& s, size_t i) {
    const RefCamera cam(s.world, s.camera, kW, kH);
    const glm::dvec3 dir = cam.dir(uint32_t(i % kW), uint32_t(i / kW));
    return cam.eye + dir * (-cam.eye.y / dir.y);
}

double closedFormAo(double x, double r) {
    const double d2 = x * x + r * r;
    return 1.0 - r * r * r / (d2 * std::sqrt(d2));
}

struct ErrorStats {
    double mean = 0.0, max = 0.0;
    size_t pixels = 0;
};

// Mean and max |AO - closed form| over the plane pixels whose point lies within `maxX` of the
// contact point (the far plane pixels all have AO near 1 and dilute the mean).
ErrorStats planeError(const AoScene& s, const AoImage& img, double maxX = 1e30) {
    ErrorStats e;
    for (size_t i = 0; i < img.ao.size(); ++i) {
        if (img.id[i] != int(s.plane.index)) continue;
        const glm::dvec3 p = planePoint(s, i);
        const double x = std::hypot(p.x, p.z);
        if (x > maxX) continue;
        const double err = std::abs(double(img.ao[i]) - closedFormAo(x, 1.0));
        e.mean += err;
        e.max = std::max(e.max, err);
        ++e.pixels;
    }
    if (e.pixels) e.mean /= double(e.pixels);
    return e;
}

constexpr double kDeg = 180.0 / 3.14159265358979323846;

class SdfAo : public GpuTest {};

// ---- 1. closed form -------------------------------------------------------------------------------

// Every variant and trace quality at maxDistance 2 (the scale of the sphere) and 1000 (unbounded),
// errors over all plane pixels and over the near field x <= 3. Multi-ray at "reference" quality runs
// 128 exact rays here instead of the preset's 1024: llvmpipe / lavapipe (the test backends) stop
// the loops of an invocation after 65535 iterations in total, which 1024 traced rays exceed (their
// AO then comes out wrong; 256 still did near the sphere at maxDistance 1000); 128 Fibonacci directions
// integrate the cosine-weighted hemisphere to well below the 0.02 criterion.
TEST_P(SdfAo, AoAgainstClosedFormSphereOnPlane) {
    AoScene s(true);
    const TraceQuality qs[] = {TraceQuality::Low, TraceQuality::Medium, TraceQuality::High,
                               TraceQuality::Reference};
    std::printf(
        "  variant    quality   maxDist rays | all plane: px  mean|err| max|err| | x<=3: px  mean|err| "
        "max|err|\n");
    for (AoVariant v : {AoVariant::FiveTap, AoVariant::MultiRay, AoVariant::Cones})
        for (TraceQuality q : qs)
            for (float maxDistance : {2.0f, 1000.0f}) {
                const bool exact = v == AoVariant::MultiRay && q == TraceQuality::Reference;
                const uint32_t rays = exact ? 128u : 0u;
                const AoImage img = renderAo(dev(), s, {v, q, maxDistance, 1.0f, rays});
                const ErrorStats e = planeError(s, img), nearField = planeError(s, img, 3.0);
                std::printf("  %-10s %-9s %7.0f %4u | %12zu %9.4f %8.4f | %8zu %9.4f %8.4f\n",
                            scene::toString(v), scene::toString(q), maxDistance, rays, e.pixels, e.mean,
                            e.max, nearField.pixels, nearField.mean, nearField.max);
                ASSERT_GT(e.pixels, size_t(kW) * kH / 3) << "the plane covers a good part of the image";
                if (exact && maxDistance > 100.0f) {
                    // Acceptance: the exact multi-ray AO converges to the ray-traced (closed-form) AO.
                    EXPECT_LE(e.mean, 0.02)
                        << "multi-ray reference: mean |AO - closed form| <= 0.02 (all plane)";
                    EXPECT_LE(nearField.mean, 0.02)
                        << "multi-ray reference: mean |AO - closed form| <= 0.02 (x <= 3)";
                } else if (maxDistance < 100.0f && !exact) {
                    // Regression bound for the approximations at maxDistance 2 (measured 0.014 - 0.024
                    // when written, docs/ao_measurements.md): mean |error| over all plane px <= 0.03.
                    EXPECT_LE(e.mean, 0.03) << scene::toString(v) << ": mean |AO - closed form| <= 0.03";
                }
            }
}

// ---- 2. bent normal -------------------------------------------------------------------------------

// Near the sphere (1.1 <= x <= 2.5) the bent normal of cones and multi-ray tilts away from it: its
// horizontal part points away from the contact point on >= 95 % of those pixels, by > 2 degrees on
// average. On an open plane it is the normal: angle <= 1 degree (RGBA8 quantisation ~0.3 degrees).
TEST_P(SdfAo, BentNormalTiltsAwayFromOccluders) {
    for (AoVariant v : {AoVariant::Cones, AoVariant::MultiRay}) {
        AoScene s(true);
        const AoImage img = renderAo(dev(), s, {v, TraceQuality::Medium, 2.0f, 1.0f});
        size_t n = 0, away = 0;
        double tilt = 0.0;
        for (size_t i = 0; i < img.ao.size(); ++i) {
            if (img.id[i] != int(s.plane.index)) continue;
            const glm::dvec3 p = planePoint(s, i);
            const double x = std::hypot(p.x, p.z);
            if (x < 1.1 || x > 2.5) continue;
            const glm::dvec3 b = glm::normalize(glm::dvec3(img.bent[i]));
            const double outward = (b.x * p.x + b.z * p.z) / x;  // horizontal part away from the sphere
            ++n;
            if (outward > 0.0) ++away;
            tilt += std::asin(std::clamp(outward, -1.0, 1.0)) * kDeg;
        }
        ASSERT_GT(n, 100u);
        const double fraction = double(away) / double(n), meanTilt = tilt / double(n);
        std::printf("  %s: near the sphere %zu px, %.1f %% tilt away, mean tilt %.2f deg\n",
                    scene::toString(v), n, 100.0 * fraction, meanTilt);
        EXPECT_GE(fraction, 0.95) << "bent normal tilts away from the sphere on >= 95 % of near pixels";
        EXPECT_GT(meanTilt, 2.0) << "mean tilt away from the sphere > 2 degrees";

        AoScene open(false);
        const AoImage flat = renderAo(dev(), open, {v, TraceQuality::Medium, 2.0f, 1.0f});
        double maxAngle = 0.0;
        for (size_t i = 0; i < flat.ao.size(); ++i) {
            if (flat.id[i] != int(open.plane.index)) continue;
            const glm::dvec3 b = glm::normalize(glm::dvec3(flat.bent[i]));
            maxAngle = std::max(maxAngle, std::acos(std::clamp(b.y, -1.0, 1.0)) * kDeg);
        }
        std::printf("  %s: open plane, max angle bent normal / normal %.3f deg\n", scene::toString(v),
                    maxAngle);
        EXPECT_LE(maxAngle, 1.0) << "open plane: bent normal within 1 degree of the normal";
    }
}

// ---- 3. strength and maxDistance --------------------------------------------------------------------

// strength 0: AO is 1 on every pixel (exactly 255/255). A sphere whose bottom is 3 above the plane
// with maxDistance 2: no plane pixel below 254/255, every variant; with maxDistance 6 it does occlude
// (min AO on the plane < 0.98: the control).
TEST_P(SdfAo, StrengthAndMaxDistance) {
    for (AoVariant v : {AoVariant::FiveTap, AoVariant::MultiRay, AoVariant::Cones}) {
        AoScene s(true);
        const AoImage zero = renderAo(dev(), s, {v, TraceQuality::Medium, 2.0f, 0.0f});
        const float minZero = *std::min_element(zero.ao.begin(), zero.ao.end());
        AoScene high(true, 1.0f, 4.0f);
        const AoImage beyond = renderAo(dev(), high, {v, TraceQuality::Medium, 2.0f, 1.0f});
        const AoImage within = renderAo(dev(), high, {v, TraceQuality::Medium, 6.0f, 1.0f});
        float minBeyond = 1.0f, minWithin = 1.0f;
        for (size_t i = 0; i < beyond.ao.size(); ++i) {
            if (beyond.id[i] == int(high.plane.index)) minBeyond = std::min(minBeyond, beyond.ao[i]);
            if (within.id[i] == int(high.plane.index)) minWithin = std::min(minWithin, within.ao[i]);
        }
        std::printf(
            "  %s: strength 0 min AO %.4f; sphere 3 above the plane: min plane AO %.4f (maxDistance 2), "
            "%.4f (maxDistance 6)\n",
            scene::toString(v), minZero, minBeyond, minWithin);
        EXPECT_EQ(minZero, 1.0f) << "strength 0: AO 1 everywhere";
        EXPECT_GE(minBeyond, 254.0f / 255.0f) << "an occluder beyond maxDistance does not occlude";
        EXPECT_LT(minWithin, 0.98f) << "control: within maxDistance it occludes";
    }
}

// ---- 4. golden + parity -----------------------------------------------------------------------------

std::mutex g_goldenMutex;
std::map<rhi::Backend, ImageRGBA8> g_goldens;

// tests/renderer/sdf_ao_scene.json (cones AO, sky / ground ambient, one unshadowed sun) at 160x90:
// the golden rule of support/golden.h per backend, and the same rule between the two backends.
TEST_P(SdfAo, GoldenConesScene) {
    EngineDesc desc;
    desc.loadStaticPlugins = false;
    std::string error;
    auto engine = Engine::create(desc, error);
    ASSERT_TRUE(engine) << error;
    ASSERT_TRUE(engine->loadScene(PENUMBRA_SOURCE_DIR "/tests/renderer/sdf_ao_scene.json", error)) << error;
    engine->update(0.0);
    SceneRenderer renderer(dev());
    FrameDesc frame;
    frame.width = 160;
    frame.height = 90;
    frame.settings = engine->settings();
    frame.camera = scene::findCamera(engine->world(), engine->settings().camera);
    ImageRGBA8 image;
    ASSERT_TRUE(renderer.render(engine->world(), engine->assets(), frame, error)) << error;
    ASSERT_TRUE(renderer.readPixels(image, error)) << error;
    bool ran = false;
    for (const auto& p : renderer.lastFrameStats().passes) ran = ran || p.name == "sdf_ao";
    EXPECT_TRUE(ran) << "the sdf_ao pass ran";
    const std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
    const std::string failure = checkGolden(backend, "sdf_ao_cones", image);
    EXPECT_TRUE(failure.empty()) << failure;
    std::lock_guard<std::mutex> lock(g_goldenMutex);
    g_goldens[GetParam()] = image;
    if (g_goldens.size() == 2) {
        const ImageDiff d = compareImages(g_goldens.begin()->second, g_goldens.rbegin()->second);
        std::printf("  parity Vulkan vs OpenGL: %s\n", d.summary().c_str());
        EXPECT_TRUE(d.pass) << "parity rule (support/golden.h): " << d.summary();
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfAo, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test
