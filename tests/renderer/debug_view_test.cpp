// The SDF debug views (renderer/features/debug_view.h, debug_field_slice.h), on both backends under
// validation:
// - parsing: --slice plane forms, the view names, the scene's render.debugView / render.slice;
// - a small two-object scene (a sphere and a box, traced, no mesh) at 160x90 shows what each view
//   promises: steps non-black on traced pixels and black where no ray met a bound; ids the hash
//   colour of each entity index (distinct for the two objects) and black background; field-slice
//   "inside" blue at the sphere's centre, "outside" orange between the objects, the white zero line
//   and darker iso-lines, black where the camera ray does not meet the plane; the scene setting
//   alone selects a view and makes the frame write gbuffer.aux; a frame without SDF objects shows
//   the grey plane;
// - goldens per backend of steps, ids, field-slice, normals and depth of scenes/shapes.json, and
//   Vulkan-vs-OpenGL parity with the golden rule (support/golden.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "engine/engine.h"
#include "renderer/features/debug_view.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/test_device.h"
#include "support/test_files.h"

namespace penumbra::test {
namespace {

constexpr uint32_t kWidth = 160, kHeight = 90;

// ---- parsing ----------------------------------------------------------------------------------

TEST(DebugViewParse, SlicePlaneForms) {
    glm::vec4 p;
    std::string error;
    ASSERT_TRUE(render::parseSlicePlane("y=0.5", p, error)) << error;
    EXPECT_EQ(p, glm::vec4(0, 1, 0, 0.5f));
    ASSERT_TRUE(render::parseSlicePlane("x=-2", p, error)) << error;
    EXPECT_EQ(p, glm::vec4(1, 0, 0, -2));
    ASSERT_TRUE(render::parseSlicePlane("0,2,0,0.25", p, error)) << error;  // normalized
    EXPECT_EQ(p, glm::vec4(0, 1, 0, 0.25f));
    ASSERT_TRUE(render::parseSlicePlane("1, 1, 0, 1", p, error)) << error;
    EXPECT_NEAR(p.x, std::sqrt(0.5f), 1e-6f);
    EXPECT_NEAR(p.y, std::sqrt(0.5f), 1e-6f);
    for (const char* bad :
         {"", "y", "y=", "w=1", "y=abc", "1,2,3", "1,2,3,4,5", "0,0,0,1", "1,0,0,nan", "y=0.5x", "1,,0,0"}) {
        error.clear();
        EXPECT_FALSE(render::parseSlicePlane(bad, p, error)) << bad;
        EXPECT_NE(error.find("--slice"), std::string::npos) << bad << ": " << error;
    }
}

TEST(DebugViewParse, NamesRoundTrip) {
    for (const char* name : {"none", "normals", "depth", "albedo", "steps", "ids", "field-slice"}) {
        render::DebugView v = render::DebugView::None;
        ASSERT_TRUE(render::parseDebugView(name, v)) << name;
        EXPECT_STREQ(render::toString(v), name);
    }
    render::DebugView v;
    EXPECT_FALSE(render::parseDebugView("field_slice", v));
    EXPECT_TRUE(render::frameNeedsAux(false, render::DebugView::Ids));
    EXPECT_TRUE(render::frameNeedsAux(false, render::DebugView::Steps));
    EXPECT_FALSE(render::frameNeedsAux(false, render::DebugView::FieldSlice));
    scene::RenderSettings s;
    s.debugView = render::DebugView::Steps;
    EXPECT_EQ(render::frameDebugView(render::DebugView::None, s), render::DebugView::Steps);
    EXPECT_EQ(render::frameDebugView(render::DebugView::Ids, s), render::DebugView::Ids);
}

bool parseRender(const std::string& render, scene::RenderSettings& out, std::string& error) {
    assets::AssetManager assets;
    scene::Scene s;
    const std::string text = R"({"version": 2, "render": )" + render + R"(, "entities": []})";
    if (!scene::parseJsonScene(text, "test.json", ".", assets, s, error)) return false;
    out = s.settings;
    scene::unloadScene(s, assets);
    return true;
}

TEST(DebugViewParse, SceneRenderBlock) {
    scene::RenderSettings s;
    std::string error;
    ASSERT_TRUE(parseRender(R"({"debugView": "field-slice", "slice": {"normal": [0, 0, 2], "offset": -1.5}})",
                            s, error))
        << error;
    EXPECT_EQ(s.debugView, render::DebugView::FieldSlice);
    EXPECT_EQ(s.slice, glm::vec4(0, 0, 1, -1.5f));
    scene::RenderSettings d;
    ASSERT_TRUE(parseRender(R"({"slice": {"normal": [1, 0, 0]}})", d, error)) << error;
    EXPECT_EQ(d.slice, glm::vec4(1, 0, 0, 0));
    EXPECT_EQ(d.debugView, render::DebugView::None);
    const std::pair<const char*, const char*> bad[] = {
        {R"({"debugView": "heat"})", "/render/debugView: unknown debug view 'heat'"},
        {R"({"debugView": 3})", "/render/debugView"},
        {R"({"slice": {"offset": 1}})", "/render/slice: missing \"normal\""},
        {R"({"slice": {"normal": [0, 0, 0]}})", "/render/slice/normal: the normal is zero"},
        {R"({"slice": {"normal": [0, 1, 0], "axis": "y"}})", "/render/slice"},
        {R"({"slice": "y=0.5"})", "/render/slice"},
    };
    for (const auto& [json, message] : bad) {
        scene::RenderSettings x;
        error.clear();
        EXPECT_FALSE(parseRender(json, x, error)) << json;
        EXPECT_NE(error.find(message), std::string::npos) << json << ": " << error;
    }
}

// ---- a small scene ----------------------------------------------------------------------------

// A sphere left and a box right of the origin, camera on +z looking at the origin.
const char* kTwoObjects = R"({
  "version": 2,
  "render": {"camera": "cam"},
  "materials": {"a": {"baseColor": [0.8, 0.2, 0.1]}, "b": {"baseColor": [0.1, 0.3, 0.8]}},
  "entities": [
    {"name": "cam", "transform": {"position": [0, 0, 3.5]}, "camera": {"fovYDegrees": 40, "near": 0.1, "far": 50}},
    {"name": "sphere", "transform": {"position": [-1, 0, 0]},
     "sdf": {"shape": {"shape": "sphere", "radius": 0.6}, "material": "a"}},
    {"name": "box", "transform": {"position": [1, 0, 0]},
     "sdf": {"shape": {"shape": "box", "halfExtents": 0.5}, "material": "b"}}
  ]
})";

