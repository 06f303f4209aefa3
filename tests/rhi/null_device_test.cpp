// Unit tests of the null backend: handles, deferred destruction, CPU-side resource contents,
// recorded commands and timestamps.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "rhi/device.h"
#include "rhi/null/null_device.h"

namespace {

using rhi::null::RecordedCommand;

class NullDeviceTest : public testing::Test {
protected:
    void SetUp() override {
        rhi::DeviceDesc desc;
        desc.backend = rhi::Backend::Null;
        desc.log = [this](rhi::LogSeverity s, std::string_view msg) {
            if (s == rhi::LogSeverity::Error) m_errors.emplace_back(msg);
        };
        m_device = rhi::createDevice(desc);
        ASSERT_NE(m_device, nullptr);
    }
    void TearDown() override { m_device.reset(); }

    rhi::Device& dev() { return *m_device; }

    rhi::BufferHandle makeBuffer(uint64_t size, rhi::MemoryType memory = rhi::MemoryType::GpuOnly,
                                 const void* data = nullptr) {
        rhi::BufferDesc d;
        d.size = size;
        d.usage = rhi::BufferUsage::Storage | rhi::BufferUsage::CopySrc | rhi::BufferUsage::CopyDst;
        d.memory = memory;
        d.debugName = "buf";
        return dev().createBuffer(d, data);
    }

    std::vector<uint8_t> read(rhi::BufferHandle b, uint64_t offset, uint64_t size) {
        std::vector<uint8_t> out(size);
        EXPECT_TRUE(dev().readBuffer(b, offset, size, out.data()));
        return out;
    }

