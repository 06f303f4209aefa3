// Acceptance tests of the cone-traced soft shadows (issue 12 item 1; renderer/features/sdf_shadow.h,
// renderer/shaders/sdf_shadow.comp, sdf_cone.glsl) on both backends under validation:
//   1. closed form: a sphere light partly hidden by a sphere occluder above a receiving plane; the
//      exact visible fraction is 1 - (overlap of the light's and the occluder's spherical caps) /
//      (the light's cap); the cone-traced visibility across the penumbra against it (mean |error|
//      <= 0.05 at the default quality, full resolution), the error curve printed;
//   2. the hard setting and point lights give binary visibility, matching the exact segment test
//      away from the shadow edge;
//   3. a directional light of angular radius a: the penumbra width under a straight edge grows
//      with the edge's height h as 2 h tan(a) predicts;
//   4. nine shadowed lights in one frame, each in its own layer; a light with castShadows false
//      gets none (fewer layers), lights that cast none cost no pass, an SdfRenderer with
//      castShadows false casts nothing;
//   5. a lit, shadowed scene: golden per backend and Vulkan-vs-OpenGL parity.
// Every criterion is asserted with its metric and threshold next to it; measured numbers are
// printed. Images are small (160x120, one frame each).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"
#include "engine/image/image.h"
#include "engine/scene/scene.h"
#include "engine/sdf/shape_program.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/ref_camera.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using render::FrameDesc;
using render::SceneRenderer;
using sdf::ShapeNode;

constexpr double kPi = 3.14159265358979323846;
constexpr uint32_t kW = 160, kH = 120;

glm::quat lookRotation(glm::vec3 dir, glm::vec3 up = {0, 1, 0}) {
    if (std::abs(glm::dot(glm::normalize(dir), glm::normalize(up))) > 0.999f) up = {0, 0, -1};
    return glm::quat_cast(glm::inverse(glm::lookAtRH(glm::vec3(0), dir, up)));
}

// A World of shape-program SDF objects, lights and a camera.
struct ShadowScene {
    ecs::World world;
    assets::AssetManager assets;
    ecs::Entity camera;

    ShadowScene(glm::vec3 eye, glm::vec3 target, glm::vec3 up = {0, 0, -1}) {
        camera = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(camera);
        t->position = eye;
        t->rotation = lookRotation(target - eye, up);
        ecs::Camera c;
        c.fovY = 1.0471976f;  // 60 degrees
        c.nearPlane = 0.1f;
        c.farPlane = 100.0f;
        world.add<ecs::Camera>(camera, c);
    }
    ecs::Entity object(const ShapeNode& root, glm::vec3 position, bool castShadows = true,
                       assets::AssetId material = 0) {
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
        sr.castShadows = castShadows;
        sr.material = material;
        world.add<ecs::SdfRenderer>(e, sr);
        return e;
    }
    ecs::Entity light(ecs::LightType type, glm::vec3 position, float radius, glm::vec3 direction = {0, -1, 0},
                      float angularRadius = 0.0f, bool castShadows = true) {
        ecs::Entity e = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = position;
        t->rotation = lookRotation(direction);
        ecs::Light l;
        l.type = type;
        l.radius = radius;
        l.angularRadius = angularRadius;
        l.range = 0.0f;  // no range window
        l.intensity = type == ecs::LightType::Directional ? 2.0f : 20.0f;
        l.castShadows = castShadows;
        world.add<ecs::Light>(e, l);
        return e;
    }
    FrameDesc frame() const {
        FrameDesc d;
        d.width = kW;
        d.height = kH;
        d.camera = camera;
        d.settings.quality = scene::TraceQuality::Medium;
        d.settings.shadows.resolutionScale = 1.0f;
        return d;
    }
    bool render(SceneRenderer& r, const FrameDesc& d, std::string& error) {
        ecs::updateTransforms(world);
        return r.render(world, assets, d, error);
    }
};

// The effects.shadow strip: `layers` blocks of kW x kH visible fractions.
struct ShadowStrip {
    uint32_t layers = 0;
    std::vector<uint8_t> texels;
    float at(uint32_t layer, uint32_t x, uint32_t y) const {
        return float(texels[size_t(y) * kW * layers + layer * kW + x]) / 255.0f;
    }
};