struct Loaded {
    std::unique_ptr<Engine> engine;
    render::FrameDesc frame;
    std::string error;
};

Loaded loadPath(const std::string& path) {
    Loaded l;
    EngineDesc desc;
    desc.loadStaticPlugins = false;
    l.engine = Engine::create(desc, l.error);
    if (!l.engine || !l.engine->loadScene(path, l.error)) {
        l.engine.reset();
        return l;
    }
    l.engine->update(0.0);
    l.frame.width = kWidth;
    l.frame.height = kHeight;
    l.frame.settings = l.engine->settings();
    l.frame.camera = scene::findCamera(l.engine->world(), l.engine->settings().camera);
    return l;
}

// Writes `json` (a scene) into the build tree and loads it.
Loaded loadText(const std::string& name, const std::string& json) {
    const std::string dir = PENUMBRA_BINARY_DIR "/debug_view_test";
    std::filesystem::create_directories(dir);
    const std::string path = dir + "/" + name + ".json";
    writeTestFile(path, json);
    return loadPath(path);
}

uint32_t entityIndex(const ecs::World& world, const std::string& name) {
    for (auto [e, n] : world.view<ecs::Name>())
        if (n.value == name) return e.index;
    return UINT32_MAX;
}

// The pixel a world point projects to (the renderer's camera: docs in scene_renderer.cpp).
glm::ivec2 project(const ecs::World& world, ecs::Entity camera, float fovYDegrees, glm::vec3 p) {
    const glm::mat4 cw = world.get<ecs::Transform>(camera)->worldMatrix;
    const glm::vec3 v = glm::vec3(glm::inverse(cw) * glm::vec4(p, 1.0f));
    const float f = 1.0f / std::tan(glm::radians(fovYDegrees) * 0.5f);
    const float ndcX = f / (float(kWidth) / float(kHeight)) * v.x / -v.z;
    const float ndcY = -f * v.y / -v.z;  // NDC y = -1 is row 0
    return {int((ndcX * 0.5f + 0.5f) * kWidth), int((ndcY * 0.5f + 0.5f) * kHeight)};
}

