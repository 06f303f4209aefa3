// Acceptance tests of the subsurface thickness and reflection effects (issue 12 items 4 and 5;
// renderer/features/sdf_thickness.h, renderer/features/sdf_reflection.h) on both backends under
// validation:
//   1. thickness: a sphere of radius r seen head-on measures 2 r on its whole disc (along -n from
//      any point of a sphere the ray crosses the centre), a slab of width w seen along its normal
//      measures w; materials without subsurface get 0; no subsurface material -> no pass;
//   2. reflection: a mirror floor under a lit sphere shows the sphere where the analytic mirror image
//      predicts, with the radiance the lighting's BRDF gives at the reflected hit (CPU, exact ray
//      casts); elsewhere the background; a material above the roughness cut-off gets weight 0; no
//      reflective material -> no pass; reflected hits are shadowed (a plate out of view hides the
//      light from the sphere: its reflection shows only the ambient) and lit with shadows off;
//   3. translucency in the lit image: two back-lit slabs, the thinner transmits more, by
//      exp(-(w1 - w2) / radius);
//   4. a golden image per backend of a small scene with both effects, and Vulkan-vs-OpenGL parity.
// Every criterion is asserted with its metric and threshold next to it; measured numbers are printed.
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
#include <glm/gtc/packing.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"
#include "engine/image/image.h"
#include "engine/scene/scene.h"
#include "engine/sdf/shape_program.h"
#include "renderer/features/lighting_reference.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/ref_camera.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using render::FrameDesc;
using render::SceneRenderer;
using sdf::ShapeNode;

constexpr float kFovY = 1.0471976f;  // 60 degrees

// Rotation whose local -Z points along `dir` (cameras and directional lights).
glm::quat lookRotation(glm::vec3 dir) {
    glm::vec3 up(0, 1, 0);
    if (std::abs(glm::dot(glm::normalize(dir), up)) > 0.999f) up = {0, 0, 1};
    return glm::quat_cast(glm::inverse(glm::lookAtRH(glm::vec3(0), dir, up)));
}

struct Scene {
    ecs::World world;
    assets::AssetManager assets;
    ecs::Entity camera;
    int materials = 0;

    Scene(glm::vec3 eye, glm::vec3 target) {
        camera = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(camera);
        t->position = eye;
        t->rotation = lookRotation(target - eye);
        ecs::Camera c;
        c.fovY = kFovY;
        c.nearPlane = 0.1f;
        c.farPlane = 100.0f;
        world.add<ecs::Camera>(camera, c);
    }
    assets::AssetId material(const ecs::Material& m) {
        return assets.addMaterial("material" + std::to_string(materials++), m);
    }
    ecs::Entity object(const ShapeNode& root, glm::vec3 position, assets::AssetId material) {
        sdf::ShapeProgram p;
        std::string error;
        EXPECT_TRUE(sdf::compileShapeProgram(root, p, error)) << error;
        const std::string key = assets::AssetManager::shapeProgramKey(p);
        const assets::AssetId program = assets.addShapeProgram(key, std::move(p), error);
        EXPECT_NE(program, 0u) << error;
        ecs::Entity e = world.create();
        world.add<ecs::Transform>(e)->position = position;
        ecs::SdfRenderer sr;
        sr.sdf = program;
        sr.source = ecs::SdfSource::Shapes;
        sr.material = material;
        world.add<ecs::SdfRenderer>(e, sr);
        return e;
    }
    void directionalLight(glm::vec3 travel, glm::vec3 color, float intensity) {
        ecs::Entity e = world.create();
        world.add<ecs::Transform>(e)->rotation = lookRotation(travel);
        ecs::Light l;
        l.type = ecs::LightType::Directional;
        l.color = color;
        l.intensity = intensity;
        world.add<ecs::Light>(e, l);
    }
    FrameDesc frame(uint32_t w, uint32_t h) const {
        FrameDesc d;
        d.width = w;
        d.height = h;
        d.camera = camera;
        d.aux = true;
        d.settings.quality = scene::TraceQuality::High;
        return d;
    }
    void render(SceneRenderer& r, const FrameDesc& d) {
        ecs::updateTransforms(world);
        std::string error;
        ASSERT_TRUE(r.render(world, assets, d, error)) << error;
    }
};

