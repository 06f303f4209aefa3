// OpenGL windowed device: a GLFW window with a 4.5 core context (run under Xvfb by CTest), three
// frames rendered into the device's backbuffer and presented, then a resize and one more frame.
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <gtest/gtest.h>

#include <shaders/gl_window_triangle.h>

#include "rhi/device.h"
#include "support/test_device.h"

namespace {

bool openGLSelected() {
    const auto backends = penumbra::test::gpuBackends();
    return std::find(backends.begin(), backends.end(), rhi::Backend::OpenGL) != backends.end();
}

struct Push {
    float color[4];
    float offset;
};
static_assert(sizeof(Push) == 20);

class GlWindowTest : public testing::Test {
protected:
    void SetUp() override {
        if (!openGLSelected()) GTEST_SKIP() << "OpenGL not selected (--backend)";
        // GLFW stays initialised for the rest of the process (renderer_window_test.cpp).
        if (!glfwInit()) GTEST_SKIP() << "glfwInit failed: no display (run under xvfb-run)";
        glfwDefaultWindowHints();
        glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
        glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
        glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
        glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
        glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
        glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, GLFW_TRUE);
        m_window = glfwCreateWindow(160, 120, "penumbra gl window test", nullptr, nullptr);
        ASSERT_NE(m_window, nullptr) << "cannot create a GLFW window with an OpenGL 4.5 core context";

        m_log = std::make_shared<penumbra::test::LogCapture>();
        rhi::DeviceDesc desc;
        desc.backend = rhi::Backend::OpenGL;
        desc.headless = false;
        desc.window = m_window;
        desc.validation = true;
        desc.vsync = false;
        auto log = m_log;
        desc.log = [log](rhi::LogSeverity s, std::string_view msg) {
            std::lock_guard lock(log->mutex);
            log->all.emplace_back(msg);
            if (s == rhi::LogSeverity::Error) log->errors.emplace_back(msg);
        };
        m_device = rhi::createDevice(desc);
        ASSERT_NE(m_device, nullptr) << (m_log->all.empty() ? std::string() : m_log->all.back());
    }

    void TearDown() override {
        if (m_device) {
            for (auto h : m_pipelines) m_device->destroy(h);
            for (auto h : m_shaders) m_device->destroy(h);
            m_device->waitIdle();
        }
        m_device.reset();
        if (m_window) glfwDestroyWindow(m_window);
        if (m_log) {
            EXPECT_TRUE(m_log->errors.empty())
                << m_log->errors.size()
                << " error(s), first: " << (m_log->errors.empty() ? "" : m_log->errors.front());
        }
    }

    rhi::PipelineHandle makePipeline() {
        rhi::GraphicsPipelineDesc gp;
        gp.vertexShader = m_device->createShader(penumbra::shaders::gl_window_triangle::vertex());
        gp.fragmentShader = m_device->createShader(penumbra::shaders::gl_window_triangle::fragment());
        m_shaders.push_back(gp.vertexShader);
        m_shaders.push_back(gp.fragmentShader);
        gp.colorFormats = {m_device->backbufferFormat()};
        gp.debugName = "gl window triangle";
        rhi::PipelineHandle p = m_device->createGraphicsPipeline(gp);
        m_pipelines.push_back(p);
        return p;
    }

    // Renders one frame: clear to `clear`, one triangle; optionally reads the backbuffer back
    // before presenting it.
    void renderFrame(rhi::PipelineHandle pipeline, rhi::TextureHandle backbuffer, const float (&clear)[4],
                     const Push& push, std::vector<uint8_t>* readback) {
        rhi::CommandList& cmd = m_device->beginCommandList("gl window frame");
        cmd.barrier(rhi::Barrier::tex(backbuffer, m_backbufferState, rhi::Access::ColorTarget));
        rhi::RenderPassDesc pass;
        rhi::ColorAttachment color;
        color.texture = backbuffer;
        color.clearColor = {clear[0], clear[1], clear[2], clear[3]};
        pass.colorAttachments.push_back(color);
        pass.debugName = "frame";
        cmd.beginRenderPass(pass);
        const rhi::TextureDesc* d = m_device->describe(backbuffer);
        rhi::Viewport vp;
        vp.width = float(d->width);
        vp.height = float(d->height);
        cmd.setViewport(vp);
        rhi::Rect scissor;
        scissor.width = d->width;
        scissor.height = d->height;
        cmd.setScissor(scissor);
        cmd.bindPipeline(pipeline);
        cmd.pushConstants(&push, sizeof(push));
        cmd.draw(3);
        cmd.endRenderPass();
        if (readback) {
            cmd.barrier(rhi::Barrier::tex(backbuffer, rhi::Access::ColorTarget, rhi::Access::CopySrc));
            cmd.barrier(rhi::Barrier::tex(backbuffer, rhi::Access::CopySrc, rhi::Access::Present));
            m_device->waitForSubmission(m_device->submit(cmd));
            // The backbuffer's content stays valid after the Present transition on GL.
            EXPECT_TRUE(m_device->readTexture(backbuffer, {}, rhi::Access::Present, *readback));
        } else {
            cmd.barrier(rhi::Barrier::tex(backbuffer, rhi::Access::ColorTarget, rhi::Access::Present));
            m_device->submit(cmd);
        }
        m_backbufferState = rhi::Access::Present;
        EXPECT_TRUE(m_device->present());
        glfwPollEvents();
    }

