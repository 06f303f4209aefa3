// Motion blur (issue 14 item 3; renderer/features/post_output.h) on both backends, on
// tests/renderer/taa_scene.json at 128x72 with TAA off: the emissive `mover` jumps 0.3 units
// (about 4.4 pixels) to the right between two frames of a static camera.
//   - the blur follows the motion: the mover's footprint widens by at least 2 columns and keeps
//     its rows (+-1), and pixels farther than the velocity tiles reach (3x3 tiles of 16 pixels
//     around the mover) keep their colour within 1/255 (the linear RGBA16F round trip);
//   - nothing moving: the frame equals the one without motion blur within 1/255;
//   - goldens per backend and Vulkan-vs-OpenGL parity (support/golden.h).
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>

#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/test_device.h"
#include "taa_support.h"

namespace penumbra::test {
namespace {

constexpr uint32_t kW = 128, kH = 72;
const glm::vec3 kStart{2.2f, 0.0f, 0.0f}, kStep{0.3f, 0.0f, 0.0f};

// Two frames: the mover at kStart, then at kStart + kStep; the second one's image.
bool blurredFrame(rhi::Device& device, TaaScene& scene, bool motionBlur, ImageRGBA8& out,
                  std::string& error) {
    render::SceneRenderer r(device);
    scene.pose(glm::vec3(0.0f), kStart);
    if (!scene.render(r, kW, kH, withMotionBlur(motionBlur), out, error)) return false;
    scene.pose(glm::vec3(0.0f), kStart + kStep);
    return scene.render(r, kW, kH, withMotionBlur(motionBlur), out, error);
}

int maxDelta(const ImageRGBA8& a, const ImageRGBA8& b, size_t p) {
    int d = 0;
    for (int c = 0; c < 3; ++c)
        d = std::max(d, std::abs(int(a.pixels[p * 4 + c]) - int(b.pixels[p * 4 + c])));
    return d;
}

class MotionBlur : public GpuTest {
protected:
    void SetUp() override {
        GpuTest::SetUp();
        std::string error;
        ASSERT_TRUE(scene.load(error)) << error;
    }
    std::string backend() const { return GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl"; }
    TaaScene scene;
};

TEST_P(MotionBlur, BlursAlongTheMotionOnly) {
    std::string error;
    ImageRGBA8 background, sharp, blurred;
    {
        render::SceneRenderer r(dev());
        scene.showMover(false);
        ASSERT_TRUE(scene.render(r, kW, kH, {}, background, error)) << error;
        scene.showMover(true);
    }
    ASSERT_TRUE(blurredFrame(dev(), scene, false, sharp, error)) << error;
    ASSERT_TRUE(blurredFrame(dev(), scene, true, blurred, error)) << error;
    // Footprints: pixels that differ from the background by more than 8/255.
    auto footprint = [&](const ImageRGBA8& img, uint32_t& x0, uint32_t& x1, uint32_t& y0, uint32_t& y1) {
        x0 = y0 = ~0u;
        x1 = y1 = 0;
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x)
                if (maxDelta(img, background, size_t(y) * kW + x) > 8) {
                    x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
                }
    };
    uint32_t sx0, sx1, sy0, sy1, bx0, bx1, by0, by1;
    footprint(sharp, sx0, sx1, sy0, sy1);
    footprint(blurred, bx0, bx1, by0, by1);
    std::printf("%s: mover footprint x %u..%u y %u..%u sharp, x %u..%u y %u..%u blurred\n", backend().c_str(),
                sx0, sx1, sy0, sy1, bx0, bx1, by0, by1);
    ASSERT_LE(sx0, sx1) << "the mover is not in the frame";
    EXPECT_GE(int(bx1 - bx0), int(sx1 - sx0) + 2);
    EXPECT_LE(std::abs(int(by0) - int(sy0)), 1);
    EXPECT_LE(std::abs(int(by1) - int(sy1)), 1);
    // Far from the mover (beyond its tiles' 3x3 neighbourhood) the image is unchanged.
    const int tx0 = int(std::min(sx0, bx0)) / 16 - 1, tx1 = int(std::max(sx1, bx1)) / 16 + 1;
    const int ty0 = int(std::min(sy0, by0)) / 16 - 1, ty1 = int(std::max(sy1, by1)) / 16 + 1;
    int farDelta = 0;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            const int tx = int(x) / 16, ty = int(y) / 16;
            if (tx >= tx0 - 1 && tx <= tx1 + 1 && ty >= ty0 - 1 && ty <= ty1 + 1) continue;
            farDelta = std::max(farDelta, maxDelta(blurred, sharp, size_t(y) * kW + x));
        }
    EXPECT_LE(farDelta, 1);
}

TEST_P(MotionBlur, NothingMovingNothingBlurred) {
    std::string error;
    render::SceneRenderer off(dev()), on(dev());
    ImageRGBA8 a, b;
    scene.pose(glm::vec3(0.0f), kStart);
    for (int k = 0; k < 2; ++k) {
        ASSERT_TRUE(scene.render(off, kW, kH, {}, a, error)) << error;
        ASSERT_TRUE(scene.render(on, kW, kH, withMotionBlur(true), b, error)) << error;
    }
    int worst = 0;
    for (size_t p = 0; p < size_t(kW) * kH; ++p) worst = std::max(worst, maxDelta(a, b, p));
    EXPECT_LE(worst, 1);
}

TEST_P(MotionBlur, MatchesGolden) {
    std::string error;
    ImageRGBA8 img;
    ASSERT_TRUE(blurredFrame(dev(), scene, true, img, error)) << error;
    const std::string failure = checkGolden(backend(), "motion_blur", img);
    EXPECT_TRUE(failure.empty()) << failure;
}

INSTANTIATE_TEST_SUITE_P(Backends, MotionBlur, testing::ValuesIn(gpuBackends()), backendName);

TEST(MotionBlurParity, VulkanMatchesOpenGL) {
    expectTaaSceneParity("motion_blur",
                         [](rhi::Device& device, TaaScene& scene, ImageRGBA8& image, std::string& error) {
                             return blurredFrame(device, scene, true, image, error);
                         });
}

}  // namespace
}  // namespace penumbra::test
