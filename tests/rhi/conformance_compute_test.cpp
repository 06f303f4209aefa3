// RHI conformance: compute writes to storage images (rgba32f, rgba8, r32ui, individual mip levels)
// and storage buffers, and timestamp queries around dispatches.
#include <cstdint>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include <shaders/conf_busy.h>
#include <shaders/conf_image_atomics.h>
#include <shaders/conf_storage_mip.h>
#include <shaders/conf_storage_rgba32f.h>
#include <shaders/conf_storage_rgba8_r32ui.h>

#include "conformance_common.h"

namespace {

using namespace rhi;
using penumbra::conformance::ConformanceTest;
using penumbra::conformance::Rng;

class ConformanceCompute : public ConformanceTest {};
class ConformanceQueries : public ConformanceTest {
protected:
    // The timestamp tests' work: conf_busy over a storage buffer of kBusyElements uints, and a query
    // pool of `stamps` slots.
    static constexpr uint32_t kBusyElements = 16384;
    struct Busy {
        BufferHandle data;
        PipelineHandle pipeline;
        BindGroupHandle group;
        QueryPoolHandle pool;
        bool valid() const {
            return data.isValid() && pipeline.isValid() && group.isValid() && pool.isValid();
        }
    };
    Busy makeBusy(uint32_t stamps) {
        Busy b;
        b.data = makeBuffer(kBusyElements * 4, BufferUsage::Storage | BufferUsage::CopyDst);
        b.pipeline = makeComputePipeline(penumbra::shaders::conf_busy::compute());
        b.pool = makeQueryPool(stamps);
        if (b.data.isValid() && b.pipeline.isValid())
            b.group = makeBindGroup(b.pipeline, 0, {BindGroupEntry::makeBuffer(0, b.data)});
        return b;
    }
};

// imageStore into an rgba32f storage image and plain stores into a storage buffer.
TEST_P(ConformanceCompute, StorageImageRgba32fAndStorageBuffer) {
    const uint32_t kW = 37, kH = 21;  // not multiples of the 8x8 workgroup
    TextureHandle image =
        makeTexture2D(Format::RGBA32_FLOAT, kW, kH, TextureUsage::Storage | TextureUsage::CopySrc);
    BufferHandle words = makeBuffer(kW * kH * 4, BufferUsage::Storage | BufferUsage::CopySrc);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_storage_rgba32f::compute());
    ASSERT_TRUE(image.isValid() && words.isValid() && pipeline.isValid());
    BindGroupHandle group = makeBindGroup(
        pipeline, 0, {BindGroupEntry::makeStorage(0, image), BindGroupEntry::makeBuffer(1, words)});
    ASSERT_TRUE(group.isValid());

    const uint32_t size[4] = {kW, kH, 0, 0};
    CommandList& cmd = dev().beginCommandList("storage rgba32f");
    cmd.barrier(Barrier::tex(image, Access::None, Access::ShaderWrite));
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.pushConstants(size, sizeof(size));
    cmd.dispatch((kW + 7) / 8, (kH + 7) / 8);
    cmd.barrier(Barrier::tex(image, Access::ShaderWrite, Access::CopySrc));
    cmd.barrier(Barrier::buf(words, Access::ShaderWrite, Access::HostRead));
    submitAndWait(cmd);

    const std::vector<float> texels = readTextureAs<float>(image, {}, Access::CopySrc);
    const std::vector<uint32_t> result = readBuffer<uint32_t>(words, kW * kH);
    ASSERT_EQ(texels.size(), size_t(kW) * kH * 4);
    ASSERT_EQ(result.size(), size_t(kW) * kH);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            const float* t = &texels[(y * kW + x) * 4];
            const float expected[4] = {float(x), float(y), float(x) * 0.25f, -float(y) * 0.5f - 1.0f};
            for (int c = 0; c < 4; ++c) {
                // Metric: texel channel equals the pattern (exactly representable). Threshold: exact.
                EXPECT_EQ(t[c], expected[c]) << "texel (" << x << ", " << y << ") channel " << c;
            }
            // Metric: buffer word equals the hash pattern. Threshold: exact.
            EXPECT_EQ(result[y * kW + x], (x * 2654435761u) ^ (y << 16) ^ 0xA5A5A5A5u)
                << "word (" << x << ", " << y << ")";
        }
    }
}