ShadowStrip readShadow(SceneRenderer& r) {
    ShadowStrip s;
    rhi::Format format{};
    std::string error;
    EXPECT_TRUE(r.readTarget("effects.shadow", s.texels, format, error)) << error;
    EXPECT_EQ(format, rhi::Format::R8_UNORM);
    s.layers = uint32_t(s.texels.size() / (size_t(kW) * kH));
    EXPECT_EQ(s.texels.size(), size_t(kW) * kH * s.layers);
    return s;
}

std::vector<float> readDepth(SceneRenderer& r) {
    std::vector<uint8_t> texels;
    rhi::Format format{};
    std::string error;
    EXPECT_TRUE(r.readTarget("gbuffer.depth", texels, format, error)) << error;
    std::vector<float> depth(texels.size() / 4);
    std::memcpy(depth.data(), texels.data(), depth.size() * 4);
    return depth;
}

bool hasPass(const SceneRenderer& r, const std::string& name) {
    for (const auto& p : r.lastFrameStats().passes)
        if (p.name == name) return true;
    return false;
}

// The receiving plane y = 0 seen through pixel (x, y): the exact point, when the GPU's depth says
// the pixel shows the plane (within 1e-3 relative; else the pixel shows an occluder).
bool planePoint(const RefCamera& cam, const std::vector<float>& depth, uint32_t x, uint32_t y,
                glm::dvec3& p) {
    const glm::dvec3 dir = cam.dir(x, y);
    if (dir.y >= -1e-9) return false;
    const double t = -cam.eye.y / dir.y;  // linear depth (dir has unit forward component)
    const float gpu = depth[size_t(y) * kW + x];
    if (gpu <= 0.0f || std::abs(gpu - t) > 1e-3 * t) return false;
    p = cam.eye + dir * t;
    return true;
}

// ---- exact visibility ---------------------------------------------------------------------------------

double capSolidAngle(double a) { return 2.0 * kPi * (1.0 - std::cos(a)); }

// Solid angle of the intersection of two caps of angular radii a, b whose centres are g apart.
double capIntersection(double a, double b, double g) {
    if (g >= a + b) return 0.0;
    if (g <= std::abs(a - b)) return capSolidAngle(std::min(a, b));
    auto acosc = [](double x) { return std::acos(std::clamp(x, -1.0, 1.0)); };
    const double ca = std::cos(a), cb = std::cos(b), cg = std::cos(g);
    const double sa = std::sin(a), sb = std::sin(b), sg = std::sin(g);
    return 2.0 * (kPi - acosc((cg - ca * cb) / (sa * sb)) - acosc((cb - cg * ca) / (sg * sa)) * ca -
                  acosc((ca - cg * cb) / (sg * sb)) * cb);
}

// The visible fraction of a sphere light (centre l, radius rl) from p behind a sphere occluder
// (centre c, radius rc): 1 - cap overlap / light cap.
double exactSphereVisibility(glm::dvec3 p, glm::dvec3 l, double rl, glm::dvec3 c, double rc) {
    const glm::dvec3 tl = l - p, tc = c - p;
    const double a = std::asin(rl / glm::length(tl)), b = std::asin(rc / glm::length(tc));
    const double g = std::acos(std::clamp(glm::dot(glm::normalize(tl), glm::normalize(tc)), -1.0, 1.0));
    return 1.0 - capIntersection(a, b, g) / capSolidAngle(a);
}

// Signed clearance of the segment p -> l from the sphere (c, r): the segment's distance to the
// centre minus r (negative: the segment passes through the sphere).
double segmentClearance(glm::dvec3 p, glm::dvec3 l, glm::dvec3 c, double r) {
    const glm::dvec3 d = l - p;
    const double s = std::clamp(glm::dot(c - p, d) / glm::dot(d, d), 0.0, 1.0);
    return glm::length(p + d * s - c) - r;
}

class SdfShadow : public GpuTest {};

// ---- 1. closed form --------------------------------------------------------------------------------------

struct CapCase {
    const char* name;
    glm::vec3 light;
    float lightRadius;
    glm::vec3 occluder;
    float occluderRadius;
    float sunAngularRadius = 0.0f;  // > 0: a directional light of this angular radius shining from
                                    // `light` toward the occluder's centre instead of the sphere light
};