ecs::Material subsurfaceMaterial(glm::vec3 base, float radius) {
    ecs::Material m;
    m.baseColor = glm::vec4(base, 1.0f);
    m.roughness = 1.0f;
    m.subsurface = 1.0f;
    m.subsurfaceColor = glm::vec3(1.0f);
    m.subsurfaceRadius = radius;
    return m;
}

ecs::Material plainMaterial(glm::vec3 base, float roughness = 0.8f) {
    ecs::Material m;
    m.baseColor = glm::vec4(base, 1.0f);
    m.roughness = roughness;
    return m;
}

// ---- readback -------------------------------------------------------------------------------------

std::vector<uint8_t> readRaw(SceneRenderer& r, const std::string& name, rhi::Format expected) {
    std::vector<uint8_t> texels;
    rhi::Format format{};
    std::string error;
    EXPECT_TRUE(r.readTarget(name, texels, format, error)) << name << ": " << error;
    EXPECT_EQ(format, expected) << name;
    return texels;
}

// Half-float target with `channels` channels, as floats.
std::vector<float> readHalf(SceneRenderer& r, const std::string& name, rhi::Format format, int channels) {
    const std::vector<uint8_t> texels = readRaw(r, name, format);
    std::vector<float> out(texels.size() / 2);
    for (size_t i = 0; i < out.size(); ++i) {
        uint16_t h;
        std::memcpy(&h, &texels[i * 2], 2);
        out[i] = glm::unpackHalf1x16(h);
    }
    EXPECT_EQ(out.size() % size_t(channels), 0u);
    return out;
}

// gbuffer.aux x: the entity index of each pixel (-1: background).
std::vector<int> readEntities(SceneRenderer& r) {
    const std::vector<uint8_t> a = readRaw(r, "gbuffer.aux", rhi::Format::RG32_FLOAT);
    std::vector<int> ids(a.size() / 8);
    for (size_t i = 0; i < ids.size(); ++i) {
        float x;
        std::memcpy(&x, &a[i * 8], 4);
        ids[i] = int(std::lround(x));
    }
    return ids;
}

std::vector<glm::vec2> readNormalsOct(SceneRenderer& r) {
    const std::vector<float> f = readHalf(r, "gbuffer.normal", rhi::Format::RG16_FLOAT, 2);
    std::vector<glm::vec2> out(f.size() / 2);
    for (size_t i = 0; i < out.size(); ++i) out[i] = {f[2 * i], f[2 * i + 1]};
    return out;
}

bool hasPass(const SceneRenderer& r, const std::string& name) {
    for (const auto& p : r.lastFrameStats().passes)
        if (p.name == name) return true;
    return false;
}

double srgbDecode(uint8_t v) {
    const double e = v / 255.0;
    return e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
}

// Relative-error statistics of one region.
struct Errors {
    size_t count = 0, within = 0;
    double sum = 0, max = 0;
    void add(double measured, double expected, double tolerance) {
        const double e = std::abs(measured - expected) / expected;
        ++count;
        within += e <= tolerance;
        sum += e;
        max = std::max(max, e);
    }
    double mean() const { return count ? sum / double(count) : 0.0; }
    double fraction() const { return count ? double(within) / double(count) : 0.0; }
};

class SdfThicknessReflection : public GpuTest {};

// ---- 1. thickness ------------------------------------------------------------------------------------

