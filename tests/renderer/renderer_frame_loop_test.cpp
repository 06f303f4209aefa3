// The renderer architecture's promises, on both backends under validation:
// - steady state: rendering the same scene frame after frame creates no pipeline and no bind group
//   after frame 2 (counted by the RHI, Device::stats());
// - timings: a 20-frame loop that takes its timings without waiting performs no blocking
//   timestamp read (RHI counter), and after the run every frame's timings have arrived, each
//   listing every pass of the frame;
// - debug views: `normals`, `depth` and `albedo` of the materials scene (it has an albedo target)
//   and of the primitives scene (no albedo target: base colour from the material) match their
//   goldens per backend, and Vulkan matches OpenGL with the golden rule (support/golden.h).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>

#include <gtest/gtest.h>

#include "engine/engine.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

constexpr uint32_t kWidth = 160, kHeight = 90;

struct Loaded {
    std::unique_ptr<Engine> engine;
    render::FrameDesc frame;
    std::string error;
};

Loaded load(const char* scenePath) {
    Loaded l;
    EngineDesc desc;
    desc.loadStaticPlugins = false;
    l.engine = Engine::create(desc, l.error);
    if (!l.engine || !l.engine->loadScene(std::string(PENUMBRA_SOURCE_DIR "/") + scenePath, l.error)) {
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

class RendererFrameLoop : public GpuTest {};

TEST_P(RendererFrameLoop, NoCreationsAfterFrameTwo) {
    Loaded l = load("scenes/materials.json");
    ASSERT_TRUE(l.engine) << l.error;
    render::SceneRenderer renderer(dev());
    rhi::DeviceStats afterTwo{};
    for (int frame = 0; frame < 10; ++frame) {
        l.engine->update(0.1);
        std::string error;
        ASSERT_TRUE(renderer.render(l.engine->world(), l.engine->assets(), l.frame, error)) << error;
        if (frame == 1) afterTwo = dev().stats();
    }
    const rhi::DeviceStats end = dev().stats();
    EXPECT_GT(afterTwo.pipelinesCreated, 0u);
    EXPECT_EQ(end.pipelinesCreated, afterTwo.pipelinesCreated) << "pipelines created after frame 2";
    EXPECT_EQ(end.bindGroupsCreated, afterTwo.bindGroupsCreated) << "bind groups created after frame 2";
}

TEST_P(RendererFrameLoop, TimingsArriveWithoutBlockingReads) {
    Loaded l = load("scenes/primitives.json");
    ASSERT_TRUE(l.engine) << l.error;
    render::SceneRenderer renderer(dev());
    std::vector<fg::FrameTimings> timings;
    const uint64_t blockingBefore = dev().stats().blockingTimestampReads;
    for (int frame = 0; frame < 20; ++frame) {
        l.engine->update(0.05);
        std::string error;
        ASSERT_TRUE(renderer.render(l.engine->world(), l.engine->assets(), l.frame, error)) << error;
        for (auto& t : renderer.takeTimings(false)) timings.push_back(std::move(t));
    }
    EXPECT_EQ(dev().stats().blockingTimestampReads, blockingBefore)
        << "a timestamp read waited inside the loop";
    for (auto& t : renderer.takeTimings(true)) timings.push_back(std::move(t));
    ASSERT_EQ(timings.size(), 20u);
    for (size_t i = 0; i < timings.size(); ++i) {
        if (i > 0) {
            EXPECT_EQ(timings[i].frame, timings[i - 1].frame + 1);
        }
        std::vector<std::string> names;
        for (const fg::PassTiming& p : timings[i].passes) {
            names.push_back(p.name);
            EXPECT_GE(p.gpuMs, 0.0) << p.name;
        }
        EXPECT_EQ(names, (std::vector<std::string>{"scene_upload", "gbuffer_mesh", "lighting"}))
            << "frame " << i;
    }
}

struct DebugCase {
    const char* scene;
    const char* name;
    render::DebugView view;
    size_t minColours;  // independent of the golden: smooth views vary, flat albedo shows each material
};
const DebugCase kDebugCases[] = {
    {"scenes/materials.json", "debug_normals", render::DebugView::Normals, 64},
    {"scenes/materials.json", "debug_depth", render::DebugView::Depth, 64},
    {"scenes/materials.json", "debug_albedo", render::DebugView::Albedo, 16},  // textured floor
    // five flat materials (four shapes and the floor) + the black background
    {"scenes/primitives.json", "debug_albedo_material", render::DebugView::Albedo, 6},
};

bool renderDebug(rhi::Device& device, const DebugCase& c, ImageRGBA8& image, std::string& error) {
    Loaded l = load(c.scene);
    if (!l.engine) {
        error = l.error;
        return false;
    }
    l.frame.debugView = c.view;
    render::SceneRenderer renderer(device);
    const bool ok = renderer.render(l.engine->world(), l.engine->assets(), l.frame, error) &&
                    renderer.readPixels(image, error);
    device.waitIdle();
    return ok;
}

TEST_P(RendererFrameLoop, DebugViewsMatchGoldens) {
    const std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
    for (const DebugCase& c : kDebugCases) {
        ImageRGBA8 image;
        std::string error;
        ASSERT_TRUE(renderDebug(dev(), c, image, error)) << c.name << ": " << error;
        std::set<uint32_t> colours;
        for (size_t i = 0; i + 3 < image.pixels.size(); i += 4)
            colours.insert(uint32_t(image.pixels[i]) | uint32_t(image.pixels[i + 1]) << 8 |
                           uint32_t(image.pixels[i + 2]) << 16);
        EXPECT_GE(colours.size(), c.minColours) << c.name;
        const std::string failure = checkGolden(backend, std::string("scene_") + c.name, image);
        EXPECT_TRUE(failure.empty()) << failure;
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, RendererFrameLoop, testing::ValuesIn(gpuBackends()), backendName);

TEST(RendererFrameLoopParity, DebugViewsVulkanMatchesOpenGL) {
    BackendPair pair;
    ASSERT_TRUE(pair.ready());
    auto& vkDevice = pair.vk;
    auto& glDevice = pair.gl;
    for (const DebugCase& c : kDebugCases) {
        ImageRGBA8 vk, gl;
        std::string error;
        ASSERT_TRUE(renderDebug(*vkDevice, c, vk, error)) << error;
        ASSERT_TRUE(renderDebug(*glDevice, c, gl, error)) << error;
        ImageDiff d = compareImages(vk, gl);
        std::printf("Vulkan vs OpenGL, %s: %s\n", c.name, d.summary().c_str());
        EXPECT_TRUE(d.pass) << c.name << ": " << d.summary();
    }
    pair.expectNoErrors();
}

}  // namespace
}  // namespace penumbra::test