struct CapResult {
    uint32_t penumbraPixels = 0;
    double meanError = 0, maxError = 0, meanSigned = 0;
};

// Renders the case and compares every plane pixel in the exact penumbra (0 < exact < 1 or GPU
// strictly between 0 and 1); prints the curve along the row through the shadow's centre.
CapResult compareCapCase(rhi::Device& dev, const CapCase& cc, float resolutionScale, bool printCurve) {
    ShadowScene s({1.2f, 5.0f, 0.0f}, {1.2f, 0.0f, 0.0f});
    s.object(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0});
    s.object(ShapeNode::sphere(cc.occluderRadius), cc.occluder);
    const bool sun = cc.sunAngularRadius > 0.0f;
    const glm::dvec3 sunDir = glm::normalize(glm::dvec3(cc.occluder) - glm::dvec3(cc.light));  // travels
    if (sun)
        s.light(ecs::LightType::Directional, cc.light, 0.0f, glm::vec3(sunDir), cc.sunAngularRadius);
    else
        s.light(ecs::LightType::Sphere, cc.light, cc.lightRadius);
    SceneRenderer r(dev);
    FrameDesc d = s.frame();
    d.settings.shadows.resolutionScale = resolutionScale;
    std::string error;
    EXPECT_TRUE(s.render(r, d, error)) << error;
    EXPECT_TRUE(hasPass(r, "sdf_shadow"));
    const ShadowStrip strip = readShadow(r);
    const std::vector<float> depth = readDepth(r);
    const RefCamera cam(s.world, s.camera, kW, kH);
    CapResult res;
    if (strip.layers != 1u) return res;
    const glm::dvec3 l(cc.light), c(cc.occluder);
    // The shadow's centre on the plane: the line from the light through the occluder's centre.
    const glm::dvec3 centre = l + (c - l) * (l.y / (l.y - c.y));
    const glm::dvec2 centrePixel = cam.project(centre);
    const uint32_t row = uint32_t(std::clamp(centrePixel.y, 0.0, double(kH - 1)));
    if (printCurve)
        std::printf("  [%s, scale %.2f] curve along row %u (x px, plane x, GPU, exact, error):\n", cc.name,
                    resolutionScale, row);
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            glm::dvec3 p;
            if (!planePoint(cam, depth, x, y, p)) continue;
            // A sun of angular radius a is the sphere light of radius sin(a) at unit distance.
            const double exact =
                sun ? exactSphereVisibility(p, p - sunDir, std::sin(double(cc.sunAngularRadius)), c,
                                            cc.occluderRadius)
                    : exactSphereVisibility(p, l, cc.lightRadius, c, cc.occluderRadius);
            const double gpu = strip.at(0, x, y);
            const bool penumbra = (exact > 0.0 && exact < 1.0) || (gpu > 0.0 && gpu < 1.0);
            if (!penumbra) continue;
            const double err = gpu - exact;
            ++res.penumbraPixels;
            res.meanError += std::abs(err);
            res.meanSigned += err;
            res.maxError = std::max(res.maxError, std::abs(err));
            if (printCurve && y == row && x % 2 == 0)
                std::printf("    %3u  %+.3f  %.3f  %.3f  %+.3f\n", x, p.x, gpu, exact, err);
        }
    if (res.penumbraPixels > 0) {
        res.meanError /= res.penumbraPixels;
        res.meanSigned /= res.penumbraPixels;
    }
    std::printf("  [%s, scale %.2f] %u penumbra px: |error| mean %.4f, max %.4f; mean signed %+.4f\n",
                cc.name, resolutionScale, res.penumbraPixels, res.meanError, res.maxError, res.meanSigned);
    return res;
}

// The acceptance case: the occluder's cap (about 0.26 rad from the plane) a few times the light's
// (about 0.09 rad), the common case of an area light well above its occluders.
constexpr CapCase kAcceptanceCase{
    "sphere light r 0.5 at 5.5, occluder r 0.5 at 2", {-1.5f, 5.5f, 0.0f}, 0.5f, {0.0f, 2.0f, 0.0f}, 0.5f};

