// Acceptance tests of hybrid occlusion (issue 12 item 3; engine/scene/mesh_sdf.h --mesh-sdf
// occlusion, SdfRenderer::occluderOnly in renderer/scene_renderer.cpp) on both backends under
// validation. Rasterized meshes get a coarse baked field used only by shadows and AO (Wright's mesh
// distance fields); the reference is the all-SDF render of the same scene (--mesh-sdf trace: each
// mesh traced from the same baked field, so occluders are identical and only the primary
// visibility differs):
//   1. a mesh cube resting on an SDF floor plane (the cube casts a soft shadow and AO onto the
//      floor and receives AO from it);
//   2. an SDF sphere over a mesh floor slab (the floor receives the sphere's shadow and AO, and
//      its own field must not shadow it: no acne);
//   3. frame structure: occluders run sdf_upload and the effects but no sdf_trace in a mesh-only
//      frame, are not counted as traced objects (FrameStats::sdfObjects / sdfOccluders).
// Comparison (stated per test): the raster surface and the traced baked field agree to within the
// field's voxel, so pixels are compared where both frames see the same surface (linear depths
// within 0.5 % and normals within 8 degrees); on those pixels the lit image must meet the parity
// rule of shared/design.md (per-channel |delta| <= 5/255 for all but <= 0.1 % of the pixels, none
// over 64/255) and effects.shadow / effects.ao are compared with the same thresholds. The fraction
// of pixels left out (silhouettes, the traced field's rounded edges) is printed and bounded.
// Shadows and AO run at full resolution (resolutionScale 1) so that the comparison sees the passes
// themselves, not upsampling at silhouettes that differ by construction. Images are 160x120.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/packing.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/components.h"
#include "engine/image/image.h"
#include "engine/scene/mesh_sdf.h"
#include "engine/scene/scene.h"
#include "renderer/core/gbuffer_encoding.h"
#include "renderer/scene_renderer.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using render::FrameDesc;
using render::SceneRenderer;
using scene::MeshSdfMode;

constexpr uint32_t kW = 160, kH = 120;
constexpr uint32_t kFieldResolution = scene::kOcclusionResolution;  // both modes bake the same field

// Shared by both scenes: a soft directional sun, cones AO, full-resolution effects.
constexpr const char* kRenderBlock = R"("render": {
    "shading": "cook-torrance", "toneMapper": "aces", "ambient": [0.25, 0.25, 0.28],
    "background": [0.05, 0.06, 0.08], "quality": "medium",
    "shadows": {"enabled": true, "resolutionScale": 1.0},
    "ao": {"variant": "cones", "maxDistance": 1.5, "resolutionScale": 1.0}})";
constexpr const char* kLightsAndCamera = R"(
    {"name": "cam", "transform": {"position": [0, 3.2, 4.2], "eulerDegrees": [-35, 0, 0]},
     "camera": {"fovYDegrees": 50, "near": 0.1, "far": 40}},
    {"name": "sun", "transform": {"eulerDegrees": [-35, 35, 0]},
     "light": {"type": "directional", "intensity": 2.5, "angularRadiusDegrees": 3}})";

// (a) a mesh cube resting on an SDF floor plane.
std::string cubeOnSdfFloor() {
    return std::string(R"({"version": 2, )") + kRenderBlock + R"(,
  "materials": {"floor": {"baseColor": [0.6, 0.6, 0.6], "roughness": 0.9},
                "cube": {"baseColor": [0.2, 0.35, 0.8], "roughness": 0.5}},
  "entities": [)" +
           kLightsAndCamera + R"(,
    {"name": "floor", "sdf": {"shape": {"shape": "plane", "normal": [0, 1, 0], "offset": 0}, "material": "floor"}},
    {"name": "cube", "transform": {"position": [0, 0.5, 0], "eulerDegrees": [0, 25, 0]},
     "mesh": {"primitive": {"shape": "box", "halfExtents": 0.5}, "material": "cube"}}]})";
}

// (b) an SDF sphere over a mesh floor slab (top face at y = 0).
std::string sdfSphereOverMeshFloor() {
    return std::string(R"({"version": 2, )") + kRenderBlock + R"(,
  "materials": {"floor": {"baseColor": [0.6, 0.6, 0.6], "roughness": 0.9},
                "ball": {"baseColor": [0.8, 0.2, 0.15], "roughness": 0.4}},
  "entities": [)" +
           kLightsAndCamera + R"(,
    {"name": "floor", "transform": {"position": [0, -0.25, 0]},
     "mesh": {"primitive": {"shape": "box", "halfExtents": [3, 0.25, 3]}, "material": "floor"}},
    {"name": "ball", "transform": {"position": [0, 0.75, 0]},
     "sdf": {"shape": {"shape": "sphere", "radius": 0.5}, "material": "ball"}}]})";
}

