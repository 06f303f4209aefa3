// Vulkan-backend specific tests (rhi/vulkan): device information, the validation layer and its
// debug messenger, leak-free destruction, and small end-to-end checks (clear + readback, compute
// storage-buffer round trip, storage-image mips, 3D / array uploads, timestamps, misuse handling).
// Always run on Vulkan (lavapipe here), whatever --backend selects for the cross-backend suites.
#include <gtest/gtest.h>

#include <vulkan/vulkan.h>

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <shaders/vk_double.h>
#include <shaders/vk_fetch.h>
#include <shaders/vk_gradient.h>

#include "rhi/device.h"
#include "rhi/vulkan/vulkan_inspect.h"
#include "support/test_device.h"

namespace {

using penumbra::test::LogCapture;

bool layerInstalled(const char* name) {
    uint32_t count = 0;
    vkEnumerateInstanceLayerProperties(&count, nullptr);
    std::vector<VkLayerProperties> layers(count);
    vkEnumerateInstanceLayerProperties(&count, layers.data());
    for (const auto& l : layers)
        if (std::strcmp(l.layerName, name) == 0) return true;
    return false;
}

bool logContains(LogCapture& log, const std::string& needle) {
    std::lock_guard lock(log.mutex);
    for (const auto& m : log.all)
        if (m.find(needle) != std::string::npos) return true;
    return false;
}

std::vector<std::string> errorsOf(LogCapture& log) {
    std::lock_guard lock(log.mutex);
    return log.errors;
}

class VulkanBackend : public testing::Test {
protected:
    void SetUp() override {
        m_log = std::make_shared<LogCapture>();
        m_device = penumbra::test::createTestDevice(rhi::Backend::Vulkan, m_log);
        ASSERT_NE(m_device, nullptr);
    }
    void TearDown() override {
        if (m_device) {
            m_device->waitIdle();
            m_device.reset();  // destruction must be clean too (leaks are validation errors)
        }
        const auto errors = errorsOf(*m_log);
        EXPECT_TRUE(errors.empty()) << errors.size()
                                    << " error(s), first: " << (errors.empty() ? "" : errors[0]);
    }
    rhi::Device& dev() { return *m_device; }