// An rgba8 storage image (write-only) and an r32ui storage image (read-modify-write of texels that
// were uploaded with writeTexture).
TEST_P(ConformanceCompute, StorageImageRgba8AndR32uiReadModifyWrite) {
    const uint32_t kW = 64, kH = 32;
    TextureHandle colors =
        makeTexture2D(Format::RGBA8_UNORM, kW, kH, TextureUsage::Storage | TextureUsage::CopySrc);
    TextureHandle counters = makeTexture2D(
        Format::R32_UINT, kW, kH, TextureUsage::Storage | TextureUsage::CopyDst | TextureUsage::CopySrc);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_storage_rgba8_r32ui::compute());
    ASSERT_TRUE(colors.isValid() && counters.isValid() && pipeline.isValid());
    std::vector<uint32_t> initial(kW * kH);
    Rng rng(77);
    for (auto& v : initial) v = rng.next() >> 4;
    dev().writeTexture(counters, {}, initial.data(), initial.size() * 4);  // leaves it ShaderSampled

    BindGroupHandle group = makeBindGroup(
        pipeline, 0, {BindGroupEntry::makeStorage(0, colors), BindGroupEntry::makeStorage(1, counters)});
    ASSERT_TRUE(group.isValid());
    const uint32_t size[4] = {kW, kH, 0, 0};
    CommandList& cmd = dev().beginCommandList("storage rgba8 r32ui");
    const Barrier before[] = {
        Barrier::tex(colors, Access::None, Access::ShaderWrite),
        Barrier::tex(counters, Access::ShaderSampled, Access::ShaderRead | Access::ShaderWrite)};
    cmd.barrier(before);
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.pushConstants(size, sizeof(size));
    cmd.dispatch(kW / 8, kH / 8);
    const Barrier after[] = {
        Barrier::tex(colors, Access::ShaderWrite, Access::CopySrc),
        Barrier::tex(counters, Access::ShaderRead | Access::ShaderWrite, Access::CopySrc)};
    cmd.barrier(after);
    submitAndWait(cmd);

    const std::vector<uint8_t> rgba = readTexture(colors, {}, Access::CopySrc);
    const std::vector<uint32_t> values = readTextureAs<uint32_t>(counters, {}, Access::CopySrc);
    ASSERT_EQ(rgba.size(), size_t(kW) * kH * 4);
    ASSERT_EQ(values.size(), size_t(kW) * kH);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            const uint8_t* p = &rgba[(y * kW + x) * 4];
            // Metric: UNORM8 encoding of (x/255, y/255, (x+y)/255, 1) is (x, y, x+y, 255). Threshold: exact.
            EXPECT_EQ(p[0], x);
            EXPECT_EQ(p[1], y);
            EXPECT_EQ(p[2], x + y);
            EXPECT_EQ(p[3], 255) << "texel (" << x << ", " << y << ")";
            // Metric: r32ui texel = initial * 3 + (x << 8) + y + 0x10000000 (mod 2^32). Threshold: exact.
            EXPECT_EQ(values[y * kW + x], initial[y * kW + x] * 3u + (x << 8) + y + 0x10000000u)
                << "texel (" << x << ", " << y << ")";
        }
    }
}

// Each mip level of a storage image is bound separately (BindGroupEntry::mip) and written.
TEST_P(ConformanceCompute, StorageImageMipLevelBinding) {
    const uint32_t kW = 32, kH = 16, kMips = 3;
    TextureHandle image =
        makeTexture2D(Format::R32_UINT, kW, kH, TextureUsage::Storage | TextureUsage::CopySrc, kMips);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_storage_mip::compute());
    ASSERT_TRUE(image.isValid() && pipeline.isValid());
    BindGroupHandle groups[kMips];
    for (uint32_t mip = 0; mip < kMips; ++mip) {
        groups[mip] = makeBindGroup(pipeline, 0, {BindGroupEntry::makeStorage(0, image, mip)});
        ASSERT_TRUE(groups[mip].isValid());
    }

    CommandList& cmd = dev().beginCommandList("storage mips");
    cmd.barrier(Barrier::tex(image, Access::None, Access::ShaderWrite));
    cmd.bindPipeline(pipeline);
    for (uint32_t mip = 0; mip < kMips; ++mip) {
        const uint32_t w = kW >> mip, h = kH >> mip;
        const uint32_t info[4] = {mip, w, h, 0};
        cmd.bindGroup(0, groups[mip]);
        cmd.pushConstants(info, sizeof(info));
        cmd.dispatch((w + 7) / 8, (h + 7) / 8);
    }
    cmd.barrier(Barrier::tex(image, Access::ShaderWrite, Access::CopySrc));
    submitAndWait(cmd);

    for (uint32_t mip = 0; mip < kMips; ++mip) {
        const uint32_t w = kW >> mip, h = kH >> mip;
        const std::vector<uint32_t> values = readTextureAs<uint32_t>(image, {mip, 0}, Access::CopySrc);
        ASSERT_EQ(values.size(), size_t(w) * h) << "mip " << mip;
        for (uint32_t y = 0; y < h; ++y)
            for (uint32_t x = 0; x < w; ++x) {
                // Metric: texel of mip m holds (m << 24 | y << 12 | x). Threshold: exact.
                EXPECT_EQ(values[y * w + x], (mip << 24) | (y << 12) | x)
                    << "mip " << mip << " texel (" << x << ", " << y << ")";
            }
    }
}

