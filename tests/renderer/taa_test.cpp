// TAA (issue 14 item 2; renderer/features/taa.h) on both backends, on tests/renderer/taa_scene.json
// at 128x72, measured as the acceptance asks:
//   - error against a 16x supersampled reference (the scene rendered at 512x288 without TAA, each
//     4x4 block averaged in linear colour) over a 32-frame camera path: mean squared error of the
//     displayed sRGB values at most half that of the frames without AA (PSNR printed too): ratio
//     0.470 on the path, 0.209 with the camera still (both tested);
//   - temporal flicker on a static camera (mean absolute frame-to-frame difference, 8-bit steps)
//     at least 4x lower than the jittered frames without the history (FrameDesc::resetHistory
//     every frame: each shows its raw sample). Without AA and without jitter a static frame never
//     changes (flicker 0), so the flicker TAA must steady is that of its own jittered samples;
//   - the same flicker with the half-resolution sun shadows and quarter-resolution cone AO on,
//     measured on the pixels they change (item 2: TAA also steadies them), at least 4x lower;
//   - ghosting: the emissive `mover` crossing the dark background; 4 frames after it left a pixel
//     (not covered, nor next to it, in the last 4 frames) no pixel keeps more than 10 % of its colour;
//     the same 4 frames after the mover is removed from view.
// Also: the history restarts on a resize (the frame equals a fresh renderer's first), TAA off adds
// no pass or target (the frame is the one of before TAA existed), goldens after 16 frames, parity.
#include <algorithm>
#include <cmath>
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
constexpr int kPathFrames = 32;

// The camera path: a strafe of 0.9 units (about 12 pixels at the objects) over 32 frames.
glm::vec3 pathOffset(int k) { return {-0.45f + 0.9f * float(k) / float(kPathFrames - 1), 0.0f, 0.0f}; }
// The mover parks out of the way (behind the camera's view, far right) unless a test moves it.
const glm::vec3 kMoverAway{0.0f, 0.0f, -30.0f};

