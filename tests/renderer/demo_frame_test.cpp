// RHI demo frame: content sanity, golden images per backend, and Vulkan-vs-OpenGL parity.
#include <filesystem>

#include <gtest/gtest.h>

#include "renderer/demo/rhi_demo.h"
#include "support/golden.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

constexpr uint32_t kWidth = 160, kHeight = 120;

demo::DemoResult renderOn(rhi::Backend backend, std::shared_ptr<LogCapture> log) {
    auto device = createTestDevice(backend, log);
    if (!device) return {};
    demo::DemoSettings s;
    s.width = kWidth;
    s.height = kHeight;
    demo::DemoResult r = demo::renderDemoFrame(*device, s);
    device->waitIdle();
    return r;
}

class DemoFrame : public GpuTest {};

// The frame must show what the scene holds, independent of any golden: sky at the top, the
// ground plane at the bottom, the red sphere on the left, the blue box on the right, and every
// pass of the graph timed.
TEST_P(DemoFrame, ContentAndTimings) {
    demo::DemoSettings s;
    s.width = kWidth;
    s.height = kHeight;
    demo::DemoResult r = demo::renderDemoFrame(dev(), s);
    ASSERT_TRUE(r.ok) << r.error;
    ASSERT_EQ(r.image.width, kWidth);
    auto px = [&](uint32_t x, uint32_t y) { return r.image.at(x, y); };
    const uint8_t* sky = px(kWidth / 2, 2);
    EXPECT_GT(sky[2], sky[0]) << "sky should be blue-ish";
    const uint8_t* ground = px(kWidth / 2, kHeight - 3);
    EXPECT_NEAR(int(ground[0]), int(ground[1]), 20) << "ground should be grey";
    // Probe points (fractions of the image) inside each object, with the dominant channel its
    // material must show: red sphere, blue box, gold sampled-volume blob, green rasterised torus.
    const uint8_t* sphere = px(uint32_t(kWidth * 0.26), uint32_t(kHeight * 0.46));
    EXPECT_GT(int(sphere[0]), int(sphere[2]) + 40) << "expected the red sphere";
    const uint8_t* box = px(uint32_t(kWidth * 0.76), uint32_t(kHeight * 0.47));
    EXPECT_GT(int(box[2]), int(box[0]) + 40) << "expected the blue box";
    const uint8_t* blob = px(uint32_t(kWidth * 0.47), uint32_t(kHeight * 0.40));
    EXPECT_GT(int(blob[0]), int(blob[2]) + 40) << "expected the gold volume blob (3D texture)";
    const uint8_t* torus = px(uint32_t(kWidth * 0.50), uint32_t(kHeight * 0.62));
    EXPECT_GT(int(torus[1]), int(torus[0]) + 40) << "expected the green torus (raster pass)";
    std::vector<std::string> names;
    for (auto& t : r.timings) {
        names.push_back(t.name);
        EXPECT_GE(t.gpuMs, 0.0) << t.name;
    }
    EXPECT_EQ(names, (std::vector<std::string>{"trace", "depth", "mesh", "shade"}));
}

// Golden image per backend; rule: exact, else |delta| <= 5/255 for all but 0.1 % of pixels and no
// pixel over 64/255 (support/golden.h).
TEST_P(DemoFrame, MatchesGolden) {
    demo::DemoSettings s;
    s.width = kWidth;
    s.height = kHeight;
    demo::DemoResult r = demo::renderDemoFrame(dev(), s);
    ASSERT_TRUE(r.ok) << r.error;
    std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
    std::string failure = checkGolden(backend, "demo_frame", r.image);
    EXPECT_TRUE(failure.empty()) << failure;
}

INSTANTIATE_TEST_SUITE_P(Backends, DemoFrame, testing::ValuesIn(gpuBackends()), backendName);

// Backend parity: the same frame on Vulkan and OpenGL agrees under the golden rule.
TEST(DemoParity, VulkanMatchesOpenGL) {
    auto logVk = std::make_shared<LogCapture>();
    auto logGl = std::make_shared<LogCapture>();
    demo::DemoResult vk = renderOn(rhi::Backend::Vulkan, logVk);
    demo::DemoResult gl = renderOn(rhi::Backend::OpenGL, logGl);
    ASSERT_TRUE(vk.ok) << vk.error;
    ASSERT_TRUE(gl.ok) << gl.error;
    EXPECT_TRUE(logVk->errors.empty()) << logVk->errors.front();
    EXPECT_TRUE(logGl->errors.empty()) << logGl->errors.front();
    ImageDiff d = compareImages(vk.image, gl.image);
    std::printf("Vulkan vs OpenGL demo frame (%ux%u): %s\n", kWidth, kHeight, d.summary().c_str());
    RecordProperty("max_delta", d.maxDelta);
    RecordProperty("mean_delta", std::to_string(d.meanDelta));
    if (!d.pass) {
        std::filesystem::create_directories(goldenOutDir("parity"));
        writePng(goldenOutDir("parity") + "/demo_frame.vulkan.png", vk.image);
        writePng(goldenOutDir("parity") + "/demo_frame.gl.png", gl.image);
        writePng(goldenOutDir("parity") + "/demo_frame.diff.png", d.diffImage);
    }
    EXPECT_TRUE(d.pass) << d.summary();
}

}  // namespace
}  // namespace penumbra::test
