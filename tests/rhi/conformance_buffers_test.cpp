// RHI conformance: buffers (creation with initial data, writeBuffer, readBuffer, mapped Upload and
// Readback memory, updateBuffer / fillBuffer / copyBuffer, bind-group buffer ranges) and resource
// binding (push constants, several bind groups, indirect dispatch). Every test runs on Vulkan and
// OpenGL with validation on; any validation error fails it.
#include <cstdint>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include <shaders/conf_copy_buffer.h>
#include <shaders/conf_indirect_args.h>
#include <shaders/conf_indirect_count.h>
#include <shaders/conf_multi_set.h>
#include <shaders/conf_push_constants.h>

#include "conformance_common.h"

namespace {

using namespace rhi;
using penumbra::conformance::ConformanceTest;
using penumbra::conformance::Rng;

std::vector<uint32_t> randomWords(size_t count, uint32_t seed) {
    Rng rng(seed);
    std::vector<uint32_t> out(count);
    for (auto& w : out) w = rng.next();
    return out;
}

class ConformanceBuffers : public ConformanceTest {};
class ConformanceBinding : public ConformanceTest {};

// createBuffer(initialData) -> readBuffer; writeBuffer at an offset; partial readBuffer at an offset;
// Upload memory created with initial data is visible through its persistent mapping.
TEST_P(ConformanceBuffers, InitialDataWriteBufferReadBufferRoundTrip) {
    const std::vector<uint32_t> initial = randomWords(64, 0x1234u);
    BufferHandle buffer = makeBuffer(256, BufferUsage::Storage | BufferUsage::CopySrc | BufferUsage::CopyDst,
                                     MemoryType::GpuOnly, initial.data());
    ASSERT_TRUE(buffer.isValid());
    // Metric: describe() returns the creation description. Threshold: size exactly 256.
    ASSERT_NE(dev().describe(buffer), nullptr);
    EXPECT_EQ(dev().describe(buffer)->size, 256u);

    // Metric: every word read back equals the initial data. Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(buffer, 64), initial);

    const std::vector<uint32_t> patch = randomWords(8, 0x777u);
    dev().writeBuffer(buffer, 64, patch.data(), patch.size() * 4);
    std::vector<uint32_t> expected = initial;
    std::copy(patch.begin(), patch.end(), expected.begin() + 16);
    // Metric: words [16, 24) replaced by the patch, all others unchanged. Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(buffer, 64), expected);

    // Metric: a partial read at byte offset 60 returns words [15, 23). Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(buffer, 8, 60),
              std::vector<uint32_t>(expected.begin() + 15, expected.begin() + 23));

    BufferHandle upload =
        makeBuffer(256, BufferUsage::Storage | BufferUsage::CopySrc, MemoryType::Upload, initial.data());
    ASSERT_TRUE(upload.isValid());
    const void* mapped = dev().mappedPointer(upload);
    ASSERT_NE(mapped, nullptr);
    // Metric: the mapped bytes equal the initial data. Threshold: exact (memcmp == 0).
    EXPECT_EQ(std::memcmp(mapped, initial.data(), 256), 0);
    // Metric: GpuOnly memory has no mapping. Threshold: mappedPointer == nullptr.
    EXPECT_EQ(dev().mappedPointer(buffer), nullptr);
}

// CPU writes through the persistent mapping of an Upload buffer; a compute shader copies it into a
// GpuOnly buffer, which is read back.
TEST_P(ConformanceBuffers, UploadMappedWriteComputeCopyToGpuOnly) {
    constexpr uint32_t kCount = 1000;
    BufferHandle src = makeBuffer(kCount * 4, BufferUsage::Storage, MemoryType::Upload);
    BufferHandle dst = makeBuffer(kCount * 4, BufferUsage::Storage | BufferUsage::CopySrc);
    ASSERT_TRUE(src.isValid() && dst.isValid());
    void* mapped = dev().mappedPointer(src);
    ASSERT_NE(mapped, nullptr);
    const std::vector<uint32_t> data = randomWords(kCount, 0xC0FFEEu);
    std::memcpy(mapped, data.data(), kCount * 4);

    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_copy_buffer::compute());
    ASSERT_TRUE(pipeline.isValid());
    BindGroupHandle group =
        makeBindGroup(pipeline, 0, {BindGroupEntry::makeBuffer(0, src), BindGroupEntry::makeBuffer(1, dst)});
    ASSERT_TRUE(group.isValid());

    CommandList& cmd = dev().beginCommandList("upload copy");
    cmd.barrier(Barrier::buf(src, Access::HostWrite, Access::ShaderRead));
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.pushConstants(&kCount, sizeof(kCount));
    cmd.dispatch((kCount + 63) / 64);
    cmd.barrier(Barrier::buf(dst, Access::ShaderWrite, Access::HostRead));
    submitAndWait(cmd);

    // Metric: all 1000 words of the GpuOnly buffer equal what the CPU wrote. Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(dst, kCount), data);
}

