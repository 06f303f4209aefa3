// Goldens of the SDF effects (issue 12 acceptance: "Goldens on both backends: ... each AO variant,
// soft vs hard shadows, 8 shadowed lights, SSS, reflections, each new debug view; Vulkan-vs-OpenGL
// parity"), each a small scene file written by this test and rendered end to end (scene file ->
// Engine -> SceneRenderer, as tests/renderer/scene_golden_test.cpp) at 160x90, with the golden rule
// of support/golden.h (exact, else per-channel |delta| <= 5/255 for all but 0.1 % of pixels and no
// pixel over 64/255) per backend, and Vulkan-vs-OpenGL parity per case with the same rule.
//
// Shadows and AO run at full effect resolution here (render.shadows / render.ao resolutionScale 1),
// so these goldens show the effect passes themselves, not effects_upsample; the default scene's
// golden (scene_golden_test.cpp, scene_default) renders them at their default scales (0.5, 0.25).
//
//   effects_ao_five_tap     AO scene (spheres, torus, a box on a box and a wall corner on a floor,
//   effects_ao_multi_ray    ambient light only, shadows off): the AO variant five-tap, multi-ray
//   effects_ao_cones        (8 rays at medium) and 9-cone AO with the bent normal
//   effects_shadows_soft    shadow scene (a pillar, a floating sphere, an upright torus) under a sphere
//   effects_shadows_hard    light of radius 0.35 and a sun of angular radius 4 degrees: cone-traced
//                           soft shadows, and the same frame with render.shadows.hard (binary)
//   effects_eight_lights    eight shadowed lights of different colours (four point, four sphere)
//                           in a ring above a sphere, a box and a capsule: eight shadow layers
//   effects_debug_thickness the thickness debug view (t / (t + r) grey) of three subsurface objects
//                           (sphere, slab, smooth blob) of different radii next to an opaque box (black)
// The default scene (scenes/default.json: every effect, subsurface and reflections included) has its
// golden and parity in scene_golden_test.cpp (MeshScene.DefaultMatchesGolden,
// MeshSceneParity.VulkanMatchesOpenGL/default); SSS and reflections lit also in
// sdf_thickness_reflection_test.cpp, the ao / shadow / bentnormal views in debug_view_test.cpp.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/engine.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/test_device.h"
#include "support/test_files.h"

namespace penumbra::test {
namespace {

constexpr uint32_t kWidth = 160, kHeight = 90;

// ---- scenes ------------------------------------------------------------------------------------

// Camera above and in front of the origin, looking down at it.
const char* kCamera =
    R"({"name": "cam", "transform": {"position": [0, 1.9, 3.5], "eulerDegrees": [-22, 0, 0]},
        "camera": {"fovYDegrees": 45, "near": 0.1, "far": 40}})";

// Ambient light only (sky above, darker ground), one weak unshadowed sun: the AO is what shades.
std::string aoScene(const char* variant) {
    return std::string(R"({
  "version": 2,
  "render": {"camera": "cam", "shading": "cook-torrance", "toneMapper": "aces",
             "ambient": [0.12, 0.11, 0.1], "ambientSky": [0.6, 0.65, 0.7], "background": [0.2, 0.22, 0.26],
             "shadows": {"enabled": false},
             "ao": {"variant": ")") +
           variant + R"(", "maxDistance": 1.0, "resolutionScale": 1}},
  "materials": {"white": {"baseColor": [0.8, 0.8, 0.78], "roughness": 0.9},
                "clay": {"baseColor": [0.75, 0.45, 0.3], "roughness": 0.8}},
  "entities": [
    )" + kCamera +
           R"(,
    {"name": "sun", "transform": {"eulerDegrees": [-60, 20, 0]},
     "light": {"type": "directional", "intensity": 0.4, "castShadows": false}},
    {"name": "floor", "sdf": {"shape": {"shape": "plane", "normal": [0, 1, 0], "offset": 0}, "material": "white"}},
    {"name": "corner", "sdf": {"csg": {"op": "union", "children": [
        {"shape": "box", "halfExtents": [1.6, 0.8, 0.1], "transform": {"position": [0, 0.8, -1.5]}},
        {"shape": "box", "halfExtents": [0.1, 0.8, 1.2], "transform": {"position": [-1.7, 0.8, -0.4]}}]},
     "material": "white"}},
    {"name": "ball", "transform": {"position": [-0.9, 0.45, -0.3]},
     "sdf": {"shape": {"shape": "sphere", "radius": 0.45}, "material": "clay"}},
    {"name": "small ball", "transform": {"position": [-0.2, 0.2, 0.4]},
     "sdf": {"shape": {"shape": "sphere", "radius": 0.2}, "material": "clay"}},
    {"name": "ring", "transform": {"position": [0.5, 0.12, 0.5]},
     "sdf": {"shape": {"shape": "torus", "majorRadius": 0.35, "minorRadius": 0.12}, "material": "white"}},
    {"name": "stack", "transform": {"position": [1.0, 0, -0.8], "eulerDegrees": [0, 25, 0]},
     "sdf": {"csg": {"op": "union", "children": [
        {"shape": "box", "halfExtents": [0.4, 0.25, 0.4], "transform": {"position": [0, 0.25, 0]}},
        {"shape": "box", "halfExtents": [0.2, 0.2, 0.2], "transform": {"position": [0.1, 0.7, 0.05]}}]},
     "material": "clay"}}
  ]
})";
}

