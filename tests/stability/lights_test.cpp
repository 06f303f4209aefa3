// Hard cases of lighting input (issue 11 item 4), both backends under validation:
//   9  zero-area lights: a sphere light of radius 0 placed exactly on a traced surface, and a
//      directional light of angular radius 0.
// The lit image (RGBA8 output) is compared with the CPU reference of the lighting pass
// (renderer/features/lighting_reference.h shadeSurface + displayEncode) evaluated on the frame's own
// G-buffer (position from depth along the pixel's ray, decoded normal): a NaN or inf anywhere in the
// light path would show as 0 (UNORM conversion) or a wrong value. Criteria: the parity rule
// (tests/support/golden.h: per channel <= 5/255 for all but 0.1 % of pixels, none over 64/255), no hit
// pixel darker than its ambient-only value minus 2/255 (a NaN writes 0), and the sphere light of
// radius 0 gives exactly the image of a point light at the same place (the falloff clamps at 0.01).
// Shadows (renderer/features/sdf_shadow.h) of these lights: a radius-0 sphere light and an angle-0
// directional light have a zero cone, so their visibility (effects.shadow, one layer per light) is
// binary: every texel is exactly 0 or 1 (a NaN would not be), and it agrees with the exact
// visibility (segment / ray against the analytic sphere, in double precision) on every plane pixel
// within the bulb's range whose exact shadow ray clears the sphere's surface, or enters it, by more
// than 2 pixel footprints (the pass starts its rays a few footprints off the surface). The lit image is
// compared with the CPU lighting given the GPU's per-light visibility.
#include "renderer/features/lighting_reference.h"
#include "stability/stability_util.h"
#include "support/golden.h"

