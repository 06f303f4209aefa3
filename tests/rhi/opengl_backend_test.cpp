// OpenGL backend specifics: both headless context platforms (EGL surfaceless and OSMesa, chosen
// with PENUMBRA_GL_PLATFORM), clears and readback, compute round trips, storage images, the
// Vulkan-compatible image orientation of rendering, error reporting and handle robustness.
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include <EGL/egl.h>
#include <GL/glcorearb.h>
#include <gtest/gtest.h>

#include <shaders/gl_half_screen.h>
#include <shaders/gl_image_fill.h>
#include <shaders/gl_scale_bias.h>

#include "rhi/device.h"
#include "support/test_device.h"

namespace {

using penumbra::test::LogCapture;

bool openGLSelected() {
    const auto backends = penumbra::test::gpuBackends();
    return std::find(backends.begin(), backends.end(), rhi::Backend::OpenGL) != backends.end();
}

// Sets PENUMBRA_GL_PLATFORM for the lifetime of the object and restores the previous value.
class PlatformOverride {
public:
    explicit PlatformOverride(const char* value) {
        if (const char* old = std::getenv("PENUMBRA_GL_PLATFORM")) m_old = old;
        if (value)
            setenv("PENUMBRA_GL_PLATFORM", value, 1);
        else
            unsetenv("PENUMBRA_GL_PLATFORM");
    }
    ~PlatformOverride() {
        if (m_old)
            setenv("PENUMBRA_GL_PLATFORM", m_old->c_str(), 1);
        else
            unsetenv("PENUMBRA_GL_PLATFORM");
    }
    PlatformOverride(const PlatformOverride&) = delete;
    PlatformOverride& operator=(const PlatformOverride&) = delete;

private:
    std::optional<std::string> m_old;
};

std::unique_ptr<rhi::Device> makeGlDevice(const char* platform, std::shared_ptr<LogCapture> log,
                                          bool validation = true) {
    PlatformOverride env(platform);
    return penumbra::test::createTestDevice(rhi::Backend::OpenGL, std::move(log), validation);
}

void expectNoErrors(const LogCapture& log) {
    EXPECT_TRUE(log.errors.empty()) << log.errors.size()
                                    << " error(s), first: " << (log.errors.empty() ? "" : log.errors.front());
}

// Clears a 4x4 RGBA8_SRGB target and checks the sRGB-encoded bytes (as Vulkan writes them).
void clearAndRead(rhi::Device& dev) {
    rhi::TextureDesc td;
    td.format = rhi::Format::RGBA8_SRGB;
    td.width = 4;
    td.height = 4;
    td.usage = rhi::TextureUsage::ColorTarget | rhi::TextureUsage::CopySrc;
    td.debugName = "gl clear target";
    rhi::TextureHandle tex = dev.createTexture(td);
    ASSERT_TRUE(tex.isValid());

    rhi::CommandList& cmd = dev.beginCommandList("gl clear");
    cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::None, rhi::Access::ColorTarget));
    rhi::RenderPassDesc pass;
    rhi::ColorAttachment color;
    color.texture = tex;
    color.clearColor = {0.5f, 0.25f, 1.0f, 1.0f};
    pass.colorAttachments.push_back(color);
    cmd.beginRenderPass(pass);
    cmd.endRenderPass();
    cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::ColorTarget, rhi::Access::CopySrc));
    dev.waitForSubmission(dev.submit(cmd));

    std::vector<uint8_t> px;
    ASSERT_TRUE(dev.readTexture(tex, {}, rhi::Access::CopySrc, px));
    ASSERT_EQ(px.size(), 4u * 4u * 4u);
    // sRGB(0.5) = 0.7354 -> 188, sRGB(0.25) = 0.5371 -> 137.
    for (size_t i = 0; i < px.size(); i += 4) {
        EXPECT_EQ(px[i + 0], 188);
        EXPECT_EQ(px[i + 1], 137);
        EXPECT_EQ(px[i + 2], 255);
        EXPECT_EQ(px[i + 3], 255);
    }
    dev.destroy(tex);
}

