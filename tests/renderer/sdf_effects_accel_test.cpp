// Acceleration of the SDF effects (issue 13 items 1 and 3, effects side: renderer/features/
// sdf_effects_cull.h, renderer/shaders/sdf_cone.glsl, sdf_shadow.comp, sdf_ao.comp) on both backends
// under validation. Each scene is rendered lit at 160x90 with the acceleration toggles
//   off       culling, world cache, id field all off (every casting object at every step)
//   culling   the shadow / AO tile lists only
//   cache     world cache only
//   ids       id field only
//   all       every toggle on (the default)
// and every accelerated frame is compared with the unaccelerated one. Shadows and AO run at full
// resolution here (resolutionScale 1: no upsampling), so each effect pixel depends only on its own
// G-buffer pixel, and the comparisons are made over the pixels whose G-buffer (depth and normal) is
// bitwise the same in both frames: the primary trace's own acceleration (sdf_trace, another module,
// with its own parity tests) moves depths by a few 1e-4 at thousands of pixels, and the shadow
// estimator turns some of those moves into 0 <-> 1 flips at contact points. On those pixels:
//   - the lit image within the parity rule (support/golden.h default ImageRule: per-channel
//     |delta| <= 5/255 for all but 0.1 % of the pixels, none over 64/255);
//   - the effect targets effects.shadow and effects.ao (SceneRenderer::readTarget): mean per-byte
//     |delta| <= 2/255; the per-texel parity numbers are printed. AO is bitwise equal (culled and unculled AO
//     count the same occluders: those within maxDistance of the point); shadows differ in a few texels
//     because the per-ray cull (sdfConeCull) skips objects the cone has left, which moves the later march
//     samples (soft shadows up to ~20/255 in 0.1-0.3 % of the texels, a hard ray's flip at a contact point);
//     the world cache (hard rays only: sdf_cone.glsl says why) and the id field leave them bitwise equal;
//   - the mesh-occluder scene traces nothing: there the G-buffer must agree everywhere (100 % of
//     the pixels compared), so its checks are whole-frame;
//   - the lists cull: the mean length of the lists of tiles with a surface (the pass's counters,
//     SceneRenderer::readBuffer "sdf.effects_cull_counters") is below the frame's object count, and
//     no list ran past the indices' capacity.
// The whole-frame comparison is printed for every scene as well.
// Scenes: scenes/default.json (meshes with occlusion fields, sun + two point lights, cone AO),
// scenes/lights.json (directional, point and sphere light, all shadowed, cone AO), a generated
// grid of 24 objects (sun with an angular radius and a sphere light, five-tap AO) and the same kind
// of grid as rasterized meshes with occlusion fields (cone AO).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/engine.h"
#include "engine/scene/mesh_sdf.h"
#include "renderer/scene_renderer.h"
#include "support/accel_toggles.h"
#include "support/golden.h"
#include "support/test_device.h"
#include "support/test_files.h"