class Taa : public GpuTest {
protected:
    void SetUp() override {
        GpuTest::SetUp();
        std::string error;
        ASSERT_TRUE(scene.load(error)) << error;
    }
    std::string backend() const { return GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl"; }
    TaaScene scene;
};

// Mean squared error (displayed sRGB values) against the 16x supersampled reference over 32 frames
// of TAA and of no AA, the camera at `offset(k)` in frame k.
struct ErrorPair {
    double taa = 0.0, plain = 0.0;
};
template <typename Offset>
ErrorPair measureError(rhi::Device& device, TaaScene& scene, Offset offset, const std::string& label,
                       std::string& error) {
    render::SceneRenderer taa(device), plain(device), reference(device);
    ErrorPair e;
    for (int k = 0; k < kPathFrames; ++k) {
        scene.pose(offset(k), kMoverAway);
        ImageRGBA8 a, b, big;
        if (!scene.render(taa, kW, kH, withTaa(), a, error) || !scene.render(plain, kW, kH, {}, b, error) ||
            !scene.render(reference, kW * 4, kH * 4, {}, big, error))
            return {};
        const std::vector<float> ref = downsampleReference(big, 4);
        e.taa += meanSquaredError(a, ref) / kPathFrames;
        e.plain += meanSquaredError(b, ref) / kPathFrames;
    }
    std::printf(
        "%s: MSE vs 16x SS over %d frames: no AA %.3g (PSNR %.2f dB), TAA %.3g (PSNR %.2f dB), "
        "ratio %.3f\n",
        label.c_str(), kPathFrames, e.plain, -10.0 * std::log10(e.plain), e.taa, -10.0 * std::log10(e.taa),
        e.taa / e.plain);
    return e;
}

// The acceptance's measurement: the 32-frame camera path. Measured MSE ratio TAA / no AA = 0.470
// on both backends (no AA 7.17e-4, PSNR 31.44 dB; TAA 3.37e-4, PSNR 34.72 dB). It was 0.81 with
// the first resolve, 0.608 before the history went to 2x2 texels per pixel (0.514) and thin
// surfaces the jitter missed kept their own motion (0.470); docs/ACCURACY.md "TAA" has the steps.
// Most of the rest lies in the 8 rows where sub-pixel-thin pillars stand against the sky (ratio
// 0.63 there, 0.21-0.43 elsewhere): a pillar drops out where this and the previous frame's
// samples both missed it.
TEST_P(Taa, ErrorOnCameraPathAtLeastHalved) {
    std::string error;
    const ErrorPair e = measureError(dev(), scene, pathOffset, backend() + " camera path", error);
    ASSERT_GT(e.plain, 0.0) << error;
    // Acceptance: the error at least halved (MSE of displayed sRGB values, mean over the 32 frames,
    // the first ones without history included).
    EXPECT_LE(e.taa, 0.5 * e.plain);
}

// The same measurement with the camera still (the scene's view), 32 frames: TAA's accumulation
// against the same reference. Not the acceptance's camera path (see above); measured ratio 0.209
// on both backends (no AA 7.21e-4, PSNR 31.42 dB; TAA 1.51e-4, PSNR 38.22 dB).
TEST_P(Taa, ErrorOnStaticCameraAtLeastHalved) {
    std::string error;
    const ErrorPair e = measureError(
        dev(), scene, [](int) { return glm::vec3(0.0f); }, backend() + " static camera", error);
    ASSERT_GT(e.plain, 0.0) << error;
    // MSE of displayed sRGB values, mean over the 32 frames (the first without history included).
    EXPECT_LE(e.taa, 0.5 * e.plain);
}

// Flicker (mean |frame - previous| in 8-bit steps over 31 differences, on the pixels `mask`
// selects) of 32 static-camera TAA frames and of the same jittered frames without accumulation
// (FrameDesc::resetHistory every frame: each shows its raw jittered sample).
struct FlickerPair {
    double taa = 0.0, jittered = 0.0;
};
FlickerPair measureFlicker(rhi::Device& device, TaaScene& scene, bool effects,
                           const std::vector<uint8_t>& mask, std::string& error) {
    render::SceneRenderer taa(device), jittered(device);
    scene.pose(glm::vec3(0.0f), kMoverAway);
    FlickerPair f;
    ImageRGBA8 lastTaa, lastJitter;
    for (int k = 0; k < kPathFrames; ++k) {
        ImageRGBA8 a, b;
        TaaScene::Options on = withTaa(), raw = withTaa(true);
        if (effects) on = withEffects(on), raw = withEffects(raw);
        if (!scene.render(taa, kW, kH, on, a, error) || !scene.render(jittered, kW, kH, raw, b, error))
            return {};
        if (k > 0) {
            f.taa += meanAbsoluteDifference(a, lastTaa, mask) / (kPathFrames - 1);
            f.jittered += meanAbsoluteDifference(b, lastJitter, mask) / (kPathFrames - 1);
        }
        lastTaa = std::move(a);
        lastJitter = std::move(b);
    }
    return f;
}

TEST_P(Taa, FlickerOnStaticCameraAtLeastFourTimesLower) {
    std::string error;
    const FlickerPair f = measureFlicker(dev(), scene, false, {}, error);
    ASSERT_TRUE(error.empty()) << error;
    std::printf(
        "%s: static-camera flicker (mean |frame - previous|, 8-bit): jittered samples %.4f, TAA %.4f "
        "(%.1fx lower)\n",
        backend().c_str(), f.jittered, f.taa, f.jittered / std::max(f.taa, 1e-12));
    EXPECT_GT(f.jittered, 0.0);
    // Acceptance: flicker at least 4x lower than the raw jittered frames.
    EXPECT_LE(f.taa * 4.0, f.jittered);
}

// Issue 14 item 2: TAA also steadies the half-resolution sun shadows and the quarter-resolution
// cone AO (defaults), which follow the jittered rays. The flicker is measured on the pixels the
// effects change (the unjittered frame with the effects differs there from the one without by more
// than 2 steps in some channel: shadowed or occluded surface), same metric and the same 4x bar as
// the acceptance's flicker.
TEST_P(Taa, FlickerOfShadowsAndAoAtLeastFourTimesLower) {
    std::string error;
    render::SceneRenderer plain(dev());
    scene.pose(glm::vec3(0.0f), kMoverAway);
    ImageRGBA8 withFx, withoutFx;
    ASSERT_TRUE(scene.render(plain, kW, kH, withEffects({}), withFx, error)) << error;
    ASSERT_TRUE(scene.render(plain, kW, kH, {}, withoutFx, error)) << error;
    std::vector<uint8_t> mask(size_t(kW) * kH, 0);
    size_t masked = 0;
    for (size_t p = 0; p < mask.size(); ++p)
        for (int c = 0; c < 3; ++c)
            if (std::abs(int(withFx.pixels[p * 4 + c]) - int(withoutFx.pixels[p * 4 + c])) > 2) mask[p] = 1;
    for (uint8_t m : mask) masked += m;
    ASSERT_GT(masked, size_t(kW) * kH / 20) << "the shadows and AO should change a good part of the frame";
    const FlickerPair f = measureFlicker(dev(), scene, true, mask, error);
    ASSERT_TRUE(error.empty()) << error;
    std::printf(
        "%s: static-camera flicker on the %zu pixels shadows / AO change: jittered samples %.4f, TAA "
        "%.4f (%.1fx lower)\n",
        backend().c_str(), masked, f.jittered, f.taa, f.jittered / std::max(f.taa, 1e-12));
    EXPECT_GT(f.jittered, 0.0);
    EXPECT_LE(f.taa * 4.0, f.jittered);
}

// The mover's share of a TAA pixel: |taa - background| / |mover - background|, worst channel, in
// linear colour (the fraction TAA blends) and in the displayed sRGB values. Over the pixels
// `mask` selects, the worst of both into `worst` (x linear, y sRGB); returns how many it checked.
struct Ghost {
    double linear = 0.0, srgb = 0.0;
};
size_t worstGhost(const ImageRGBA8& taa, const ImageRGBA8& background, glm::vec3 moverColour,
                  const std::vector<uint8_t>& mask, Ghost& worst) {
    size_t checked = 0;
    for (size_t p = 0; p < mask.size(); ++p) {
        if (!mask[p]) continue;
        ++checked;
        for (int c = 0; c < 3; ++c) {
            const float bg = background.pixels[p * 4 + c] / 255.0f, t = taa.pixels[p * 4 + c] / 255.0f;
            const float m = moverColour[c] / 255.0f;
            worst.srgb = std::max(worst.srgb, double(std::abs(t - bg) / std::max(std::abs(m - bg), 1e-3f)));
            worst.linear =
                std::max(worst.linear, double(std::abs(srgbToLinear(t) - srgbToLinear(bg)) /
                                              std::max(std::abs(srgbToLinear(m) - srgbToLinear(bg)), 1e-4f)));
        }
    }
    return checked;
}

// The pixels where `frame` differs from `background` by more than 2 steps, grown by one pixel;
// `colour` += their colours, `count` += their number.
std::vector<uint8_t> moverMask(const ImageRGBA8& frame, const ImageRGBA8& background, glm::vec3& colour,
                               uint32_t& count) {
    std::vector<uint8_t> mask(size_t(kW) * kH, 0);
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            const size_t p = (size_t(y) * kW + x) * 4;
            int d = 0;
            for (int c = 0; c < 3; ++c)
                d = std::max(d, std::abs(int(frame.pixels[p + c]) - int(background.pixels[p + c])));
            if (d <= 2) continue;
            colour += glm::vec3(frame.pixels[p], frame.pixels[p + 1], frame.pixels[p + 2]);
            ++count;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int qx = int(x) + dx, qy = int(y) + dy;
                    if (qx >= 0 && qy >= 0 && qx < int(kW) && qy < int(kH)) mask[size_t(qy) * kW + qx] = 1;
                }
        }
    return mask;
}