TEST_P(SdfShadow, SphereLightMatchesCapOverlap) {
    const CapResult res = compareCapCase(dev(), kAcceptanceCase, 1.0f, true);
    ASSERT_GE(res.penumbraPixels, 200u) << "the penumbra covers a measurable band of pixels";
    // Criterion (issue 12): mean |GPU - exact| over the penumbra <= 0.05 at the default (medium)
    // quality and full resolution.
    EXPECT_LE(res.meanError, 0.05);
}

// Not an acceptance criterion: a light as large (in angle) as the occluder, where the estimate's
// straight-edge model departs most from the exact caps; the curve documents it (printed only).
TEST_P(SdfShadow, LargeLightErrorCurveIsReported) {
    const CapCase large{"sphere light r 1.2 at 5.5, occluder r 0.5 at 2",
                        {-1.5f, 5.5f, 0.0f},
                        1.2f,
                        {0.0f, 2.0f, 0.0f},
                        0.5f};
    const CapResult res = compareCapCase(dev(), large, 1.0f, true);
    EXPECT_GE(res.penumbraPixels, 200u) << "the penumbra covers a measurable band of pixels";
}

// The default half resolution through effects_upsample: the same comparison, printed for the docs
// (the upsampler's accuracy is effects_upsample's criterion; here only that a penumbra is measured).
TEST_P(SdfShadow, SphereLightAtHalfResolutionIsReported) {
    const CapResult res = compareCapCase(dev(), kAcceptanceCase, 0.5f, false);
    EXPECT_GE(res.penumbraPixels, 200u) << "the penumbra covers a measurable band of pixels";
}

// The same closed form for a directional light (the sun's disc of directions is a cap of its
// angular radius, 0.09 rad, about the sphere light's above): the same criterion.
TEST_P(SdfShadow, DirectionalLightMatchesCapOverlap) {
    CapCase sun = kAcceptanceCase;
    sun.name = "sun of angular radius 0.09, occluder r 0.5 at 2";
    sun.sunAngularRadius = 0.09f;
    const CapResult res = compareCapCase(dev(), sun, 1.0f, false);
    ASSERT_GE(res.penumbraPixels, 200u) << "the penumbra covers a measurable band of pixels";
    // Criterion (issue 12): mean |GPU - exact| over the penumbra <= 0.05 at the default quality.
    EXPECT_LE(res.meanError, 0.05);
}

// ---- 2. hard shadows ----------------------------------------------------------------------------------

struct HardResult {
    uint32_t planePixels = 0, nonBinary = 0, clearPixels = 0, mismatches = 0;
};

// Binary values everywhere; away from the edge (|clearance| > 3 pixel footprints) the exact
// segment test decides.
HardResult compareHard(const ShadowStrip& strip, uint32_t layer, const ShadowScene& s,
                       const std::vector<float>& depth, glm::dvec3 light, glm::dvec3 c, double rc) {
    const RefCamera cam(s.world, s.camera, kW, kH);
    HardResult res;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            glm::dvec3 p;
            if (!planePoint(cam, depth, x, y, p)) continue;
            ++res.planePixels;
            const float v = strip.at(layer, x, y);
            if (v != 0.0f && v != 1.0f) ++res.nonBinary;
            const double footprint = 2.0 * cam.tanHalf / kH * glm::length(p - cam.eye);
            const double clearance = segmentClearance(p, light, c, rc);
            if (std::abs(clearance) <= 3.0 * footprint) continue;
            ++res.clearPixels;
            if ((clearance > 0.0) != (v > 0.5f)) ++res.mismatches;
        }
    return res;
}

void checkHard(rhi::Device& dev, ecs::LightType type, bool hardSetting, const char* what) {
    const glm::vec3 light(-1.5f, 5.5f, 0.0f), occluder(0.0f, 2.0f, 0.0f);
    ShadowScene s({1.2f, 5.0f, 0.0f}, {1.2f, 0.0f, 0.0f});
    s.object(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0});
    s.object(ShapeNode::sphere(0.5), occluder);
    s.light(type, light, 0.5f);
    SceneRenderer r(dev);
    FrameDesc d = s.frame();
    d.settings.shadows.hard = hardSetting;
    std::string error;
    ASSERT_TRUE(s.render(r, d, error)) << error;
    const ShadowStrip strip = readShadow(r);
    ASSERT_EQ(strip.layers, 1u);
    const HardResult res = compareHard(strip, 0, s, readDepth(r), light, occluder, 0.5);
    std::printf(
        "  [%s] %u plane px, %u not binary; %u px off the edge, %u disagree with the exact segment test\n",
        what, res.planePixels, res.nonBinary, res.clearPixels, res.mismatches);
    EXPECT_GE(res.planePixels, kW * kH / 2) << what;
    EXPECT_EQ(res.nonBinary, 0u) << what << ": visibility is binary (0 or 1 exactly)";
    EXPECT_EQ(res.mismatches, 0u) << what << ": 0 disagreements more than 3 pixel footprints off the edge";
}