glm::ivec3 at(const ImageRGBA8& img, glm::ivec2 px) {
    const size_t i = (size_t(px.y) * img.width + size_t(px.x)) * 4;
    return {img.pixels[i], img.pixels[i + 1], img.pixels[i + 2]};
}

// The documented id colour: 0.2 + 0.8 * (bytes 0..2 of pcg32(index)) / 255, as 8-bit values.
glm::ivec3 idColour(uint32_t id) {
    const uint32_t state = id * 747796405u + 2891336453u;
    const uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    const uint32_t h = (word >> 22u) ^ word;
    glm::ivec3 c;
    for (int k = 0; k < 3; ++k)
        c[k] = int(std::lround((0.2 + 0.8 * double((h >> (8 * k)) & 255u) / 255.0) * 255.0));
    return c;
}

struct Frame {
    ImageRGBA8 image;
    std::vector<std::string> passes;
    bool auxPresent = false;
};

bool renderFrame(rhi::Device& device, Loaded& l, Frame& out, std::string& error) {
    render::SceneRenderer renderer(device);
    if (!renderer.render(l.engine->world(), l.engine->assets(), l.frame, error) ||
        !renderer.readPixels(out.image, error))
        return false;
    for (const fg::PassTiming& p : renderer.lastFrameStats().passes) out.passes.push_back(p.name);
    std::vector<uint8_t> texels;
    rhi::Format format;
    std::string ignored;
    out.auxPresent = renderer.readTarget("gbuffer.aux", texels, format, ignored);
    device.waitIdle();
    return true;
}

class DebugViews : public GpuTest {
protected:
    void SetUp() override {
        GpuTest::SetUp();
        l = loadText("two_objects", kTwoObjects);
        ASSERT_TRUE(l.engine) << l.error;
        const ecs::World& w = l.engine->world();
        sphere = project(w, l.frame.camera, 40.0f, {-1.0f, 0, 0});
        box = project(w, l.frame.camera, 40.0f, {1.0f, 0, 0});
        between = project(w, l.frame.camera, 40.0f, {0.0f, 1.0f, 0});
        ASSERT_GE(sphere.x, 10);
        ASSERT_LT(box.x, int(kWidth) - 10);
    }
    Frame render(render::DebugView view) {
        l.frame.debugView = view;
        Frame f;
        std::string error;
        EXPECT_TRUE(renderFrame(dev(), l, f, error)) << error;
        return f;
    }
    Loaded l;
    glm::ivec2 sphere, box, between;
    const glm::ivec2 corner{1, 1};
};

TEST_P(DebugViews, StepsHeatMap) {
    Frame f = render(render::DebugView::Steps);
    ASSERT_EQ(f.image.width, kWidth);
    EXPECT_TRUE(f.auxPresent) << "steps must make the frame write gbuffer.aux";
    // Off the sphere's centre the surface lies inside its bounds box, so the ray takes steps (a ray
    // that starts on a surface, e.g. the box's front face at its bounds, hits with 0: black).
    const glm::ivec2 px = project(l.engine->world(), l.frame.camera, 40.0f, {-1.0f, 0.35f, 0.0f});
    const glm::ivec3 c = at(f.image, px);
    EXPECT_GT(c.r + c.g + c.b, 0) << "traced pixel " << px.x << "," << px.y << " is black";
    size_t lit = 0;
    for (size_t i = 0; i + 3 < f.image.pixels.size(); i += 4)
        lit += f.image.pixels[i] + f.image.pixels[i + 1] + f.image.pixels[i + 2] > 0;
    EXPECT_GT(lit, size_t(200));
    EXPECT_EQ(at(f.image, corner), glm::ivec3(0)) << "no bounds met: 0 steps, black";
    EXPECT_NE(std::find(f.passes.begin(), f.passes.end(), "debug_view"), f.passes.end());
}

