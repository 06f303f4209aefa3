// RHI conformance: subresources. Barriers on a mip range (a mip chain written one level at a time
// with barriers on single mips).
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include <shaders/conf_mip_chain.h>

#include "conformance_common.h"

namespace {

using namespace rhi;
using penumbra::conformance::ConformanceTest;
using penumbra::conformance::Rng;

class ConformanceSubresource : public ConformanceTest {};

// CPU reference of conf_mip_chain: each texel of the next level is the sum of its 2x2 source texels.
std::vector<uint32_t> downsample(const std::vector<uint32_t>& src, uint32_t srcSize) {
    const uint32_t n = srcSize / 2;
    std::vector<uint32_t> out(size_t(n) * n);
    for (uint32_t y = 0; y < n; ++y)
        for (uint32_t x = 0; x < n; ++x)
            out[y * n + x] = src[(2 * y) * srcSize + 2 * x] + src[(2 * y) * srcSize + 2 * x + 1] +
                             src[(2 * y + 1) * srcSize + 2 * x] + src[(2 * y + 1) * srcSize + 2 * x + 1];
    return out;
}

// A mip chain in one command list: mip N is read while mip N + 1 is written, with barriers that name
// one mip each (TextureRange). Fails if a barrier on one mip changes the state of another (the
// validation wrapper then reports the write of mip 2, and Vulkan would see wrong layouts).
TEST_P(ConformanceSubresource, MipChainWithPerMipBarriers) {
    const uint32_t kSize = 16, kMips = 3;
    TextureHandle chain =
        makeTexture2D(Format::R32_UINT, kSize, kSize,
                      TextureUsage::Storage | TextureUsage::CopyDst | TextureUsage::CopySrc, kMips);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_mip_chain::compute());
    ASSERT_TRUE(chain.isValid() && pipeline.isValid());
    std::vector<uint32_t> level0(kSize * kSize);
    Rng rng(4242);
    for (auto& v : level0) v = rng.next() >> 8;
    dev().writeTexture(chain, {0, 0}, level0.data(), level0.size() * 4);  // every mip: ShaderSampled
    BindGroupHandle step0 = makeBindGroup(
        pipeline, 0, {BindGroupEntry::makeStorage(0, chain, 0), BindGroupEntry::makeStorage(1, chain, 1)});
    BindGroupHandle step1 = makeBindGroup(
        pipeline, 0, {BindGroupEntry::makeStorage(0, chain, 1), BindGroupEntry::makeStorage(1, chain, 2)});
    ASSERT_TRUE(step0.isValid() && step1.isValid());

    CommandList& cmd = dev().beginCommandList("mip chain");
    const Barrier start[] = {
        Barrier::tex(chain, Access::ShaderSampled, Access::ShaderRead, TextureRange{0, 1}),
        Barrier::tex(chain, Access::ShaderSampled, Access::ShaderWrite, TextureRange{1, kRemaining})};
    cmd.barrier(start);
    cmd.bindPipeline(pipeline);
    for (uint32_t step = 0; step < 2; ++step) {
        const uint32_t dstSize = kSize >> (step + 1);
        const uint32_t size[4] = {dstSize, dstSize, 0, 0};
        if (step == 1)  // mip 1 was written; it becomes the source. Mip 2 stays in ShaderWrite.
            cmd.barrier(Barrier::tex(chain, Access::ShaderWrite, Access::ShaderRead, TextureRange{1, 1}));
        cmd.bindGroup(0, step == 0 ? step0 : step1);
        cmd.pushConstants(size, sizeof(size));
        cmd.dispatch(1, 1);
    }
    const Barrier end[] = {Barrier::tex(chain, Access::ShaderRead, Access::CopySrc, TextureRange{0, 2}),
                           Barrier::tex(chain, Access::ShaderWrite, Access::CopySrc, TextureRange{2, 1})};
    cmd.barrier(end);
    submitAndWait(cmd);

    const std::vector<uint32_t> level1 = downsample(level0, kSize);
    const std::vector<uint32_t> level2 = downsample(level1, kSize / 2);
    // Metric: mips 0, 1 and 2 read back equal the upload and the CPU sums. Threshold: exact.
    EXPECT_EQ(readTextureAs<uint32_t>(chain, {0, 0}, Access::CopySrc), level0);
    EXPECT_EQ(readTextureAs<uint32_t>(chain, {1, 0}, Access::CopySrc), level1);
    EXPECT_EQ(readTextureAs<uint32_t>(chain, {2, 0}, Access::CopySrc), level2);
}

INSTANTIATE_TEST_SUITE_P(Backends, ConformanceSubresource, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