TEST_P(SdfThicknessReflection, ThicknessOfSphereAndSlab) {
    constexpr uint32_t w = 160, h = 120;
    constexpr float kRadius = 0.5f, kSlab = 0.3f;
    Scene s({0, 0, 0}, {0, 0, -1});
    const assets::AssetId sss = s.material(subsurfaceMaterial({0.8f, 0.7f, 0.6f}, 0.5f));  // cap 8 * 0.5 = 4
    const ecs::Entity sphere = s.object(ShapeNode::sphere(kRadius), {-0.8f, -0.2f, -4.0f}, sss);
    const ecs::Entity slab = s.object(ShapeNode::box({0.45, 0.45, kSlab / 2}), {0.8f, -0.2f, -4.0f}, sss);
    const ecs::Entity plain =
        s.object(ShapeNode::sphere(0.3), {0.0f, 0.8f, -4.0f}, s.material(plainMaterial({0.5f, 0.5f, 0.5f})));
    s.directionalLight({0, -1, -1}, {1, 1, 1}, 2.0f);
    SceneRenderer r(dev());
    s.render(r, s.frame(w, h));
    EXPECT_TRUE(hasPass(r, "sdf_thickness")) << "a subsurface material is in the frame";
    const std::vector<float> thick = readHalf(r, "effects.thickness", rhi::Format::R16_FLOAT, 1);
    const std::vector<int> ids = readEntities(r);
    const std::vector<glm::vec2> oct = readNormalsOct(r);
    ASSERT_EQ(thick.size(), size_t(w) * h);
    Errors sphereErr, slabErr;
    size_t plainPx = 0, plainNonZero = 0, backgroundNonZero = 0;
    for (size_t i = 0; i < thick.size(); ++i) {
        if (ids[i] == int(sphere.index)) {
            sphereErr.add(thick[i], 2.0 * kRadius, 0.01);
        } else if (ids[i] == int(slab.index)) {
            // The face seen along its normal (oct-encoded +Z is (x, y) with |x| + |y| small).
            if (std::abs(oct[i].x) + std::abs(oct[i].y) < 0.01f) slabErr.add(thick[i], kSlab, 0.01);
        } else if (ids[i] == int(plain.index)) {
            ++plainPx;
            plainNonZero += thick[i] != 0.0f;
        } else {
            backgroundNonZero += thick[i] != 0.0f;
        }
    }
    std::printf("  sphere r %.2f: %zu px, |rel err| of 2r mean %.5f, max %.5f, within 1 %%: %.4f\n", kRadius,
                sphereErr.count, sphereErr.mean(), sphereErr.max, sphereErr.fraction());
    std::printf("  slab w %.2f: %zu face px, |rel err| mean %.5f, max %.5f, within 1 %%: %.4f\n", kSlab,
                slabErr.count, slabErr.mean(), slabErr.max, slabErr.fraction());
    std::printf("  no-subsurface sphere: %zu px, %zu non-zero; background non-zero %zu\n", plainPx,
                plainNonZero, backgroundNonZero);
    ASSERT_GT(sphereErr.count, 300u);
    ASSERT_GT(slabErr.count, 300u);
    EXPECT_GE(sphereErr.fraction(), 0.99) << "sphere: thickness within 1 % of 2r on >= 99 % of its pixels";
    EXPECT_LE(sphereErr.mean(), 0.003) << "sphere: mean |rel err| <= 0.3 %";
    EXPECT_LE(sphereErr.max, 0.05) << "sphere: max |rel err| <= 5 % (silhouette pixels included)";
    EXPECT_GE(slabErr.fraction(), 0.99) << "slab: thickness within 1 % of w on >= 99 % of face pixels";
    EXPECT_LE(slabErr.mean(), 0.003) << "slab: mean |rel err| <= 0.3 %";
    EXPECT_GT(plainPx, 50u);
    EXPECT_EQ(plainNonZero, 0u) << "materials without subsurface: thickness exactly 0";
    EXPECT_EQ(backgroundNonZero, 0u) << "background: thickness exactly 0";

    // No subsurface material in the frame: no pass, no target.
    Scene none({0, 0, 0}, {0, 0, -1});
    none.object(ShapeNode::sphere(kRadius), {0, 0, -4}, none.material(plainMaterial({0.5f, 0.5f, 0.5f})));
    SceneRenderer r2(dev());
    none.render(r2, none.frame(w, h));
    EXPECT_FALSE(hasPass(r2, "sdf_thickness")) << "no subsurface material -> no thickness pass";
    EXPECT_FALSE(hasPass(r2, "sdf_reflection")) << "no reflective material -> no reflection pass";
}

// ---- 2. reflection -----------------------------------------------------------------------------------