// A pillar, a floating sphere (its penumbra widens with height) and an upright torus under a sphere
// light and a sun with an angular radius.
std::string shadowScene(bool hard) {
    return std::string(R"({
  "version": 2,
  "render": {"camera": "cam", "shading": "cook-torrance", "toneMapper": "aces",
             "ambient": [0.04, 0.04, 0.05], "background": [0.05, 0.06, 0.08],
             "shadows": {"hard": )") +
           (hard ? "true" : "false") + R"(, "resolutionScale": 1}},
  "materials": {"floor": {"baseColor": [0.7, 0.7, 0.68], "roughness": 0.9},
                "stone": {"baseColor": [0.6, 0.58, 0.55], "roughness": 0.8},
                "red": {"baseColor": [0.8, 0.2, 0.15], "roughness": 0.5},
                "blue": {"baseColor": [0.2, 0.35, 0.8], "roughness": 0.4}},
  "entities": [
    )" + kCamera +
           R"(,
    {"name": "sun", "transform": {"eulerDegrees": [-38, -65, 0]},
     "light": {"type": "directional", "intensity": 1.5, "color": [1.0, 0.95, 0.88], "angularRadiusDegrees": 4}},
    {"name": "bulb", "transform": {"position": [1.6, 2.2, 1.2]},
     "light": {"type": "sphere", "radius": 0.35, "intensity": 8, "color": [1.0, 0.8, 0.6], "range": 10}},
    {"name": "floor", "sdf": {"shape": {"shape": "plane", "normal": [0, 1, 0], "offset": 0}, "material": "floor"}},
    {"name": "pillar", "transform": {"position": [-1.2, 0.7, -0.6]},
     "sdf": {"shape": {"shape": "box", "halfExtents": [0.2, 0.7, 0.2]}, "material": "stone"}},
    {"name": "floating", "transform": {"position": [0.0, 0.9, 0.1]},
     "sdf": {"shape": {"shape": "sphere", "radius": 0.35}, "material": "red"}},
    {"name": "hoop", "transform": {"position": [1.2, 0.5, -0.7], "eulerDegrees": [0, 30, 0]},
     "sdf": {"shape": {"shape": "torus", "majorRadius": 0.38, "minorRadius": 0.1,
                       "transform": {"eulerDegrees": [90, 0, 0]}}, "material": "blue"}}
  ]
})";
}