    std::shared_ptr<LogCapture> m_log;
    std::unique_ptr<rhi::Device> m_device;
};

TEST_F(VulkanBackend, InfoDescribesAVulkan13Device) {
    const rhi::DeviceInfo& info = dev().info();
    EXPECT_EQ(info.backend, rhi::Backend::Vulkan);
    EXPECT_EQ(info.apiVersion.rfind("Vulkan 1.3", 0), 0u) << info.apiVersion;
    EXPECT_FALSE(info.deviceName.empty());
    EXPECT_FALSE(info.driverName.empty());
    EXPECT_FALSE(info.driverVersion.empty());
    EXPECT_EQ(info.platform, "headless");
    EXPECT_GE(info.limits.maxTextureSize2D, 4096u);
    EXPECT_GE(info.limits.maxTextureSize3D, 256u);
    EXPECT_GE(info.limits.maxTextureArrayLayers, 256u);
    EXPECT_GE(info.limits.maxComputeWorkgroupInvocations, 128u);
    EXPECT_GE(info.limits.maxStorageBufferRange, uint64_t(1) << 27);
    EXPECT_GE(info.limits.maxUniformBufferRange, 16384u);
    EXPECT_EQ(info.limits.maxPushConstantSize, rhi::kMaxPushConstantSize);
    EXPECT_EQ(info.limits.maxBindGroups, rhi::kMaxBindGroups);
    EXPECT_GE(info.limits.maxColorTargets, 4u);
    EXPECT_GT(info.limits.timestampPeriodNs, 0.0);
    EXPECT_TRUE(info.limits.conservativeDepth);
    EXPECT_EQ(dev().backbufferFormat(), rhi::Format::Undefined);
}

TEST_F(VulkanBackend, ValidationLayerAndMessengerAreActive) {
    ASSERT_TRUE(layerInstalled("VK_LAYER_KHRONOS_validation"))
        << "package vulkan-validationlayers is required for this test";
    const rhi::vulkan::Inspection state = rhi::vulkan::inspect(dev());
    EXPECT_TRUE(state.isVulkan);
    EXPECT_TRUE(state.validationLayerEnabled);
    EXPECT_TRUE(state.debugMessengerInstalled);
    EXPECT_TRUE(logContains(*m_log, "VK_LAYER_KHRONOS_validation enabled, debug-utils messenger installed"));
    // The layer's own informational message at vkCreateInstance travelled through the messenger
    // (routed at Debug severity) into the device's log.
    EXPECT_TRUE(logContains(*m_log, "[vulkan validation]"));
}

TEST(VulkanBackendStandalone, WithoutValidationNoMessengerIsInstalled) {
    auto log = std::make_shared<LogCapture>();
    auto device = penumbra::test::createTestDevice(rhi::Backend::Vulkan, log, false);
    ASSERT_NE(device, nullptr);
    const rhi::vulkan::Inspection state = rhi::vulkan::inspect(*device);
    EXPECT_TRUE(state.isVulkan);
    EXPECT_FALSE(state.validationLayerEnabled);
    EXPECT_FALSE(state.debugMessengerInstalled);
}

// Creates one object of every kind, uses them in a submission, destroys half of them and leaves
// the rest to the device: vkDestroyDevice must find nothing left over (the validation layer reports
// every leaked child object as an error through the messenger, which lives until the instance dies).
TEST(VulkanBackendStandalone, DestructionReleasesEverything) {
    auto log = std::make_shared<LogCapture>();
    {
        auto device = penumbra::test::createTestDevice(rhi::Backend::Vulkan, log);
        ASSERT_NE(device, nullptr);
        rhi::Device& d = *device;
        ASSERT_TRUE(rhi::vulkan::inspect(d).debugMessengerInstalled);

        const std::vector<uint32_t> data(64, 7u);
        rhi::BufferDesc bd;
        bd.size = data.size() * 4;
        bd.usage = rhi::BufferUsage::Storage;
        bd.debugName = "src";
        rhi::BufferHandle src = d.createBuffer(bd, data.data());
        bd.debugName = "dst";
        rhi::BufferHandle dst = d.createBuffer(bd);
        bd.memory = rhi::MemoryType::Upload;
        bd.debugName = "upload";
        rhi::BufferHandle upload = d.createBuffer(bd, data.data());
        rhi::TextureDesc td;
        td.width = td.height = 16;
        td.mipLevels = 3;
        td.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::Storage | rhi::TextureUsage::ColorTarget;
        td.debugName = "tex";
        rhi::TextureHandle tex = d.createTexture(td);
        rhi::SamplerHandle sampler = d.createSampler({});
        rhi::ShaderHandle shader = d.createShader(penumbra::shaders::vk_double::compute());
        rhi::ComputePipelineDesc pd;
        pd.shader = shader;
        rhi::PipelineHandle pipeline = d.createComputePipeline(pd);
        rhi::BindGroupDesc gd;
        gd.pipeline = pipeline;
        gd.entries = {rhi::BindGroupEntry::makeBuffer(0, src), rhi::BindGroupEntry::makeBuffer(1, dst)};
        rhi::BindGroupHandle group = d.createBindGroup(gd);
        rhi::QueryPoolHandle queries = d.createQueryPool({});
        ASSERT_TRUE(src && dst && upload && tex && sampler && shader && pipeline && group && queries);

        rhi::CommandList& cmd = d.beginCommandList("leak check");
        cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::None, rhi::Access::ColorTarget));
        rhi::RenderPassDesc rp;
        rp.colorAttachments.push_back({});
        rp.colorAttachments[0].texture = tex;
        rp.colorAttachments[0].mip = 1;
        cmd.beginRenderPass(rp);
        cmd.endRenderPass();
        cmd.resetQueries(queries, 0, 2);
        cmd.writeTimestamp(queries, 0);
        cmd.bindPipeline(pipeline);
        cmd.bindGroup(0, group);
        const uint32_t push[2] = {64, 1};
        cmd.pushConstants(push, sizeof push);
        cmd.dispatch(1);
        cmd.writeTimestamp(queries, 1);
        const uint64_t serial = d.submit(cmd);
        EXPECT_GT(serial, 0u);