// dst = src * scale + bias on 1000 elements, twice in one list with a barrier in between.
void computeRoundTrip(rhi::Device& dev) {
    constexpr uint32_t kCount = 1000;
    std::vector<uint32_t> input(kCount);
    for (uint32_t i = 0; i < kCount; ++i) input[i] = i * 3 + 1;

    rhi::BufferDesc bd;
    bd.size = kCount * 4;
    bd.usage = rhi::BufferUsage::Storage | rhi::BufferUsage::CopySrc;
    bd.debugName = "gl src";
    rhi::BufferHandle src = dev.createBuffer(bd, input.data());
    bd.debugName = "gl dst";
    rhi::BufferHandle dst = dev.createBuffer(bd);
    bd.debugName = "gl readback";
    bd.memory = rhi::MemoryType::Readback;
    bd.usage = rhi::BufferUsage::CopyDst;
    rhi::BufferHandle readback = dev.createBuffer(bd);
    ASSERT_TRUE(src && dst && readback);
    ASSERT_NE(dev.mappedPointer(readback), nullptr);

    const auto& cs = penumbra::shaders::gl_scale_bias::compute();
    rhi::ComputePipelineDesc pd;
    pd.shader = dev.createShader(cs);
    pd.debugName = "gl scale bias";
    rhi::PipelineHandle pipeline = dev.createComputePipeline(pd);
    ASSERT_TRUE(pipeline.isValid());

    rhi::BindGroupDesc g0;
    g0.pipeline = pipeline;
    g0.set = 0;
    g0.entries = {rhi::BindGroupEntry::makeBuffer(0, src)};
    rhi::BindGroupDesc g1 = g0;
    g1.set = 1;
    g1.entries = {rhi::BindGroupEntry::makeBuffer(0, dst)};
    rhi::BindGroupHandle group0 = dev.createBindGroup(g0);
    rhi::BindGroupHandle group1 = dev.createBindGroup(g1);
    ASSERT_TRUE(group0 && group1);

    struct Push {
        uint32_t scale, bias, count;
    };
    rhi::CommandList& cmd = dev.beginCommandList("gl compute");
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group0);
    cmd.bindGroup(1, group1);
    Push push{3, 5, kCount};
    cmd.pushConstants(&push, sizeof(push));
    cmd.dispatch((kCount + 63) / 64);
    // Second pass reads what the first one wrote: dst = dst * 2 + 1.
    cmd.barrier(
        rhi::Barrier::buf(dst, rhi::Access::ShaderWrite, rhi::Access::ShaderRead | rhi::Access::ShaderWrite));
    rhi::BindGroupDesc g0b = g0;
    g0b.entries = {rhi::BindGroupEntry::makeBuffer(0, dst)};
    rhi::BindGroupHandle group0b = dev.createBindGroup(g0b);
    cmd.bindGroup(0, group0b);
    // Writing in place: the same buffer is bound as source and destination.
    push = {2, 1, kCount};
    cmd.pushConstants(&push, sizeof(push));
    cmd.dispatch((kCount + 63) / 64);
    cmd.barrier(
        rhi::Barrier::buf(dst, rhi::Access::ShaderRead | rhi::Access::ShaderWrite, rhi::Access::CopySrc));
    cmd.copyBuffer(dst, 0, readback, 0, kCount * 4);
    cmd.barrier(rhi::Barrier::buf(readback, rhi::Access::CopyDst, rhi::Access::HostRead));
    dev.waitForSubmission(dev.submit(cmd));

    std::vector<uint32_t> viaRead(kCount);
    ASSERT_TRUE(dev.readBuffer(dst, 0, kCount * 4, viaRead.data()));
    const auto* mapped = static_cast<const uint32_t*>(dev.mappedPointer(readback));
    for (uint32_t i = 0; i < kCount; ++i) {
        const uint32_t expected = (input[i] * 3 + 5) * 2 + 1;
        ASSERT_EQ(viaRead[i], expected) << "element " << i;
        ASSERT_EQ(mapped[i], expected) << "mapped element " << i;
    }
    for (auto g : {group0, group1, group0b}) dev.destroy(g);
    dev.destroy(pipeline);
    dev.destroy(pd.shader);
    for (auto b : {src, dst, readback}) dev.destroy(b);
}