// One rendered frame and the targets the comparison reads.
struct Frame {
    ImageRGBA8 image;
    std::vector<float> depth;
    std::vector<glm::vec3> normal;
    std::vector<uint8_t> shadow;  // layer 0 (the sun)
    std::vector<uint8_t> ao;      // r of effects.ao
    glm::vec3 toSun{0.0f};        // unit direction towards the sun
    render::FrameStats stats;
};

class MeshOcclusionTest : public GpuTest {
public:
    // Loads `json`, applies `mode` (fields at kFieldResolution) and renders one frame.
    bool renderFrame(const std::string& json, MeshSdfMode mode, Frame& out) {
        assets::AssetManager assets;
        scene::Scene s;
        std::string error;
        EXPECT_TRUE(scene::parseJsonScene(json, "mesh_occlusion.json", ".", assets, s, error)) << error;
        EXPECT_TRUE(scene::applyMeshSdf(s, assets, mode, error, kFieldResolution)) << error;
        if (!error.empty()) return false;
        ecs::updateTransforms(s.world);
        for (auto [e, light, t] : std::as_const(s.world).view<ecs::Light, ecs::Transform>())
            out.toSun = -glm::normalize(t.worldForward());
        FrameDesc d;
        d.width = kW;
        d.height = kH;
        d.camera = scene::findCamera(s.world, "cam");
        d.settings = s.settings;
        SceneRenderer r(dev());
        const bool ok = r.render(s.world, assets, d, error) && r.readPixels(out.image, error) &&
                        readTargets(r, out, error);
        EXPECT_TRUE(ok) << error;
        out.stats = r.lastFrameStats();
        scene::unloadScene(s, assets);
        return ok;
    }

    static bool readTargets(SceneRenderer& r, Frame& out, std::string& error) {
        std::vector<uint8_t> texels;
        rhi::Format format{};
        if (!r.readTarget("gbuffer.depth", texels, format, error)) return false;
        out.depth.resize(size_t(kW) * kH);
        std::memcpy(out.depth.data(), texels.data(), out.depth.size() * sizeof(float));
        if (!r.readTarget("gbuffer.normal", texels, format, error)) return false;
        out.normal.resize(size_t(kW) * kH);
        for (size_t i = 0; i < out.normal.size(); ++i) {
            uint16_t h[2];
            std::memcpy(h, texels.data() + i * 4, 4);
            out.normal[i] = render::octDecode({glm::unpackHalf1x16(h[0]), glm::unpackHalf1x16(h[1])});
        }
        if (!r.readTarget("effects.shadow", texels, format, error)) return false;
        // Layer 0 (the sun) is the first kW texels of each row of the strip.
        const size_t layers = texels.size() / (size_t(kW) * kH);
        out.shadow.resize(size_t(kW) * kH);
        for (uint32_t y = 0; y < kH; ++y)
            std::memcpy(out.shadow.data() + size_t(y) * kW, texels.data() + size_t(y) * kW * layers, kW);
        if (!r.readTarget("effects.ao", texels, format, error)) return false;
        out.ao.resize(size_t(kW) * kH);
        for (size_t i = 0; i < out.ao.size(); ++i) out.ao[i] = texels[i * 4];
        return true;
    }
};

// Pixels where both frames see the same surface: depths within 0.5 % and normals within 8 degrees.
std::vector<bool> sameSurface(const Frame& a, const Frame& b, size_t& count) {
    std::vector<bool> mask(size_t(kW) * kH, false);
    count = 0;
    for (size_t i = 0; i < mask.size(); ++i) {
        const float da = a.depth[i], db = b.depth[i];
        if (da <= 0.0f || db <= 0.0f) continue;
        if (std::abs(da - db) > 0.005f * db) continue;
        if (glm::dot(a.normal[i], b.normal[i]) < std::cos(glm::radians(8.0f))) continue;
        mask[i] = true;
        ++count;
    }
    return mask;
}

// Pixels of `mask` that face the sun in both frames (n . l > 0.05): the lighting multiplies the
// visibility by n . l, so where a surface faces away (or grazes) its shadow value is unused and
// flips between 0 and 1 with the slightest normal difference.
std::vector<bool> facingSun(const Frame& a, const Frame& b, const std::vector<bool>& mask, size_t& count) {
    std::vector<bool> out(mask.size(), false);
    count = 0;
    for (size_t i = 0; i < mask.size(); ++i) {
        out[i] = mask[i] && glm::dot(a.normal[i], a.toSun) > 0.05f && glm::dot(b.normal[i], b.toSun) > 0.05f;
        count += out[i] ? 1 : 0;
    }
    return out;
}