        // Destroyed while the GPU may still run the list: released later, not now.
        d.destroy(group);
        d.destroy(pipeline);
        d.destroy(src);
        d.destroy(tex);
        EXPECT_FALSE(d.isAlive(src));
        EXPECT_FALSE(d.isAlive(tex));
        EXPECT_GT(rhi::vulkan::inspect(d).pendingReleases, 0u);
        d.waitForSubmission(serial);
        // Still pending: releases are keyed to the serial of the next submission (a list still
        // being recorded may reference them); waitIdle() releases everything.
        EXPECT_GT(rhi::vulkan::inspect(d).pendingReleases, 0u);
        d.waitIdle();
        EXPECT_EQ(rhi::vulkan::inspect(d).pendingReleases, 0u);
        EXPECT_GT(rhi::vulkan::inspect(d).liveObjects, 0u);  // the rest is left to the device
    }
    const auto errors = errorsOf(*log);
    EXPECT_TRUE(errors.empty()) << errors.size() << " error(s), first: " << (errors.empty() ? "" : errors[0]);
}

TEST_F(VulkanBackend, ClearAndReadbackColorTarget) {
    rhi::TextureDesc td;
    td.format = rhi::Format::RGBA8_UNORM;
    td.width = 24;
    td.height = 16;
    td.usage = rhi::TextureUsage::ColorTarget | rhi::TextureUsage::CopySrc;
    td.debugName = "clear target";
    rhi::TextureHandle target = dev().createTexture(td);
    ASSERT_TRUE(target);

    rhi::CommandList& cmd = dev().beginCommandList("clear");
    cmd.barrier(rhi::Barrier::tex(target, rhi::Access::None, rhi::Access::ColorTarget));
    rhi::RenderPassDesc rp;
    rhi::ColorAttachment ca;
    ca.texture = target;
    ca.clearColor = {0.25f, 0.5f, 0.75f, 1.0f};
    rp.colorAttachments.push_back(ca);
    rp.debugName = "clear pass";
    cmd.pushDebugGroup("clear group");
    cmd.beginRenderPass(rp);
    cmd.endRenderPass();
    cmd.popDebugGroup();
    cmd.barrier(rhi::Barrier::tex(target, rhi::Access::ColorTarget, rhi::Access::CopySrc));
    dev().waitForSubmission(dev().submit(cmd));

    std::vector<uint8_t> pixels;
    ASSERT_TRUE(dev().readTexture(target, {}, rhi::Access::CopySrc, pixels));
    ASSERT_EQ(pixels.size(), size_t(24 * 16 * 4));
    for (size_t i = 0; i < pixels.size(); i += 4) {
        EXPECT_NEAR(pixels[i + 0], 64, 1);
        EXPECT_NEAR(pixels[i + 1], 128, 1);
        EXPECT_NEAR(pixels[i + 2], 191, 1);
        EXPECT_EQ(pixels[i + 3], 255);
        if (::testing::Test::HasFailure()) break;
    }
    dev().destroy(target);
}