// fillBuffer, updateBuffer and copyBuffer recorded in one command list with transfer barriers.
TEST_P(ConformanceBuffers, UpdateFillCopyThroughCommandList) {
    const BufferUsage usage = BufferUsage::Storage | BufferUsage::CopySrc | BufferUsage::CopyDst;
    BufferHandle x = makeBuffer(1024, usage);
    const std::vector<uint32_t> yInitial(256, 0x11111111u);
    BufferHandle y = makeBufferFrom(yInitial, usage);
    ASSERT_TRUE(x.isValid() && y.isValid());
    const std::vector<uint32_t> update = randomWords(16, 0xABCDu);

    CommandList& cmd = dev().beginCommandList("update fill copy");
    cmd.fillBuffer(x, 0, 1024, 0xDEADBEEFu);
    cmd.barrier(Barrier::buf(x, Access::CopyDst, Access::CopyDst));  // write-after-write on [512, 576)
    cmd.fillBuffer(x, 512, 64, 0x01020304u);
    cmd.barrier(Barrier::buf(x, Access::CopyDst, Access::CopyDst));
    cmd.updateBuffer(x, 128, update.data(), update.size() * 4);
    cmd.barrier(Barrier::buf(x, Access::CopyDst, Access::CopySrc));
    cmd.copyBuffer(x, 64, y, 256, 640);  // x words [16, 176) -> y words [64, 224)
    cmd.barrier(Barrier::buf(y, Access::CopyDst, Access::HostRead));
    cmd.barrier(Barrier::buf(x, Access::CopySrc, Access::HostRead));
    submitAndWait(cmd);

    std::vector<uint32_t> xExpected(256, 0xDEADBEEFu);
    std::fill(xExpected.begin() + 128, xExpected.begin() + 144, 0x01020304u);
    std::copy(update.begin(), update.end(), xExpected.begin() + 32);
    std::vector<uint32_t> yExpected = yInitial;
    std::copy(xExpected.begin() + 16, xExpected.begin() + 176, yExpected.begin() + 64);

    // Metric: every word of x (fill + fill + update) and y (copy target) as computed on the CPU.
    // Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(x, 256), xExpected);
    EXPECT_EQ(readBuffer<uint32_t>(y, 256), yExpected);
}

// copyBuffer into Readback memory; after waitForSubmission the persistent mapping holds the data.
TEST_P(ConformanceBuffers, CopyToReadbackMemoryVisibleThroughMapping) {
    const std::vector<uint32_t> data = randomWords(300, 0x5151u);
    BufferHandle src =
        makeBufferFrom(data, BufferUsage::Storage | BufferUsage::CopySrc | BufferUsage::CopyDst);
    BufferHandle readback = makeBuffer(data.size() * 4, BufferUsage::CopyDst, MemoryType::Readback);
    ASSERT_TRUE(src.isValid() && readback.isValid());
    const void* mapped = dev().mappedPointer(readback);
    ASSERT_NE(mapped, nullptr);

    CommandList& cmd = dev().beginCommandList("copy to readback");
    cmd.barrier(Barrier::buf(src, Access::None, Access::CopySrc));
    cmd.copyBuffer(src, 0, readback, 0, data.size() * 4);
    cmd.barrier(Barrier::buf(readback, Access::CopyDst, Access::HostRead));
    const uint64_t serial = dev().submit(cmd);
    EXPECT_GT(serial, 0u);
    dev().waitForSubmission(serial);

    // Metric: mapped Readback bytes equal the source data. Threshold: exact (memcmp == 0).
    EXPECT_EQ(std::memcmp(mapped, data.data(), data.size() * 4), 0);
}