// The mover crosses the dark background at about 3 pixels per frame (static camera). A pixel it
// covered (no-AA coverage, grown by one pixel) at some frame <= k - 4 and not in frames k - 3 .. k
// must show at most 10 % of the mover's colour in TAA frame k: |taa - background| <= 0.1 |mover -
// background| in every channel, in linear colour (the fraction TAA blends) and, stricter, in the
// displayed sRGB values.
TEST_P(Taa, NoGhostFourFramesAfterAMovingObject) {
    render::SceneRenderer taa(dev()), plain(dev());
    std::string error;
    constexpr int kFrames = 24;
    auto moverAt = [](int k) { return glm::vec3(0.22f * float(k), 0.0f, 0.0f); };
    // The background alone (mover hidden), without AA.
    ImageRGBA8 background;
    scene.pose(glm::vec3(0.0f), moverAt(0));
    scene.showMover(false);
    ASSERT_TRUE(scene.render(plain, kW, kH, {}, background, error)) << error;
    scene.showMover(true);
    std::vector<std::vector<uint8_t>> covered;  // per frame: grown no-AA coverage
    Ghost worst;
    size_t checked = 0;
    glm::vec3 moverColour(0.0f);
    for (int k = 0; k < kFrames; ++k) {
        scene.pose(glm::vec3(0.0f), moverAt(k));
        ImageRGBA8 a, b;
        ASSERT_TRUE(scene.render(taa, kW, kH, withTaa(), a, error)) << error;
        ASSERT_TRUE(scene.render(plain, kW, kH, {}, b, error)) << error;
        glm::vec3 colour(0.0f);
        uint32_t count = 0;
        covered.push_back(moverMask(b, background, colour, count));
        if (k == 0) {
            ASSERT_GT(count, 10u) << "the mover was not seen";
            moverColour = colour / float(count);  // its mean colour (8-bit)
        }
        if (k < 4) continue;
        std::vector<uint8_t> passed(size_t(kW) * kH, 0);
        for (size_t p = 0; p < passed.size(); ++p) {
            bool before = false, recent = false;
            for (int j = 0; j <= k; ++j) (j <= k - 4 ? before : recent) |= covered[size_t(j)][p] != 0;
            passed[p] = before && !recent;
        }
        checked += worstGhost(a, background, moverColour, passed, worst);
    }
    const double worstLinear = worst.linear, worstSrgb = worst.srgb;
    std::printf(
        "%s: ghosting 4 frames after the mover passed, %zu pixel checks: worst %.2f %% of its colour "
        "(linear), %.2f %% (sRGB values)\n",
        backend().c_str(), checked, 100.0 * worstLinear, 100.0 * worstSrgb);
    ASSERT_GT(moverColour.x + moverColour.y + moverColour.z, 300.0f) << "the mover does not contrast";
    ASSERT_GT(checked, 500u);
    // Acceptance: no pixel with more than 10 % of the mover's colour.
    EXPECT_LE(worstLinear, 0.10);
    EXPECT_LE(worstSrgb, 0.10);
}