    GLFWwindow* m_window = nullptr;
    std::shared_ptr<penumbra::test::LogCapture> m_log;
    std::unique_ptr<rhi::Device> m_device;
    std::vector<rhi::ShaderHandle> m_shaders;
    std::vector<rhi::PipelineHandle> m_pipelines;
    rhi::Access m_backbufferState = rhi::Access::None;
};

TEST_F(GlWindowTest, RendersPresentsAndResizes) {
    const rhi::DeviceInfo& info = m_device->info();
    EXPECT_EQ(info.backend, rhi::Backend::OpenGL);
    EXPECT_EQ(info.platform, "GLFW window");
    EXPECT_EQ(m_device->backbufferFormat(), rhi::Format::RGBA8_SRGB);

    rhi::PipelineHandle pipeline = makePipeline();
    ASSERT_TRUE(pipeline.isValid());

    int fbw = 0, fbh = 0;
    glfwGetFramebufferSize(m_window, &fbw, &fbh);
    rhi::TextureHandle backbuffer = m_device->acquireBackbuffer();
    ASSERT_TRUE(backbuffer.isValid());
    const rhi::TextureDesc* desc = m_device->describe(backbuffer);
    ASSERT_NE(desc, nullptr);
    EXPECT_EQ(desc->width, uint32_t(fbw));
    EXPECT_EQ(desc->height, uint32_t(fbh));
    EXPECT_TRUE(any(desc->usage & rhi::TextureUsage::ColorTarget));

    const float clears[3][4] = {{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}};
    for (int frame = 0; frame < 3; ++frame) {
        backbuffer = m_device->acquireBackbuffer();
        ASSERT_TRUE(backbuffer.isValid());
        Push push{{1, 1, 1, 1}, -0.4f + 0.4f * float(frame)};
        std::vector<uint8_t> px;
        renderFrame(pipeline, backbuffer, clears[frame], push, frame == 2 ? &px : nullptr);
        if (frame == 2) {
            ASSERT_EQ(px.size(), size_t(fbw) * size_t(fbh) * 4);
            // Corner (0, 0) is the clear colour, the triangle's centre is white.
            EXPECT_EQ(px[0], 0);
            EXPECT_EQ(px[1], 0);
            EXPECT_EQ(px[2], 255);
            const size_t cx = size_t(fbw) * 7 / 10, cy = size_t(fbh) / 2;  // offset +0.4 -> x = 0.7 W
            const uint8_t* c = px.data() + (cy * size_t(fbw) + cx) * 4;
            EXPECT_EQ(c[0], 255);
            EXPECT_EQ(c[1], 255);
            EXPECT_EQ(c[2], 255);
        }
    }

    // Resize: the window and the backbuffer.
    glfwSetWindowSize(m_window, 200, 150);
    glfwPollEvents();
    m_device->resizeBackbuffer(200, 150);
    rhi::TextureHandle resized = m_device->acquireBackbuffer();
    ASSERT_TRUE(resized.isValid());
    EXPECT_FALSE(m_device->isAlive(backbuffer) && resized != backbuffer);
    desc = m_device->describe(resized);
    ASSERT_NE(desc, nullptr);
    EXPECT_EQ(desc->width, 200u);
    EXPECT_EQ(desc->height, 150u);
    m_backbufferState = rhi::Access::None;
    const float grey[4] = {0.5f, 0.5f, 0.5f, 1.0f};
    std::vector<uint8_t> px;
    renderFrame(pipeline, resized, grey, Push{{0, 0, 0, 1}, 0.0f}, &px);
    ASSERT_EQ(px.size(), 200u * 150u * 4u);
    EXPECT_EQ(px[0], 188);  // sRGB encoding of 0.5, as on a Vulkan sRGB swapchain
    m_device->waitIdle();
}

TEST_F(GlWindowTest, WindowedDeviceWithoutWindowFails) {
    // A windowed device needs a window.
    rhi::DeviceDesc desc;
    desc.backend = rhi::Backend::OpenGL;
    desc.headless = false;
    desc.window = nullptr;
    std::vector<std::string> messages;
    desc.log = [&](rhi::LogSeverity, std::string_view m) { messages.emplace_back(m); };
    EXPECT_EQ(rhi::createDevice(desc), nullptr);
    ASSERT_FALSE(messages.empty());
    EXPECT_NE(messages.back().find("window"), std::string::npos) << messages.back();
}

}  // namespace