// Up-facing pixels (the floors and the cube's top), for counting shadowed and occluded floor pixels.
std::vector<bool> upFacing(const Frame& f) {
    std::vector<bool> out(f.normal.size(), false);
    for (size_t i = 0; i < out.size(); ++i) out[i] = f.depth[i] > 0.0f && f.normal[i].y > 0.99f;
    return out;
}

// The parity rule over the masked pixels of one 8-bit channel set (`channels` bytes per pixel).
struct Parity {
    int maxDelta = 0;
    size_t over = 0;  // pixels with a channel above 5/255
    double fractionOver = 0;
    double meanDelta = 0;
};

Parity compare(const uint8_t* a, const uint8_t* b, int channels, const std::vector<bool>& mask,
               size_t count) {
    Parity p;
    double sum = 0;
    for (size_t i = 0; i < mask.size(); ++i) {
        if (!mask[i]) continue;
        int worst = 0;
        for (int c = 0; c < channels; ++c)
            worst = std::max(worst, std::abs(int(a[i * channels + c]) - int(b[i * channels + c])));
        p.maxDelta = std::max(p.maxDelta, worst);
        p.over += worst > 5 ? 1 : 0;
        sum += worst;
    }
    p.fractionOver = count ? double(p.over) / double(count) : 0.0;
    p.meanDelta = count ? sum / double(count) : 0.0;
    return p;
}

void expectParity(const char* what, const Parity& p) {
    std::printf("    %-8s max %3d/255, mean %.3f/255, %zu pixels (%.3f %%) over 5/255\n", what, p.maxDelta,
                p.meanDelta, p.over, 100.0 * p.fractionOver);
    // Parity rule (shared/design.md) on the same-surface pixels: none over 64/255 ...
    EXPECT_LE(p.maxDelta, 64) << what;
    // ... and at most 0.1 % of them over 5/255.
    EXPECT_LE(p.fractionOver, 0.001) << what;
}

// Masked pixels whose value is below `below` (shadowed / occluded).
size_t countBelow(const std::vector<uint8_t>& v, const std::vector<bool>& mask, int below) {
    size_t n = 0;
    for (size_t i = 0; i < v.size(); ++i) n += mask[i] && v[i] < below ? 1 : 0;
    return n;
}

// Renders a scene in occlusion and trace mode and applies the comparison of the file header.
void checkAgainstAllSdf(MeshOcclusionTest& t, const std::string& json, Frame& occ, Frame& ref,
                        std::vector<bool>& mask) {
    ASSERT_TRUE(t.renderFrame(json, MeshSdfMode::Occlusion, occ));
    ASSERT_TRUE(t.renderFrame(json, MeshSdfMode::Trace, ref));
    size_t count = 0;
    mask = sameSurface(occ, ref, count);
    size_t hits = 0;
    for (float d : ref.depth) hits += d > 0.0f ? 1 : 0;
    const double left = hits ? 1.0 - double(count) / double(hits) : 1.0;
    std::printf("  same-surface pixels %zu of %zu hit pixels (%.2f %% left out)\n", count, hits,
                100.0 * left);
    // Silhouettes and the traced field's rounded edges only: at most 3 % of the hit pixels.
    EXPECT_LE(left, 0.03);
    expectParity("image", compare(occ.image.pixels.data(), ref.image.pixels.data(), 4, mask, count));
    size_t lit = 0;
    const std::vector<bool> sunward = facingSun(occ, ref, mask, lit);
    std::printf("  of which facing the sun %zu\n", lit);
    expectParity("shadow", compare(occ.shadow.data(), ref.shadow.data(), 1, sunward, lit));
    expectParity("ao", compare(occ.ao.data(), ref.ao.data(), 1, mask, count));
}

// Scene (a): the mesh cube casts its shadow and AO onto the SDF floor as the traced cube does.
TEST_P(MeshOcclusionTest, MeshCubeOnSdfFloorMatchesAllSdf) {
    Frame occ, ref, off;
    std::vector<bool> mask;
    std::printf("[%s] mesh cube on an SDF floor, occlusion vs trace:\n", rhi::toString(GetParam()));
    checkAgainstAllSdf(*this, cubeOnSdfFloor(), occ, ref, mask);
    // The cube's shadow exists (not a vacuous match): with --mesh-sdf off it casts none.
    ASSERT_TRUE(renderFrame(cubeOnSdfFloor(), MeshSdfMode::Off, off));
    const std::vector<bool> floorOcc = upFacing(occ), floorOff = upFacing(off);
    const size_t shadowedOcc = countBelow(occ.shadow, floorOcc, 128);
    const size_t shadowedOff = countBelow(off.shadow, floorOff, 128);
    const size_t occludedOcc = countBelow(occ.ao, floorOcc, 200),
                 occludedOff = countBelow(off.ao, floorOff, 200);
    std::printf(
        "  up-facing pixels in shadow (< 128/255): occlusion %zu, off %zu; AO < 200/255: occlusion %zu, "
        "off %zu\n",
        shadowedOcc, shadowedOff, occludedOcc, occludedOff);
    // Shadow on the floor: at least 0.5 % of the frame with occlusion, none without.
    EXPECT_GE(shadowedOcc, size_t(kW) * kH / 200);
    EXPECT_EQ(shadowedOff, 0u);
    // AO on the floor: the contact darkening exists with occlusion (>= 0.5 % of the frame), none without.
    EXPECT_GE(occludedOcc, size_t(kW) * kH / 200);
    EXPECT_EQ(occludedOff, 0u);
}