TEST_P(DebugViews, IdsHashColours) {
    Frame f = render(render::DebugView::Ids);
    EXPECT_TRUE(f.auxPresent);
    const ecs::World& w = l.engine->world();
    const glm::ivec3 a = at(f.image, sphere), b = at(f.image, box);
    EXPECT_NE(a, b);
    for (auto [px, name] : {std::pair{sphere, "sphere"}, std::pair{box, "box"}}) {
        const glm::ivec3 got = at(f.image, px), want = idColour(entityIndex(w, name));
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(got[k], want[k], 1) << name << " channel " << k;
    }
    EXPECT_EQ(at(f.image, corner), glm::ivec3(0)) << "background";
}

TEST_P(DebugViews, FieldSliceInsideOutsideAndLines) {
    l.frame.settings.slice = {0, 0, 1, 0};  // z = 0: through both centres, facing the camera
    Frame f = render(render::DebugView::FieldSlice);
    EXPECT_FALSE(f.auxPresent) << "field-slice does not need gbuffer.aux";
    EXPECT_NE(std::find(f.passes.begin(), f.passes.end(), "debug_field_slice"), f.passes.end());
    const glm::ivec3 in = at(f.image, sphere), in2 = at(f.image, box), out = at(f.image, between);
    EXPECT_GT(in.b, in.r + 40) << "inside the sphere: blue";
    EXPECT_GT(in2.b, in2.r + 40) << "inside the box: blue";
    EXPECT_GT(out.r, out.b + 40) << "between the objects: orange";
    // Along the row through the centres, from the image's left edge to the sphere's centre: the
    // white zero line, and iso-lines (local minima of red among orange pixels).
    int white = 0, minima = 0;
    for (int x = 1; x + 1 < sphere.x; ++x) {
        const glm::ivec3 c = at(f.image, {x, sphere.y});
        if (c.r > 220 && c.g > 220 && c.b > 220) ++white;
        const int left = at(f.image, {x - 1, sphere.y}).r, right = at(f.image, {x + 1, sphere.y}).r;
        if (c.r > c.b && c.r + 20 < std::max(left, right) && c.r <= left && c.r <= right) ++minima;
    }
    EXPECT_GE(white, 1) << "zero line";
    EXPECT_GE(minima, 2) << "iso-lines";
}

TEST_P(DebugViews, FieldSliceOffThePlaneIsBlack) {
    l.frame.settings.slice = {1, 0, 0, 0.5f};  // x = 0.5: the left half of the view never meets it
    Frame f = render(render::DebugView::FieldSlice);
    EXPECT_EQ(at(f.image, {10, int(kHeight) / 2}), glm::ivec3(0));
    const glm::ivec3 right = at(f.image, {int(kWidth) - 10, int(kHeight) / 2});
    EXPECT_GT(right.r + right.g + right.b, 0);
}

TEST_P(DebugViews, SceneSettingSelectsTheView) {
    l.frame.settings.debugView = render::DebugView::Ids;  // render.debugView, FrameDesc::debugView None
    Frame viaScene = render(render::DebugView::None);
    EXPECT_TRUE(viaScene.auxPresent);
    l.frame.settings.debugView = render::DebugView::None;
    Frame viaFrame = render(render::DebugView::Ids);
    EXPECT_EQ(viaScene.image.pixels, viaFrame.image.pixels);
    // FrameDesc::debugView wins over the scene's.
    l.frame.settings.debugView = render::DebugView::Steps;
    Frame wins = render(render::DebugView::Ids);
    EXPECT_EQ(wins.image.pixels, viaFrame.image.pixels);
}

TEST_P(DebugViews, FieldSliceWithoutSdfObjectsIsGrey) {
    Loaded m = loadPath(PENUMBRA_SOURCE_DIR "/scenes/primitives.json");
    ASSERT_TRUE(m.engine) << m.error;
    m.frame.debugView = render::DebugView::FieldSlice;
    m.frame.settings.slice = {0, 1, 0, 0.25f};
    Frame f;
    std::string error;
    ASSERT_TRUE(renderFrame(dev(), m, f, error)) << error;
    size_t grey = 0;
    for (size_t i = 0; i + 3 < f.image.pixels.size(); i += 4)
        grey += f.image.pixels[i] == 128 && f.image.pixels[i + 1] == 128 && f.image.pixels[i + 2] == 128;
    EXPECT_GT(grey, size_t(kWidth * kHeight / 4));
    EXPECT_NE(std::find(f.passes.begin(), f.passes.end(), "debug_field_slice"), f.passes.end());
}