TEST_F(VulkanBackend, ComputeStorageBufferRoundTrip) {
    constexpr uint32_t kCount = 1000;  // not a multiple of the workgroup size
    std::vector<uint32_t> input(kCount);
    for (uint32_t i = 0; i < kCount; ++i) input[i] = i * 3u + 1u;

    rhi::BufferDesc bd;
    bd.size = kCount * sizeof(uint32_t);
    bd.usage = rhi::BufferUsage::Storage;
    bd.debugName = "input";
    rhi::BufferHandle src = dev().createBuffer(bd, input.data());
    bd.debugName = "output";
    rhi::BufferHandle dst = dev().createBuffer(bd);
    rhi::ShaderHandle shader = dev().createShader(penumbra::shaders::vk_double::compute());
    rhi::ComputePipelineDesc pd;
    pd.shader = shader;
    pd.debugName = "double";
    rhi::PipelineHandle pipeline = dev().createComputePipeline(pd);
    ASSERT_TRUE(src && dst && shader && pipeline);
    rhi::BindGroupDesc gd;
    gd.pipeline = pipeline;
    gd.entries = {rhi::BindGroupEntry::makeBuffer(0, src), rhi::BindGroupEntry::makeBuffer(1, dst)};
    rhi::BindGroupHandle group = dev().createBindGroup(gd);
    ASSERT_TRUE(group);

    rhi::CommandList& cmd = dev().beginCommandList("double");
    cmd.fillBuffer(dst, 0, bd.size, 0xdeadbeefu);
    cmd.barrier(rhi::Barrier::buf(dst, rhi::Access::CopyDst, rhi::Access::ShaderWrite));
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    const uint32_t push[2] = {kCount, 5u};
    cmd.pushConstants(push, sizeof push);
    cmd.dispatch((kCount + 63) / 64);
    cmd.barrier(rhi::Barrier::buf(dst, rhi::Access::ShaderWrite, rhi::Access::CopySrc));
    const uint64_t serial = dev().submit(cmd);
    dev().waitForSubmission(serial);

    std::vector<uint32_t> output(kCount);
    ASSERT_TRUE(dev().readBuffer(dst, 0, bd.size, output.data()));
    for (uint32_t i = 0; i < kCount; ++i) ASSERT_EQ(output[i], input[i] * 2u + 5u) << "at " << i;

    // A partial readback at an offset, and an upload after the dispatch ordered before the next one.
    uint32_t two[2] = {};
    ASSERT_TRUE(dev().readBuffer(dst, 8 * sizeof(uint32_t), sizeof two, two));
    EXPECT_EQ(two[0], input[8] * 2u + 5u);
    EXPECT_EQ(two[1], input[9] * 2u + 5u);
    const std::vector<uint32_t> zeros(kCount, 0u);
    dev().writeBuffer(src, 0, zeros.data(), bd.size);
    rhi::CommandList& again = dev().beginCommandList("double again");
    again.barrier(rhi::Barrier::buf(dst, rhi::Access::CopySrc, rhi::Access::ShaderWrite));
    again.bindPipeline(pipeline);
    again.bindGroup(0, group);
    again.pushConstants(push, sizeof push);
    again.dispatch((kCount + 63) / 64);
    dev().waitForSubmission(dev().submit(again));
    ASSERT_TRUE(dev().readBuffer(dst, 0, bd.size, output.data()));
    for (uint32_t i = 0; i < kCount; ++i) ASSERT_EQ(output[i], 5u) << "at " << i;

    for (auto h : {src, dst}) dev().destroy(h);
    dev().destroy(group);
    dev().destroy(pipeline);
    dev().destroy(shader);
}