class OpenGLBackend : public testing::Test {
protected:
    void SetUp() override {
        if (!openGLSelected()) GTEST_SKIP() << "OpenGL not selected (--backend)";
        m_log = std::make_shared<LogCapture>();
    }
    std::shared_ptr<LogCapture> m_log;
};

TEST_F(OpenGLBackend, EglSurfacelessDevice) {
    auto dev = makeGlDevice("egl", m_log);
    ASSERT_NE(dev, nullptr);
    const rhi::DeviceInfo& info = dev->info();
    EXPECT_EQ(info.backend, rhi::Backend::OpenGL);
    EXPECT_EQ(info.platform, "EGL surfaceless");
    EXPECT_EQ(info.apiVersion.rfind("OpenGL 4.", 0), 0u) << info.apiVersion;
    EXPECT_FALSE(info.deviceName.empty());
    EXPECT_FALSE(info.driverName.empty());
    EXPECT_FALSE(info.driverVersion.empty());
    EXPECT_GE(info.limits.maxTextureSize2D, 2048u);
    EXPECT_GE(info.limits.maxTextureSize3D, 256u);
    EXPECT_GE(info.limits.maxComputeWorkgroupInvocations, 1024u);
    EXPECT_GE(info.limits.maxColorTargets, 4u);
    EXPECT_GE(info.limits.maxUniformBufferRange, 16384u);
    EXPECT_GE(info.limits.maxStorageBufferRange, 1u << 24);
    EXPECT_TRUE(info.limits.timestamps);
    EXPECT_TRUE(info.limits.conservativeDepth);
    clearAndRead(*dev);
    computeRoundTrip(*dev);
    dev->waitIdle();
    expectNoErrors(*m_log);
}

TEST_F(OpenGLBackend, OsMesaDevice) {
    auto dev = makeGlDevice("osmesa", m_log);
    ASSERT_NE(dev, nullptr);
    EXPECT_EQ(dev->info().platform, "OSMesa");
    EXPECT_EQ(dev->info().backend, rhi::Backend::OpenGL);
    clearAndRead(*dev);
    computeRoundTrip(*dev);
    dev->waitIdle();
    expectNoErrors(*m_log);
}

TEST_F(OpenGLBackend, DefaultPlatformIsEgl) {
    auto dev = makeGlDevice(nullptr, m_log);
    ASSERT_NE(dev, nullptr);
    EXPECT_EQ(dev->info().platform, "EGL surfaceless");
}

TEST_F(OpenGLBackend, UnknownPlatformFails) {
    PlatformOverride env("metal");
    rhi::DeviceDesc desc;
    desc.backend = rhi::Backend::OpenGL;
    std::vector<std::string> messages;
    desc.log = [&](rhi::LogSeverity, std::string_view m) { messages.emplace_back(m); };
    EXPECT_EQ(rhi::createDevice(desc), nullptr);
    ASSERT_FALSE(messages.empty());
    EXPECT_NE(messages.back().find("PENUMBRA_GL_PLATFORM"), std::string::npos) << messages.back();
}

// Devices on both platforms alive at once, used alternately from one thread: each call re-binds
// its own context.
TEST_F(OpenGLBackend, EglAndOsMesaDevicesInterleaved) {
    auto egl = makeGlDevice("egl", m_log);
    auto osmesa = makeGlDevice("osmesa", m_log);
    ASSERT_TRUE(egl && osmesa);
    for (int round = 0; round < 2; ++round) {
        computeRoundTrip(*egl);
        clearAndRead(*osmesa);
        computeRoundTrip(*osmesa);
        clearAndRead(*egl);
    }
    egl.reset();
    computeRoundTrip(*osmesa);
    osmesa->waitIdle();
    expectNoErrors(*m_log);
}