// Bind-group entries with offset and size select buffer ranges.
TEST_P(ConformanceBuffers, BindGroupBufferRanges) {
    const std::vector<uint32_t> src = randomWords(256, 0x9999u);
    const std::vector<uint32_t> dstInitial(512, 0xFFFFFFFFu);
    BufferHandle srcBuf =
        makeBufferFrom(src, BufferUsage::Storage | BufferUsage::CopySrc | BufferUsage::CopyDst);
    BufferHandle dstBuf =
        makeBufferFrom(dstInitial, BufferUsage::Storage | BufferUsage::CopySrc | BufferUsage::CopyDst);
    ASSERT_TRUE(srcBuf.isValid() && dstBuf.isValid());

    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_copy_buffer::compute());
    ASSERT_TRUE(pipeline.isValid());
    // Offsets are multiples of 256 bytes, the largest storage-buffer offset alignment APIs allow.
    BindGroupHandle group = makeBindGroup(
        pipeline, 0,
        {BindGroupEntry::makeBuffer(0, srcBuf, 256, 256), BindGroupEntry::makeBuffer(1, dstBuf, 1024, 512)});
    ASSERT_TRUE(group.isValid());

    const uint32_t count = 64;
    CommandList& cmd = dev().beginCommandList("buffer ranges");
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.pushConstants(&count, sizeof(count));
    cmd.dispatch(1);
    cmd.barrier(Barrier::buf(dstBuf, Access::ShaderWrite, Access::HostRead));
    submitAndWait(cmd);

    std::vector<uint32_t> expected = dstInitial;
    std::copy(src.begin() + 64, src.begin() + 128, expected.begin() + 256);
    // Metric: dst words [256, 320) = src words [64, 128), every other word untouched. Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(dstBuf, 512), expected);
}

// A full 128-byte push-constant block, pushed whole and in two 64-byte halves, reaches the shader,
// and each dispatch sees the values pushed before it.
TEST_P(ConformanceBinding, PushConstantsReachShader) {
    struct Push {
        uint32_t values[28];
        uint32_t slot[4];
    };
    static_assert(sizeof(Push) == kMaxPushConstantSize);
    Push first{}, second{};
    Rng rng(42);
    for (auto& v : first.values) v = rng.next();
    for (auto& v : second.values) v = rng.next();
    first.slot[0] = 0;
    second.slot[0] = 1;

    BufferHandle out = makeBuffer(56 * 4, BufferUsage::Storage | BufferUsage::CopySrc);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_push_constants::compute());
    ASSERT_TRUE(out.isValid() && pipeline.isValid());
    BindGroupHandle group = makeBindGroup(pipeline, 0, {BindGroupEntry::makeBuffer(0, out)});
    ASSERT_TRUE(group.isValid());

    CommandList& cmd = dev().beginCommandList("push constants");
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.pushConstants(&first, sizeof(first));
    cmd.dispatch(1);
    cmd.pushConstants(&second, 64, 0);
    cmd.pushConstants(reinterpret_cast<const uint8_t*>(&second) + 64, 64, 64);
    cmd.dispatch(1);
    cmd.barrier(Barrier::buf(out, Access::ShaderWrite, Access::HostRead));
    submitAndWait(cmd);

    std::vector<uint32_t> expected(first.values, first.values + 28);
    expected.insert(expected.end(), second.values, second.values + 28);
    // Metric: the 56 words written equal both pushed blocks in order. Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(out, 56), expected);
}

// Storage buffers in set 0 and a uniform buffer (two ranges of one buffer) in set 1, with the set-1
// group switched between dispatches.
TEST_P(ConformanceBinding, UniformBufferInSet1StorageBuffersInSet0) {
    std::vector<float> input(64);
    for (size_t i = 0; i < input.size(); ++i) input[i] = float(i) * 0.25f;
    struct Params {
        float scaleBias[4];
        uint32_t range[4];
    };
    std::vector<uint8_t> uniformData(512, 0);
    const Params a{{2.0f, 1.0f, 0, 0}, {0, 64, 0, 0}};
    const Params b{{-0.5f, 3.0f, 0, 0}, {64, 64, 0, 0}};
    std::memcpy(uniformData.data(), &a, sizeof(a));
    std::memcpy(uniformData.data() + 256, &b, sizeof(b));

    BufferHandle in = makeBufferFrom(input, BufferUsage::Storage | BufferUsage::CopyDst);
    BufferHandle out = makeBuffer(128 * 4, BufferUsage::Storage | BufferUsage::CopySrc);
    BufferHandle uniforms = makeBufferFrom(uniformData, BufferUsage::Uniform | BufferUsage::CopyDst);
    ASSERT_TRUE(in.isValid() && out.isValid() && uniforms.isValid());

    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_multi_set::compute());
    ASSERT_TRUE(pipeline.isValid());
    BindGroupHandle set0 =
        makeBindGroup(pipeline, 0, {BindGroupEntry::makeBuffer(0, in), BindGroupEntry::makeBuffer(1, out)});
    BindGroupHandle set1a =
        makeBindGroup(pipeline, 1, {BindGroupEntry::makeBuffer(0, uniforms, 0, sizeof(Params))});
    BindGroupHandle set1b =
        makeBindGroup(pipeline, 1, {BindGroupEntry::makeBuffer(0, uniforms, 256, sizeof(Params))});
    ASSERT_TRUE(set0.isValid() && set1a.isValid() && set1b.isValid());

    CommandList& cmd = dev().beginCommandList("multiple bind groups");
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(1, set1a);
    cmd.bindGroup(0, set0);
    cmd.dispatch(1);
    cmd.bindGroup(1, set1b);
    cmd.dispatch(1);
    cmd.barrier(Barrier::buf(out, Access::ShaderWrite, Access::HostRead));
    submitAndWait(cmd);

    const std::vector<float> result = readBuffer<float>(out, 128);
    ASSERT_EQ(result.size(), 128u);
    for (size_t i = 0; i < 64; ++i) {
        // Metric: out[i] = in[i] * 2 + 1 and out[64 + i] = in[i] * -0.5 + 3 (all exactly
        // representable). Threshold: exact.
        EXPECT_EQ(result[i], input[i] * 2.0f + 1.0f) << "element " << i;
        EXPECT_EQ(result[64 + i], input[i] * -0.5f + 3.0f) << "element " << 64 + i;
    }
}