// Timestamps written around dispatches (in two submissions) do not decrease, the last is later
// than the first, and the elapsed time is plausible.
TEST_P(ConformanceQueries, TimestampsIncrease) {
    ASSERT_TRUE(dev().info().limits.timestamps) << "timestamp queries are expected on both backends";
    constexpr uint32_t kStamps = 6;
    const Busy busy = makeBusy(8);
    ASSERT_TRUE(busy.valid());
    const uint32_t iterations = 64;

    CommandList& first = dev().beginCommandList("timestamps 1");
    first.resetQueries(busy.pool, 0, 8);
    first.fillBuffer(busy.data, 0, kBusyElements * 4, 1);
    first.barrier(Barrier::buf(busy.data, Access::CopyDst, Access::ShaderRead | Access::ShaderWrite));
    first.bindPipeline(busy.pipeline);
    first.bindGroup(0, busy.group);
    first.pushConstants(&iterations, sizeof(iterations));
    first.writeTimestamp(busy.pool, 0);
    for (uint32_t i = 1; i < 4; ++i) {
        first.dispatch(kBusyElements / 64);
        first.barrier(Barrier::buf(busy.data, Access::ShaderRead | Access::ShaderWrite,
                                   Access::ShaderRead | Access::ShaderWrite));
        first.writeTimestamp(busy.pool, i);
    }
    dev().submit(first);

    const Access rw = Access::ShaderRead | Access::ShaderWrite;
    CommandList& second = dev().beginCommandList("timestamps 2");
    second.barrier(Barrier::buf(busy.data, rw, rw));
    second.bindPipeline(busy.pipeline);
    second.bindGroup(0, busy.group);
    second.pushConstants(&iterations, sizeof(iterations));
    second.dispatch(kBusyElements / 64);
    second.writeTimestamp(busy.pool, 4);
    second.barrier(Barrier::buf(busy.data, rw, rw));
    second.dispatch(kBusyElements / 64);
    second.writeTimestamp(busy.pool, 5);
    submitAndWait(second);

    uint64_t ns[kStamps] = {};
    ASSERT_TRUE(dev().readTimestamps(busy.pool, 0, kStamps, ns));
    for (uint32_t i = 1; i < kStamps; ++i) {
        // Metric: timestamp i >= timestamp i-1. Threshold: non-decreasing.
        EXPECT_GE(ns[i], ns[i - 1]) << "timestamp " << i;
    }
    // Metric: last - first > 0 and < 10 s (1e10 ns): time passed and the period is applied.
    EXPECT_GT(ns[kStamps - 1], ns[0]);
    EXPECT_LT(ns[kStamps - 1] - ns[0], 10'000'000'000ull);
    std::printf("[ %s ] timestamps: %.3f ms across 5 dispatches\n", toString(GetParam()),
                double(ns[kStamps - 1] - ns[0]) * 1e-6);
}

// Each dispatch's time lies between the timestamps written around it: after a render pass, three
// equal dispatches, one per interval, each interval holding a share of the whole. Mesa's CPU
// drivers take a timestamp where they next flush: without the backends' flush around each timestamp
// there, lavapipe charged every dispatch to the interval before it (the third read 2-4 %), and
// llvmpipe's OpenGL charged penumbra bench objects' sdf_ao to sdf_shadow (0 ms for sdf_ao).
TEST_P(ConformanceQueries, TimestampsBracketTheirDispatches) {
    ASSERT_TRUE(dev().info().limits.timestamps) << "timestamp queries are expected on both backends";
    constexpr uint32_t kDispatches = 3;
    const Busy busy = makeBusy(kDispatches + 1);
    ASSERT_TRUE(busy.valid());
    const uint32_t iterations = 256;
    const Access rw = Access::ShaderRead | Access::ShaderWrite;

    TextureHandle target = makeColorTarget(64, 64);
    ASSERT_TRUE(target.isValid());

    CommandList& cmd = dev().beginCommandList("timestamps around dispatches");
    // A render pass first (as a frame's G-buffer clear): llvmpipe then has a scene queued.
    cmd.barrier(Barrier::tex(target, Access::None, Access::ColorTarget));
    RenderPassDesc pass;
    ColorAttachment color;
    color.texture = target;
    color.load = LoadOp::Clear;
    color.store = StoreOp::Store;
    pass.colorAttachments = {color};
    cmd.beginRenderPass(pass);
    cmd.endRenderPass();
    cmd.resetQueries(busy.pool, 0, kDispatches + 1);
    cmd.fillBuffer(busy.data, 0, kBusyElements * 4, 1);
    cmd.barrier(Barrier::buf(busy.data, Access::CopyDst, rw));
    cmd.bindPipeline(busy.pipeline);
    cmd.bindGroup(0, busy.group);
    cmd.pushConstants(&iterations, sizeof(iterations));
    cmd.writeTimestamp(busy.pool, 0);
    for (uint32_t i = 1; i <= kDispatches; ++i) {
        cmd.dispatch(kBusyElements / 64);
        cmd.barrier(Barrier::buf(busy.data, rw, rw));
        cmd.writeTimestamp(busy.pool, i);
    }
    submitAndWait(cmd);

    uint64_t ns[kDispatches + 1] = {};
    ASSERT_TRUE(dev().readTimestamps(busy.pool, 0, kDispatches + 1, ns));
    const uint64_t total = ns[kDispatches] - ns[0];
    ASSERT_GT(total, 0u);
    for (uint32_t i = 1; i <= kDispatches; ++i) {
        // Metric: interval i's share of the three equal dispatches' total. Threshold: at least 5 %
        // (a third each on a quiet machine; 0 where the timestamps do not bracket the work).
        const double share = double(ns[i] - ns[i - 1]) / double(total);
        std::printf("[ %s ] dispatch %u: %.3f ms (%.0f %%)\n", toString(GetParam()), i,
                    double(ns[i] - ns[i - 1]) * 1e-6, share * 100.0);
        EXPECT_GE(share, 0.05) << "dispatch " << i;
    }
}

// imageAtomicAdd / imageAtomicMax on R32_UINT storage images, which both backends report as
// FormatSupport::StorageAtomic: 1024 invocations hit 16 texels 64 times each.
TEST_P(ConformanceCompute, ImageAtomicsOnR32ui) {
    // Metric: R32_UINT supports storage atomics. Threshold: flag set.
    ASSERT_TRUE(any(dev().formatSupport(Format::R32_UINT) & FormatSupport::StorageAtomic));
    const uint32_t kInvocations = 1024;
    const TextureUsage usage = TextureUsage::Storage | TextureUsage::CopyDst | TextureUsage::CopySrc;
    TextureHandle counts = makeTexture2D(Format::R32_UINT, 4, 4, usage);
    TextureHandle maxima = makeTexture2D(Format::R32_UINT, 4, 4, usage);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_image_atomics::compute());
    ASSERT_TRUE(counts.isValid() && maxima.isValid() && pipeline.isValid());
    const std::vector<uint32_t> zeros(16, 0);
    dev().writeTexture(counts, {}, zeros.data(), 64);
    dev().writeTexture(maxima, {}, zeros.data(), 64);
    BindGroupHandle group = makeBindGroup(
        pipeline, 0, {BindGroupEntry::makeStorage(0, counts), BindGroupEntry::makeStorage(1, maxima)});
    ASSERT_TRUE(group.isValid());
    const Access rw = Access::ShaderRead | Access::ShaderWrite;
    const uint32_t info[4] = {kInvocations, 0, 0, 0};
    CommandList& cmd = dev().beginCommandList("image atomics");
    const Barrier before[] = {Barrier::tex(counts, Access::ShaderSampled, rw),
                              Barrier::tex(maxima, Access::ShaderSampled, rw)};
    cmd.barrier(before);
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.pushConstants(info, sizeof(info));
    cmd.dispatch(kInvocations / 64);
    const Barrier after[] = {Barrier::tex(counts, rw, Access::CopySrc),
                             Barrier::tex(maxima, rw, Access::CopySrc)};
    cmd.barrier(after);
    submitAndWait(cmd);
    const std::vector<uint32_t> c = readTextureAs<uint32_t>(counts, {}, Access::CopySrc);
    const std::vector<uint32_t> m = readTextureAs<uint32_t>(maxima, {}, Access::CopySrc);
    ASSERT_EQ(c.size(), 16u);
    ASSERT_EQ(m.size(), 16u);
    for (uint32_t t = 0; t < 16; ++t) {
        // Metric: 64 atomic adds per texel; the maximum of the invocation ids that hit it. Threshold: exact.
        EXPECT_EQ(c[t], kInvocations / 16) << "texel " << t;
        EXPECT_EQ(m[t], kInvocations - 16 + t) << "texel " << t;
    }
}