TEST_F(OpenGLBackend, BadGlslFailsWithShaderName) {
    auto dev = makeGlDevice(nullptr, m_log, /*validation=*/false);
    ASSERT_NE(dev, nullptr);
    rhi::ShaderDesc bad;
    bad.stage = rhi::ShaderStage::Compute;
    bad.glsl = "#version 450\nlayout(local_size_x = 1) in;\nvoid main() { undeclared_thing = 1; }\n";
    bad.debugName = "deliberately_broken.comp";
    rhi::ShaderHandle h = dev->createShader(bad);
    EXPECT_FALSE(h.isValid());
    ASSERT_EQ(m_log->errors.size(), 1u);
    EXPECT_NE(m_log->errors[0].find("deliberately_broken.comp"), std::string::npos) << m_log->errors[0];
    EXPECT_NE(m_log->errors[0].find("undeclared_thing"), std::string::npos) << m_log->errors[0];

    rhi::ShaderDesc empty;
    empty.stage = rhi::ShaderStage::Vertex;
    empty.debugName = "no_glsl.vert";
    EXPECT_FALSE(dev->createShader(empty).isValid());
    ASSERT_EQ(m_log->errors.size(), 2u);
    EXPECT_NE(m_log->errors[1].find("no_glsl.vert"), std::string::npos) << m_log->errors[1];
}

// With validation, KHR_debug output reaches the log at error severity and counts as a
// validation error. The RHI never issues an invalid GL call, so the test makes one itself on the
// device's (current) EGL context.
TEST_F(OpenGLBackend, DebugOutputIsRoutedToTheLog) {
    auto dev = makeGlDevice("egl", m_log);
    ASSERT_NE(dev, nullptr);
    EXPECT_EQ(rhi::validationErrorCount(*dev), 0u);
    auto glEnableRaw = reinterpret_cast<PFNGLENABLEPROC>(eglGetProcAddress("glEnable"));
    ASSERT_NE(glEnableRaw, nullptr);
    glEnableRaw(0x1234);  // GL_INVALID_ENUM
    std::lock_guard lock(m_log->mutex);
    ASSERT_EQ(m_log->errors.size(), 1u);
    EXPECT_NE(m_log->errors[0].find("GL_INVALID_ENUM"), std::string::npos) << m_log->errors[0];
    EXPECT_EQ(rhi::validationErrorCount(*dev), 1u);
}

// Invalid and stale handles are reported and ignored, never crash.
TEST_F(OpenGLBackend, StaleHandlesAreReportedAndIgnored) {
    auto dev = makeGlDevice(nullptr, m_log, /*validation=*/false);
    ASSERT_NE(dev, nullptr);
    rhi::BufferDesc bd;
    bd.size = 64;
    rhi::BufferHandle buf = dev->createBuffer(bd);
    ASSERT_TRUE(buf.isValid());
    dev->destroy(buf);
    EXPECT_FALSE(dev->isAlive(buf));
    EXPECT_EQ(dev->describe(buf), nullptr);

    uint32_t value = 0;
    size_t expected = 0;
    dev->writeBuffer(buf, 0, &value, 4);
    EXPECT_EQ(m_log->errors.size(), ++expected);
    EXPECT_FALSE(dev->readBuffer(buf, 0, 4, &value));
    EXPECT_EQ(m_log->errors.size(), ++expected);
    dev->destroy(buf);
    EXPECT_EQ(m_log->errors.size(), ++expected);

    rhi::CommandList& cmd = dev->beginCommandList("stale");
    cmd.fillBuffer(buf, 0, 64, 0);
    cmd.bindPipeline(rhi::PipelineHandle{});
    cmd.dispatch(1);  // no pipeline bound
    cmd.draw(3);      // not in a render pass
    cmd.bindGroup(0, rhi::BindGroupHandle{12345});
    expected += 5;
    EXPECT_EQ(m_log->errors.size(), expected);
    dev->submit(cmd);
    dev->waitIdle();
    EXPECT_EQ(m_log->errors.size(), expected);

    // Headless: no backbuffer.
    EXPECT_FALSE(dev->acquireBackbuffer().isValid());
    EXPECT_FALSE(dev->present());
    EXPECT_EQ(m_log->errors.size(), expected + 2);
}