namespace penumbra::test::stability {
namespace {

namespace ref = render::reference;
using sdf::ShapeNode;

class StabilityLights : public GpuTest {};

TEST_P(StabilityLights, Case09_ZeroAreaLights) {
    constexpr uint32_t w = 128, h = 96;
    ImageRGBA8 images[2];
    for (int pass = 0; pass < 2; ++pass) {  // 0: sphere light radius 0, 1: point light at the same place
        StabScene s({0, 0.4f, 0}, {0, 0, -3}, 0.1f, 100.0f);
        ecs::Material mat;
        mat.baseColor = {0.8f, 0.7f, 0.6f, 1.0f};
        mat.roughness = 0.5f;
        const assets::AssetId m = s.assets.addMaterial("stability:matte", mat);
        s.shape(ShapeNode::sphere(0.6), {0, 0, -3}, {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
        s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -0.6f, 0}, {1, 0, 0, 0}, glm::vec3(1), nullptr, m);
        const ecs::Entity bulb = s.world.create();
        s.world.add<ecs::Transform>(bulb)->position = {0.0f, 0.0f, -2.4f};  // on the sphere's surface
        ecs::Light l;
        l.type = pass == 0 ? ecs::LightType::Sphere : ecs::LightType::Point;
        l.radius = 0.0f;
        l.intensity = 3.0f;
        l.range = 10.0f;
        s.world.add<ecs::Light>(bulb, l);
        const ecs::Entity sun = s.world.create();
        s.world.add<ecs::Transform>(sun)->rotation = lookRotation({-0.4f, -1.0f, -0.3f});
        ecs::Light d;
        d.type = ecs::LightType::Directional;
        d.angularRadius = 0.0f;
        d.intensity = 1.5f;
        s.world.add<ecs::Light>(sun, d);
        ecs::updateTransforms(s.world);

        render::SceneRenderer r(dev());
        render::FrameDesc fd = s.frame(w, h);
        fd.settings.ambient = glm::vec3(0.1f);
        fd.settings.shadows.resolutionScale = 1.0f;  // the shadow pass itself (no upsampling blend)
        GBuffer g;
        ASSERT_TRUE(renderAndRead(s, r, fd, g));
        ImageRGBA8& image = images[pass];
        std::string error;
        ASSERT_TRUE(r.readPixels(image, error)) << error;
        // Layer 0: the bulb (created first), layer 1: the sun; R8, layer k at columns [k w, (k + 1) w).
        const std::vector<uint8_t> shadow = readRaw(r, "effects.shadow", rhi::Format::R8_UNORM);
        ASSERT_EQ(shadow.size(), size_t(2) * w * h);

        // The CPU reference on the frame's G-buffer.
        const RefCamera cam(s.world, s.camera, w, h);
        std::vector<ref::LightSample> lights = {
            ref::makeLightSample(*s.world.get<ecs::Light>(bulb), *s.world.get<ecs::Transform>(bulb)),
            ref::makeLightSample(*s.world.get<ecs::Light>(sun), *s.world.get<ecs::Transform>(sun))};
        ImageRGBA8 expected = image;
        const auto ambientOnly = ref::displayEncode(fd.settings.ambient * glm::vec3(mat.baseColor),
                                                    fd.settings.exposure, fd.settings.toneMapper);
        const auto background =
            ref::displayEncode(fd.settings.background, fd.settings.exposure, fd.settings.toneMapper);
        size_t dark = 0, hits = 0, nonBinary = 0, compared = 0, wrong = 0, shadowed = 0;
        const double footprint = 2.0 * std::tan(double(kFovY) / 2.0) / double(h);  // pixel size per unit
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) {
                const size_t i = g.at(x, y);
                std::array<uint8_t, 3> want = background;
                if (g.hit(i)) {
                    ++hits;
                    ref::SurfaceSample sample;
                    sample.position = glm::vec3(cam.eye + cam.dir(x, y) * double(g.depth[i]));
                    sample.normal = g.normal[i];
                    sample.baseColor = glm::vec3(mat.baseColor);
                    sample.roughness = mat.roughness;
                    const float vis[2] = {shadow[size_t(y) * 2 * w + x] / 255.0f,
                                          shadow[size_t(y) * 2 * w + w + x] / 255.0f};
                    for (float v : vis) nonBinary += v != 0.0f && v != 1.0f;
                    const glm::dvec3 p = cam.eye + cam.dir(x, y) * double(g.depth[i]);
                    if (p.y < -0.59) {  // the plane: exact visibility of both lights
                        const double margin = 2.0 * footprint * double(g.depth[i]);
                        const glm::dvec3 toBulb = glm::dvec3(0.0, 0.0, -2.4) - p;
                        const glm::dvec3 toSun = -glm::dvec3(glm::normalize(glm::vec3(-0.4f, -1.0f, -0.3f)));
                        const double reach[2] = {glm::length(toBulb), 1e9};
                        const glm::dvec3 dirs[2] = {toBulb / reach[0], toSun};
                        for (int k = 0; k < 2; ++k) {
                            // Closest approach of the ray to the sphere's centre, within the segment.
                            const glm::dvec3 oc = glm::dvec3(0, 0, -3) - p;
                            const double t = glm::clamp(glm::dot(oc, dirs[k]), 0.0, reach[k]);
                            const double clearance = glm::length(oc - t * dirs[k]) - 0.6;
                            // Beyond the bulb's range the light adds nothing and the pass skips it
                            // (visibility 1, renderer/features/sdf_shadow.h).
                            if (std::abs(clearance) <= margin || (k == 0 && reach[k] >= double(l.range)))
                                continue;
                            const bool lit = clearance > 0.0;
                            ++compared;
                            shadowed += !lit;
                            wrong += (vis[k] > 0.5f) != lit;
                        }
                    }
                    want = ref::displayEncode(ref::shadeSurface(fd.settings.shading, fd.settings.ambient,
                                                                sample, glm::vec3(cam.eye), lights, vis),
                                              fd.settings.exposure, fd.settings.toneMapper);
                    for (int c = 0; c < 3; ++c)
                        dark += int(image.pixels[i * 4 + size_t(c)]) < int(ambientOnly[size_t(c)]) - 2;
                }
                for (int c = 0; c < 3; ++c) expected.pixels[i * 4 + size_t(c)] = want[size_t(c)];
            }
        const ImageDiff diff = compareImages(image, expected);
        summary("09 zero-area lights", GetParam(),
                "%s radius 0 on the surface + directional angle 0: %zu hit px, GPU vs CPU reference %s "
                "(parity rule), "
                "%zu channel values below ambient-only (0)",
                pass == 0 ? "sphere light" : "point light ", hits, diff.summary().c_str(), dark);
        summary("09 zero-area lights", GetParam(),
                "%s: shadow texels not 0 or 1: %zu (0); exact visibility on the plane: %zu of %zu "
                "light-pixel pairs disagree (0), %zu of them shadowed",
                pass == 0 ? "sphere light" : "point light ", nonBinary, wrong, compared, shadowed);
        EXPECT_GT(hits, size_t(w) * h / 3);
        EXPECT_TRUE(diff.pass) << diff.summary();
        EXPECT_EQ(dark, 0u);
        EXPECT_EQ(nonBinary, 0u);  // zero-size lights: binary visibility
        EXPECT_EQ(wrong, 0u);      // exact agreement beyond 2 pixel footprints of a shadow edge
        EXPECT_GT(shadowed, 50u);  // the comparison covers shadowed pixels, not only lit ones
    }
    const ImageDiff same = compareImages(images[0], images[1]);
    summary("09 zero-area lights", GetParam(), "sphere light radius 0 vs point light: %s (identical)",
            same.summary().c_str());
    EXPECT_TRUE(same.identical) << same.summary();
}

INSTANTIATE_TEST_SUITE_P(Backends, StabilityLights, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test::stability