// The floor's mirror: y = 0 top of two floor boxes, left x < 0 a mirror (roughness 0, metallic 1,
// white), right x > 0 reflective but above the cut-off. A lit red sphere stands over the mirror.
struct MirrorScene {
    Scene s{{0.0f, 1.2f, 0.0f}, {0.0f, 0.2f, -4.0f}};
    ecs::Entity mirror, rough, sphere;
    static inline const glm::vec3 kCentre{-0.7f, 0.8f, -4.0f};
    static constexpr float kRadius = 0.45f;
    static inline const glm::vec3 kBackground{0.1f, 0.2f, 0.4f};
    static inline const glm::vec3 kLightTravel{0.0f, -0.3f, -1.0f};
    glm::vec3 lightTravel = kLightTravel;

    // blocker: the light comes from above the camera instead, and a plate out of view above the
    // sphere casts its shadow over the whole sphere.
    explicit MirrorScene(bool reflective, bool blocker = false) {
        ecs::Material m = plainMaterial({1, 1, 1}, 0.0f);
        m.metallic = 1.0f;
        m.reflections = reflective;
        ecs::Material rm = plainMaterial({0.6f, 0.6f, 0.6f}, 0.7f);
        rm.reflections = reflective;  // 0.7 > the cut-off 0.5
        mirror = s.object(ShapeNode::box({2.0, 0.1, 6.0}), {-2.0f, -0.1f, -5.0f}, s.material(m));
        rough = s.object(ShapeNode::box({2.0, 0.1, 6.0}), {2.0f, -0.1f, -5.0f}, s.material(rm));
        sphere = s.object(ShapeNode::sphere(kRadius), kCentre, s.material(plainMaterial({0.9f, 0.1f, 0.1f})));
        if (blocker) {
            lightTravel = {0.0f, -1.0f, -1.0f};
            s.object(ShapeNode::box({0.8, 0.05, 1.0}), {-0.7f, 2.3f, -2.5f},
                     s.material(plainMaterial({0.5f, 0.5f, 0.5f})));
        }
        s.directionalLight(lightTravel, {1, 1, 1}, 3.0f);
    }
    FrameDesc frame(uint32_t w, uint32_t h, scene::TraceQuality q) const {
        FrameDesc d = s.frame(w, h);
        d.settings.background = kBackground;
        d.settings.ambient = glm::vec3(0.05f);
        d.settings.quality = q;
        return d;
    }
};

// Exact radiance the reflection pass should see along pixel (x, y) of the mirror: the camera ray
// meets y = 0, mirrors, and hits the sphere (analytic) or not (background). Returns false when the
// camera ray does not reach the mirror floor.
bool expectedReflection(const RefCamera& cam, uint32_t x, uint32_t y, glm::dvec3& radiance, bool& hitSphere,
                        glm::vec3 lightTravel = MirrorScene::kLightTravel, float visibility = 1.0f) {
    const glm::dvec3 d = glm::normalize(cam.dir(x, y));
    if (d.y >= 0.0) return false;
    const double t = -cam.eye.y / d.y;
    const glm::dvec3 q = cam.eye + d * t;
    if (q.x > 0.0 || q.x < -4.0 || q.z < -11.0 || q.z > 1.0) return false;
    const glm::dvec3 r(d.x, -d.y, d.z), c(MirrorScene::kCentre);
    const glm::dvec3 oc = q - c;
    const double b = glm::dot(oc, r),
                 disc = b * b - (glm::dot(oc, oc) - MirrorScene::kRadius * MirrorScene::kRadius);
    hitSphere = disc > 0.0 && -b - std::sqrt(disc) > 0.0;
    if (!hitSphere) {
        radiance = glm::dvec3(MirrorScene::kBackground);
        return true;
    }
    const glm::dvec3 p = q + r * (-b - std::sqrt(disc)), n = glm::normalize(p - c);
    const glm::vec3 base(0.9f, 0.1f, 0.1f);
    // Ambient (sky = ground = 0.05) * base + the directional light by the lighting's BRDF.
    const glm::vec3 l = -glm::normalize(lightTravel);
    const glm::vec3 lit = render::reference::shadeLight(scene::ShadingModel::CookTorrance, glm::vec3(n),
                                                        glm::vec3(-r), l, glm::vec3(3.0f), base, 0.0f, 0.8f);
    radiance = glm::dvec3(0.05f * base + visibility * lit);
    return true;
}