// Rendering keeps Vulkan's memory layout: image row 0 is gl_FragCoord.y = 0.5 and NDC y = -1.
TEST_F(OpenGLBackend, RenderedRowsMatchVulkanLayout) {
    auto dev = makeGlDevice(nullptr, m_log);
    ASSERT_NE(dev, nullptr);
    constexpr uint32_t kW = 8, kH = 8;
    rhi::TextureDesc td;
    td.format = rhi::Format::RGBA8_UNORM;
    td.width = kW;
    td.height = kH;
    td.usage = rhi::TextureUsage::ColorTarget | rhi::TextureUsage::CopySrc;
    td.debugName = "gl rows";
    rhi::TextureHandle tex = dev->createTexture(td);

    rhi::GraphicsPipelineDesc gp;
    gp.vertexShader = dev->createShader(penumbra::shaders::gl_half_screen::vertex());
    gp.fragmentShader = dev->createShader(penumbra::shaders::gl_half_screen::fragment());
    gp.colorFormats = {rhi::Format::RGBA8_UNORM};
    gp.debugName = "gl half screen";
    rhi::PipelineHandle pipeline = dev->createGraphicsPipeline(gp);
    ASSERT_TRUE(tex && pipeline);

    struct Push {
        float color[4];
        float split;
    } push{{1.0f, 0.5f, 0.0f, 1.0f}, 3.0f};
    static_assert(sizeof(Push) == 20);
    rhi::CommandList& cmd = dev->beginCommandList("gl rows");
    cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::None, rhi::Access::ColorTarget));
    rhi::RenderPassDesc pass;
    rhi::ColorAttachment color;
    color.texture = tex;
    pass.colorAttachments.push_back(color);
    pass.debugName = "rows";
    cmd.beginRenderPass(pass);
    cmd.bindPipeline(pipeline);
    cmd.pushConstants(&push, sizeof(push));
    cmd.draw(3);
    cmd.endRenderPass();
    cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::ColorTarget, rhi::Access::CopySrc));
    dev->submit(cmd);

    std::vector<uint8_t> px;
    ASSERT_TRUE(dev->readTexture(tex, {}, rhi::Access::CopySrc, px));
    for (uint32_t y = 0; y < kH; ++y) {
        const uint8_t* p = px.data() + size_t(y) * kW * 4;
        if (y < 3) {
            EXPECT_EQ(p[0], 255) << "row " << y;
            EXPECT_EQ(p[1], 128) << "row " << y;
        } else {
            EXPECT_EQ(p[0], 0) << "row " << y;
            EXPECT_EQ(p[1], 0) << "row " << y;
        }
    }
    dev->destroy(pipeline);
    dev->destroy(gp.vertexShader);
    dev->destroy(gp.fragmentShader);
    dev->destroy(tex);
    dev->waitIdle();
    expectNoErrors(*m_log);
}