TEST_F(VulkanBackend, StorageImageMipsUseTheirOwnViews) {
    rhi::TextureDesc td;
    td.format = rhi::Format::RGBA8_UNORM;
    td.width = 16;
    td.height = 8;
    td.mipLevels = 3;
    td.usage = rhi::TextureUsage::Storage | rhi::TextureUsage::CopySrc;
    td.debugName = "gradient";
    rhi::TextureHandle tex = dev().createTexture(td);
    rhi::ShaderHandle shader = dev().createShader(penumbra::shaders::vk_gradient::compute());
    rhi::ComputePipelineDesc pd;
    pd.shader = shader;
    rhi::PipelineHandle pipeline = dev().createComputePipeline(pd);
    ASSERT_TRUE(tex && shader && pipeline);

    rhi::CommandList& cmd = dev().beginCommandList("mips");
    cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::None, rhi::Access::ShaderWrite));
    cmd.bindPipeline(pipeline);
    std::vector<rhi::BindGroupHandle> groups;
    for (uint32_t mip = 0; mip < 3; ++mip) {
        rhi::BindGroupDesc gd;
        gd.pipeline = pipeline;
        gd.entries = {rhi::BindGroupEntry::makeStorage(0, tex, mip)};
        groups.push_back(dev().createBindGroup(gd));
        ASSERT_TRUE(groups.back());
        cmd.bindGroup(0, groups.back());
        const uint32_t push[3] = {16u >> mip, 8u >> mip, mip};
        cmd.pushConstants(push, sizeof push);
        cmd.dispatch((push[0] + 7) / 8, (push[1] + 7) / 8);
    }
    cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::ShaderWrite, rhi::Access::CopySrc));
    dev().waitForSubmission(dev().submit(cmd));

    for (uint32_t mip = 0; mip < 3; ++mip) {
        std::vector<uint8_t> px;
        ASSERT_TRUE(dev().readTexture(tex, {mip, 0}, rhi::Access::CopySrc, px));
        const uint32_t w = 16u >> mip, h = 8u >> mip;
        ASSERT_EQ(px.size(), size_t(w) * h * 4);
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) {
                const uint8_t* p = &px[(size_t(y) * w + x) * 4];
                ASSERT_EQ(p[0], x);
                ASSERT_EQ(p[1], y);  // row 0 first
                ASSERT_EQ(p[2], mip);
                ASSERT_EQ(p[3], 255);
            }
    }
    for (auto g : groups) dev().destroy(g);
    dev().destroy(pipeline);
    dev().destroy(shader);
    dev().destroy(tex);
}

TEST_F(VulkanBackend, UploadsRoundTripFor3DAndArrayTextures) {
    rhi::TextureDesc td;
    td.dimension = rhi::TextureDimension::Tex3D;
    td.format = rhi::Format::R32_FLOAT;
    td.width = 8;
    td.height = 4;
    td.depthOrLayers = 6;
    td.mipLevels = 2;
    td.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::CopyDst | rhi::TextureUsage::CopySrc;
    td.debugName = "volume";
    rhi::TextureHandle volume = dev().createTexture(td);
    ASSERT_TRUE(volume);
    std::vector<float> mip0(8 * 4 * 6), mip1(4 * 2 * 3);
    for (size_t i = 0; i < mip0.size(); ++i) mip0[i] = float(i) * 0.5f;
    for (size_t i = 0; i < mip1.size(); ++i) mip1[i] = -float(i);
    dev().writeTexture(volume, {0, 0}, mip0.data(), mip0.size() * 4);
    dev().writeTexture(volume, {1, 0}, mip1.data(), mip1.size() * 4);
    std::vector<uint8_t> out;
    ASSERT_TRUE(dev().readTexture(volume, {1, 0}, rhi::Access::ShaderSampled, out));
    ASSERT_EQ(out.size(), mip1.size() * 4);
    EXPECT_EQ(std::memcmp(out.data(), mip1.data(), out.size()), 0);
    ASSERT_TRUE(dev().readTexture(volume, {0, 0}, rhi::Access::ShaderSampled, out));
    ASSERT_EQ(out.size(), mip0.size() * 4);
    EXPECT_EQ(std::memcmp(out.data(), mip0.data(), out.size()), 0);

    td.dimension = rhi::TextureDimension::Tex2DArray;
    td.format = rhi::Format::RGBA16_FLOAT;
    td.depthOrLayers = 3;
    td.mipLevels = 1;
    td.debugName = "array";
    rhi::TextureHandle array = dev().createTexture(td);
    ASSERT_TRUE(array);
    std::vector<std::vector<uint16_t>> layers(3, std::vector<uint16_t>(8 * 4 * 4));
    for (uint32_t l = 0; l < 3; ++l)
        for (size_t i = 0; i < layers[l].size(); ++i) layers[l][i] = uint16_t(l * 1000 + i);
    for (uint32_t l = 0; l < 3; ++l)
        dev().writeTexture(array, {0, l}, layers[l].data(), layers[l].size() * 2);
    for (uint32_t l = 0; l < 3; ++l) {
        ASSERT_TRUE(dev().readTexture(array, {0, l}, rhi::Access::ShaderSampled, out));
        ASSERT_EQ(out.size(), layers[l].size() * 2);
        EXPECT_EQ(std::memcmp(out.data(), layers[l].data(), out.size()), 0) << "layer " << l;
    }
    dev().destroy(volume);
    dev().destroy(array);
}