TEST_P(SdfThicknessReflection, MirrorFloorReflectsTheSphereWhereTheMirrorImageIs) {
    constexpr uint32_t w = 160, h = 120;
    MirrorScene m(true);
    SceneRenderer r(dev());
    // Reference quality (hit epsilon 0.01 px): at the presets' coarser epsilons the reflected hit
    // lies up to hitEpsilon footprints off the surface, which shows where the shading changes fast.
    m.s.render(r, m.frame(w, h, scene::TraceQuality::Reference));
    ASSERT_TRUE(hasPass(r, "sdf_reflection")) << "a reflective material below the cut-off is in the frame";
    const std::vector<float> refl = readHalf(r, "effects.reflection", rhi::Format::RGBA16_FLOAT, 4);
    const std::vector<int> ids = readEntities(r);
    ASSERT_EQ(refl.size(), size_t(w) * h * 4);
    ecs::updateTransforms(m.s.world);
    const RefCamera cam(m.s.world, m.s.camera, w, h);

    // The mirror image of the sphere's centre, (x, -y, z), projects to this pixel: red there.
    const glm::dvec2 image =
        cam.project(glm::dvec3(MirrorScene::kCentre.x, -MirrorScene::kCentre.y, MirrorScene::kCentre.z));
    const size_t centre = size_t(image.y) * w + size_t(image.x);
    std::printf(
        "  mirror image of the sphere centre at px (%.1f, %.1f): reflection (%.4f, %.4f, %.4f) a %.3f\n",
        image.x, image.y, refl[centre * 4], refl[centre * 4 + 1], refl[centre * 4 + 2], refl[centre * 4 + 3]);
    EXPECT_EQ(ids[centre], int(m.mirror.index)) << "the predicted pixel lies on the mirror";
    EXPECT_GT(refl[centre * 4], 4.0f * refl[centre * 4 + 2]) << "red sphere reflected there: r > 4 b";

    // Every mirror pixel whose exact reflected ray is decided (not within 2 px-widths of the sphere's
    // silhouette) against the exact radiance at its centre (white metal: Fresnel 1, fade 1 at
    // roughness 0), compared by luminance.
    Errors sphereErr, missErr;
    size_t roughPx = 0, roughNonZero = 0, othersNonZero = 0;
    double maxWeightErr = 0;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const size_t i = size_t(y) * w + x;
            const glm::vec4 v(refl[4 * i], refl[4 * i + 1], refl[4 * i + 2], refl[4 * i + 3]);
            if (ids[i] == int(m.rough.index)) {
                ++roughPx;
                roughNonZero += v != glm::vec4(0.0f);
                continue;
            }
            if (ids[i] != int(m.mirror.index)) {
                othersNonZero += v != glm::vec4(0.0f);
                continue;
            }
            glm::dvec3 expected, e2;
            bool hit, h2 = false, h3 = false;
            if (!expectedReflection(cam, x, y, expected, hit)) continue;
            // Skip pixels next to the silhouette of the reflected sphere (a neighbour disagrees).
            if ((x + 2 < w && expectedReflection(cam, x + 2, y, e2, h2) && h2 != hit) ||
                (y + 2 < h && expectedReflection(cam, x, y + 2, e2, h3) && h3 != hit) ||
                (x >= 2 && expectedReflection(cam, x - 2, y, e2, h2) && h2 != hit) ||
                (y >= 2 && expectedReflection(cam, x, y - 2, e2, h3) && h3 != hit))
                continue;
            Errors& e = hit ? sphereErr : missErr;
            const double lum = glm::dot(glm::dvec3(v), glm::dvec3(1.0 / 3.0)),
                         lumExpected = glm::dot(expected, glm::dvec3(1.0 / 3.0));
            e.add(lum, lumExpected, 0.03);
            maxWeightErr = std::max(maxWeightErr, std::abs(double(v.a) - 1.0));
        }
    std::printf(
        "  mirror px seeing the sphere: %zu, |rel err| of radiance mean %.5f, max %.5f, within 3 %%: %.4f\n",
        sphereErr.count, sphereErr.mean(), sphereErr.max, sphereErr.fraction());
    std::printf("  mirror px seeing the background: %zu, |rel err| mean %.5f, max %.5f, within 3 %%: %.4f\n",
                missErr.count, missErr.mean(), missErr.max, missErr.fraction());
    std::printf("  mirror weight: max |a - 1| %.5f\n", maxWeightErr);
    std::printf("  rough (0.7 > cut-off 0.5) px: %zu, non-zero %zu; other px non-zero %zu\n", roughPx,
                roughNonZero, othersNonZero);
    ASSERT_GT(sphereErr.count, 100u) << "the reflected sphere covers a good part of the mirror";
    ASSERT_GT(missErr.count, 1000u);
    EXPECT_GE(sphereErr.fraction(), 0.98) << "reflected sphere: radiance within 3 % on >= 98 % of pixels";
    EXPECT_LE(sphereErr.mean(), 0.01) << "reflected sphere: mean |rel err| <= 1 %";
    EXPECT_GE(missErr.fraction(), 0.999) << "background: within 3 % on >= 99.9 % of pixels";
    EXPECT_LE(maxWeightErr, 1e-3) << "mirror (roughness 0): weight a = 1 (half-float rounding)";
    EXPECT_GT(roughPx, 1000u);
    EXPECT_EQ(roughNonZero, 0u) << "above the roughness cut-off: reflection (0, 0, 0, 0)";
    EXPECT_EQ(othersNonZero, 0u) << "non-reflective materials and background: reflection 0";

    // No reflective material (the same floor without `reflections`): no pass.
    MirrorScene plain(false);
    SceneRenderer r2(dev());
    plain.s.render(r2, plain.frame(w, h, scene::TraceQuality::High));
    EXPECT_FALSE(hasPass(r2, "sdf_reflection")) << "no reflective material -> no reflection pass";
}