// Culling follows Vulkan's winding convention (polygon area in framebuffer coordinates, row 0 at
// the top). gl_half_screen's triangle (-1,-1), (3,-1), (-1,3) is clockwise in Vulkan's terms.
TEST_F(OpenGLBackend, CullingUsesVulkanWinding) {
    auto dev = makeGlDevice(nullptr, m_log);
    ASSERT_NE(dev, nullptr);
    rhi::TextureDesc td;
    td.format = rhi::Format::RGBA8_UNORM;
    td.width = 4;
    td.height = 4;
    td.usage = rhi::TextureUsage::ColorTarget | rhi::TextureUsage::CopySrc;
    td.debugName = "gl cull";
    rhi::TextureHandle tex = dev->createTexture(td);
    rhi::ShaderHandle vs = dev->createShader(penumbra::shaders::gl_half_screen::vertex());
    rhi::ShaderHandle fs = dev->createShader(penumbra::shaders::gl_half_screen::fragment());
    ASSERT_TRUE(tex && vs && fs);

    struct Case {
        rhi::CullMode cull;
        rhi::FrontFace front;
        bool drawn;
    };
    const Case cases[] = {
        {rhi::CullMode::None, rhi::FrontFace::CounterClockwise, true},
        {rhi::CullMode::Back, rhi::FrontFace::CounterClockwise, false},
        {rhi::CullMode::Back, rhi::FrontFace::Clockwise, true},
        {rhi::CullMode::Front, rhi::FrontFace::CounterClockwise, true},
        {rhi::CullMode::Front, rhi::FrontFace::Clockwise, false},
    };
    rhi::Access state = rhi::Access::None;
    for (const Case& c : cases) {
        rhi::GraphicsPipelineDesc gp;
        gp.vertexShader = vs;
        gp.fragmentShader = fs;
        gp.colorFormats = {rhi::Format::RGBA8_UNORM};
        gp.cullMode = c.cull;
        gp.frontFace = c.front;
        rhi::PipelineHandle pipeline = dev->createGraphicsPipeline(gp);
        ASSERT_TRUE(pipeline.isValid());
        struct Push {
            float color[4];
            float split;
        } push{{0.0f, 1.0f, 0.0f, 1.0f}, 100.0f};
        rhi::CommandList& cmd = dev->beginCommandList("gl cull");
        cmd.barrier(rhi::Barrier::tex(tex, state, rhi::Access::ColorTarget));
        rhi::RenderPassDesc pass;
        rhi::ColorAttachment color;
        color.texture = tex;
        color.clearColor = {1.0f, 0.0f, 0.0f, 1.0f};
        pass.colorAttachments.push_back(color);
        cmd.beginRenderPass(pass);
        cmd.bindPipeline(pipeline);
        cmd.pushConstants(&push, sizeof(push));
        cmd.draw(3);
        cmd.endRenderPass();
        cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::ColorTarget, rhi::Access::CopySrc));
        state = rhi::Access::CopySrc;
        dev->submit(cmd);
        std::vector<uint8_t> px;
        ASSERT_TRUE(dev->readTexture(tex, {}, rhi::Access::CopySrc, px));
        EXPECT_EQ(px[0], c.drawn ? 0 : 255) << "cull " << int(c.cull) << " front " << int(c.front);
        EXPECT_EQ(px[1], c.drawn ? 255 : 0) << "cull " << int(c.cull) << " front " << int(c.front);
        dev->destroy(pipeline);
    }
    dev->destroy(vs);
    dev->destroy(fs);
    dev->destroy(tex);
    dev->waitIdle();
    expectNoErrors(*m_log);
}