// A compute shader writes dispatch arguments; dispatchIndirect consumes them at a non-zero offset.
TEST_P(ConformanceBinding, DispatchIndirectWithGpuWrittenArguments) {
    const uint32_t groups[3] = {3, 2, 2};
    const uint32_t kLocal = 8;  // conf_indirect_count: local size 4 x 2 x 1
    const uint32_t kCapacity = 256;

    std::vector<uint32_t> zeros(16, 0);
    BufferHandle args = makeBufferFrom(
        zeros, BufferUsage::Storage | BufferUsage::Indirect | BufferUsage::CopyDst | BufferUsage::CopySrc);
    BufferHandle counter =
        makeBuffer((kCapacity + 1) * 4, BufferUsage::Storage | BufferUsage::CopyDst | BufferUsage::CopySrc);
    PipelineHandle writeArgs = makeComputePipeline(penumbra::shaders::conf_indirect_args::compute());
    PipelineHandle count = makeComputePipeline(penumbra::shaders::conf_indirect_count::compute());
    ASSERT_TRUE(args.isValid() && counter.isValid() && writeArgs.isValid() && count.isValid());
    BindGroupHandle argsGroup = makeBindGroup(writeArgs, 0, {BindGroupEntry::makeBuffer(0, args)});
    BindGroupHandle countGroup = makeBindGroup(count, 0, {BindGroupEntry::makeBuffer(0, counter)});
    ASSERT_TRUE(argsGroup.isValid() && countGroup.isValid());

    const uint32_t push[4] = {groups[0], groups[1], groups[2], 4};  // arguments at word 4 = byte 16
    CommandList& cmd = dev().beginCommandList("dispatch indirect");
    cmd.fillBuffer(counter, 0, (kCapacity + 1) * 4, 0);
    cmd.barrier(Barrier::buf(counter, Access::CopyDst, Access::ShaderRead | Access::ShaderWrite));
    cmd.bindPipeline(writeArgs);
    cmd.bindGroup(0, argsGroup);
    cmd.pushConstants(push, sizeof(push));
    cmd.dispatch(1);
    cmd.barrier(Barrier::buf(args, Access::ShaderWrite, Access::IndirectRead));
    cmd.bindPipeline(count);
    cmd.bindGroup(0, countGroup);
    cmd.dispatchIndirect(args, 16);
    cmd.barrier(Barrier::buf(counter, Access::ShaderRead | Access::ShaderWrite, Access::HostRead));
    submitAndWait(cmd);

    const uint32_t total = groups[0] * groups[1] * groups[2] * kLocal;
    const std::vector<uint32_t> result = readBuffer<uint32_t>(counter, kCapacity + 1);
    ASSERT_EQ(result.size(), kCapacity + 1);
    // Metric: invocation counter = 3*2*2 groups * 8 invocations = 96. Threshold: exact.
    EXPECT_EQ(result[0], total);
    for (uint32_t i = 0; i < kCapacity; ++i) {
        // Metric: hits[i] = i + 1 for every launched linear index, 0 beyond. Threshold: exact.
        EXPECT_EQ(result[1 + i], i < total ? i + 1 : 0u) << "index " << i;
    }
    // Metric: the arguments the shader wrote are the ones pushed. Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(args, 3, 16), std::vector<uint32_t>(groups, groups + 3));
}

INSTANTIATE_TEST_SUITE_P(Backends, ConformanceBuffers, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);
INSTANTIATE_TEST_SUITE_P(Backends, ConformanceBinding, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