// Eight shadowed lights in a small ring above the middle (alternately point and sphere lights, hues
// around the wheel) and a sphere, a box and a capsule around it: each object casts eight shadows,
// each lit by the other seven lights (coloured shadows).
std::string eightLightsScene() {
    const char* colours[8] = {"[1, 0.2, 0.2]", "[1, 0.6, 0.1]", "[0.9, 1, 0.2]", "[0.2, 1, 0.3]",
                              "[0.2, 1, 0.9]", "[0.2, 0.4, 1]", "[0.6, 0.2, 1]", "[1, 0.2, 0.8]"};
    std::string lights;
    for (int i = 0; i < 8; ++i) {
        const double a = 2.0 * 3.14159265358979 * (i + 0.5) / 8.0;
        char buf[512];
        std::snprintf(buf, sizeof buf,
                      R"({"name": "light %d", "transform": {"position": [%.4f, %.2f, %.4f]},
     "light": {"type": "%s", %s"intensity": 1.0, "color": %s, "range": 8}},
    )",
                      i, 0.8 * std::cos(a), i % 2 ? 2.0 : 2.3, 0.8 * std::sin(a) - 0.2,
                      i % 2 ? "point" : "sphere", i % 2 ? "" : R"("radius": 0.1, )", colours[i]);
        lights += buf;
    }
    return std::string(R"({
  "version": 2,
  "render": {"camera": "cam", "shading": "cook-torrance", "toneMapper": "aces",
             "ambient": [0.02, 0.02, 0.02], "background": [0.02, 0.02, 0.03],
             "shadows": {"resolutionScale": 1}},
  "materials": {"white": {"baseColor": [0.8, 0.8, 0.8], "roughness": 0.7}},
  "entities": [
    )") + kCamera +
           ",\n    " + lights +
           R"({"name": "floor", "sdf": {"shape": {"shape": "plane", "normal": [0, 1, 0], "offset": 0}, "material": "white"}},
    {"name": "ball", "transform": {"position": [0, 0.35, -0.8]},
     "sdf": {"shape": {"shape": "sphere", "radius": 0.35}, "material": "white"}},
    {"name": "block", "transform": {"position": [-0.8, 0.25, 0.2], "eulerDegrees": [0, 30, 0]},
     "sdf": {"shape": {"shape": "box", "halfExtents": [0.2, 0.25, 0.2]}, "material": "white"}},
    {"name": "post", "transform": {"position": [0.8, 0.55, 0.2]},
     "sdf": {"shape": {"shape": "capsule", "radius": 0.15, "halfLength": 0.4}, "material": "white"}}
  ]
})";
}

// Subsurface objects of different radii (a sphere, a thin slab, a smooth-CSG blob) and an opaque box; the
// thickness debug view (render.debugView).
std::string thicknessScene() {
    return std::string(R"({
  "version": 2,
  "render": {"camera": "cam", "debugView": "thickness"},
  "materials": {
    "wax": {"baseColor": [0.9, 0.85, 0.7], "subsurface": 0.8, "subsurfaceColor": [1, 0.6, 0.3], "subsurfaceRadius": 0.4},
    "jade": {"baseColor": [0.2, 0.55, 0.35], "subsurface": 0.6, "subsurfaceColor": [0.4, 1, 0.6], "subsurfaceRadius": 0.1},
    "skin": {"baseColor": [0.8, 0.5, 0.4], "subsurface": 0.5, "subsurfaceColor": [1, 0.3, 0.2], "subsurfaceRadius": 0.2},
    "opaque": {"baseColor": [0.5, 0.5, 0.5]}},
  "entities": [
    )") + kCamera +
           R"(,
    {"name": "sun", "transform": {"eulerDegrees": [-50, 30, 0]}, "light": {"type": "directional", "intensity": 2}},
    {"name": "floor", "sdf": {"shape": {"shape": "plane", "normal": [0, 1, 0], "offset": 0}, "material": "opaque"}},
    {"name": "wax ball", "transform": {"position": [-1.1, 0.55, -0.2]},
     "sdf": {"shape": {"shape": "sphere", "radius": 0.55}, "material": "wax"}},
    {"name": "jade slab", "transform": {"position": [-0.1, 0.5, -0.5], "eulerDegrees": [0, -20, 0]},
     "sdf": {"shape": {"shape": "roundedBox", "halfExtents": [0.35, 0.5, 0.05], "rounding": 0.03}, "material": "jade"}},
    {"name": "skin blob", "transform": {"position": [0.9, 0.35, -0.2]},
     "sdf": {"csg": {"op": "union", "smoothRadius": 0.25, "children": [
        {"shape": "sphere", "radius": 0.3, "transform": {"position": [-0.2, 0, 0]}},
        {"shape": "sphere", "radius": 0.2, "transform": {"position": [0.25, 0.15, 0.1]}},
        {"shape": "torus", "majorRadius": 0.3, "minorRadius": 0.06, "transform": {"position": [0, 0.3, 0], "eulerDegrees": [70, 0, 0]}}]},
      "material": "skin"}},
    {"name": "opaque box", "transform": {"position": [0.3, 0.2, 0.5], "eulerDegrees": [0, 20, 0]},
     "sdf": {"shape": {"shape": "box", "halfExtents": 0.2}, "material": "opaque"}}
  ]
})";
}