TEST_P(SdfShadow, HardSettingIsBinary) {
    checkHard(dev(), ecs::LightType::Sphere, true, "sphere light, hard");
}
TEST_P(SdfShadow, PointLightIsBinary) { checkHard(dev(), ecs::LightType::Point, false, "point light"); }

// ---- 3. directional penumbra width ------------------------------------------------------------------

// Where the row's visibility first rises through `level` going +x from x0 (linear interpolation
// between pixel centres), as a plane x; NaN when it does not.
double crossing(const ShadowStrip& strip, const RefCamera& cam, uint32_t y, uint32_t x0, float level) {
    for (uint32_t x = x0; x + 1 < kW; ++x) {
        const float a = strip.at(0, x, y), b = strip.at(0, x + 1, y);
        if (a < level && b >= level) {
            const double f = (level - a) / (b - a);
            const glm::dvec3 d0 = cam.dir(x, y), d1 = cam.dir(x + 1, y);
            const double x0w = cam.eye.x + d0.x * (-cam.eye.y / d0.y);
            const double x1w = cam.eye.x + d1.x * (-cam.eye.y / d1.y);
            return x0w + f * (x1w - x0w);
        }
    }
    return std::nan("");
}

TEST_P(SdfShadow, DirectionalPenumbraGrowsWithOccluderHeight) {
    // Two slabs whose edges lie on x = 0, centred at heights 0.75 (z < 0) and 1.5 (z > 0), under a
    // sun straight overhead of angular radius 0.15 rad; the camera looks straight down from x = 1.
    // The slabs are 0.5 thick, more than the cone's cross-section where it crosses them (a thinner
    // plate lets part of the light through: sdf_cone.glsl).
    const float alpha = 0.15f, heights[2] = {0.75f, 1.5f};
    ShadowScene s({1.0f, 3.5f, 0.0f}, {1.0f, 0.0f, 0.0f});
    s.object(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0});
    s.object(ShapeNode::box({1.5, 0.25, 0.8}), {-1.5f, heights[0], -1.0f});
    s.object(ShapeNode::box({1.5, 0.25, 0.8}), {-1.5f, heights[1], 1.0f});
    s.light(ecs::LightType::Directional, {0, 10, 0}, 0.0f, {0, -1, 0}, alpha);
    SceneRenderer r(dev());
    std::string error;
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    const ShadowStrip strip = readShadow(r);
    ASSERT_EQ(strip.layers, 1u);
    const RefCamera cam(s.world, s.camera, kW, kH);
    // For a straight edge under a disc of directions of angular radius a, the visible fraction at
    // signed offset u from the edge's shadow line is the disc cut at u / (h tan a): the 10 %..90 %
    // width is 2 * 0.6870 * h tan a (0.6870 = the cut offset leaving 90 % of a unit disc). For a
    // thick slab the 10 % point lies under it (set by the bottom edge, h - 0.25) and the 90 % point
    // outside (set by the top edge, h + 0.25): 0.687 tan a (h - 0.25 + h + 0.25), the same width.
    double width[2] = {0, 0};
    for (int k = 0; k < 2; ++k) {
        const float zc = k == 0 ? -1.0f : 1.0f;
        double sum = 0;
        int rows = 0;
        for (uint32_t y = 0; y < kH; ++y) {
            const glm::dvec3 d = cam.dir(kW / 2, y);
            const double z = cam.eye.z + d.z * (-cam.eye.y / d.y);
            if (std::abs(z - zc) > 0.4) continue;  // rows well inside the slab's extent in z
            const double x10 = crossing(strip, cam, y, 0, 0.1f), x90 = crossing(strip, cam, y, 0, 0.9f);
            if (std::isnan(x10) || std::isnan(x90)) continue;
            sum += x90 - x10;
            ++rows;
        }
        ASSERT_GE(rows, 10) << "slab " << k << ": rows with a measured penumbra";
        width[k] = sum / rows;
        const double predicted = 2.0 * 0.6870 * heights[k] * std::tan(alpha);
        std::printf(
            "  edge at height %.2f: 10-90 %% penumbra width %.4f (%d rows), predicted 2*0.687*h*tan(a) = "
            "%.4f (%+.1f %%)\n",
            heights[k], width[k], rows, predicted, 100.0 * (width[k] / predicted - 1.0));
        // Criterion: within 15 % of the prediction (one pixel is ~0.034 here, 6-20 % of the widths;
        // the crossings are interpolated between pixel centres).
        EXPECT_NEAR(width[k], predicted, 0.15 * predicted) << "height " << heights[k];
    }
    // Criterion: the width doubles with the height (ratio 2 within 10 %).
    std::printf("  width ratio %.3f (heights ratio 2)\n", width[1] / width[0]);
    EXPECT_NEAR(width[1] / width[0], 2.0, 0.2);
}

