// The app loop: fixed steps, accumulator, catch-up cap, deterministic integer time (real time);
// exact frame times without a cap (offline).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "engine/app/app_loop.h"
#include "engine/core/log.h"

namespace penumbra::app {
namespace {

TEST(AppLoop, OneStepPerFrameWhenFrameTimeEqualsStep) {
    AppLoop loop;
    std::string error;
    ASSERT_TRUE(loop.configure({0.01, 16}, error)) << error;
    int calls = 0;
    for (int i = 0; i < 100; ++i) {
        FrameTime t = loop.advance(0.01, [&](double dt) {
            EXPECT_DOUBLE_EQ(dt, 0.01);
            ++calls;
        });
        EXPECT_EQ(t.steps, 1u);
        EXPECT_EQ(t.frameIndex, uint64_t(i));
        EXPECT_DOUBLE_EQ(t.alpha, 0.0);
    }
    EXPECT_EQ(calls, 100);
    // Integer nanoseconds: 100 steps of 0.01 s are exactly 1 s (a double accumulator drifts).
    EXPECT_EQ(loop.simTime(), 1.0);
}

TEST(AppLoop, AccumulatesPartialFramesAndReportsAlpha) {
    AppLoop loop;
    std::string error;
    ASSERT_TRUE(loop.configure({0.02, 16}, error));
    FrameTime a = loop.advance(0.015, {});
    EXPECT_EQ(a.steps, 0u);
    EXPECT_NEAR(a.alpha, 0.75, 1e-12);
    FrameTime b = loop.advance(0.015, {});
    EXPECT_EQ(b.steps, 1u);
    EXPECT_NEAR(b.alpha, 0.5, 1e-12);
    EXPECT_NEAR(b.simTime, 0.02, 1e-12);
    FrameTime c = loop.advance(0.05, {});  // 0.01 left + 0.05 = 3 steps
    EXPECT_EQ(c.steps, 3u);
    EXPECT_EQ(loop.stepCount(), 4u);
}

TEST(AppLoop, LongStallIsCappedAndCounted) {
    AppLoop loop;
    std::string error;
    ASSERT_TRUE(loop.configure({0.01, 4}, error));
    int calls = 0;
    FrameTime t = loop.advance(1.0, [&](double) { ++calls; });
    EXPECT_EQ(t.steps, 4u);
    EXPECT_EQ(calls, 4);
    EXPECT_EQ(loop.droppedSteps(), 96u);
    EXPECT_LT(t.alpha, 1.0);
}

// Captures warnings while alive (restores the previous sink afterwards).
struct WarningCapture {
    std::vector<std::string> messages;
    log::Sink previous;
    WarningCapture() {
        previous = log::setSink([this](log::Severity s, std::string_view m) {
            if (s == log::Severity::Warning) messages.emplace_back(m);
        });
    }
    ~WarningCapture() { log::setSink(previous); }
};

TEST(AppLoop, RealTimeCapDropsTimeCountsAndLogsIt) {
    AppLoop loop;
    std::string error;
    ASSERT_TRUE(loop.configure({0.25, 2}, error));
    WarningCapture warnings;
    // 1 s = 4 steps of 0.25 s; the cap runs 2 and drops 2 (0.5 s), counted and logged.
    FrameTime t = loop.advance(1.0, {});
    EXPECT_EQ(t.steps, 2u);
    EXPECT_EQ(t.dropped, 0.5);
    EXPECT_EQ(loop.droppedSteps(), 2u);
    EXPECT_EQ(loop.droppedTime(), 0.5);
    EXPECT_EQ(loop.simTime(), 0.5);
    ASSERT_EQ(warnings.messages.size(), 1u);
    EXPECT_NE(warnings.messages[0].find("dropped 0.5 s of simulated time"), std::string::npos)
        << warnings.messages[0];
    // A frame within the cap drops and logs nothing.
    FrameTime u = loop.advance(0.5, {});
    EXPECT_EQ(u.steps, 2u);
    EXPECT_EQ(u.dropped, 0.0);
    EXPECT_EQ(warnings.messages.size(), 1u);
    // Frames above one minute are clamped: the excess is dropped time too.
    ASSERT_TRUE(loop.configure({0.25, 1000}, error));
    FrameTime v = loop.advance(100.0, {});
    EXPECT_EQ(v.steps, 240u);
    EXPECT_EQ(v.dropped, 40.0);
    EXPECT_EQ(loop.droppedTime(), 40.5);
    EXPECT_EQ(warnings.messages.size(), 2u);
}

// Offline frames: after k frames of S from time 0, simTime is exactly k * S (the double nearest to
// the product), however S relates to the update step; no cap, nothing dropped. Before the fix the
// CLI drove the real-time loop: S = 1 s with 1/60 s steps ran 16 of 60 steps per frame (the cap),
// and S = 0.1 s ran 5 or 6 steps of 16 666 667 ns, ending 10 frames at 0.98333 s instead of 1 s.
TEST(AppLoop, OfflineFramesGiveExactSimulatedTime) {
    struct Case {
        double frame;     // S
        double fixedDt;   // scene update step
        int frames;       // k
        double expected;  // k * S
        uint64_t stepsPerFrame;
    };
    const Case cases[] = {
        {1.0, 1.0 / 60.0, 2, 2.0, 60},            // penumbra render --frames 3 --fixed-dt 1
        {0.1, 1.0 / 60.0, 10, 1.0, 6},            // --frames 11 --fixed-dt 0.1
        {1.0 / 60.0, 1.0 / 60.0, 60, 1.0, 1},     // one step per frame
        {1.0 / 60.0, 1.0 / 60.0, 3600, 60.0, 1},  // a minute at 60 fps
        {0.05, 0.01, 20, 1.0, 5},
        {0.025, 1.0 / 60.0, 40, 1.0, 2},  // 1.5 steps: two steps of 0.0125 s
        {0.1, 0.1 / 3.0, 30, 3.0, 3},
        {10.0, 1.0 / 60.0, 3, 30.0, 600},   // far beyond the real-time cap of 16
        {0.001, 1.0 / 60.0, 1000, 1.0, 1},  // frames shorter than a step
    };
    for (const Case& c : cases) {
        AppLoop loop;
        std::string error;
        ASSERT_TRUE(loop.configure({c.fixedDt, 16}, error)) << error;
        double stepSum = 0.0;
        uint64_t calls = 0;
        FrameTime t;
        for (int k = 0; k < c.frames; ++k) {
            ASSERT_TRUE(loop.advanceOffline(
                c.frame,
                [&](double dt) {
                    EXPECT_LE(dt, c.fixedDt * (1.0 + 1e-9));
                    stepSum += dt;
                    ++calls;
                },
                t, error))
                << error;
            EXPECT_EQ(t.steps, c.stepsPerFrame) << "S = " << c.frame;
            EXPECT_EQ(t.dropped, 0.0);
            EXPECT_EQ(t.alpha, 0.0);
            EXPECT_EQ(t.simTime, double(k + 1) * c.frame) << "S = " << c.frame << ", frame " << k;
        }
        EXPECT_EQ(loop.simTime(), c.expected) << "S = " << c.frame << ", dt = " << c.fixedDt;
        EXPECT_EQ(calls, c.stepsPerFrame * uint64_t(c.frames));
        EXPECT_EQ(loop.stepCount(), calls);
        EXPECT_EQ(loop.droppedSteps(), 0u);
        EXPECT_EQ(loop.droppedTime(), 0.0);
        // The steps the systems saw add up to the frames' time (up to summation rounding).
        EXPECT_NEAR(stepSum, c.expected, 1e-9 * c.expected);
    }
}

TEST(AppLoop, OfflineStepCountIsTheSmallestThatKeepsStepsWithinFixedDt) {
    EXPECT_EQ(AppLoop::offlineStepsPerFrame(1.0, 1.0 / 60.0), 60u);
    EXPECT_EQ(AppLoop::offlineStepsPerFrame(0.1, 1.0 / 60.0), 6u);
    EXPECT_EQ(AppLoop::offlineStepsPerFrame(0.3, 0.1), 3u);  // 0.3 / 0.1 = 2.9999999999999996
    EXPECT_EQ(AppLoop::offlineStepsPerFrame(0.7, 0.1), 7u);  // 0.7 / 0.1 = 6.999999999999999
    EXPECT_EQ(AppLoop::offlineStepsPerFrame(0.35, 0.1), 4u);
    EXPECT_EQ(AppLoop::offlineStepsPerFrame(0.101, 0.1), 2u);
    EXPECT_EQ(AppLoop::offlineStepsPerFrame(1e-7, 0.1), 1u);
    EXPECT_EQ(AppLoop::offlineStepsPerFrame(10.0, 1e-6), 10000000u);
}

TEST(AppLoop, OfflineZeroFrameThenFramesStartAtZero) {
    // The CLI's sequence: frame 0 at t = 0, then every frame exactly S later.
    AppLoop loop;
    std::string error;
    ASSERT_TRUE(loop.configure({1.0 / 60.0, 16}, error));
    FrameTime t;
    ASSERT_TRUE(loop.advanceOffline(0.0, {}, t, error)) << error;
    EXPECT_EQ(t.steps, 0u);
    EXPECT_EQ(t.simTime, 0.0);
    for (int k = 1; k <= 10; ++k) {
        ASSERT_TRUE(loop.advanceOffline(0.1, {}, t, error)) << error;
        EXPECT_EQ(t.frameIndex, uint64_t(k));
        EXPECT_EQ(t.simTime, k * 0.1);
    }
    EXPECT_EQ(loop.simTime(), 1.0);
    EXPECT_EQ(loop.stepCount(), 60u);
}

TEST(AppLoop, OfflineRejectsInvalidFrameTimesAndChangesNothing) {
    AppLoop loop;
    std::string error;
    ASSERT_TRUE(loop.configure({0.01, 4}, error));
    FrameTime t;
    ASSERT_TRUE(loop.advanceOffline(0.5, {}, t, error));
    for (double bad : {-0.1, std::nan(""), double(INFINITY), 10.5}) {
        error.clear();
        EXPECT_FALSE(loop.advanceOffline(bad, {}, t, error)) << bad;
        EXPECT_NE(error.find("offline frame time"), std::string::npos) << error;
    }
    EXPECT_EQ(loop.simTime(), 0.5);
    EXPECT_EQ(loop.frameCount(), 1u);
    EXPECT_EQ(loop.stepCount(), 50u);
}

TEST(AppLoop, SwitchingModesContinuesFromTheCurrentTime) {
    AppLoop loop;
    std::string error;
    ASSERT_TRUE(loop.configure({0.25, 16}, error));
    loop.advance(0.6, {});  // 2 steps: 0.5 s, 0.1 s left in the accumulator
    EXPECT_EQ(loop.simTime(), 0.5);
    FrameTime t;
    ASSERT_TRUE(loop.advanceOffline(1.0, {}, t, error));  // the leftover is discarded
    EXPECT_EQ(t.simTime, 1.5);
    EXPECT_EQ(t.steps, 4u);
    t = loop.advance(0.25, {});
    EXPECT_EQ(t.simTime, 1.75);
    loop.reset();
    EXPECT_EQ(loop.simTime(), 0.0);
}

TEST(AppLoop, InvalidFrameTimesAdvanceNothing) {
    AppLoop loop;
    std::string error;
    ASSERT_TRUE(loop.configure({0.01, 4}, error));
    EXPECT_EQ(loop.advance(-1.0, {}).steps, 0u);
    EXPECT_EQ(loop.advance(std::nan(""), {}).steps, 0u);
    EXPECT_EQ(loop.advance(INFINITY, {}).steps, 0u);
    EXPECT_EQ(loop.simTime(), 0.0);
}

TEST(AppLoop, RejectsBadConfiguration) {
    AppLoop loop;
    std::string error;
    EXPECT_FALSE(loop.configure({0.0, 4}, error));
    EXPECT_NE(error.find("fixed update step"), std::string::npos) << error;
    EXPECT_FALSE(loop.configure({std::nan(""), 4}, error));
    EXPECT_FALSE(loop.configure({0.01, 0}, error));
    EXPECT_NE(error.find("maxStepsPerFrame"), std::string::npos) << error;
    EXPECT_EQ(loop.fixedDtNs(), AppLoop::toNanoseconds(1.0 / 60.0));  // unchanged
}

TEST(AppLoop, SameInputsGiveSameStepSequence) {
    auto run = [](std::vector<double> frames) {
        AppLoop loop;
        std::string error;
        loop.configure({1.0 / 60.0, 8}, error);
        std::vector<uint32_t> steps;
        for (double f : frames) steps.push_back(loop.advance(f, {}).steps);
        return std::make_pair(steps, loop.simTime());
    };
    std::vector<double> frames = {0.016, 0.017, 0.033, 0.001, 0.1, 0.0166, 0.0167};
    EXPECT_EQ(run(frames), run(frames));
}

}  // namespace
}  // namespace penumbra::app