struct EffectCase {
    const char* name;  // golden: tests/golden/<backend>/<name>.png
    std::string (*scene)();
    const char* pass;  // an effect pass the frame must run
};

const EffectCase kCases[] = {
    {"effects_ao_five_tap", [] { return aoScene("five-tap"); }, "sdf_ao"},
    {"effects_ao_multi_ray", [] { return aoScene("multi-ray"); }, "sdf_ao"},
    {"effects_ao_cones", [] { return aoScene("cones"); }, "sdf_ao"},
    {"effects_shadows_soft", [] { return shadowScene(false); }, "sdf_shadow"},
    {"effects_shadows_hard", [] { return shadowScene(true); }, "sdf_shadow"},
    {"effects_eight_lights", eightLightsScene, "sdf_shadow"},
    {"effects_debug_thickness", thicknessScene, "sdf_thickness"},
};

// ---- rendering ---------------------------------------------------------------------------------

struct Rendered {
    bool ok = false;
    std::string error;
    ImageRGBA8 image;
    std::vector<std::string> passes;
    uint32_t shadowLayers = 0;  // of effects.shadow (0: none)
};

Rendered renderCase(rhi::Device& device, const EffectCase& c) {
    Rendered r;
    const std::string dir = PENUMBRA_BINARY_DIR "/effects_golden_test";
    std::filesystem::create_directories(dir);
    const std::string path = dir + "/" + c.name + ".json";
    writeTestFile(path, c.scene());
    EngineDesc desc;
    desc.loadStaticPlugins = false;
    auto engine = Engine::create(desc, r.error);
    if (!engine || !engine->loadScene(path, r.error)) return r;
    engine->update(0.0);
    render::SceneRenderer renderer(device);
    render::FrameDesc frame;
    frame.width = kWidth;
    frame.height = kHeight;
    frame.settings = engine->settings();
    frame.camera = scene::findCamera(engine->world(), engine->settings().camera);
    if (frame.camera == ecs::kNullEntity) {
        r.error = "no camera";
        return r;
    }
    r.ok = renderer.render(engine->world(), engine->assets(), frame, r.error) &&
           renderer.readPixels(r.image, r.error);
    if (r.ok) {
        for (const fg::PassTiming& p : renderer.lastFrameStats().passes) r.passes.push_back(p.name);
        std::vector<uint8_t> texels;
        rhi::Format format{};
        std::string ignored;
        if (renderer.readTarget("effects.shadow", texels, format, ignored))
            r.shadowLayers = uint32_t(texels.size() / (size_t(kWidth) * kHeight));
    }
    device.waitIdle();
    return r;
}

size_t distinctColours(const ImageRGBA8& image) {
    std::set<uint32_t> colours;
    for (size_t i = 0; i + 3 < image.pixels.size(); i += 4)
        colours.insert(uint32_t(image.pixels[i]) | uint32_t(image.pixels[i + 1]) << 8 |
                       uint32_t(image.pixels[i + 2]) << 16);
    return colours.size();
}

bool ranPass(const Rendered& r, const std::string& name) {
    return std::find(r.passes.begin(), r.passes.end(), name) != r.passes.end();
}

// ---- goldens per backend -----------------------------------------------------------------------

class EffectsGolden : public GpuTest {
protected:
    Rendered check(const EffectCase& c) {
        Rendered r = renderCase(dev(), c);
        EXPECT_TRUE(r.ok) << c.name << ": " << r.error;
        if (!r.ok) return r;
        EXPECT_EQ(r.image.width, kWidth);
        EXPECT_EQ(r.image.height, kHeight);
        // Independent of the golden: the effect ran, and the frame is not flat.
        EXPECT_TRUE(ranPass(r, c.pass)) << c.name << " ran no " << c.pass << " pass";
        EXPECT_GE(distinctColours(r.image), 32u) << c.name;
        const std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
        const std::string failure = checkGolden(backend, c.name, r.image);
        EXPECT_TRUE(failure.empty()) << failure;
        return r;
    }
};

