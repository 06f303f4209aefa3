// Hard cases of the SDF effects (issue 12, "Robustness: 0 lights, 200 lights (8 shadowed), a light
// inside an object, a zero-radius sphere light (= hard shadow), AO distance 0 and 1e6 -- a defined
// image or a clear error, never a crash or a hang"), both backends under validation (a validation
// error fails the case, as everywhere in tests/stability). 128 x 96 frames, one frame per setting.
//
// What "defined" is checked against: the lit image (RGBA8 output) is compared with the CPU lighting
// (renderer/features/lighting_reference.h shadeSurface + displayEncode) evaluated on the frame's own
// G-buffer with the GPU's own effect results (effects.shadow layer per shadowed light, effects.ao r),
// under the parity rule (tests/support/golden.h: per channel <= 5/255 for all but 0.1 % of pixels,
// none over 64/255); and no hit pixel may be darker than its ambient-only value (ambient * albedo *
// AO) minus 2/255: a NaN or inf anywhere in a light's term makes the pixel 0 (UNORM conversion) or
// wrong. Effect targets are UNORM (R8 shadow, RGBA8 AO), so [0, 1] holds by construction; a NaN is
// written as 0, so each case asserts exact values where the answer is known (visibility exactly 0,
// AO exactly 1) instead of a range. "The frame returns" is the hang criterion: every frame's wall
// time (render + readback) is printed and must stay under 60 s (a hang would not return at all; the
// case's CTest timeout is 600 s).
//
//   E1  0 lights, AO cones on: no sdf_shadow pass, effects.shadowLayers 0, sdf_ao ran; the image is the
//       CPU ambient * albedo * AO (parity rule), and identical to the same frame with shadows off.
//   E2  200 point lights, 8 with castShadows: 8 shadow layers, one sdf_shadow pass; parity with the
//       CPU lighting in which the 192 others have visibility 1; no pixel below ambient-only; and where
//       all 8 shadowed lights are fully visible (every layer 255) but the exact segment to at least one
//       unshadowed light passes through the sphere (by more than 2 pixel footprints), the pixel is
//       identical to the frame with shadows off (the unshadowed lights add their light unshadowed).
//   E3  lights inside an SDF sphere (a point light at its centre, a sphere light of radius 0.2 at its
//       centre) and on its surface (a point light and a sphere light of radius 0.1 centred on the
//       equator): the frame returns; the inside lights' visibility is exactly 0 on every hit pixel
//       within their range (every segment from outside to the centre crosses at least 0.4 units of
//       the sphere, or the surface faces away), so the frame with only the inside lights is
//       identical to the frame with no lights; the on-surface point light is 0 on every sphere pixel
//       (a chord to a point on the sphere runs inside it) and on every plane pixel within its range
//       more than 2 pixel footprints on the sphere's side of its tangent plane x = 0.6 (the segment
//       enters the sphere there); the lit image passes the parity rule with the GPU's visibilities
//       and nothing is below ambient-only. Reported, not asserted: the plane beyond the tangent
//       plane, which a point light exactly on a surface lights in reality, is dark too (the hard
//       ray converges on the surface the light sits on and stops there, sdf_cone.glsl
//       sdfConeVisibility: d < epsilon before t reaches tMax).
//   E4  a sphere light of radius 0 and a point light at the same place (resolutionScale 1): their
//       shadow layers are bitwise identical and binary (only 0 and 255), with > 200 shadowed
//       texels; at the default resolutionScale 0.5 (upsampled) still bitwise identical.
//   E5  AO maxDistance. _TinyAndHuge: the scene file refuses 0 with a message naming
//       /render/ao/maxDistance (1e-30 and 1e6 load); through the API, for each variant (five-tap,
//       multi-ray, cones) in a scene where maxDistance 1 occludes (min AO <= 0.8: a sphere 0.25
//       above a plane), maxDistance 1e-30 gives AO exactly 1 (255) on every texel (nothing within
//       1e-30 of any shaded point); 1e6 on an open plane with a sphere 10 units away outside the
//       view: the frame returns and AO >= 0.9 on every texel (a NaN would be 0; the sphere's true
//       cosine-weighted occlusion there is < 0.01). _Zero: maxDistance 0 through the API gives AO
//       exactly 1 on every texel for each variant, at resolutionScale 1 and upsampled from 0.25.
#include "renderer/features/lighting_reference.h"
#include "stability/stability_util.h"
#include "support/golden.h"

