// The bake progress bar: silent unless a terminal, silent for work under a second, silent when
// disabled; a single redrawn line with percentage and ETA that is cleared at the end.
#include <gtest/gtest.h>

#include "engine/core/progress.h"

namespace {

using penumbra::ProgressBar;
using penumbra::ProgressOutput;
using penumbra::ProgressSettings;

struct CaptureOutput : ProgressOutput {
    bool terminal = true;
    std::string text;
    int writes = 0;
    bool isTerminal() const override { return terminal; }
    void write(std::string_view t) override {
        text += t;
        ++writes;
    }
};

struct FakeClock {
    double t = 0;
    ProgressSettings settings(bool enabled = true) {
        ProgressSettings s;
        s.enabled = enabled;
        s.clock = [this] { return t; };
        return s;
    }
};

TEST(Progress, FormatsPhaseBarPercentAndEta) {
    EXPECT_EQ(ProgressBar::formatLine("distance", 0.5, 2.0, 10), "distance  [#####-----]  50% ETA 2s");
    EXPECT_EQ(ProgressBar::formatLine("sign", 1.0, 0.0, 4), "sign      [####] 100% ETA 0s");
    EXPECT_EQ(ProgressBar::formatLine("bvh", 0.0, -1.0, 4), "bvh       [----]   0% ETA --");
    EXPECT_EQ(ProgressBar::formatLine("distance", 0.25, 125.0, 4), "distance  [#---]  25% ETA 2:05");
}

TEST(Progress, SilentWhenNotATerminal) {
    CaptureOutput out;
    out.terminal = false;
    FakeClock clock;
    {
        ProgressBar bar(out, clock.settings());
        for (int i = 0; i <= 100; ++i) {
            clock.t = i * 0.1;
            bar.update(i / 100.0, "distance");
        }
    }
    EXPECT_EQ(out.writes, 0);
}

TEST(Progress, SilentWhenQuiet) {
    CaptureOutput out;
    FakeClock clock;
    {
        ProgressBar bar(out, clock.settings(false));
        clock.t = 5;
        bar.update(0.5, "distance");
    }
    EXPECT_EQ(out.writes, 0);
}

TEST(Progress, SilentForWorkUnderASecond) {
    CaptureOutput out;
    FakeClock clock;
    {
        ProgressBar bar(out, clock.settings());
        for (int i = 0; i <= 90; ++i) {
            clock.t = i * 0.01;
            bar.update(i / 90.0, "distance");
        }
        bar.finish();
    }
    EXPECT_EQ(out.writes, 0);
}

TEST(Progress, DrawsAfterASecondWithEtaRateLimitedAndClearsAtTheEnd) {
    CaptureOutput out;
    FakeClock clock;
    ProgressBar bar(out, clock.settings());
    clock.t = 0.5;
    bar.update(0.1, "distance");
    EXPECT_EQ(out.writes, 0);
    clock.t = 2.0;
    bar.update(0.5, "distance");  // 2 s for half the phase -> 2 s left
    ASSERT_EQ(out.writes, 1);
    EXPECT_EQ(out.text, "\rdistance  [###############---------------]  50% ETA 2s");
    clock.t = 2.05;
    bar.update(0.55, "distance");  // within the redraw interval: skipped
    EXPECT_EQ(out.writes, 1);
    clock.t = 2.2;
    bar.update(0.6, "distance");
    EXPECT_EQ(out.writes, 2);
    clock.t = 2.25;
    bar.update(0.0, "sign");  // a new phase draws at once and restarts the ETA
    EXPECT_EQ(out.writes, 3);
    EXPECT_NE(out.text.rfind("sign "), std::string::npos);
    EXPECT_NE(out.text.rfind("ETA --"), std::string::npos);
    bar.finish();
    EXPECT_EQ(out.writes, 4);
    const std::string tail = out.text.substr(out.text.rfind('\r', out.text.size() - 2));
    EXPECT_EQ(tail.find_first_not_of(" \r"), std::string::npos) << "finish must blank the line";
    bar.update(0.9, "sign");  // nothing after finish
    EXPECT_EQ(out.writes, 4);
    EXPECT_TRUE(bar.drawn());
    EXPECT_EQ(out.text.find('\n'), std::string::npos);
}

}  // namespace