// Sampled-texture descriptors say READ_ONLY_OPTIMAL (what ShaderSampled maps to); a texture in a
// combined state such as ShaderSampled | ShaderRead lives in GENERAL, and binding the group then
// must use a descriptor with that layout (the validation layer checks the layouts at submit).
TEST_F(VulkanBackend, SampledTextureInGeneralLayoutState) {
    rhi::TextureDesc td;
    td.format = rhi::Format::RGBA8_UNORM;
    td.width = 2;
    td.height = 1;
    td.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::Storage | rhi::TextureUsage::CopyDst;
    td.debugName = "two texels";
    rhi::TextureHandle tex = dev().createTexture(td);
    const uint8_t texels[8] = {255, 0, 0, 255, 0, 0, 255, 255};
    dev().writeTexture(tex, {}, texels, sizeof texels);
    rhi::BufferDesc bd;
    bd.size = 2 * 16;
    bd.usage = rhi::BufferUsage::Storage;
    bd.debugName = "fetched";
    rhi::BufferHandle out = dev().createBuffer(bd);
    rhi::ShaderHandle shader = dev().createShader(penumbra::shaders::vk_fetch::compute());
    rhi::ComputePipelineDesc pd;
    pd.shader = shader;
    rhi::PipelineHandle pipeline = dev().createComputePipeline(pd);
    rhi::SamplerDesc sd;
    sd.minFilter = sd.magFilter = rhi::Filter::Nearest;
    rhi::SamplerHandle sampler = dev().createSampler(sd);
    ASSERT_TRUE(tex && out && shader && pipeline && sampler);
    rhi::BindGroupDesc gd;
    gd.pipeline = pipeline;
    gd.entries = {rhi::BindGroupEntry::makeSampled(0, tex, sampler), rhi::BindGroupEntry::makeBuffer(1, out)};
    rhi::BindGroupHandle group = dev().createBindGroup(gd);
    ASSERT_TRUE(group);

    for (rhi::Access state :
         {rhi::Access::ShaderSampled, rhi::Access::ShaderSampled | rhi::Access::ShaderRead}) {
        rhi::CommandList& cmd = dev().beginCommandList("fetch");
        cmd.barrier(rhi::Barrier::tex(tex, rhi::Access::ShaderSampled, state));
        cmd.barrier(rhi::Barrier::buf(out, rhi::Access::None, rhi::Access::ShaderWrite));
        cmd.bindPipeline(pipeline);
        cmd.bindGroup(0, group);
        cmd.dispatch(1);
        cmd.barrier(rhi::Barrier::buf(out, rhi::Access::ShaderWrite, rhi::Access::CopySrc));
        cmd.barrier(rhi::Barrier::tex(tex, state, rhi::Access::ShaderSampled));
        dev().waitForSubmission(dev().submit(cmd));
        float got[8] = {};
        ASSERT_TRUE(dev().readBuffer(out, 0, sizeof got, got));
        const float want[8] = {1, 0, 0, 1, 0, 0, 1, 1};
        for (int i = 0; i < 8; ++i)
            EXPECT_EQ(got[i], want[i]) << "state " << rhi::toString(state) << " at " << i;
    }
    dev().destroy(group);
    dev().destroy(sampler);
    dev().destroy(pipeline);
    dev().destroy(shader);
    dev().destroy(out);
    dev().destroy(tex);
}