// An object removed from view (the mover hidden after 8 still frames; static camera): where the
// history still holds its depth, nearer than anything the frame hits, the resolve reprojects that
// pixel as the removed surface (taa.comp: thin surfaces the jitter missed keep their own motion).
// The clipping box then holds only the new frame and the previous frame's raw samples, so the
// object may show in the first frame without it but not later: 4 frames after, as for the moving
// object, no pixel it covered (grown by one pixel) shows more than 10 % of its colour.
TEST_P(Taa, NoGhostFourFramesAfterAnObjectIsRemoved) {
    render::SceneRenderer taa(dev()), plain(dev());
    std::string error;
    const glm::vec3 at(0.66f, 0.0f, 0.0f);
    scene.pose(glm::vec3(0.0f), at);
    scene.showMover(false);
    ImageRGBA8 background, shown, img;
    ASSERT_TRUE(scene.render(plain, kW, kH, {}, background, error)) << error;
    scene.showMover(true);
    ASSERT_TRUE(scene.render(plain, kW, kH, {}, shown, error)) << error;
    glm::vec3 colour(0.0f);
    uint32_t count = 0;
    const std::vector<uint8_t> mask = moverMask(shown, background, colour, count);
    ASSERT_GT(count, 10u) << "the mover was not seen";
    for (int k = 0; k < 8; ++k) ASSERT_TRUE(scene.render(taa, kW, kH, withTaa(), img, error)) << error;
    Ghost first;
    ASSERT_GT(worstGhost(img, background, colour / float(count), mask, first), 0u);
    ASSERT_GT(first.linear, 0.9) << "the mover is not in the history before its removal";
    scene.showMover(false);
    Ghost after[4];
    for (int k = 0; k < 4; ++k) {
        ASSERT_TRUE(scene.render(taa, kW, kH, withTaa(), img, error)) << error;
        worstGhost(img, background, colour / float(count), mask, after[k]);
    }
    std::printf(
        "%s: removed object, worst share of its colour (linear) in the 4 frames after: %.2f %% "
        "%.2f %% %.2f %% %.2f %% (sRGB values in the last: %.2f %%)\n",
        backend().c_str(), 100.0 * after[0].linear, 100.0 * after[1].linear, 100.0 * after[2].linear,
        100.0 * after[3].linear, 100.0 * after[3].srgb);
    EXPECT_LE(after[3].linear, 0.10);
    EXPECT_LE(after[3].srgb, 0.10);
}