namespace penumbra::test::stability {
namespace {

namespace ref = render::reference;
using sdf::ShapeNode;

constexpr uint32_t kW = 128, kH = 96;
constexpr double kMaxFrameMs = 60000.0;  // "the frame returns"

// One rendered frame with its G-buffer, lit image and effect targets.
struct EffectFrame {
    GBuffer g;
    ImageRGBA8 image;
    std::vector<uint8_t> shadow;  // effects.shadow: R8, (kW * layers) x kH (empty: no shadow pass)
    std::vector<uint8_t> ao;      // effects.ao: RGBA8 (empty: AO off)
    uint32_t layers = 0;
    uint32_t lights = 0;
    std::string aoVariant;
    std::vector<std::string> passes;
    double ms = 0.0;

    uint8_t shadowAt(uint32_t layer, uint32_t x, uint32_t y) const {
        return shadow[(size_t(y) * layers + layer) * g.w + x];
    }
    float aoAt(size_t i) const { return ao.empty() ? 1.0f : float(ao[i * 4]) / 255.0f; }
    size_t passCount(const std::string& name) const {
        return size_t(std::count(passes.begin(), passes.end(), name));
    }
};

bool renderEffects(StabScene& s, render::SceneRenderer& r, const render::FrameDesc& d, EffectFrame& f) {
    const Stopwatch watch;
    f = {};
    if (!renderAndRead(s, r, d, f.g)) return false;
    std::string error;
    if (!r.readPixels(f.image, error)) {
        ADD_FAILURE() << error;
        return false;
    }
    const render::FrameStats& stats = r.lastFrameStats();
    for (const fg::PassTiming& p : stats.passes) f.passes.push_back(p.name);
    f.layers = stats.effects.shadowLayers;
    f.lights = stats.lights;
    f.aoVariant = stats.effects.ao;
    if (f.layers > 0) {
        f.shadow = readRaw(r, "effects.shadow", rhi::Format::R8_UNORM);
        if (f.shadow.size() != size_t(f.layers) * d.width * d.height) {
            ADD_FAILURE() << "effects.shadow: " << f.shadow.size() << " bytes";
            return false;
        }
    }
    if (f.aoVariant != "off") {
        f.ao = readRaw(r, "effects.ao", rhi::Format::RGBA8_UNORM);
        if (f.ao.size() != size_t(4) * d.width * d.height) {
            ADD_FAILURE() << "effects.ao: " << f.ao.size() << " bytes";
            return false;
        }
    }
    f.ms = watch.ms();
    return true;
}

ecs::Material matte() {
    ecs::Material m;
    m.baseColor = {0.8f, 0.7f, 0.6f, 1.0f};
    m.roughness = 0.5f;
    return m;
}

ecs::Entity addLight(StabScene& s, ecs::LightType type, glm::vec3 position, float intensity, float radius,
                     bool castShadows, float range = 10.0f) {
    const ecs::Entity e = s.world.create();
    s.world.add<ecs::Transform>(e)->position = position;
    ecs::Light l;
    l.type = type;
    l.intensity = intensity;
    l.radius = radius;
    l.range = range;
    l.castShadows = castShadows;
    s.world.add<ecs::Light>(e, l);
    return e;
}

// The frame's lit image against the CPU lighting on its own G-buffer with the GPU's effect results.
// `lights` in entity order (the renderer's light order); the k-th light with castShadows reads shadow
// layer k when the frame has layers, the others visibility 1.
struct RefCheck {
    ImageDiff diff;
    size_t hits = 0, dark = 0;
};
RefCheck checkAgainstReference(const StabScene& s, const render::FrameDesc& fd, const EffectFrame& f,
                               const ecs::Material& mat, const std::vector<ecs::Entity>& lights) {
    RefCheck c;
    const RefCamera cam(s.world, s.camera, fd.width, fd.height);
    std::vector<ref::LightSample> samples;
    std::vector<int> layerOf;
    int next = 0;
    for (ecs::Entity e : lights) {
        const ecs::Light& l = *s.world.get<ecs::Light>(e);
        samples.push_back(ref::makeLightSample(l, *s.world.get<ecs::Transform>(e)));
        layerOf.push_back(l.castShadows && f.layers > 0 ? next++ : -1);
    }
    const auto background =
        ref::displayEncode(fd.settings.background, fd.settings.exposure, fd.settings.toneMapper);
    ImageRGBA8 expected = f.image;
    std::vector<float> vis(samples.size());
    for (uint32_t y = 0; y < fd.height; ++y)
        for (uint32_t x = 0; x < fd.width; ++x) {
            const size_t i = f.g.at(x, y);
            std::array<uint8_t, 3> want = background;
            if (f.g.hit(i)) {
                ++c.hits;
                ref::SurfaceSample sample;
                sample.position = glm::vec3(cam.eye + cam.dir(x, y) * double(f.g.depth[i]));
                sample.normal = f.g.normal[i];
                sample.baseColor = glm::vec3(mat.baseColor);
                sample.roughness = mat.roughness;
                sample.ao = f.aoAt(i);
                for (size_t k = 0; k < samples.size(); ++k)
                    vis[k] = layerOf[k] >= 0 ? float(f.shadowAt(uint32_t(layerOf[k]), x, y)) / 255.0f : 1.0f;
                want = ref::displayEncode(ref::shadeSurface(fd.settings.shading, fd.settings.ambient, sample,
                                                            glm::vec3(cam.eye), samples, vis),
                                          fd.settings.exposure, fd.settings.toneMapper);
                const auto ambientOnly =
                    ref::displayEncode(fd.settings.ambient * sample.baseColor * sample.ao,
                                       fd.settings.exposure, fd.settings.toneMapper);
                for (int ch = 0; ch < 3; ++ch)
                    c.dark += int(f.image.pixels[i * 4 + size_t(ch)]) < int(ambientOnly[size_t(ch)]) - 2;
            }
            for (int ch = 0; ch < 3; ++ch) expected.pixels[i * 4 + size_t(ch)] = want[size_t(ch)];
        }
    c.diff = compareImages(f.image, expected);
    return c;
}

// Closest approach of the segment p -> q to the point c, minus r (< 0: the segment enters the ball).
double segmentClearance(const glm::dvec3& p, const glm::dvec3& q, const glm::dvec3& c, double r) {
    const glm::dvec3 d = q - p;
    const double len = glm::length(d);
    const glm::dvec3 u = d / len;
    const double t = glm::clamp(glm::dot(c - p, u), 0.0, len);
    return glm::length(c - p - t * u) - r;
}

class StabilityEffects : public GpuTest {};

// ---- E1 ------------------------------------------------------------------------------------------
TEST_P(StabilityEffects, E1_ZeroLightsWithConeAo) {
    const ecs::Material mat = matte();
    EffectFrame frames[2];  // 0: shadows on (default), 1: shadows off
    StabScene s({0, 0.6f, 0.5f}, {0, -0.2f, -3}, 0.1f, 100.0f);
    const assets::AssetId m = s.assets.addMaterial("stability:matte", mat);
    s.shape(ShapeNode::sphere(0.6), {0, 0, -3}, {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
    s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -0.6f, 0}, {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
    render::SceneRenderer r(dev());
    render::FrameDesc fd = s.frame(kW, kH);
    fd.settings.ambient = glm::vec3(0.6f);
    fd.settings.ao.variant = scene::AoVariant::Cones;
    for (int pass = 0; pass < 2; ++pass) {
        fd.settings.shadows.enabled = pass == 0;
        ASSERT_TRUE(renderEffects(s, r, fd, frames[pass]));
    }
    const EffectFrame& f = frames[0];
    const RefCheck c = checkAgainstReference(s, fd, f, mat, {});
    float aoMin = 1.0f;
    for (size_t i = 0; i < f.g.size(); ++i)
        if (f.g.hit(i)) aoMin = std::min(aoMin, f.aoAt(i));
    const ImageDiff same = compareImages(frames[0].image, frames[1].image);
    summary("E1 0 lights + AO cones", GetParam(),
            "%u lights, %u shadow layers (0), sdf_shadow passes %zu (0), sdf_ao passes %zu (1), AO '%s', "
            "frame %.0f ms (< 60000)",
            f.lights, f.layers, f.passCount("sdf_shadow"), f.passCount("sdf_ao"), f.aoVariant.c_str(), f.ms);
    summary("E1 0 lights + AO cones", GetParam(),
            "%zu hit px, min AO %.3f (<= 0.8: AO ran), image vs CPU ambient * albedo * AO %s (parity rule), "
            "%zu channel values below ambient-only (0); vs shadows off: %s (identical)",
            c.hits, aoMin, c.diff.summary().c_str(), c.dark, same.summary().c_str());
    EXPECT_EQ(f.lights, 0u);
    EXPECT_EQ(f.layers, 0u);                   // no shadowed light: no shadow layers
    EXPECT_EQ(f.passCount("sdf_shadow"), 0u);  // ... and no sdf_shadow pass
    EXPECT_EQ(f.passCount("sdf_ao"), 1u);      // AO ran
    EXPECT_STREQ(f.aoVariant.c_str(), "cones");
    EXPECT_LT(f.ms, kMaxFrameMs);
    EXPECT_GT(c.hits, size_t(kW) * kH / 3);
    EXPECT_LE(aoMin, 0.8f);                         // the AO comparison is not vacuous
    EXPECT_TRUE(c.diff.pass) << c.diff.summary();   // parity rule against the CPU lighting
    EXPECT_EQ(c.dark, 0u);                          // no pixel below ambient * albedo * AO - 2/255
    EXPECT_TRUE(same.identical) << same.summary();  // shadows on/off identical without lights
}

// ---- E2 ------------------------------------------------------------------------------------------
TEST_P(StabilityEffects, E2_TwoHundredLightsEightShadowed) {
    const ecs::Material mat = matte();
    const glm::dvec3 centre(0, 0, -3);
    const double radius = 0.6;
    StabScene s({0, 1.0f, 0.5f}, {0, -0.4f, -3}, 0.1f, 100.0f);
    const assets::AssetId m = s.assets.addMaterial("stability:matte", mat);
    s.shape(ShapeNode::sphere(radius), glm::vec3(centre), {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
    s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -0.6f, 0}, {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
    // 200 point lights on rings around the sphere's vertical axis (golden-angle azimuths), every 25th
    // with castShadows (8 of them, brighter), the others without.
    std::vector<ecs::Entity> lights;
    std::vector<glm::dvec3> unshadowed;
    for (int i = 0; i < 200; ++i) {
        const bool shadowed = i % 25 == 0;
        const double phi = 2.39996323 * i;
        const double ring = 1.2 + 0.3 * (i % 4), height = 0.1 + 0.35 * (i % 3);
        const glm::dvec3 p = centre + glm::dvec3(ring * std::cos(phi), height, ring * std::sin(phi));
        lights.push_back(
            addLight(s, ecs::LightType::Point, glm::vec3(p), shadowed ? 0.4f : 0.03f, 0.0f, shadowed));
        if (!shadowed) unshadowed.push_back(p);
    }
    render::SceneRenderer r(dev());
    render::FrameDesc fd = s.frame(kW, kH);
    fd.settings.ambient = glm::vec3(0.1f);
    EffectFrame f, off;
    ASSERT_TRUE(renderEffects(s, r, fd, f));
    fd.settings.shadows.enabled = false;
    ASSERT_TRUE(renderEffects(s, r, fd, off));
    fd.settings.shadows.enabled = true;

    const RefCheck c = checkAgainstReference(s, fd, f, mat, lights);
    // Plane pixels where every shadowed light is fully visible but some unshadowed one is behind the
    // sphere: identical to the shadows-off frame.
    const RefCamera cam(s.world, s.camera, kW, kH);
    size_t behind = 0, differ = 0;
    int maxDelta = 0;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            const size_t i = f.g.at(x, y);
            if (!f.g.hit(i) || f.layers != 8) continue;
            const glm::dvec3 p = cam.eye + cam.dir(x, y) * double(f.g.depth[i]);
            if (p.y > -0.59) continue;  // the plane only
            bool allVisible = true;
            for (uint32_t k = 0; k < 8; ++k) allVisible = allVisible && f.shadowAt(k, x, y) == 255;
            if (!allVisible) continue;
            const double margin = 2.0 * cam.footprint() * double(f.g.depth[i]);
            bool blocked = false;
            for (const glm::dvec3& q : unshadowed)
                blocked = blocked || segmentClearance(p, q, centre, radius) < -margin;
            if (!blocked) continue;
            ++behind;
            int d = 0;
            for (int ch = 0; ch < 3; ++ch)
                d = std::max(d, std::abs(int(f.image.pixels[i * 4 + size_t(ch)]) -
                                         int(off.image.pixels[i * 4 + size_t(ch)])));
            differ += d != 0;
            maxDelta = std::max(maxDelta, d);
        }
    summary("E2 200 lights, 8 shadowed", GetParam(),
            "%u lights (200), %u shadow layers (8), sdf_shadow passes %zu (1), frame %.0f ms (< 60000), "
            "shadows off %.0f ms",
            f.lights, f.layers, f.passCount("sdf_shadow"), f.ms, off.ms);
    summary("E2 200 lights, 8 shadowed", GetParam(),
            "%zu hit px, vs CPU lighting (192 lights visibility 1) %s (parity rule), %zu channel values "
            "below ambient-only (0)",
            c.hits, c.diff.summary().c_str(), c.dark);
    summary(
        "E2 200 lights, 8 shadowed", GetParam(),
        "%zu plane px with all 8 layers 255 and an unshadowed light behind the sphere (> 100): %zu differ "
        "from shadows off (0), max %d/255",
        behind, differ, maxDelta);
    EXPECT_EQ(f.lights, 200u);
    EXPECT_EQ(f.layers, 8u);  // one layer per castShadows light
    EXPECT_EQ(f.passCount("sdf_shadow"), 1u);
    EXPECT_EQ(off.layers, 0u);
    EXPECT_LT(f.ms, kMaxFrameMs);
    EXPECT_GT(c.hits, size_t(kW) * kH / 3);
    EXPECT_TRUE(c.diff.pass) << c.diff.summary();  // parity rule, unshadowed lights at visibility 1
    EXPECT_EQ(c.dark, 0u);                         // every lit pixel >= its ambient-only value - 2/255
    EXPECT_GT(behind, 100u);                       // the next check is not vacuous
    EXPECT_EQ(differ, 0u);                         // unshadowed lights are not shadowed
}

// ---- E3 ------------------------------------------------------------------------------------------
TEST_P(StabilityEffects, E3_LightsInsideAndOnAnObject) {
    const ecs::Material mat = matte();
    const glm::dvec3 centre(0, 0.2, -3);  // 0.2 above the plane y = -0.6
    const double radius = 0.6;
    const float range = 20.0f;
    EffectFrame frames[3];  // 0: all four lights, 1: only the two inside lights, 2: no lights
    std::vector<ecs::Entity> lightsAll;
    render::FrameDesc fd;
    for (int pass = 0; pass < 3; ++pass) {
        StabScene s({0, 1.2f, 0.8f}, {0, -0.3f, -3}, 0.1f, 100.0f);
        const assets::AssetId m = s.assets.addMaterial("stability:matte", mat);
        const ecs::Entity sphere =
            s.shape(ShapeNode::sphere(radius), glm::vec3(centre), {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
        const ecs::Entity plane =
            s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -0.6f, 0}, {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
        std::vector<ecs::Entity> lights;
        if (pass < 2) {
            lights.push_back(addLight(s, ecs::LightType::Point, glm::vec3(centre), 3.0f, 0.0f, true, range));
            lights.push_back(addLight(s, ecs::LightType::Sphere, glm::vec3(centre), 3.0f, 0.2f, true, range));
        }
        if (pass == 0) {
            lights.push_back(addLight(s, ecs::LightType::Point, glm::vec3(centre + glm::dvec3(radius, 0, 0)),
                                      1.0f, 0.0f, true, range));
            lights.push_back(addLight(s, ecs::LightType::Sphere, glm::vec3(centre - glm::dvec3(radius, 0, 0)),
                                      1.0f, 0.1f, true, range));
        }
        render::SceneRenderer r(dev());
        fd = s.frame(kW, kH);
        fd.settings.ambient = glm::vec3(0.1f);
        fd.settings.shadows.resolutionScale = 1.0f;
        ASSERT_TRUE(renderEffects(s, r, fd, frames[pass]));
        if (pass > 0) continue;

        const EffectFrame& f = frames[0];
        ASSERT_EQ(f.layers, 4u);
        const RefCheck c = checkAgainstReference(s, fd, f, mat, lights);
        const RefCamera cam(s.world, s.camera, kW, kH);
        size_t insideInRange = 0, insideLit[2] = {0, 0};
        size_t sphereSurface = 0, surfaceOnSphereLit = 0, planeBehind = 0, planeBehindLit = 0, planeFront = 0,
               planeFrontLit = 0, planeFrontDark = 0, softSum = 0, softCount = 0;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) {
                const size_t i = f.g.at(x, y);
                if (!f.g.hit(i)) continue;
                const glm::dvec3 p = cam.eye + cam.dir(x, y) * double(f.g.depth[i]);
                if (glm::length(p - centre) < double(range)) {
                    ++insideInRange;
                    for (uint32_t k = 0; k < 2; ++k) insideLit[k] += f.shadowAt(k, x, y) != 0;
                }
                softSum += f.shadowAt(3, x, y);
                ++softCount;
                // The on-surface point light: pixels within its range (beyond it the pass writes 1
                // without a trace, renderer/features/sdf_shadow.h), by the entity the pixel shows.
                const glm::dvec3 bulb = centre + glm::dvec3(radius, 0, 0);
                if (glm::length(p - bulb) >= double(range)) continue;
                const bool onSphere = f.g.id(i) == int(sphere.index);
                if (!onSphere && f.g.id(i) != int(plane.index)) continue;
                const double margin = 2.0 * cam.footprint() * double(f.g.depth[i]);
                const uint8_t v = f.shadowAt(2, x, y);
                if (onSphere) {
                    ++sphereSurface;
                    surfaceOnSphereLit += v != 0;
                } else if (p.x < centre.x + radius - margin) {
                    ++planeBehind;
                    planeBehindLit += v != 0;
                } else if (p.x > centre.x + radius + margin) {
                    ++planeFront;
                    planeFrontLit += v == 255;
                    planeFrontDark += v == 0;
                }
            }
        summary(
            "E3 lights inside/on", GetParam(),
            "frame %.0f ms (< 60000), %u layers (4); inside point / sphere light: %zu / %zu of %zu hit px "
            "in range with visibility > 0 (0)",
            f.ms, f.layers, insideLit[0], insideLit[1], insideInRange);
        summary(
            "E3 lights inside/on", GetParam(),
            "point light on the surface: %zu of %zu sphere px visibility > 0 (0), %zu of %zu plane px on "
            "the sphere's side of x = 0.6 visibility > 0 (0); plane px beyond x = 0.6: %zu of %zu at 255, "
            "%zu at 0 (reported; in reality lit)",
            surfaceOnSphereLit, sphereSurface, planeBehindLit, planeBehind, planeFrontLit, planeFront,
            planeFrontDark);
        summary("E3 lights inside/on", GetParam(),
                "sphere light r 0.1 on the surface: mean visibility %.3f over %zu hit px (reported); lit "
                "image vs "
                "CPU %s (parity rule), %zu channel values below ambient-only (0)",
                softCount ? double(softSum) / 255.0 / double(softCount) : 0.0, softCount,
                c.diff.summary().c_str(), c.dark);
        EXPECT_LT(f.ms, kMaxFrameMs);
        EXPECT_GT(insideInRange, size_t(kW) * kH / 3);
        EXPECT_EQ(insideLit[0], 0u);  // inside point light: visibility exactly 0 outside the sphere
        EXPECT_EQ(insideLit[1], 0u);  // inside sphere light (radius 0.2 < 0.6): exactly 0
        EXPECT_GT(sphereSurface, 500u);
        EXPECT_EQ(surfaceOnSphereLit, 0u);  // on-surface light: the sphere's own surface is dark
        EXPECT_GT(planeBehind, 500u);
        EXPECT_EQ(planeBehindLit, 0u);  // ... and the plane on the sphere's side of its tangent plane
        EXPECT_TRUE(c.diff.pass) << c.diff.summary();
        EXPECT_EQ(c.dark, 0u);
        lightsAll = lights;
    }
    EXPECT_LT(frames[1].ms, kMaxFrameMs);
    const ImageDiff same = compareImages(frames[1].image, frames[2].image);
    summary("E3 lights inside/on", GetParam(),
            "only the two inside lights vs no lights: %s (identical), %u layers (2)", same.summary().c_str(),
            frames[1].layers);
    EXPECT_EQ(frames[1].layers, 2u);
    EXPECT_TRUE(same.identical) << same.summary();  // the inside lights add nothing outside
}

// ---- E4 ------------------------------------------------------------------------------------------
TEST_P(StabilityEffects, E4_ZeroRadiusSphereLightShadowIsPointLightShadow) {
    const ecs::Material mat = matte();
    const float scales[2] = {1.0f, 0.5f};
    std::vector<uint8_t> shadow[2][2];  // [scale][0 sphere light radius 0, 1 point light]
    for (int si = 0; si < 2; ++si)
        for (int pass = 0; pass < 2; ++pass) {
            StabScene s({0, 1.0f, 0.5f}, {0, -0.3f, -3}, 0.1f, 100.0f);
            const assets::AssetId m = s.assets.addMaterial("stability:matte", mat);
            s.shape(ShapeNode::sphere(0.5), {-0.3f, -0.1f, -3}, {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
            s.shape(ShapeNode::sphere(0.25), {0.6f, -0.35f, -2.6f}, {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
            s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -0.6f, 0}, {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
            addLight(s, pass == 0 ? ecs::LightType::Sphere : ecs::LightType::Point, {0.4f, 1.4f, -2.4f}, 3.0f,
                     0.0f, true);
            render::SceneRenderer r(dev());
            render::FrameDesc fd = s.frame(kW, kH);
            fd.settings.shadows.resolutionScale = scales[si];
            EffectFrame f;
            ASSERT_TRUE(renderEffects(s, r, fd, f));
            ASSERT_EQ(f.layers, 1u);
            EXPECT_LT(f.ms, kMaxFrameMs);
            shadow[si][pass] = f.shadow;
        }
    size_t nonBinary = 0, zeros = 0, differ[2] = {0, 0};
    for (uint8_t v : shadow[0][0]) {
        nonBinary += v != 0 && v != 255;
        zeros += v == 0;
    }
    for (int si = 0; si < 2; ++si)
        for (size_t i = 0; i < shadow[si][0].size(); ++i) differ[si] += shadow[si][0][i] != shadow[si][1][i];
    summary("E4 sphere r 0 = point", GetParam(),
            "resolutionScale 1: %zu of %zu shadow texels differ (0), not 0 or 255: %zu (0), shadowed %zu (> "
            "200); "
            "resolutionScale 0.5 (upsampled): %zu differ (0)",
            differ[0], shadow[0][0].size(), nonBinary, zeros, differ[1]);
    EXPECT_EQ(differ[0], 0u);  // bitwise identical layers
    EXPECT_EQ(nonBinary, 0u);  // binary: a zero-size light has no penumbra
    EXPECT_GT(zeros, 200u);    // and it does cast a shadow
    EXPECT_EQ(differ[1], 0u);
}

// ---- E5 ------------------------------------------------------------------------------------------
// Scene A: a sphere 0.25 above a plane (occluded at maxDistance 1; nothing within 1e-30 of any shaded
// point). Scene B: an open plane seen from above, a sphere of radius 1 ten units away outside the view.
struct AoScenes {
    StabScene a{{0, 0.6f, 0.5f}, {0, -0.2f, -3}, 0.1f, 100.0f};
    StabScene b{{0, 2.0f, 0}, {0, 0, -0.01f}, 0.1f, 100.0f};
    explicit AoScenes(const ecs::Material& mat) {
        const assets::AssetId ma = a.assets.addMaterial("stability:matte", mat);
        a.shape(ShapeNode::sphere(0.6), {0, 0.25f, -3}, {1, 0, 0, 0}, glm::vec3(1), nullptr, ma);
        a.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -0.6f, 0}, {1, 0, 0, 0}, glm::vec3(1), nullptr, ma);
        const assets::AssetId mb = b.assets.addMaterial("stability:matte", mat);
        b.shape(ShapeNode::sphere(1.0), {10.0f, 0.0f, 0}, {1, 0, 0, 0}, glm::vec3(1), nullptr, mb);
        b.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -1.0f, 0}, {1, 0, 0, 0}, glm::vec3(1), nullptr, mb);
    }
};

struct AoRun {
    float maxDistance, scale;
    bool open;  // scene B
};
struct AoResult {
    size_t hits = 0, not255 = 0;
    float aoMin = 1.0f;
    double aoMean = 0.0, ms = 0.0;
};

// One AO frame; prints its summary line. False (failure added) when the frame failed.
bool renderAo(rhi::Backend backend, AoScenes& scenes, render::SceneRenderer& ra, render::SceneRenderer& rb,
              scene::AoVariant variant, const AoRun& run, AoResult& out) {
    const char* name = scene::toString(variant);
    StabScene& s = run.open ? scenes.b : scenes.a;
    render::FrameDesc fd = s.frame(kW, kH);
    fd.settings.ao.variant = variant;
    fd.settings.ao.maxDistance = run.maxDistance;
    fd.settings.ao.resolutionScale = run.scale;
    EffectFrame f;
    if (!renderEffects(s, run.open ? rb : ra, fd, f)) return false;
    EXPECT_STREQ(f.aoVariant.c_str(), name);
    if (f.ao.size() != size_t(4) * kW * kH) {
        ADD_FAILURE() << name << ": no effects.ao";
        return false;
    }
    out = {};
    double sum = 0.0;
    for (size_t i = 0; i < f.g.size(); ++i) {
        out.not255 += f.ao[i * 4] != 255;
        if (!f.g.hit(i)) continue;
        ++out.hits;
        out.aoMin = std::min(out.aoMin, f.aoAt(i));
        sum += f.aoAt(i);
    }
    out.aoMean = out.hits ? sum / double(out.hits) : 0.0;
    out.ms = f.ms;
    summary("E5 AO maxDistance", backend,
            "%-9s maxDistance %-5g scale %-4g %s: %zu hit px, AO min %.3f mean %.4f, texels != 255: %zu, "
            "frame %.0f ms (< 60000)",
            name, double(run.maxDistance), double(run.scale), run.open ? "open plane  " : "sphere+plane",
            out.hits, out.aoMin, out.aoMean, out.not255, out.ms);
    EXPECT_LT(out.ms, kMaxFrameMs);
    EXPECT_GT(out.hits, size_t(kW) * kH / 3);
    return true;
}

constexpr scene::AoVariant kAoVariants[] = {scene::AoVariant::FiveTap, scene::AoVariant::MultiRay,
                                            scene::AoVariant::Cones};

// The scene file refuses 0; 1e-30 and 1e6 through the API for every variant (and 1 as the baseline
// that shows the scene does occlude).
TEST_P(StabilityEffects, E5_AoMaxDistanceTinyAndHuge) {
    {
        assets::AssetManager assets;
        scene::Scene out;
        std::string error;
        EXPECT_FALSE(scene::parseJsonScene(R"({"version": 2, "render": {"ao": {"maxDistance": 0}}})",
                                           "ao.json", ".", assets, out, error));
        const bool named = error.find("/render/ao/maxDistance") != std::string::npos;
        summary("E5 AO maxDistance", GetParam(),
                "scene file maxDistance 0: \"%s\" (load fails, names /render/ao/maxDistance)", error.c_str());
        EXPECT_TRUE(named) << error;
        for (const char* ok : {"1e-30", "1e6"}) {
            scene::Scene s2;
            std::string e2;
            const std::string text =
                std::string(R"({"version": 2, "render": {"ao": {"maxDistance": )") + ok + "}}}";
            EXPECT_TRUE(scene::parseJsonScene(text, "ao.json", ".", assets, s2, e2)) << ok << ": " << e2;
            scene::unloadScene(s2, assets);
        }
    }
    AoScenes scenes(matte());
    render::SceneRenderer ra(dev()), rb(dev());
    for (scene::AoVariant variant : kAoVariants) {
        const char* name = scene::toString(variant);
        AoResult res;
        ASSERT_TRUE(renderAo(GetParam(), scenes, ra, rb, variant, {1.0f, 1.0f, false}, res));
        EXPECT_LE(res.aoMin, 0.8f) << name;  // the scene does occlude at maxDistance 1
        ASSERT_TRUE(renderAo(GetParam(), scenes, ra, rb, variant, {1e-30f, 1.0f, false}, res));
        EXPECT_EQ(res.not255, 0u) << name;  // nothing within 1e-30: AO exactly 1 on every texel
        ASSERT_TRUE(renderAo(GetParam(), scenes, ra, rb, variant, {1e6f, 1.0f, true}, res));
        EXPECT_GE(res.aoMin, 0.9f) << name;  // open plane, far sphere: ~1 (a NaN would write 0)
    }
}

// maxDistance 0 through the API (the scene file refuses it, E5 above): nothing is within 0, so AO is
// exactly 1 on every texel, at resolutionScale 1 and upsampled from 0.25, for every variant.
TEST_P(StabilityEffects, E5_AoMaxDistanceZero) {
    AoScenes scenes(matte());
    render::SceneRenderer ra(dev()), rb(dev());
    for (scene::AoVariant variant : kAoVariants)
        for (float scale : {1.0f, 0.25f}) {
            AoResult res;
            ASSERT_TRUE(renderAo(GetParam(), scenes, ra, rb, variant, {0.0f, scale, false}, res));
            EXPECT_EQ(res.not255, 0u) << scene::toString(variant) << " scale " << scale;  // AO exactly 1
        }
}

INSTANTIATE_TEST_SUITE_P(Backends, StabilityEffects, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test::stability