INSTANTIATE_TEST_SUITE_P(Backends, DebugViews, testing::ValuesIn(gpuBackends()), backendName);

// ---- goldens: scenes/shapes.json --------------------------------------------------------------

struct GoldenCase {
    const char* name;
    render::DebugView view;
    size_t minColours;
};
const GoldenCase kGoldens[] = {
    {"debug_sdf_steps", render::DebugView::Steps, 16},
    {"debug_sdf_ids", render::DebugView::Ids, 8},  // eight SDF entities + background
    {"debug_sdf_field_slice", render::DebugView::FieldSlice, 64},
    {"debug_sdf_normals", render::DebugView::Normals, 64},
    {"debug_sdf_depth", render::DebugView::Depth, 32},
    // The effect views (issue 12 item 7), with 9-cone AO switched on for the frame: AO and the
    // shadow of the first shadowed light in grey, the bent normal as normal * 0.5 + 0.5.
    {"debug_sdf_ao", render::DebugView::Ao, 32},
    {"debug_sdf_shadow", render::DebugView::Shadow, 16},
    {"debug_sdf_bentnormal", render::DebugView::BentNormal, 64},
};

bool renderShapes(rhi::Device& device, const GoldenCase& c, ImageRGBA8& image, std::string& error) {
    Loaded l = loadPath(PENUMBRA_SOURCE_DIR "/scenes/shapes.json");
    if (!l.engine) {
        error = l.error;
        return false;
    }
    l.frame.debugView = c.view;
    l.frame.settings.slice = {0, 1, 0, 0.7f};  // --slice y=0.7: through the pillars, boxes, blob and cone
    l.frame.settings.ao.variant = scene::AoVariant::Cones;  // only the effect views show it
    Frame f;
    if (!renderFrame(device, l, f, error)) return false;
    image = std::move(f.image);
    return true;
}

class DebugViewGoldens : public GpuTest {};

TEST_P(DebugViewGoldens, ShapesMatchGoldens) {
    const std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
    for (const GoldenCase& c : kGoldens) {
        ImageRGBA8 image;
        std::string error;
        ASSERT_TRUE(renderShapes(dev(), c, image, error)) << c.name << ": " << error;
        std::set<uint32_t> colours;
        for (size_t i = 0; i + 3 < image.pixels.size(); i += 4)
            colours.insert(uint32_t(image.pixels[i]) | uint32_t(image.pixels[i + 1]) << 8 |
                           uint32_t(image.pixels[i + 2]) << 16);
        EXPECT_GE(colours.size(), c.minColours) << c.name;
        const std::string failure = checkGolden(backend, std::string("scene_") + c.name, image);
        EXPECT_TRUE(failure.empty()) << failure;
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, DebugViewGoldens, testing::ValuesIn(gpuBackends()), backendName);

TEST(DebugViewParity, ShapesVulkanMatchesOpenGL) {
    BackendPair pair;
    ASSERT_TRUE(pair.ready());
    auto& vkDevice = pair.vk;
    auto& glDevice = pair.gl;
    for (const GoldenCase& c : kGoldens) {
        ImageRGBA8 vk, gl;
        std::string error;
        ASSERT_TRUE(renderShapes(*vkDevice, c, vk, error)) << error;
        ASSERT_TRUE(renderShapes(*glDevice, c, gl, error)) << error;
        ImageDiff d = compareImages(vk, gl);
        std::printf("Vulkan vs OpenGL, %s: %s\n", c.name, d.summary().c_str());
        if (!d.pass) {
            const std::string dir = goldenOutDir("parity");
            std::filesystem::create_directories(dir);
            writePng(dir + "/scene_" + std::string(c.name) + ".vulkan.png", vk);
            writePng(dir + "/scene_" + std::string(c.name) + ".gl.png", gl);
            writePng(dir + "/scene_" + std::string(c.name) + ".diff.png", d.diffImage);
        }
        EXPECT_TRUE(d.pass) << c.name << ": " << d.summary();
    }
    pair.expectNoErrors();
}

}  // namespace
}  // namespace penumbra::test
