// Prints the wall time of the stability cases this process ran ("[ stability ] total ..."), so a CI
// log shows the suite's cost (CTest runs each case in its own process and prints its own total).
#include "stability/stability_util.h"

namespace penumbra::test::stability {
namespace {

class SuiteTimer : public testing::Environment {
public:
    void SetUp() override { m_watch = Stopwatch(); }
    void TearDown() override {
        std::printf("[ stability ] total: %.1f s wall for the cases run in this process\n",
                    m_watch.ms() / 1000.0);
        std::fflush(stdout);
    }

private:
    Stopwatch m_watch;
};

[[maybe_unused]] testing::Environment* const kTimer = testing::AddGlobalTestEnvironment(new SuiteTimer);

}  // namespace
}  // namespace penumbra::test::stability