TEST_F(VulkanBackend, TimestampsAreOrderedNanoseconds) {
    ASSERT_TRUE(dev().info().limits.timestamps);
    rhi::QueryPoolDesc qd;
    qd.count = 4;
    rhi::QueryPoolHandle pool = dev().createQueryPool(qd);
    ASSERT_TRUE(pool);
    rhi::BufferDesc bd;
    bd.size = 1 << 20;
    bd.usage = rhi::BufferUsage::Storage;
    rhi::BufferHandle buf = dev().createBuffer(bd);
    rhi::CommandList& cmd = dev().beginCommandList("timestamps");
    cmd.resetQueries(pool, 0, 4);
    cmd.writeTimestamp(pool, 0);
    cmd.fillBuffer(buf, 0, bd.size, 1u);
    cmd.writeTimestamp(pool, 1);
    dev().submit(cmd);
    uint64_t ns[2] = {};
    ASSERT_TRUE(dev().readTimestamps(pool, 0, 2, ns));
    EXPECT_GT(ns[0], 0u);
    EXPECT_GE(ns[1], ns[0]);
    // Queries that were reset but never written are reported, not waited on forever.
    uint64_t unused = 0;
    EXPECT_FALSE(dev().readTimestamps(pool, 2, 1, &unused));
    {
        std::lock_guard lock(m_log->mutex);
        ASSERT_EQ(m_log->errors.size(), 1u);
        m_log->errors.clear();
    }
    dev().destroy(pool);
    dev().destroy(buf);
}

TEST_F(VulkanBackend, UnsupportedFormatUsageFailsClearly) {
    rhi::TextureDesc td;
    td.format = rhi::Format::RGBA8_SRGB;
    td.width = td.height = 4;
    td.usage = rhi::TextureUsage::Storage;  // sRGB storage images are not a Vulkan feature
    td.debugName = "srgb storage";
    auto log = std::make_shared<LogCapture>();
    auto device = penumbra::test::createTestDevice(rhi::Backend::Vulkan, log, false);
    ASSERT_NE(device, nullptr);
    EXPECT_FALSE(device->createTexture(td).isValid());
    const auto errors = errorsOf(*log);
    ASSERT_EQ(errors.size(), 1u);
    EXPECT_NE(errors[0].find("does not support Storage"), std::string::npos) << errors[0];
}

// Without the validation wrapper the backend itself must survive misuse: one clear error each,
// no crash, no Vulkan validation error.
TEST(VulkanBackendStandalone, StaleHandlesAndHeadlessPresentationAreReported) {
    auto log = std::make_shared<LogCapture>();
    auto device = penumbra::test::createTestDevice(rhi::Backend::Vulkan, log, false);
    ASSERT_NE(device, nullptr);
    rhi::Device& d = *device;
    rhi::BufferDesc bd;
    bd.size = 256;
    rhi::BufferHandle buf = d.createBuffer(bd);
    ASSERT_TRUE(buf);
    d.destroy(buf);
    d.destroy(buf);  // stale: error
    rhi::CommandList& cmd = d.beginCommandList("misuse");
    cmd.fillBuffer(buf, 0, 256, 0);  // stale: error
    cmd.draw(3);                     // outside a render pass: error
    cmd.dispatch(1);                 // no pipeline: error
    d.submit(cmd);
    d.waitIdle();
    uint32_t word = 0;
    EXPECT_FALSE(d.readBuffer(buf, 0, 4, &word));   // stale: error
    EXPECT_FALSE(d.acquireBackbuffer().isValid());  // headless: error
    EXPECT_FALSE(d.present());                      // headless: error
    EXPECT_EQ(errorsOf(*log).size(), 7u);
    for (const auto& e : errorsOf(*log)) EXPECT_EQ(e.find("[vulkan validation]"), std::string::npos) << e;
}

}  // namespace
