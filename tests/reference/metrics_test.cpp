// Error metrics (tools/reference/metrics.h) against values computed by hand.
#include <cmath>

#include <gtest/gtest.h>

#include "reference/metrics.h"

namespace penumbra::test {
namespace {

using namespace penumbra::reference;

FloatImage img(uint32_t w, uint32_t h, std::vector<float> data, uint32_t channels = 1) {
    return FloatImage{w, h, channels, std::move(data)};
}

TEST(Metrics, HandComputedErrors) {
    // e = (1, 0, 0, 0): mean e^2 = 1/4, rmse = 1/2, mean |e| = 1/4, max 1, p99 = the 4th of 4
    // (nearest rank ceil(0.99 * 4) = 4) = 1, PSNR = 10 log10(1 / 0.25) = 6.0206 dB.
    ErrorStats s;
    std::string error;
    ASSERT_TRUE(compareImages(img(2, 2, {1, 0, 0, 0}), img(2, 2, {0, 0, 0, 0}), {}, s, error)) << error;
    EXPECT_EQ(s.count, 4u);
    EXPECT_DOUBLE_EQ(s.rmse, 0.5);
    EXPECT_DOUBLE_EQ(s.meanAbs, 0.25);
    EXPECT_DOUBLE_EQ(s.maxAbs, 1.0);
    EXPECT_DOUBLE_EQ(s.p99Abs, 1.0);
    EXPECT_NEAR(s.psnr, 6.020599913, 1e-8);
    // Equal images: zero error, infinite PSNR, SSIM 1.
    ASSERT_TRUE(compareImages(img(2, 2, {1, 2, 3, 4}), img(2, 2, {1, 2, 3, 4}), {}, s, error));
    EXPECT_EQ(s.rmse, 0.0);
    EXPECT_TRUE(std::isinf(s.psnr));
    EXPECT_DOUBLE_EQ(s.ssim, 1.0);
}

TEST(Metrics, NearestRankPercentile) {
    // |e| = 0.01, 0.02, ..., 2.00 (200 values): the 99th percentile is the 198th = 1.98.
    std::vector<float> a(200), b(200, 0.0f);
    for (int i = 0; i < 200; ++i) a[i] = float(i + 1) / 100.0f;
    ErrorStats s;
    std::string error;
    ASSERT_TRUE(compareImages(img(20, 10, a), img(20, 10, b), {}, s, error)) << error;
    EXPECT_NEAR(s.p99Abs, 1.98, 1e-6);
    EXPECT_NEAR(s.maxAbs, 2.0, 1e-6);
    EXPECT_NEAR(s.meanAbs, 1.005, 1e-6);  // (0.01 + 2.00) / 2
}

TEST(Metrics, SsimOfConstantImages) {
    // Two constant images 0.5 and 0.6: every window has zero variance, so
    // SSIM = (2 * 0.5 * 0.6 + C1) / (0.5^2 + 0.6^2 + C1) with C1 = (0.01 * 1)^2 = 1e-4:
    // 0.6001 / 0.6101 = 0.983609...
    const FloatImage a = img(16, 16, std::vector<float>(256, 0.5f)),
                     b = img(16, 16, std::vector<float>(256, 0.6f));
    EXPECT_NEAR(ssim(a, b, {}, 1.0), 0.6001 / 0.6101, 1e-6);
    // A structural difference lowers it more than a small offset does.
    std::vector<float> checker(256);
    for (int i = 0; i < 256; ++i) checker[i] = ((i % 16 + i / 16) % 2) ? 0.6f : 0.4f;
    EXPECT_LT(ssim(img(16, 16, checker), a, {}, 1.0), ssim(b, a, {}, 1.0));
}

TEST(Metrics, MaskSelectsPixels) {
    // Only pixel 1 is compared: |e| = 0.5.
    MetricsDesc desc;
    desc.mask = {0, 1, 0};
    ErrorStats s;
    std::string error;
    ASSERT_TRUE(compareImages(img(3, 1, {9, 1.5f, 9}), img(3, 1, {0, 1, 0}), desc, s, error)) << error;
    EXPECT_EQ(s.count, 1u);
    EXPECT_DOUBLE_EQ(s.meanAbs, 0.5);
    desc.mask = {0, 0, 0};
    EXPECT_FALSE(compareImages(img(3, 1, {9, 1.5f, 9}), img(3, 1, {0, 1, 0}), desc, s, error));
    EXPECT_NE(error.find("no pixel"), std::string::npos);
    EXPECT_FALSE(compareImages(img(3, 1, {0, 0, 0}), img(1, 3, {0, 0, 0}), {}, s, error));
    EXPECT_NE(error.find("size"), std::string::npos);
}

TEST(Metrics, Rgba8UsesRgbOverFullScale) {
    // (255, 0, 0, 255) against (0, 0, 0, 0): RGB errors 1, 0, 0 (alpha ignored): mean |e| = 1/3,
    // rmse = sqrt(1/3), PSNR = 10 log10(3) = 4.7712 dB.
    ImageRGBA8 a{1, 1, {255, 0, 0, 255}}, b{1, 1, {0, 0, 0, 0}};
    ErrorStats s;
    std::string error;
    ASSERT_TRUE(compareImages(a, b, {}, s, error)) << error;
    EXPECT_EQ(s.count, 3u);
    EXPECT_NEAR(s.meanAbs, 1.0 / 3.0, 1e-12);
    EXPECT_NEAR(s.rmse, std::sqrt(1.0 / 3.0), 1e-12);
    EXPECT_NEAR(s.psnr, 4.771212547, 1e-8);
}

TEST(Metrics, SilhouetteMismatch) {
    // A hits pixels 0, 1, 2; B hits 1, 2, 3: both 2, either 4, mismatch (4 - 2) / 4 = 0.5.
    const FloatImage a = img(5, 1, {1, 2, 3, 0, 0}), b = img(5, 1, {0, 2, 3, 4, 0});
    SilhouetteStats s;
    std::string error;
    ASSERT_TRUE(silhouetteMismatch(a, b, s, error)) << error;
    EXPECT_EQ(s.hitA, 3u);
    EXPECT_EQ(s.hitB, 3u);
    EXPECT_EQ(s.hitBoth, 2u);
    EXPECT_EQ(s.hitEither, 4u);
    EXPECT_DOUBLE_EQ(s.mismatchRate, 0.5);
    EXPECT_EQ(bothHitMask(a, b), (std::vector<uint8_t>{0, 1, 1, 0, 0}));
    // Nothing hit anywhere: rate 0.
    ASSERT_TRUE(silhouetteMismatch(img(2, 1, {0, 0}), img(2, 1, {0, 0}), s, error));
    EXPECT_EQ(s.mismatchRate, 0.0);
}

}  // namespace
}  // namespace penumbra::test