// A resize restarts the history: the first frame at the new size equals a frame at that size that
// restarts it explicitly at the same frame index (same jitter phase), and the history is used again
// on the next frame.
TEST_P(Taa, HistoryRestartsOnResize) {
    render::SceneRenderer resized(dev()), reset(dev());
    std::string error;
    scene.pose(glm::vec3(0.0f), kMoverAway);
    ImageRGBA8 img, afterResize, restarted, next, nextReset;
    for (int k = 0; k < 4; ++k) {
        ASSERT_TRUE(scene.render(resized, kW, kH, withTaa(), img, error)) << error;
        ASSERT_TRUE(scene.render(reset, 96, 54, withTaa(), img, error)) << error;
    }
    ASSERT_TRUE(scene.render(resized, 96, 54, withTaa(), afterResize, error)) << error;
    ASSERT_TRUE(scene.render(reset, 96, 54, withTaa(true), restarted, error)) << error;
    ASSERT_EQ(afterResize.width, 96u);
    EXPECT_EQ(afterResize.pixels, restarted.pixels) << "the frame after a resize did not restart the history";
    ASSERT_TRUE(scene.render(resized, 96, 54, withTaa(), next, error)) << error;
    ASSERT_TRUE(scene.render(reset, 96, 54, withTaa(true), nextReset, error)) << error;
    EXPECT_NE(next.pixels, nextReset.pixels) << "the history is not used after the resize";
}

// Without TAA and motion blur the frame has no post pass, no scene.color target and no history
// (the frame of before); with TAA it has "taa" and "post_output".
TEST_P(Taa, OffAddsNothing) {
    std::string error;
    scene.pose(glm::vec3(0.0f), kMoverAway);
    auto passes = [&](bool taa, uint64_t& targetBytes) {
        render::SceneRenderer r(dev());
        ImageRGBA8 img;
        std::vector<std::string> names;
        if (!scene.render(r, kW, kH, taa ? withTaa() : TaaScene::Options{}, img, error)) return names;
        for (const fg::PassTiming& p : r.lastFrameStats().passes) names.push_back(p.name);
        targetBytes = r.lastFrameStats().memory.renderTargets;
        return names;
    };
    uint64_t offBytes = 0, onBytes = 0;
    const std::vector<std::string> off = passes(false, offBytes), on = passes(true, onBytes);
    ASSERT_FALSE(off.empty()) << error;
    ASSERT_FALSE(on.empty()) << error;
    auto has = [](const std::vector<std::string>& v, const char* n) {
        return std::find(v.begin(), v.end(), n) != v.end();
    };
    EXPECT_FALSE(has(off, "taa") || has(off, "post_output") || has(off, "motion_blur_tiles"));
    EXPECT_TRUE(has(on, "taa") && has(on, "post_output"));
    EXPECT_EQ(off.back(), "lighting");
    // TAA: scene.color (RGBA16F) and four RGBA16F history targets more: the resolved pair at 2x2
    // texels per pixel, the raw samples' pair at 1x.
    EXPECT_EQ(onBytes - offBytes, uint64_t(kW) * kH * 8 * (1 + 2 * 4 + 2));
}

// Golden: 16 TAA frames of the static camera (the scene's view), per backend.
ImageRGBA8 sixteenFrames(rhi::Device& device, TaaScene& scene, std::string& error) {
    render::SceneRenderer r(device);
    scene.pose(glm::vec3(0.0f), glm::vec3(3.2f, 0.0f, 0.0f));
    ImageRGBA8 img;
    for (int k = 0; k < 16; ++k)
        if (!scene.render(r, kW, kH, withTaa(), img, error)) return {};
    return img;
}

TEST_P(Taa, SixteenFramesMatchGolden) {
    std::string error;
    const ImageRGBA8 img = sixteenFrames(dev(), scene, error);
    ASSERT_EQ(img.width, kW) << error;
    const std::string failure = checkGolden(backend(), "taa_16_frames", img);
    EXPECT_TRUE(failure.empty()) << failure;
}

INSTANTIATE_TEST_SUITE_P(Backends, Taa, testing::ValuesIn(gpuBackends()), backendName);

// Vulkan vs OpenGL after 16 TAA frames, the golden rule (support/golden.h).
TEST(TaaParity, VulkanMatchesOpenGL) {
    expectTaaSceneParity("taa_16_frames",
                         [](rhi::Device& device, TaaScene& scene, ImageRGBA8& image, std::string& error) {
                             image = sixteenFrames(device, scene, error);
                             return image.width == kW;
                         });
}

}  // namespace
}  // namespace penumbra::test