TEST_P(EffectsGolden, AoFiveTap) { check(kCases[0]); }
TEST_P(EffectsGolden, AoMultiRay) { check(kCases[1]); }
TEST_P(EffectsGolden, AoCones) { check(kCases[2]); }

TEST_P(EffectsGolden, ShadowsSoftAndHard) {
    const Rendered soft = check(kCases[3]);
    const Rendered hard = check(kCases[4]);
    ASSERT_TRUE(soft.ok && hard.ok);
    EXPECT_EQ(soft.shadowLayers, 2u);
    EXPECT_EQ(hard.shadowLayers, 2u);
    // The two frames differ in the penumbrae: hard visibility is binary, soft is not.
    const ImageDiff d = compareImages(hard.image, soft.image);
    std::printf("  hard vs soft shadows: %s\n", d.summary().c_str());
    EXPECT_GT(d.pixelsOver, uint64_t(kWidth * kHeight / 100)) << "hard and soft shadows look alike";
}

TEST_P(EffectsGolden, EightShadowedLights) {
    const Rendered r = check(kCases[5]);
    ASSERT_TRUE(r.ok);
    EXPECT_EQ(r.shadowLayers, 8u) << "one shadow layer per shadowed light";
    EXPECT_GE(distinctColours(r.image), 256u) << "eight coloured lights";
}

TEST_P(EffectsGolden, ThicknessDebugView) {
    const Rendered r = check(kCases[6]);
    ASSERT_TRUE(r.ok);
    EXPECT_TRUE(ranPass(r, "debug_view"));
    // The opaque floor is black (no thickness), the subsurface objects grey.
    size_t black = 0, grey = 0;
    for (size_t i = 0; i + 3 < r.image.pixels.size(); i += 4) {
        const int v = r.image.pixels[i];
        black += v == 0;
        grey += v > 20 && v == r.image.pixels[i + 1] && v == r.image.pixels[i + 2];
    }
    EXPECT_GT(black, size_t(kWidth * kHeight / 4));
    EXPECT_GT(grey, size_t(kWidth * kHeight / 20));
}

INSTANTIATE_TEST_SUITE_P(Backends, EffectsGolden, testing::ValuesIn(gpuBackends()), backendName);

// ---- Vulkan-vs-OpenGL parity per case, same rule -----------------------------------------------

class EffectsGoldenParity : public testing::TestWithParam<int> {};

TEST_P(EffectsGoldenParity, VulkanMatchesOpenGL) {
    const EffectCase& c = kCases[GetParam()];
    BackendPair pair;
    ASSERT_TRUE(pair.ready());
    auto& vkDevice = pair.vk;
    auto& glDevice = pair.gl;
    const Rendered vk = renderCase(*vkDevice, c);
    const Rendered gl = renderCase(*glDevice, c);
    ASSERT_TRUE(vk.ok) << vk.error;
    ASSERT_TRUE(gl.ok) << gl.error;
    pair.expectNoErrors();
    const ImageDiff d = compareImages(vk.image, gl.image);
    std::printf("Vulkan vs OpenGL, %s (%ux%u): %s\n", c.name, kWidth, kHeight, d.summary().c_str());
    RecordProperty("max_delta", d.maxDelta);
    RecordProperty("mean_delta", std::to_string(d.meanDelta));
    if (!d.pass) {
        const std::string dir = goldenOutDir("parity");
        std::filesystem::create_directories(dir);
        writePng(dir + "/" + c.name + ".vulkan.png", vk.image);
        writePng(dir + "/" + c.name + ".gl.png", gl.image);
        writePng(dir + "/" + c.name + ".diff.png", d.diffImage);
    }
    EXPECT_TRUE(d.pass) << d.summary();
}

INSTANTIATE_TEST_SUITE_P(Cases, EffectsGoldenParity, testing::Range(0, int(std::size(kCases))),
                         [](const testing::TestParamInfo<int>& info) {
                             return std::string(kCases[info.param].name);
                         });

}  // namespace
}  // namespace penumbra::test