// Scene (b): the SDF sphere shadows the mesh floor as it shadows the traced floor, and the floor's
// own occlusion field does not shadow the floor (no acne).
TEST_P(MeshOcclusionTest, SdfSphereOverMeshFloorMatchesAllSdf) {
    Frame occ, ref;
    std::vector<bool> mask;
    std::printf("[%s] SDF sphere over a mesh floor, occlusion vs trace:\n", rhi::toString(GetParam()));
    checkAgainstAllSdf(*this, sdfSphereOverMeshFloor(), occ, ref, mask);
    // Acne: pixels fully lit and unoccluded in the all-SDF frame (shadow >= 250/255, AO >= 250/255)
    // that the occlusion frame darkens by more than 8/255.
    size_t open = 0, acneShadow = 0, acneAo = 0;
    for (size_t i = 0; i < mask.size(); ++i) {
        if (!mask[i] || ref.shadow[i] < 250 || ref.ao[i] < 250) continue;
        ++open;
        acneShadow += occ.shadow[i] + 8 < ref.shadow[i] ? 1 : 0;
        acneAo += occ.ao[i] + 8 < ref.ao[i] ? 1 : 0;
    }
    std::printf("  open floor pixels %zu: darker shadow %zu, darker AO %zu\n", open, acneShadow, acneAo);
    ASSERT_GT(open, size_t(kW) * kH / 8);  // precondition: the open slab fills >= 1/8 of the frame
    // No self-shadowing acne: at most 0.1 % of the open pixels darker by more than 8/255.
    EXPECT_LE(double(acneShadow), 0.001 * double(open));
    EXPECT_LE(double(acneAo), 0.001 * double(open));
    const size_t shadowed = countBelow(occ.shadow, upFacing(occ), 128);
    std::printf("  pixels in the sphere's shadow (< 128/255): %zu\n", shadowed);
    EXPECT_GE(shadowed, size_t(kW) * kH / 200);  // the sphere's shadow: >= 0.5 % of the frame
}

// Frame structure: a mesh-only scene in occlusion mode uploads its occluders and runs the effects,
// but traces nothing; occluders are counted apart from traced objects.
TEST_P(MeshOcclusionTest, MeshOnlyFrameRunsEffectsWithoutTrace) {
    const std::string json = std::string(R"({"version": 2, )") + kRenderBlock + R"(,
  "entities": [)" + kLightsAndCamera +
                             R"(,
    {"name": "floor", "transform": {"position": [0, -0.25, 0]},
     "mesh": {"primitive": {"shape": "box", "halfExtents": [3, 0.25, 3]}}},
    {"name": "cube", "transform": {"position": [0, 0.5, 0]}, "mesh": {"primitive": {"shape": "box", "halfExtents": 0.5}}}]})";
    Frame occ;
    ASSERT_TRUE(renderFrame(json, MeshSdfMode::Auto, occ));  // auto: shadows and AO are on
    std::vector<std::string> names;
    for (const fg::PassTiming& p : occ.stats.passes) names.push_back(p.name);
    auto has = [&](const char* n) { return std::find(names.begin(), names.end(), n) != names.end(); };
    std::string list;
    for (const std::string& n : names) list += n + " ";
    std::printf("[%s] passes: %s; sdfObjects %u, sdfOccluders %u, draw calls %u\n", rhi::toString(GetParam()),
                list.c_str(), occ.stats.sdfObjects, occ.stats.sdfOccluders, occ.stats.drawCalls);
    EXPECT_TRUE(has("gbuffer_mesh") && has("sdf_upload") && has("sdf_shadow") && has("sdf_ao")) << list;
    EXPECT_FALSE(has("sdf_trace")) << list;
    EXPECT_EQ(occ.stats.sdfObjects, 0u);
    EXPECT_EQ(occ.stats.sdfOccluders, 2u);
    EXPECT_EQ(occ.stats.drawCalls, 2u);
    // The cube's shadow on the mesh floor: >= 0.25 % of the frame.
    EXPECT_GE(countBelow(occ.shadow, upFacing(occ), 128), size_t(kW) * kH / 400);
}

INSTANTIATE_TEST_SUITE_P(Backends, MeshOcclusionTest, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test
