// Test helpers: which GPU backends to test (--backend / PENUMBRA_BACKEND) and validated devices
// whose every error-severity message (RHI validation wrapper, Vulkan validation layer, GL debug
// output) fails the test.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rhi/device.h"

namespace penumbra::test {

// Called by the test main before InitGoogleTest: strips `--backend X` from argv.
void parseTestArgs(int& argc, char** argv);

// GPU backends under test: both (Vulkan, OpenGL) unless --backend or PENUMBRA_BACKEND names one.
std::vector<rhi::Backend> gpuBackends();

// For INSTANTIATE_TEST_SUITE_P(..., testing::ValuesIn(gpuBackends()), backendName).
std::string backendName(const testing::TestParamInfo<rhi::Backend>& info);

// Collects everything the device logs; errors are what make a test fail.
struct LogCapture {
    std::mutex mutex;
    std::vector<std::string> errors;
    std::vector<std::string> all;
};

// Creates a headless device with validation on; fails the calling test if it cannot.
std::unique_ptr<rhi::Device> createTestDevice(rhi::Backend backend, std::shared_ptr<LogCapture> log,
                                              bool validation = true);

// A Vulkan and an OpenGL device, validation on, for the Vulkan-vs-OpenGL parity tests:
//   BackendPair pair;
//   ASSERT_TRUE(pair.ready());
//   ... render on *pair.vk and *pair.gl, compare ...
//   pair.expectNoErrors();
struct BackendPair {
    std::shared_ptr<LogCapture> logVk = std::make_shared<LogCapture>();
    std::shared_ptr<LogCapture> logGl = std::make_shared<LogCapture>();
    std::unique_ptr<rhi::Device> vk = createTestDevice(rhi::Backend::Vulkan, logVk);
    std::unique_ptr<rhi::Device> gl = createTestDevice(rhi::Backend::OpenGL, logGl);

    bool ready() const { return vk && gl; }
    // Fails the calling test if either device logged a validation error (the first one shown).
    void expectNoErrors() const {
        EXPECT_TRUE(logVk->errors.empty()) << logVk->errors.front();
        EXPECT_TRUE(logGl->errors.empty()) << logGl->errors.front();
    }
};

// Fixture parameterised over backend: creates the device in SetUp and, in TearDown, waits for the
// GPU and fails the test if any validation error was reported.
class GpuTest : public testing::TestWithParam<rhi::Backend> {
protected:
    void SetUp() override;
    void TearDown() override;
    rhi::Device& dev() { return *m_device; }
    // Expect exactly this many validation errors so far (for tests that provoke misuse), then
    // forget them so TearDown does not fail on them.
    void consumeExpectedErrors(size_t expected);

    std::unique_ptr<rhi::Device> m_device;
    std::shared_ptr<LogCapture> m_log;
};

}  // namespace penumbra::test