    std::unique_ptr<rhi::Device> m_device;
    std::vector<std::string> m_errors;
};

TEST_F(NullDeviceTest, InfoDescribesAHeadlessNullDevice) {
    const rhi::DeviceInfo& info = dev().info();
    EXPECT_EQ(info.backend, rhi::Backend::Null);
    EXPECT_EQ(info.deviceName, "null");
    EXPECT_EQ(info.platform, "headless");
    EXPECT_EQ(info.limits.maxTextureSize2D, 16384u);
    EXPECT_EQ(info.limits.maxTextureSize3D, 2048u);
    EXPECT_EQ(info.limits.maxComputeWorkgroupInvocations, 1024u);
    EXPECT_EQ(info.limits.maxPushConstantSize, rhi::kMaxPushConstantSize);
    EXPECT_EQ(info.limits.maxBindGroups, rhi::kMaxBindGroups);
    EXPECT_TRUE(info.limits.timestamps);
    EXPECT_EQ(rhi::validationErrorCount(dev()), 0u);
}

TEST_F(NullDeviceTest, HandlesCarryGenerationsAndStaleOnesAreRejected) {
    rhi::BufferHandle a = makeBuffer(16);
    ASSERT_TRUE(a.isValid());
    EXPECT_GE(a.generation(), 1);
    EXPECT_TRUE(dev().isAlive(a));
    ASSERT_NE(dev().describe(a), nullptr);
    EXPECT_EQ(dev().describe(a)->size, 16u);

    dev().destroy(a);
    EXPECT_FALSE(dev().isAlive(a));
    EXPECT_EQ(dev().describe(a), nullptr);

    // The slot is reused with a new generation; the old handle stays dead.
    rhi::BufferHandle b = makeBuffer(32);
    EXPECT_EQ(b.index(), a.index());
    EXPECT_NE(b.generation(), a.generation());
    EXPECT_TRUE(dev().isAlive(b));
    EXPECT_FALSE(dev().isAlive(a));
    EXPECT_FALSE(dev().isAlive(rhi::BufferHandle{}));

    // Using the stale handle logs an error and does nothing.
    uint32_t v = 7;
    dev().writeBuffer(a, 0, &v, 4);
    uint32_t out = 0;
    EXPECT_FALSE(dev().readBuffer(a, 0, 4, &out));
    dev().destroy(a);
    EXPECT_EQ(m_errors.size(), 3u);
    EXPECT_EQ(read(b, 0, 4), std::vector<uint8_t>(4, 0));

    // Different handle kinds live in different pools.
    rhi::TextureDesc td;
    td.width = td.height = 4;
    rhi::TextureHandle t = dev().createTexture(td);
    EXPECT_TRUE(dev().isAlive(t));
    EXPECT_FALSE(dev().isAlive(rhi::SamplerHandle{t.value}));
}

TEST_F(NullDeviceTest, DestructionIsDeferredUntilTheNextSubmissionCompletes) {
    const size_t base = rhi::null::liveObjectCount(dev());
    rhi::BufferHandle b = makeBuffer(64);
    rhi::TextureDesc td;
    td.width = td.height = 8;
    rhi::TextureHandle t = dev().createTexture(td);
    EXPECT_EQ(rhi::null::liveObjectCount(dev()), base + 2);

    dev().destroy(b);
    dev().destroy(t);
    EXPECT_FALSE(dev().isAlive(b));
    // Destroyed but pending: still counted, and collectGarbage without a submission keeps them.
    EXPECT_EQ(rhi::null::liveObjectCount(dev()), base + 2);
    dev().collectGarbage();
    EXPECT_EQ(rhi::null::liveObjectCount(dev()), base + 2);

    // The next submission completes at once on null, which releases them.
    rhi::CommandList& list = dev().beginCommandList("empty");
    uint64_t serial = dev().submit(list);
    EXPECT_EQ(serial, 1u);
    EXPECT_EQ(rhi::null::liveObjectCount(dev()), base);

    // waitIdle releases everything pending as well.
    rhi::BufferHandle c = makeBuffer(4);
    dev().destroy(c);
    EXPECT_EQ(rhi::null::liveObjectCount(dev()), base + 1);
    dev().waitIdle();
    EXPECT_EQ(rhi::null::liveObjectCount(dev()), base);
    EXPECT_TRUE(m_errors.empty());
}

TEST_F(NullDeviceTest, ObjectDestroyedWhileRecordedStillExecutes) {
    std::vector<uint8_t> init(16);
    std::iota(init.begin(), init.end(), uint8_t(1));
    rhi::BufferHandle src = makeBuffer(16, rhi::MemoryType::GpuOnly, init.data());
    rhi::BufferHandle dst = makeBuffer(16);
    rhi::CommandList& list = dev().beginCommandList();
    list.copyBuffer(src, 0, dst, 0, 16);
    dev().destroy(src);  // the recorded copy may still use it
    dev().submit(list);
    EXPECT_EQ(read(dst, 0, 16), init);
    EXPECT_TRUE(m_errors.empty());
}

TEST_F(NullDeviceTest, SubmissionSerialsIncrease) {
    uint64_t last = 0;
    for (int i = 0; i < 3; ++i) {
        uint64_t s = dev().submit(dev().beginCommandList());
        EXPECT_GT(s, last);
        dev().waitForSubmission(s);
        last = s;
    }
    EXPECT_TRUE(m_errors.empty());
}

TEST_F(NullDeviceTest, BufferContentsRoundTrip) {
    const uint32_t init[4] = {1, 2, 3, 4};
    rhi::BufferHandle b = makeBuffer(16, rhi::MemoryType::GpuOnly, init);
    std::vector<uint8_t> bytes = read(b, 0, 16);
    EXPECT_EQ(std::memcmp(bytes.data(), init, 16), 0);
    EXPECT_EQ(dev().mappedPointer(b), nullptr);

    const uint32_t patch = 0xdeadbeef;
    dev().writeBuffer(b, 8, &patch, 4);
    uint32_t out[4] = {};
    ASSERT_TRUE(dev().readBuffer(b, 0, 16, out));
    EXPECT_EQ(out[0], 1u);
    EXPECT_EQ(out[2], 0xdeadbeefu);

    rhi::BufferHandle up = makeBuffer(8, rhi::MemoryType::Upload);
    auto* mapped = static_cast<uint32_t*>(dev().mappedPointer(up));
    ASSERT_NE(mapped, nullptr);
    mapped[1] = 42;
    ASSERT_TRUE(dev().readBuffer(up, 4, 4, out));
    EXPECT_EQ(out[0], 42u);
    rhi::BufferHandle rb = makeBuffer(8, rhi::MemoryType::Readback);
    EXPECT_NE(dev().mappedPointer(rb), nullptr);

    // Out of range (including offsets that would overflow) is rejected without a crash.
    dev().writeBuffer(b, 12, init, 8);
    EXPECT_FALSE(dev().readBuffer(b, ~uint64_t(0) - 2, 8, out));
    EXPECT_EQ(m_errors.size(), 2u);
}

TEST_F(NullDeviceTest, TransfersExecuteInOrderAtSubmit) {
    rhi::BufferHandle a = makeBuffer(16);
    rhi::BufferHandle b = makeBuffer(16);
    rhi::CommandList& list = dev().beginCommandList("transfers");
    const uint32_t words[2] = {10, 20};
    list.updateBuffer(a, 0, words, 8);
    list.fillBuffer(a, 8, 8, 0x01010101u);
    list.copyBuffer(a, 0, b, 4, 12);
    list.fillBuffer(a, 0, 4, 99);  // after the copy: b must not see it
    // Nothing happens before submit().
    EXPECT_EQ(read(a, 0, 16), std::vector<uint8_t>(16, 0));
    dev().submit(list);

    uint32_t av[4], bv[4];
    ASSERT_TRUE(dev().readBuffer(a, 0, 16, av));
    ASSERT_TRUE(dev().readBuffer(b, 0, 16, bv));
    EXPECT_EQ(av[0], 99u);
    EXPECT_EQ(av[1], 20u);
    EXPECT_EQ(av[2], 0x01010101u);
    EXPECT_EQ(bv[0], 0u);
    EXPECT_EQ(bv[1], 10u);
    EXPECT_EQ(bv[2], 20u);
    EXPECT_EQ(bv[3], 0x01010101u);
    EXPECT_TRUE(m_errors.empty());
}

TEST_F(NullDeviceTest, TextureSubresourcesRoundTrip) {
    rhi::TextureDesc d;
    d.dimension = rhi::TextureDimension::Tex2DArray;
    d.format = rhi::Format::RGBA8_UNORM;
    d.width = 8;
    d.height = 4;
    d.depthOrLayers = 3;
    d.mipLevels = 4;
    d.debugName = "array";
    rhi::TextureHandle t = dev().createTexture(d);
    ASSERT_TRUE(t.isValid());

    // mip 2 is 2x1 texels of 4 bytes; each layer is separate.
    std::vector<uint8_t> layer1(8), layer2(8);
    std::iota(layer1.begin(), layer1.end(), uint8_t(1));
    std::iota(layer2.begin(), layer2.end(), uint8_t(100));
    dev().writeTexture(t, {2, 1}, layer1.data(), layer1.size());
    dev().writeTexture(t, {2, 2}, layer2.data(), layer2.size());
    std::vector<uint8_t> out;
    ASSERT_TRUE(dev().readTexture(t, {2, 1}, rhi::Access::ShaderSampled, out));
    EXPECT_EQ(out, layer1);
    ASSERT_TRUE(dev().readTexture(t, {2, 2}, rhi::Access::ShaderSampled, out));
    EXPECT_EQ(out, layer2);
    ASSERT_TRUE(dev().readTexture(t, {2, 0}, rhi::Access::ShaderSampled, out));
    EXPECT_EQ(out, std::vector<uint8_t>(8, 0));
    ASSERT_TRUE(dev().readTexture(t, {0, 0}, rhi::Access::ShaderSampled, out));
    EXPECT_EQ(out.size(), 8u * 4u * 4u);

    // Tex3D: one subresource per mip is the whole volume (4x4x2 at mip 1 of R32_FLOAT).
    rhi::TextureDesc v;
    v.dimension = rhi::TextureDimension::Tex3D;
    v.format = rhi::Format::R32_FLOAT;
    v.width = v.height = 8;
    v.depthOrLayers = 4;
    v.mipLevels = 2;
    rhi::TextureHandle vol = dev().createTexture(v);
    ASSERT_TRUE(vol.isValid());
    std::vector<uint8_t> volume(4 * 4 * 2 * 4);
    std::iota(volume.begin(), volume.end(), uint8_t(0));
    dev().writeTexture(vol, {1, 0}, volume.data(), volume.size());
    ASSERT_TRUE(dev().readTexture(vol, {1, 0}, rhi::Access::ShaderSampled, out));
    EXPECT_EQ(out, volume);
    EXPECT_TRUE(m_errors.empty());

    // Wrong sizes and missing subresources are rejected.
    dev().writeTexture(vol, {1, 0}, volume.data(), volume.size() - 4);
    dev().writeTexture(t, {4, 0}, layer1.data(), layer1.size());
    EXPECT_FALSE(dev().readTexture(t, {0, 3}, rhi::Access::ShaderSampled, out));
    EXPECT_EQ(m_errors.size(), 3u);
}

TEST_F(NullDeviceTest, InvalidTextureDescsAreRejected) {
    rhi::TextureDesc d;
    d.width = 0;
    EXPECT_FALSE(dev().createTexture(d).isValid());
    d.width = 16;
    d.height = 16;
    d.mipLevels = 6;  // full chain of 16x16 is 5
    EXPECT_FALSE(dev().createTexture(d).isValid());
    d.mipLevels = 5;
    EXPECT_TRUE(dev().createTexture(d).isValid());
    EXPECT_EQ(m_errors.size(), 2u);
}

TEST_F(NullDeviceTest, RecordsCommandsInSubmissionOrder) {
    rhi::ShaderBinding bindings[1];
    bindings[0].name = "data";
    bindings[0].type = rhi::BindingType::StorageBuffer;
    bindings[0].writes = true;
    rhi::ShaderDesc sd;
    sd.stage = rhi::ShaderStage::Compute;
    sd.bindings = bindings;
    sd.workgroupSize = {64, 1, 1};
    sd.debugName = "cs";
    rhi::ShaderHandle cs = dev().createShader(sd);
    ASSERT_TRUE(cs.isValid());
    rhi::ComputePipelineDesc pd;
    pd.shader = cs;
    rhi::PipelineHandle pipe = dev().createComputePipeline(pd);
    ASSERT_TRUE(pipe.isValid());
    rhi::BufferHandle buf = makeBuffer(256);
    rhi::BindGroupDesc gd;
    gd.pipeline = pipe;
    gd.entries = {rhi::BindGroupEntry::makeBuffer(0, buf)};
    rhi::BindGroupHandle group = dev().createBindGroup(gd);
    ASSERT_TRUE(group.isValid());

    rhi::TextureDesc td;
    td.width = td.height = 16;
    td.usage = rhi::TextureUsage::ColorTarget;
    rhi::TextureHandle color = dev().createTexture(td);
    td.format = rhi::Format::D32_FLOAT;
    td.usage = rhi::TextureUsage::DepthTarget;
    rhi::TextureHandle depth = dev().createTexture(td);

    rhi::CommandList& list = dev().beginCommandList("frame");
    list.pushDebugGroup("compute");
    list.bindPipeline(pipe);
    list.bindGroup(0, group);
    list.dispatch(4, 2, 1);
    list.barrier(rhi::Barrier::buf(buf, rhi::Access::ShaderWrite, rhi::Access::ShaderRead));
    list.popDebugGroup();
    rhi::RenderPassDesc rp;
    rp.colorAttachments.resize(1);
    rp.colorAttachments[0].texture = color;
    rp.depthAttachment.texture = depth;
    rp.debugName = "main";
    list.beginRenderPass(rp);
    list.draw(3, 2);
    list.endRenderPass();
    dev().submit(list);

    using K = RecordedCommand::Kind;
    const auto& cmds = rhi::null::recordedCommands(dev());
    ASSERT_EQ(cmds.size(), 9u);
    EXPECT_EQ(cmds[0].kind, K::PushDebugGroup);
    EXPECT_EQ(cmds[0].label, "compute");
    EXPECT_EQ(cmds[1].kind, K::BindPipeline);
    EXPECT_EQ(cmds[1].pipeline, pipe);
    EXPECT_EQ(cmds[2].kind, K::BindGroup);
    EXPECT_EQ(cmds[2].group, group);
    EXPECT_EQ(cmds[2].set, 0u);
    EXPECT_EQ(cmds[3].kind, K::Dispatch);
    EXPECT_EQ(cmds[3].counts[0], 4u);
    EXPECT_EQ(cmds[3].counts[1], 2u);
    EXPECT_EQ(cmds[3].counts[2], 1u);
    EXPECT_EQ(cmds[4].kind, K::Barrier);
    ASSERT_EQ(cmds[4].barriers.size(), 1u);
    EXPECT_EQ(cmds[4].barriers[0].buffer, buf);
    EXPECT_EQ(cmds[4].barriers[0].before, rhi::Access::ShaderWrite);
    EXPECT_EQ(cmds[4].barriers[0].after, rhi::Access::ShaderRead);
    EXPECT_EQ(cmds[5].kind, K::PopDebugGroup);
    EXPECT_EQ(cmds[6].kind, K::BeginRenderPass);
    EXPECT_EQ(cmds[6].label, "main");
    ASSERT_EQ(cmds[6].attachments.size(), 2u);
    EXPECT_EQ(cmds[6].attachments[0], color);
    EXPECT_EQ(cmds[6].attachments[1], depth);
    EXPECT_EQ(cmds[7].kind, K::Draw);
    EXPECT_EQ(cmds[7].counts[0], 3u);
    EXPECT_EQ(cmds[7].counts[1], 2u);
    EXPECT_EQ(cmds[8].kind, K::EndRenderPass);

    rhi::null::clearRecordedCommands(dev());
    EXPECT_TRUE(rhi::null::recordedCommands(dev()).empty());
    EXPECT_TRUE(m_errors.empty());
}

TEST_F(NullDeviceTest, CommandsWithDeadHandlesAreDroppedWithAnError) {
    rhi::BufferHandle b = makeBuffer(16);
    dev().destroy(b);
    rhi::CommandList& list = dev().beginCommandList();
    list.fillBuffer(b, 0, 16, 1);
    list.bindPipeline(rhi::PipelineHandle{});
    list.barrier(rhi::Barrier::buf(b, rhi::Access::None, rhi::Access::ShaderRead));
    list.dispatch(1);
    dev().submit(list);
    EXPECT_EQ(m_errors.size(), 3u);
    ASSERT_EQ(rhi::null::recordedCommands(dev()).size(), 1u);
    EXPECT_EQ(rhi::null::recordedCommands(dev())[0].kind, RecordedCommand::Kind::Dispatch);
}

TEST_F(NullDeviceTest, TimestampsIncrease) {
    rhi::QueryPoolDesc qd;
    qd.count = 4;
    rhi::QueryPoolHandle pool = dev().createQueryPool(qd);
    ASSERT_TRUE(pool.isValid());
    rhi::CommandList& list = dev().beginCommandList();
    list.resetQueries(pool, 0, 4);
    for (uint32_t i = 0; i < 4; ++i) list.writeTimestamp(pool, i);
    dev().submit(list);
    uint64_t ns[4] = {};
    ASSERT_TRUE(dev().readTimestamps(pool, 0, 4, ns));
    for (int i = 1; i < 4; ++i) EXPECT_GT(ns[i], ns[i - 1]);

    // A later submission's timestamps are later still.
    rhi::CommandList& again = dev().beginCommandList();
    again.writeTimestamp(pool, 0);
    dev().submit(again);
    uint64_t later = 0;
    ASSERT_TRUE(dev().readTimestamps(pool, 0, 1, &later));
    EXPECT_GT(later, ns[3]);
    EXPECT_TRUE(m_errors.empty());

    // Unwritten or out-of-range queries fail.
    rhi::CommandList& reset = dev().beginCommandList();
    reset.resetQueries(pool, 1, 1);
    dev().submit(reset);
    EXPECT_FALSE(dev().readTimestamps(pool, 1, 1, ns));
    EXPECT_FALSE(dev().readTimestamps(pool, 3, 2, ns));
    EXPECT_EQ(m_errors.size(), 2u);
}

TEST_F(NullDeviceTest, HasNoBackbuffer) {
    EXPECT_FALSE(dev().acquireBackbuffer().isValid());
    EXPECT_FALSE(dev().present());
    EXPECT_EQ(m_errors.size(), 2u);
}

TEST_F(NullDeviceTest, LiveObjectCountStartsAtZero) {
    EXPECT_EQ(rhi::null::liveObjectCount(dev()), 0u);
    rhi::BufferHandle b = makeBuffer(4);
    EXPECT_TRUE(b.isValid());
    EXPECT_EQ(rhi::null::liveObjectCount(dev()), 1u);
}

}  // namespace