// Luminance errors of the mirror pixels that see the sphere (and whose +-2 px neighbours agree)
// against the exact radiance with the light's visibility at the hit.
Errors reflectedSphereErrors(const std::vector<float>& refl, const std::vector<int>& ids,
                             const MirrorScene& m, const RefCamera& cam, float visibility) {
    Errors e;
    for (uint32_t y = 2; y + 2 < cam.h; ++y)
        for (uint32_t x = 2; x + 2 < cam.w; ++x) {
            const size_t i = size_t(y) * cam.w + x;
            glm::dvec3 expected, other;
            bool hit = false, h2 = false;
            if (ids[i] != int(m.mirror.index) ||
                !expectedReflection(cam, x, y, expected, hit, m.lightTravel, visibility) || !hit)
                continue;
            bool edge = false;
            for (glm::ivec2 o : {glm::ivec2(2, 0), glm::ivec2(-2, 0), glm::ivec2(0, 2), glm::ivec2(0, -2)})
                edge = edge || !expectedReflection(cam, x + o.x, y + o.y, other, h2) || !h2;
            if (edge) continue;
            const double lum = (refl[4 * i] + refl[4 * i + 1] + refl[4 * i + 2]) / 3.0;
            e.add(lum, (expected.r + expected.g + expected.b) / 3.0, 0.03);
        }
    return e;
}

TEST_P(SdfThicknessReflection, ReflectedHitsAreShadowed) {
    constexpr uint32_t w = 160, h = 120;
    MirrorScene m(true, true);
    ecs::updateTransforms(m.s.world);
    const RefCamera cam(m.s.world, m.s.camera, w, h);
    for (int shadows = 0; shadows < 2; ++shadows) {
        FrameDesc d = m.frame(w, h, scene::TraceQuality::Reference);
        d.settings.shadows.enabled = shadows == 1;
        SceneRenderer r(dev());
        m.s.render(r, d);
        const std::vector<float> refl = readHalf(r, "effects.reflection", rhi::Format::RGBA16_FLOAT, 4);
        const std::vector<int> ids = readEntities(r);
        // Shadows on: the plate hides the light from the whole sphere (visibility 0 at every hit).
        const Errors e = reflectedSphereErrors(refl, ids, m, cam, shadows == 1 ? 0.0f : 1.0f);
        std::printf(
            "  shadows %s: %zu reflected-sphere px vs exact (visibility %d): |rel err| mean %.5f, max %.5f, "
            "within 3 %%: %.4f\n",
            shadows ? "on" : "off", e.count, shadows ? 0 : 1, e.mean(), e.max, e.fraction());
        ASSERT_GT(e.count, 100u);
        EXPECT_GE(e.fraction(), 0.98) << "radiance within 3 % of exact on >= 98 % of reflected-sphere pixels";
        EXPECT_LE(e.mean(), 0.01) << "mean |rel err| <= 1 %";
    }
}