namespace penumbra::test {
namespace {

constexpr uint32_t kWidth = 160, kHeight = 90;

const AccelToggles kOff{"off", false, false, false};
const AccelToggles kAccelerated[] = {
    {"culling", true, false, false},
    {"cache", false, true, false},
    {"ids", false, false, true},
    {"all", true, true, true},
};

struct Frame {
    bool ok = false;
    std::string error;
    ImageRGBA8 image;
    std::vector<uint8_t> shadow, ao;  // effect targets (empty: not written)
    std::vector<float> depth;         // gbuffer.depth
    std::vector<uint8_t> normal;      // gbuffer.normal bytes
    uint32_t counters[4] = {};        // sdf.effects_cull_counters (culling frames)
    bool haveCounters = false;
    uint32_t objects = 0;  // SDF objects of the frame (traced + occluders)
    uint64_t tileListBytes = 0;
    uint64_t tileListScratchBytes = 0;
    uint64_t graphCullBytes = 0;  // the culling's buffers as the frame graph declared them
};

// The bytes of the frame graph's buffers that the tile culling passes create (sdf_tile_cull*,
// sdf_tile_cull_effects*: named sdf.tile_*, sdf.effects_*, sdf.shadow_tile_*, sdf.ao_tile_*), read
// from the Graphviz dump, whose resource labels are "NAME\nN bytes...".
uint64_t cullBufferBytes(const std::string& dot) {
    uint64_t total = 0;
    for (size_t at = dot.find("label=\""); at != std::string::npos; at = dot.find("label=\"", at + 1)) {
        const size_t start = at + 7, end = dot.find("\\n", start);
        if (end == std::string::npos) continue;
        const std::string name = dot.substr(start, end - start);
        const bool cull = name.rfind("sdf.tile_", 0) == 0 || name.rfind("sdf.effects_", 0) == 0 ||
                          name.rfind("sdf.shadow_tile_", 0) == 0 || name.rfind("sdf.ao_tile_", 0) == 0;
        const size_t bytes = dot.find(" bytes", end);
        if (cull && bytes != std::string::npos) total += std::stoull(dot.substr(end + 2, bytes - end - 2));
    }
    return total;
}

// A 6 x 4 grid of small objects on a floor under a sun (angular radius 3 deg) and a sphere light.
std::string gridScene() {
    std::string objects;
    for (int z = 0; z < 4; ++z)
        for (int x = 0; x < 6; ++x) {
            char buf[400];
            const bool ball = (x + z) % 2 == 0;
            std::snprintf(buf, sizeof buf,
                          R"(,
    {"name": "o%d_%d", "transform": {"position": [%.2f, %.2f, %.2f], "eulerDegrees": [0, %d, 0]},
     "sdf": {"shape": %s, "material": "%s"}})",
                          x, z, -2.5 + x, ball ? 0.3 : 0.25, -3.0 + 1.1 * z, 17 * (x + z),
                          ball ? R"({"shape": "sphere", "radius": 0.3})"
                               : R"({"shape": "box", "halfExtents": [0.25, 0.25, 0.25]})",
                          ball ? "red" : "white");
            objects += buf;
        }
    return std::string(R"({
  "version": 2,
  "render": {"camera": "cam", "shading": "cook-torrance", "toneMapper": "aces",
             "ambient": [0.05, 0.05, 0.06], "ambientSky": [0.2, 0.22, 0.25], "background": [0.02, 0.02, 0.03],
             "ao": {"variant": "five-tap", "maxDistance": 0.6}},
  "materials": {"white": {"baseColor": [0.8, 0.8, 0.78], "roughness": 0.8},
                "red": {"baseColor": [0.8, 0.25, 0.2], "roughness": 0.6}},
  "entities": [
    {"name": "cam", "transform": {"position": [0, 2.6, 3.2], "eulerDegrees": [-32, 0, 0]},
     "camera": {"fovYDegrees": 50, "near": 0.1, "far": 40}},
    {"name": "sun", "transform": {"eulerDegrees": [-40, 35, 0]},
     "light": {"type": "directional", "intensity": 2, "angularRadiusDegrees": 3}},
    {"name": "bulb", "transform": {"position": [0.5, 1.2, -1.2]},
     "light": {"type": "sphere", "radius": 0.2, "intensity": 4, "range": 6}},
    {"name": "floor", "sdf": {"shape": {"shape": "plane", "normal": [0, 1, 0], "offset": 0}, "material": "white"}})") +
           objects + R"(
  ]
})";
}