// A storage image array written by compute (glBindImageTexture, layered) and sampled back as
// bytes, plus a timestamp pair around the dispatch.
TEST_F(OpenGLBackend, StorageImageArrayAndTimestamps) {
    auto dev = makeGlDevice(nullptr, m_log);
    ASSERT_NE(dev, nullptr);
    rhi::TextureDesc td;
    td.dimension = rhi::TextureDimension::Tex2DArray;
    td.format = rhi::Format::RGBA8_UNORM;
    td.width = 16;
    td.height = 8;
    td.depthOrLayers = 3;
    td.usage = rhi::TextureUsage::Storage | rhi::TextureUsage::CopySrc;
    td.debugName = "gl image array";
    rhi::TextureHandle tex = dev->createTexture(td);
    ASSERT_TRUE(tex.isValid());

    rhi::ComputePipelineDesc pd;
    pd.shader = dev->createShader(penumbra::shaders::gl_image_fill::compute());
    rhi::PipelineHandle pipeline = dev->createComputePipeline(pd);
    rhi::BindGroupDesc gd;
    gd.pipeline = pipeline;
    gd.entries = {rhi::BindGroupEntry::makeStorage(0, tex)};
    rhi::BindGroupHandle group = dev->createBindGroup(gd);
    rhi::QueryPoolDesc qd;
    qd.count = 2;
    rhi::QueryPoolHandle queries = dev->createQueryPool(qd);
    ASSERT_TRUE(pipeline && group && queries);

    rhi::CommandList& cmd = dev->beginCommandList("gl image fill");
    cmd.resetQueries(queries, 0, 2);
    cmd.writeTimestamp(queries, 0);
    cmd.pushDebugGroup("fill");
    cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::None, rhi::Access::ShaderWrite));
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.dispatch(2, 1, 3);
    cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::ShaderWrite, rhi::Access::CopySrc));
    cmd.popDebugGroup();
    cmd.writeTimestamp(queries, 1);
    dev->waitForSubmission(dev->submit(cmd));

    uint64_t ns[2] = {};
    ASSERT_TRUE(dev->readTimestamps(queries, 0, 2, ns));
    EXPECT_GT(ns[0], 0u);
    EXPECT_GE(ns[1], ns[0]);

    for (uint32_t layer = 0; layer < 3; ++layer) {
        std::vector<uint8_t> px;
        ASSERT_TRUE(dev->readTexture(tex, {0, layer}, rhi::Access::CopySrc, px));
        ASSERT_EQ(px.size(), 16u * 8u * 4u);
        for (uint32_t y = 0; y < 8; ++y)
            for (uint32_t x = 0; x < 16; ++x) {
                const uint8_t* p = px.data() + (size_t(y) * 16 + x) * 4;
                ASSERT_EQ(p[0], x);
                ASSERT_EQ(p[1], y);
                ASSERT_EQ(p[2], layer);
                ASSERT_EQ(p[3], 255);
            }
    }
    dev->destroy(group);
    dev->destroy(pipeline);
    dev->destroy(pd.shader);
    dev->destroy(queries);
    dev->destroy(tex);
    dev->waitIdle();
    expectNoErrors(*m_log);
}

// Deferred destruction: a buffer destroyed while a submitted list still uses it keeps working
// for that list, and is released once the GPU is done.
TEST_F(OpenGLBackend, DeferredDestructionKeepsInFlightResources) {
    auto dev = makeGlDevice(nullptr, m_log);
    ASSERT_NE(dev, nullptr);
    rhi::BufferDesc bd;
    bd.size = 256;
    bd.usage = rhi::BufferUsage::Storage | rhi::BufferUsage::CopySrc | rhi::BufferUsage::CopyDst;
    rhi::BufferHandle a = dev->createBuffer(bd);
    bd.memory = rhi::MemoryType::Readback;
    rhi::BufferHandle b = dev->createBuffer(bd);
    ASSERT_TRUE(a && b);

    rhi::CommandList& cmd = dev->beginCommandList("gl deferred");
    cmd.fillBuffer(a, 0, 256, 0xabcdef01u);
    cmd.barrier(rhi::Barrier::buf(a, rhi::Access::CopyDst, rhi::Access::CopySrc));
    cmd.copyBuffer(a, 0, b, 0, 256);
    cmd.barrier(rhi::Barrier::buf(b, rhi::Access::CopyDst, rhi::Access::HostRead));
    dev->destroy(a);  // recorded, not yet submitted
    EXPECT_FALSE(dev->isAlive(a));
    const uint64_t serial = dev->submit(cmd);
    dev->waitForSubmission(serial);
    const auto* mapped = static_cast<const uint32_t*>(dev->mappedPointer(b));
    ASSERT_NE(mapped, nullptr);
    for (int i = 0; i < 64; ++i) ASSERT_EQ(mapped[i], 0xabcdef01u);
    dev->destroy(b);
    dev->collectGarbage();
    dev->waitIdle();
    expectNoErrors(*m_log);
}

}  // namespace