// ---- 3. translucency in the lit image ----------------------------------------------------------------

TEST_P(SdfThicknessReflection, BackLitThinSlabTransmitsMoreByTheExpRatio) {
    constexpr uint32_t w = 160, h = 120;
    constexpr float kThin = 0.1f, kThick = 0.3f, kSssRadius = 0.2f, kIntensity = 2.0f;
    Scene s({0, 0, 0}, {0, 0, -1});
    // Black base colour, no ambient: the back-lit front faces show only the translucency term.
    const assets::AssetId sss = s.material(subsurfaceMaterial({0, 0, 0}, kSssRadius));
    const ecs::Entity thin = s.object(ShapeNode::box({0.5, 0.6, kThin / 2}), {-0.65f, 0, -4}, sss);
    const ecs::Entity thick = s.object(ShapeNode::box({0.5, 0.6, kThick / 2}), {0.65f, 0, -4}, sss);
    s.directionalLight({0, 0, 1}, {1, 1, 1}, kIntensity);  // from behind the slabs towards the camera
    FrameDesc d = s.frame(w, h);
    d.settings.ambient = glm::vec3(0.0f);
    d.settings.toneMapper = scene::ToneMapper::Clamp;
    SceneRenderer r(dev());
    s.render(r, d);
    ImageRGBA8 image;
    std::string error;
    ASSERT_TRUE(r.readPixels(image, error)) << error;
    const std::vector<int> ids = readEntities(r);
    const std::vector<glm::vec2> oct = readNormalsOct(r);
    ecs::updateTransforms(s.world);
    const RefCamera cam(s.world, s.camera, w, h);
    // Translucency (deferred_lighting.frag): colour * exp(-t / radius) * max(v . -(l + 0.2 n), 0)^4 * I
    // with l = (0, 0, -1), n = (0, 0, 1): divide out the view term per pixel.
    double sum[2] = {0, 0};
    size_t count[2] = {0, 0};
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const size_t i = size_t(y) * w + x;
            const int k = ids[i] == int(thin.index) ? 0 : ids[i] == int(thick.index) ? 1 : -1;
            if (k < 0 || std::abs(oct[i].x) + std::abs(oct[i].y) > 0.01f) continue;
            const glm::dvec3 v = -glm::normalize(cam.dir(x, y));
            const double facing = std::pow(std::max(glm::dot(v, glm::dvec3(0, 0, 0.8)), 0.0), 4.0);
            sum[k] += srgbDecode(image.pixels[4 * i + 1]) / (facing * kIntensity);
            ++count[k];
        }
    ASSERT_GT(count[0], 300u);
    ASSERT_GT(count[1], 300u);
    const double tThin = sum[0] / double(count[0]), tThick = sum[1] / double(count[1]);
    const double ratio = tThick / tThin, expected = std::exp(-(kThick - kThin) / kSssRadius);
    std::printf("  transmitted: thin %.4f (exp %.4f), thick %.4f (exp %.4f); ratio %.4f vs exp(-dw/R) %.4f\n",
                tThin, std::exp(-kThin / kSssRadius), tThick, std::exp(-kThick / kSssRadius), ratio,
                expected);
    EXPECT_GT(tThin, tThick) << "the thinner slab transmits more";
    EXPECT_NEAR(ratio, expected, 0.02 * expected)
        << "ratio thick / thin within 2 % of exp(-(w2 - w1) / radius)";
    EXPECT_NEAR(tThin, std::exp(-kThin / kSssRadius), 0.02)
        << "thin slab's transmission within 0.02 of exp(-w/R)";
    EXPECT_NEAR(tThick, std::exp(-kThick / kSssRadius), 0.02) << "thick slab's transmission within 0.02";
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfThicknessReflection, testing::ValuesIn(gpuBackends()), backendName);