// The same layout (4 x 3) as rasterized meshes with occlusion fields (render.meshSdf occlusion):
// no object is traced, so the G-buffer is the mesh pass's whatever the toggles, and the frames differ
// only in what the effects' own acceleration does.
std::string meshGridScene() {
    std::string objects;
    for (int z = 0; z < 3; ++z)
        for (int x = 0; x < 4; ++x) {
            char buf[400];
            const bool ball = (x + z) % 2 == 0;
            std::snprintf(buf, sizeof buf,
                          R"(,
    {"name": "m%d_%d", "transform": {"position": [%.2f, %.2f, %.2f], "eulerDegrees": [0, %d, 0]},
     "mesh": {"primitive": %s, "material": "%s"}})",
                          x, z, -1.8 + 1.2 * x, ball ? 0.3 : 0.25, -2.6 + 1.1 * z, 17 * (x + z),
                          ball ? R"({"shape": "sphere", "radius": 0.3, "segments": 24, "rings": 12})"
                               : R"({"shape": "box", "halfExtents": 0.25})",
                          ball ? "red" : "white");
            objects += buf;
        }
    return std::string(R"({
  "version": 2,
  "render": {"camera": "cam", "shading": "cook-torrance", "toneMapper": "aces", "meshSdf": "occlusion",
             "ambient": [0.05, 0.05, 0.06], "ambientSky": [0.2, 0.22, 0.25], "background": [0.02, 0.02, 0.03],
             "ao": {"variant": "cones", "maxDistance": 0.6}},
  "materials": {"white": {"baseColor": [0.8, 0.8, 0.78], "roughness": 0.8},
                "red": {"baseColor": [0.8, 0.25, 0.2], "roughness": 0.6}},
  "entities": [
    {"name": "cam", "transform": {"position": [0, 2.4, 2.6], "eulerDegrees": [-35, 0, 0]},
     "camera": {"fovYDegrees": 50, "near": 0.1, "far": 40}},
    {"name": "sun", "transform": {"eulerDegrees": [-40, 35, 0]},
     "light": {"type": "directional", "intensity": 2, "angularRadiusDegrees": 3}},
    {"name": "bulb", "transform": {"position": [0.5, 1.2, -1.2]},
     "light": {"type": "sphere", "radius": 0.2, "intensity": 4, "range": 6}},
    {"name": "floor", "transform": {"position": [0, -0.1, -1.5]},
     "mesh": {"primitive": {"shape": "box", "halfExtents": [3, 0.1, 2.5]}, "material": "white"}})") +
           objects + R"(
  ]
})";
}

std::string scenePath(const std::string& name) {
    if (name == "grid" || name == "meshes") {
        const std::string dir = PENUMBRA_BINARY_DIR "/sdf_effects_accel_test";
        std::filesystem::create_directories(dir);
        const std::string path = dir + "/" + name + ".json";
        writeTestFile(path, name == "grid" ? gridScene() : meshGridScene());
        return path;
    }
    return std::string(PENUMBRA_SOURCE_DIR "/scenes/") + name + ".json";
}

Frame renderFrame(rhi::Device& device, Engine& engine, const AccelToggles& t) {
    Frame f;
    render::SceneRenderer renderer(device);
    render::FrameDesc frame;
    frame.width = kWidth;
    frame.height = kHeight;
    frame.settings = engine.settings();
    t.applyTo(frame.settings.acceleration);
    frame.settings.acceleration.prepass = false;
    frame.settings.shadows.resolutionScale = 1.0f;  // no upsampling: an effect pixel reads its own G-buffer
    frame.settings.ao.resolutionScale = 1.0f;
    frame.camera = scene::findCamera(engine.world(), engine.settings().camera);
    if (frame.camera == ecs::kNullEntity) {
        f.error = "no camera";
        return f;
    }
    f.ok = renderer.render(engine.world(), engine.assets(), frame, f.error) &&
           renderer.readPixels(f.image, f.error);
    if (!f.ok) return f;
    rhi::Format format{};
    std::string ignored;
    if (!renderer.readTarget("effects.shadow", f.shadow, format, ignored)) f.shadow.clear();
    if (!renderer.readTarget("effects.ao", f.ao, format, ignored)) f.ao.clear();
    std::vector<uint8_t> depth;
    if (renderer.readTarget("gbuffer.depth", depth, format, ignored)) {
        f.depth.resize(depth.size() / 4);
        std::memcpy(f.depth.data(), depth.data(), f.depth.size() * 4);
    }
    if (!renderer.readTarget("gbuffer.normal", f.normal, format, ignored)) f.normal.clear();
    std::vector<uint8_t> bytes;
    if (renderer.readBuffer("sdf.effects_cull_counters", bytes, ignored) &&
        bytes.size() >= sizeof f.counters) {
        std::memcpy(f.counters, bytes.data(), sizeof f.counters);
        f.haveCounters = true;
    }
    const render::FrameStats& stats = renderer.lastFrameStats();
    f.objects = stats.sdfObjects + stats.sdfOccluders;
    f.tileListBytes = stats.tileListBytes;
    f.tileListScratchBytes = stats.tileListScratchBytes;
    f.graphCullBytes = cullBufferBytes(renderer.lastFrameGraphviz());
    device.waitIdle();
    return f;
}