// tryReadTimestamps never waits: false while a query has no result, the values once it has, and
// only readTimestamps counts as a blocking read in Device::stats().
TEST_P(ConformanceQueries, TryReadTimestampsDoesNotBlock) {
    constexpr uint32_t kElements = 16384;
    BufferHandle data = makeBuffer(kElements * 4, BufferUsage::Storage | BufferUsage::CopyDst);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_busy::compute());
    QueryPoolHandle pool = makeQueryPool(2);
    ASSERT_TRUE(data.isValid() && pipeline.isValid() && pool.isValid());
    BindGroupHandle group = makeBindGroup(pipeline, 0, {BindGroupEntry::makeBuffer(0, data)});
    ASSERT_TRUE(group.isValid());
    const uint64_t blockingBefore = dev().stats().blockingTimestampReads;

    CommandList& reset = dev().beginCommandList("reset only");
    reset.resetQueries(pool, 0, 2);
    submitAndWait(reset);
    uint64_t ns[2] = {7, 7};
    // Metric: reset but never written queries are not available; outNs untouched. Threshold: exact.
    EXPECT_FALSE(dev().tryReadTimestamps(pool, 0, 2, ns));
    EXPECT_EQ(ns[0], 7u);
    EXPECT_EQ(ns[1], 7u);

    const uint32_t iterations = 64;
    CommandList& cmd = dev().beginCommandList("timestamps");
    cmd.fillBuffer(data, 0, kElements * 4, 1);
    cmd.barrier(Barrier::buf(data, Access::CopyDst, Access::ShaderRead | Access::ShaderWrite));
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.pushConstants(&iterations, sizeof(iterations));
    cmd.writeTimestamp(pool, 0);
    cmd.dispatch(kElements / 64);
    cmd.writeTimestamp(pool, 1);
    const uint64_t serial = dev().submit(cmd);
    // Polling while the GPU runs must not block; once the submission completed, the results are there.
    int polls = 0;
    while (!dev().tryReadTimestamps(pool, 0, 2, ns) && polls < 1000000) {
        ++polls;
        if (polls == 1000) dev().waitForSubmission(serial);
    }
    // Metric: results became available. Threshold: within the poll budget.
    ASSERT_LT(polls, 1000000) << "timestamps never became available";
    // Metric: ordered timestamps. Threshold: non-decreasing.
    EXPECT_GE(ns[1], ns[0]);
    // Metric: no blocking reads counted so far. Threshold: exact.
    EXPECT_EQ(dev().stats().blockingTimestampReads, blockingBefore);

    uint64_t blocking[2] = {};
    ASSERT_TRUE(dev().readTimestamps(pool, 0, 2, blocking));
    // Metric: both reads give the same values; one blocking read counted. Threshold: exact.
    EXPECT_EQ(blocking[0], ns[0]);
    EXPECT_EQ(blocking[1], ns[1]);
    EXPECT_EQ(dev().stats().blockingTimestampReads, blockingBefore + 1);
}

INSTANTIATE_TEST_SUITE_P(Backends, ConformanceCompute, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);
INSTANTIATE_TEST_SUITE_P(Backends, ConformanceQueries, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