// ---- 4. goldens and parity ---------------------------------------------------------------------------

// A mirror floor, a back-lit translucent sphere and slab, and a matte box.
bool renderGoldenScene(rhi::Device& device, ImageRGBA8& image, std::string& error) {
    Scene s({0.0f, 1.4f, 1.0f}, {0.0f, 0.4f, -4.0f});
    ecs::Material mirror = plainMaterial({0.9f, 0.9f, 0.95f}, 0.1f);
    mirror.metallic = 1.0f;
    mirror.reflections = true;
    s.object(ShapeNode::box({4.0, 0.1, 6.0}), {0, -0.1f, -5}, s.material(mirror));
    ecs::Material jade = subsurfaceMaterial({0.2f, 0.5f, 0.3f}, 0.3f);
    jade.subsurfaceColor = {0.4f, 1.0f, 0.6f};
    s.object(ShapeNode::sphere(0.6), {-0.9f, 0.6f, -4.5f}, s.material(jade));
    s.object(ShapeNode::box({0.4, 0.5, 0.05}), {0.2f, 0.5f, -4.2f}, s.material(jade));
    s.object(ShapeNode::box({0.35, 0.35, 0.35}), {1.3f, 0.35f, -4.0f},
             s.material(plainMaterial({0.8f, 0.5f, 0.1f})));
    s.directionalLight({0.2f, -0.4f, 1.0f}, {1.0f, 0.95f, 0.9f}, 3.0f);
    FrameDesc d = s.frame(160, 120);
    d.aux = false;
    d.settings.background = {0.15f, 0.2f, 0.3f};
    d.settings.ambient = glm::vec3(0.05f);
    ecs::updateTransforms(s.world);
    SceneRenderer r(device);
    return r.render(s.world, s.assets, d, error) && r.readPixels(image, error);
}

class SdfThicknessReflectionGolden : public GpuTest {};

TEST_P(SdfThicknessReflectionGolden, SceneMatchesGolden) {
    const std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
    ImageRGBA8 image;
    std::string error;
    ASSERT_TRUE(renderGoldenScene(dev(), image, error)) << error;
    // Golden rule of shared/design.md: |delta| <= 5/255 on all but 0.1 % of pixels, none over 64/255.
    const std::string failure = checkGolden(backend, "sdf_reflection_thickness_scene", image);
    EXPECT_TRUE(failure.empty()) << failure;
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfThicknessReflectionGolden, testing::ValuesIn(gpuBackends()),
                         backendName);

TEST(SdfThicknessReflectionParity, VulkanMatchesOpenGL) {
    BackendPair pair;
    ASSERT_TRUE(pair.ready());
    auto& vkDevice = pair.vk;
    auto& glDevice = pair.gl;
    ImageRGBA8 vk, gl;
    std::string error;
    ASSERT_TRUE(renderGoldenScene(*vkDevice, vk, error)) << error;
    ASSERT_TRUE(renderGoldenScene(*glDevice, gl, error)) << error;
    // The parity rule (shared/design.md): the golden rule between the two backends.
    const ImageDiff d = compareImages(vk, gl);
    std::printf("  Vulkan vs OpenGL: %s\n", d.summary().c_str());
    if (!d.pass) {
        const std::string dir = goldenOutDir("parity");
        std::filesystem::create_directories(dir);
        writePng(dir + "/sdf_reflection_thickness_scene.vulkan.png", vk);
        writePng(dir + "/sdf_reflection_thickness_scene.gl.png", gl);
        writePng(dir + "/sdf_reflection_thickness_scene.diff.png", d.diffImage);
    }
    EXPECT_TRUE(d.pass) << d.summary();
    pair.expectNoErrors();
}

}  // namespace
}  // namespace penumbra::test
