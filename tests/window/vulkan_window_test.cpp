// Windowed Vulkan device under Xvfb (ctest runs window_tests through xvfb-run): GLFW window
// without a client API, swapchain, acquire / render / present, resize, validation layer on.
#include <gtest/gtest.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <shaders/vkwin_triangle.h>

#include "rhi/device.h"
#include "rhi/vulkan/vulkan_inspect.h"
#include "support/test_device.h"

namespace {

using penumbra::test::LogCapture;

// GLFW stays initialised for the rest of the process (renderer_window_test.cpp).
struct GlfwWindow {
    GLFWwindow* window = nullptr;
    ~GlfwWindow() {
        if (window) glfwDestroyWindow(window);
    }
};

// Opens a 160x120 window for Vulkan (no GL context). Fails the test when there is no display.
bool openWindow(GlfwWindow& w, int width, int height) {
    if (!glfwInit()) {
        ADD_FAILURE() << "glfwInit failed (no X display? run under xvfb-run)";
        return false;
    }
    if (!glfwVulkanSupported()) {
        ADD_FAILURE() << "GLFW finds no Vulkan loader";
        return false;
    }
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
    w.window = glfwCreateWindow(width, height, "penumbra vulkan window test", nullptr, nullptr);
    if (!w.window) ADD_FAILURE() << "glfwCreateWindow failed";
    return w.window != nullptr;
}

std::unique_ptr<rhi::Device> createWindowedDevice(GLFWwindow* window, bool vsync,
                                                  std::shared_ptr<LogCapture> log) {
    rhi::DeviceDesc desc;
    desc.backend = rhi::Backend::Vulkan;
    desc.headless = false;
    desc.window = window;
    desc.vsync = vsync;
    desc.validation = true;
    desc.log = [log](rhi::LogSeverity s, std::string_view msg) {
        std::lock_guard lock(log->mutex);
        log->all.emplace_back(msg);
        if (s == rhi::LogSeverity::Error) {
            log->errors.emplace_back(msg);
            std::fprintf(stderr, "[rhi error] %.*s\n", int(msg.size()), msg.data());
        }
    };
    return rhi::createDevice(desc);
}

std::array<int, 2> framebufferSize(GLFWwindow* window) {
    int w = 0, h = 0;
    glfwGetFramebufferSize(window, &w, &h);
    return {w, h};
}

// Resizes the window and waits (bounded) until the X server reports the new size.
std::array<int, 2> resizeWindow(GLFWwindow* window, int width, int height) {
    glfwSetWindowSize(window, width, height);
    for (int i = 0; i < 100; ++i) {
        glfwPollEvents();
        auto size = framebufferSize(window);
        if (size[0] == width && size[1] == height) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return framebufferSize(window);
}

struct Frame {
    std::array<float, 4> clear;
    std::array<float, 4> triangle;
};

// Renders one frame into the acquired backbuffer, reads it back (so the test sees what is
// presented) and presents it.
void renderAndPresent(rhi::Device& dev, rhi::PipelineHandle pipeline, const Frame& frame, int expectW,
                      int expectH) {
    rhi::TextureHandle backbuffer = dev.acquireBackbuffer();
    ASSERT_TRUE(backbuffer.isValid());
    const rhi::TextureDesc* desc = dev.describe(backbuffer);
    ASSERT_NE(desc, nullptr);
    EXPECT_EQ(desc->format, dev.backbufferFormat());
    EXPECT_EQ(int(desc->width), expectW);
    EXPECT_EQ(int(desc->height), expectH);
    EXPECT_TRUE(any(desc->usage & rhi::TextureUsage::ColorTarget));

    rhi::CommandList& cmd = dev.beginCommandList("window frame");
    cmd.barrier(rhi::Barrier::tex(backbuffer, rhi::Access::None, rhi::Access::ColorTarget));
    rhi::RenderPassDesc rp;
    rhi::ColorAttachment ca;
    ca.texture = backbuffer;
    ca.clearColor = frame.clear;
    rp.colorAttachments.push_back(ca);
    rp.debugName = "window pass";
    cmd.beginRenderPass(rp);
    cmd.bindPipeline(pipeline);
    cmd.pushConstants(frame.triangle.data(), sizeof(float) * 4);
    cmd.draw(3);
    cmd.endRenderPass();
    cmd.barrier(rhi::Barrier::tex(backbuffer, rhi::Access::ColorTarget, rhi::Access::CopySrc));
    dev.submit(cmd);

    std::vector<uint8_t> pixels;
    ASSERT_TRUE(dev.readTexture(backbuffer, {}, rhi::Access::CopySrc, pixels));
    ASSERT_EQ(pixels.size(), size_t(desc->width) * desc->height * 4);
    auto pixel = [&](uint32_t x, uint32_t y) {
        const uint8_t* p = &pixels[(size_t(y) * desc->width + x) * 4];
        return std::array<int, 4>{p[0], p[1], p[2], p[3]};
    };
    auto expectColor = [](std::array<int, 4> got, const std::array<float, 4>& want, const char* where) {
        for (int c = 0; c < 4; ++c) EXPECT_NEAR(got[c], want[c] * 255.0f, 1.0f) << where << " channel " << c;
    };
    expectColor(pixel(2, 2), frame.clear, "corner");
    expectColor(pixel(desc->width / 2, desc->height / 2), frame.triangle, "centre");
    // Row 0 is NDC y = -1: the triangle's wide edge (y = -0.5) is near the top rows.
    expectColor(pixel(desc->width / 2, desc->height * 3 / 10), frame.triangle, "wide edge");
    expectColor(pixel(desc->width / 2 + desc->width / 8, desc->height * 7 / 10), frame.clear,
                "beside the apex");

    rhi::CommandList& toPresent = dev.beginCommandList("to present");
    toPresent.barrier(rhi::Barrier::tex(backbuffer, rhi::Access::CopySrc, rhi::Access::Present));
    dev.submit(toPresent);
    EXPECT_TRUE(dev.present());
    glfwPollEvents();
}

TEST(VulkanWindow, AcquireRenderPresentAndResize) {
    GlfwWindow w;
    ASSERT_TRUE(openWindow(w, 160, 120));
    auto log = std::make_shared<LogCapture>();
    auto device = createWindowedDevice(w.window, true, log);
    ASSERT_NE(device, nullptr);
    rhi::Device& dev = *device;
    EXPECT_EQ(dev.info().platform, "GLFW window");
    EXPECT_EQ(dev.backbufferFormat(), rhi::Format::RGBA8_UNORM);
    EXPECT_TRUE(rhi::vulkan::inspect(dev).validationLayerEnabled);
    EXPECT_TRUE(rhi::vulkan::inspect(dev).debugMessengerInstalled);

    rhi::GraphicsPipelineDesc pd;
    pd.vertexShader = dev.createShader(penumbra::shaders::vkwin_triangle::vertex());
    pd.fragmentShader = dev.createShader(penumbra::shaders::vkwin_triangle::fragment());
    pd.colorFormats = {dev.backbufferFormat()};
    pd.debugName = "window triangle";
    rhi::PipelineHandle pipeline = dev.createGraphicsPipeline(pd);
    ASSERT_TRUE(pipeline.isValid());

    const Frame frames[] = {
        {{1.0f, 0.0f, 0.0f, 1.0f}, {0.0f, 1.0f, 0.0f, 1.0f}},
        {{0.0f, 0.0f, 1.0f, 1.0f}, {1.0f, 1.0f, 0.0f, 1.0f}},
        {{0.2f, 0.4f, 0.6f, 1.0f}, {1.0f, 1.0f, 1.0f, 1.0f}},
    };
    auto size = framebufferSize(w.window);
    for (const Frame& f : frames) {
        renderAndPresent(dev, pipeline, f, size[0], size[1]);
        if (testing::Test::HasFatalFailure()) return;
    }

    size = resizeWindow(w.window, 200, 150);
    EXPECT_EQ(size[0], 200);
    EXPECT_EQ(size[1], 150);
    dev.resizeBackbuffer(uint32_t(size[0]), uint32_t(size[1]));
    for (const Frame& f : frames) {
        renderAndPresent(dev, pipeline, f, size[0], size[1]);
        if (testing::Test::HasFatalFailure()) return;
    }

    // A resize the device is not told about: the next acquire notices the new surface size.
    size = resizeWindow(w.window, 128, 96);
    renderAndPresent(dev, pipeline, frames[0], size[0], size[1]);

    dev.waitIdle();
    dev.destroy(pipeline);
    dev.destroy(pd.vertexShader);
    dev.destroy(pd.fragmentShader);
    EXPECT_EQ(rhi::validationErrorCount(dev), 0u);
    device.reset();  // leaks would be reported by the validation layer here
    std::lock_guard lock(log->mutex);
    EXPECT_TRUE(log->errors.empty()) << log->errors.size() << " error(s), first: " << log->errors.front();
}

TEST(VulkanWindow, NoVsyncPresentsToo) {
    GlfwWindow w;
    ASSERT_TRUE(openWindow(w, 96, 64));
    auto log = std::make_shared<LogCapture>();
    auto device = createWindowedDevice(w.window, false, log);
    ASSERT_NE(device, nullptr);
    rhi::Device& dev = *device;
    for (int i = 0; i < 4; ++i) {
        rhi::TextureHandle backbuffer = dev.acquireBackbuffer();
        ASSERT_TRUE(backbuffer.isValid());
        rhi::CommandList& cmd = dev.beginCommandList("clear");
        cmd.barrier(rhi::Barrier::tex(backbuffer, rhi::Access::None, rhi::Access::ColorTarget));
        rhi::RenderPassDesc rp;
        rhi::ColorAttachment ca;
        ca.texture = backbuffer;
        ca.clearColor = {0.0f, float(i) / 4.0f, 0.0f, 1.0f};
        rp.colorAttachments.push_back(ca);
        cmd.beginRenderPass(rp);
        cmd.endRenderPass();
        cmd.barrier(rhi::Barrier::tex(backbuffer, rhi::Access::ColorTarget, rhi::Access::Present));
        dev.submit(cmd);
        EXPECT_TRUE(dev.present());
        glfwPollEvents();
    }
    device.reset();
    std::lock_guard lock(log->mutex);
    EXPECT_TRUE(log->errors.empty()) << log->errors.size() << " error(s), first: " << log->errors.front();
}

TEST(VulkanWindow, WindowedDeviceWithoutWindowFails) {
    auto log = std::make_shared<LogCapture>();
    rhi::DeviceDesc desc;
    desc.backend = rhi::Backend::Vulkan;
    desc.headless = false;
    desc.log = [log](rhi::LogSeverity s, std::string_view msg) {
        std::lock_guard lock(log->mutex);
        if (s == rhi::LogSeverity::Error) log->errors.emplace_back(msg);
    };
    EXPECT_EQ(rhi::createDevice(desc), nullptr);
    std::lock_guard lock(log->mutex);
    ASSERT_EQ(log->errors.size(), 1u);
    EXPECT_NE(log->errors[0].find("window"), std::string::npos) << log->errors[0];
}

}  // namespace