// The G-buffer pixels (kWidth x kHeight) whose depth and normal are bitwise equal in both frames.
std::vector<char> sameGBuffer(const Frame& a, const Frame& b) {
    std::vector<char> mask(size_t(kWidth) * kHeight, 0);
    if (a.depth.size() != mask.size() || b.depth.size() != mask.size() || a.normal.size() != b.normal.size())
        return mask;
    const size_t nb = a.normal.size() / mask.size();
    for (size_t i = 0; i < mask.size(); ++i)
        mask[i] = std::memcmp(&a.depth[i], &b.depth[i], 4) == 0 &&
                  std::memcmp(&a.normal[i * nb], &b.normal[i * nb], nb) == 0;
    return mask;
}

// The parity rule (ImageRule's numbers) over masked texels of an image of `channels` bytes per
// texel and `width` texels per row; texel (x, y) belongs to G-buffer pixel (x mod kWidth, y).
struct MaskedDiff {
    size_t texels = 0, over = 0;
    int maxDelta = 0;
    double mean = 0.0;  // per byte
    bool pass() const {
        const ImageRule rule;
        return texels > 0 && maxDelta <= rule.hardLimit &&
               double(over) <= rule.maxFractionOver * double(texels);
    }
    std::string summary() const {
        char buf[160];
        std::snprintf(buf, sizeof buf, "max %d/255, mean %.4f/255, %zu of %zu texels (%.4f %%) over 5/255",
                      maxDelta, mean, over, texels, texels ? 100.0 * double(over) / double(texels) : 0.0);
        return buf;
    }
};

MaskedDiff compareMasked(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, uint32_t channels,
                         const std::vector<char>& mask) {
    MaskedDiff d;
    if (a.size() != b.size() || a.empty()) return d;
    const size_t texels = a.size() / channels, width = texels / kHeight;
    double sum = 0.0;
    for (size_t t = 0; t < texels; ++t) {
        if (!mask[(t / width) * kWidth + (t % width) % kWidth]) continue;
        int worst = 0;
        for (uint32_t c = 0; c < channels; ++c) {
            const int delta = std::abs(int(a[t * channels + c]) - int(b[t * channels + c]));
            worst = std::max(worst, delta);
            sum += delta;
        }
        ++d.texels;
        d.over += worst > ImageRule{}.perChannelTolerance;
        d.maxDelta = std::max(d.maxDelta, worst);
    }
    d.mean = d.texels ? sum / (double(d.texels) * channels) : 0.0;
    return d;
}

void compareTarget(const std::string& scene, const char* toggles, const char* target,
                   const std::vector<uint8_t>& off, const std::vector<uint8_t>& on, uint32_t channels,
                   const std::vector<char>& mask) {
    ASSERT_FALSE(off.empty()) << scene << ": " << target << " was not written";
    ASSERT_EQ(off.size(), on.size()) << scene << " " << toggles << " " << target;
    const MaskedDiff d = compareMasked(on, off, channels, mask);
    std::printf("  %-8s %-8s %-15s %s\n", scene.c_str(), toggles, target, d.summary().c_str());
    EXPECT_LE(d.mean, 2.0) << scene << " " << toggles << " " << target << ": mean |delta| <= 2/255";
}