// ---- 4. many lights, layers, castShadows ------------------------------------------------------------------

TEST_P(SdfShadow, NineShadowedLightsEachGetTheirOwnLayer) {
    const glm::vec3 occluder(0.0f, 1.5f, 0.0f);
    ShadowScene s({0.0f, 6.0f, 0.0f}, {0.0f, 0.0f, 0.0f});
    s.object(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0});
    s.object(ShapeNode::sphere(0.5), occluder);
    // Nine point lights on a ring (hard shadows pointing nine ways), and one unshadowed light
    // created in the middle of them (lights take layers in entity order, skipping it).
    std::vector<glm::vec3> shadowed;
    for (int i = 0; i < 9; ++i) {
        const float a = float(2.0 * kPi * i / 9.0);
        shadowed.push_back({2.0f * std::cos(a), 4.0f, 2.0f * std::sin(a)});
        s.light(ecs::LightType::Point, shadowed.back(), 0.0f);
        if (i == 4) s.light(ecs::LightType::Point, {0.0f, 5.0f, 0.0f}, 0.0f, {0, -1, 0}, 0.0f, false);
    }
    SceneRenderer r(dev());
    std::string error;
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    const ShadowStrip strip = readShadow(r);
    // Criterion: one layer per shadowed light, none for the unshadowed one (9, not 10).
    EXPECT_EQ(strip.layers, 9u);
    if (strip.layers != 9u) return;
    const std::vector<float> depth = readDepth(r);
    for (uint32_t k = 0; k < 9; ++k) {
        const HardResult res = compareHard(strip, k, s, depth, shadowed[k], occluder, 0.5);
        uint32_t shadowedPixels = 0;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) shadowedPixels += strip.at(k, x, y) < 0.5f;
        std::printf(
            "  layer %u: %u px in shadow, %u of %u px off the edge disagree with light %u's exact test\n", k,
            shadowedPixels, res.mismatches, res.clearPixels, k);
        // Criterion: layer k is light k's shadow: 0 disagreements off the edge, and a shadow exists.
        EXPECT_EQ(res.mismatches, 0u) << "layer " << k;
        EXPECT_GT(shadowedPixels, 50u) << "layer " << k;
    }
}

TEST_P(SdfShadow, UnshadowedLightsAndObjectsCostNothing) {
    ShadowScene s({0.0f, 6.0f, 0.0f}, {0.0f, 0.0f, 0.0f});
    s.object(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0});
    s.object(ShapeNode::sphere(0.5), {0.0f, 1.5f, 0.0f}, false);  // casts no shadow
    const ecs::Entity light = s.light(ecs::LightType::Sphere, {-1.0f, 4.0f, 0.0f}, 0.3f);
    SceneRenderer r(dev());
    std::string error;
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    ASSERT_TRUE(hasPass(r, "sdf_shadow"));
    const ShadowStrip strip = readShadow(r);
    ASSERT_EQ(strip.layers, 1u);
    const std::vector<float> depth = readDepth(r);
    const RefCamera cam(s.world, s.camera, kW, kH);
    uint32_t dark = 0, plane = 0;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            glm::dvec3 p;
            if (!planePoint(cam, depth, x, y, p)) continue;
            ++plane;
            dark += strip.at(0, x, y) < 1.0f;
        }
    std::printf("  occluder with castShadows false: %u of %u plane px below full visibility\n", dark, plane);
    // Criterion: the plane faces the light everywhere and nothing else casts: all 1 on the plane
    // (the sphere's own far side is lit by nothing, shadow or not).
    EXPECT_EQ(dark, 0u);
    // Criterion: no light casts shadows -> no sdf_shadow pass.
    s.world.get<ecs::Light>(light)->castShadows = false;
    ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
    EXPECT_FALSE(hasPass(r, "sdf_shadow"));
}

