// The app loop: fixed steps, accumulator, catch-up cap, deterministic integer time.
#include <gtest/gtest.h>

#include <cmath>

#include "engine/app/app_loop.h"

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