class SdfEffectsAccel : public GpuTest {
protected:
    void check(const std::string& name) {
        if (name == "default" && !std::filesystem::exists(PENUMBRA_SOURCE_DIR "/data/meshes/bunny.ply"))
            GTEST_SKIP() << "data/meshes is missing: run tools/fetch_meshes.sh";
        EngineDesc desc;
        desc.loadStaticPlugins = false;
        desc.cacheDir = PENUMBRA_BINARY_DIR "/test_cache";  // the default scene bakes its meshes once
        std::string error;
        auto engine = Engine::create(desc, error);
        ASSERT_TRUE(engine) << error;
        ASSERT_TRUE(engine->loadScene(scenePath(name), error)) << error;
        ASSERT_TRUE(scene::applyMeshSdf(engine->scene(), engine->assets(), engine->settings().meshSdf, error))
            << error;
        engine->update(0.0);

        const Frame off = renderFrame(dev(), *engine, kOff);
        ASSERT_TRUE(off.ok) << name << " off: " << off.error;
        EXPECT_FALSE(off.haveCounters) << name << ": culling off builds no effect lists";
        for (const AccelToggles& t : kAccelerated) {
            const Frame on = renderFrame(dev(), *engine, t);
            ASSERT_TRUE(on.ok) << name << " " << t.name << ": " << on.error;
            const std::vector<char> mask = sameGBuffer(off, on);
            const size_t same = size_t(std::count(mask.begin(), mask.end(), 1));
            const ImageDiff whole = compareImages(on.image, off.image);
            std::printf("  %-8s %-8s whole frame    %s; G-buffer identical at %zu of %zu px\n", name.c_str(),
                        t.name, whole.summary().c_str(), same, mask.size());
            if (name == "meshes") {  // nothing traced: the G-buffer is the mesh pass's in every frame
                EXPECT_EQ(same, mask.size()) << "mesh scene: identical G-buffer at every pixel";
            }
            EXPECT_GE(same, mask.size() / 10)
                << name << " " << t.name << ": at least 10 % of the pixels compared";
            std::vector<uint8_t> litOff(off.image.pixels), litOn(on.image.pixels);
            const MaskedDiff lit = compareMasked(litOn, litOff, 4, mask);
            std::printf("  %-8s %-8s lit image      %s\n", name.c_str(), t.name, lit.summary().c_str());
            EXPECT_TRUE(lit.pass()) << name << " " << t.name << " vs off: parity rule, " << lit.summary();
            compareTarget(name, t.name, "effects.shadow", off.shadow, on.shadow, 1, mask);
            compareTarget(name, t.name, "effects.ao", off.ao, on.ao, 4, mask);
            if (!t.culling) continue;
            ASSERT_TRUE(on.haveCounters) << name << " " << t.name << ": no effect lists were built";
            const uint32_t lists = on.counters[3], total = on.counters[2], over = on.counters[1];
            const double mean = lists ? double(total) / lists : 0.0;
            std::printf(
                "  %-8s %-8s lists: %u of surface tiles, mean length %.2f of %u objects, %u over capacity, "
                "%llu list bytes (all kinds)\n",
                name.c_str(), t.name, lists, mean, on.objects, over,
                static_cast<unsigned long long>(on.tileListBytes));
            EXPECT_GT(lists, 0u) << name << ": tiles with a surface have lists";
            EXPECT_LT(mean, double(on.objects))
                << name << ": mean list length < object count (the lists cull)";
            EXPECT_EQ(over, 0u) << name << ": no list past the capacity (<= 32 objects: the exact bound)";
            EXPECT_GT(on.tileListBytes, 0u) << name << ": FrameStats::tileListBytes counts the lists";
            // The lists and the culling's working buffers together are every buffer the culling
            // passes declared (exact: the stats are computed from the same sizes).
            EXPECT_EQ(on.tileListBytes + on.tileListScratchBytes, on.graphCullBytes)
                << name << ": FrameStats::tileListScratchBytes counts the rest of the culling's buffers";
        }
    }
};

TEST_P(SdfEffectsAccel, DefaultScene) { check("default"); }
TEST_P(SdfEffectsAccel, LightsScene) { check("lights"); }
TEST_P(SdfEffectsAccel, GridScene) { check("grid"); }
TEST_P(SdfEffectsAccel, MeshOccluderScene) { check("meshes"); }

INSTANTIATE_TEST_SUITE_P(Backends, SdfEffectsAccel, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test