// ---- 5. golden and parity ---------------------------------------------------------------------------------

// A lit scene: plane, sphere, box and torus under a soft sun and a sphere light (Cook-Torrance,
// ACES), shadows at full resolution (the golden does not depend on effects_upsample).
ImageRGBA8 renderLitScene(rhi::Device& dev, std::string& error) {
    ShadowScene s({0.0f, 3.0f, 5.0f}, {0.0f, 0.5f, 0.0f}, {0, 1, 0});
    s.object(ShapeNode::plane({0, 1, 0}, 0.0), {0, 0, 0});
    s.object(ShapeNode::sphere(0.6), {-1.2f, 0.6f, 0.0f});
    s.object(ShapeNode::box({0.4, 0.6, 0.4}), {0.4f, 0.6f, -0.6f});
    s.object(ShapeNode::torus(0.45, 0.15), {1.4f, 0.9f, 0.6f});
    const ecs::Entity sun = s.light(ecs::LightType::Directional, {0, 10, 0}, 0.0f,
                                    glm::normalize(glm::vec3(0.5f, -1.0f, -0.4f)), 0.05f);
    const ecs::Entity bulb = s.light(ecs::LightType::Sphere, {-2.0f, 2.5f, 1.5f}, 0.4f);
    s.world.get<ecs::Light>(sun)->intensity = 1.0f;
    s.world.get<ecs::Light>(bulb)->intensity = 6.0f;
    SceneRenderer r(dev);
    FrameDesc d = s.frame();
    ImageRGBA8 image;
    if (!s.render(r, d, error) || !r.readPixels(image, error)) return {};
    if (!hasPass(r, "sdf_shadow")) error = "no sdf_shadow pass";
    return image;
}

TEST_P(SdfShadow, LitSceneMatchesGolden) {
    std::string error;
    const ImageRGBA8 image = renderLitScene(dev(), error);
    ASSERT_TRUE(error.empty()) << error;
    const std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
    // Criterion: the golden rule of support/golden.h (design.md "Golden images and parity").
    const std::string failure = checkGolden(backend, "sdf_shadow_lit", image);
    EXPECT_TRUE(failure.empty()) << failure;
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfShadow, testing::ValuesIn(gpuBackends()), backendName);

TEST(SdfShadowParity, VulkanMatchesOpenGL) {
    BackendPair pair;
    ASSERT_TRUE(pair.ready());
    auto& vk = pair.vk;
    auto& gl = pair.gl;
    std::string errorVk, errorGl;
    const ImageRGBA8 a = renderLitScene(*vk, errorVk);
    const ImageRGBA8 b = renderLitScene(*gl, errorGl);
    vk->waitIdle();
    gl->waitIdle();
    ASSERT_TRUE(errorVk.empty()) << errorVk;
    ASSERT_TRUE(errorGl.empty()) << errorGl;
    pair.expectNoErrors();
    const ImageDiff d = compareImages(a, b);
    std::printf("  Vulkan vs OpenGL, sdf_shadow_lit (%ux%u): %s\n", kW, kH, d.summary().c_str());
    if (!d.pass) {
        const std::string dir = goldenOutDir("parity");
        std::filesystem::create_directories(dir);
        writePng(dir + "/sdf_shadow_lit.vulkan.png", a);
        writePng(dir + "/sdf_shadow_lit.gl.png", b);
        writePng(dir + "/sdf_shadow_lit.diff.png", d.diffImage);
    }
    // Criterion: the parity rule of support/golden.h.
    EXPECT_TRUE(d.pass) << d.summary();
}

}  // namespace
}  // namespace penumbra::test
