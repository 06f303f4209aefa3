// The frame graph on the GPU backends under validation: a mip chain built by dependent compute
// passes that declare mip subresources (fill mip 0, then each pass samples mip i-1 through a
// one-level view and writes mip i) runs without a single hand-written barrier and without a
// validation error (the RHI wrapper and the Vulkan layers check every subresource's state), and
// every texel of every mip is the exact mean of its source block.
#include <cmath>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include <shaders/fg_mip_down.h>
#include <shaders/fg_mip_fill.h>

#include "renderer/core/gpu_cache.h"
#include "renderer/core/shader_params.h"
#include "renderer/frame_graph/frame_graph.h"
#include "support/test_device.h"

namespace {

using penumbra::fg::FrameGraph;
using penumbra::fg::PassBuilder;
using penumbra::fg::PassContext;
using penumbra::fg::PassKind;
using penumbra::fg::Subresource;
using penumbra::fg::TextureRef;
using penumbra::render::GpuCache;
using penumbra::render::ShaderParams;

class FrameGraphGpu : public penumbra::test::GpuTest {};

TEST_P(FrameGraphGpu, MipChainOfDependentPassesWithoutHandWrittenBarriers) {
    constexpr uint32_t kSize = 32, kMips = 6;
    rhi::TextureDesc d;
    d.format = rhi::Format::R32_FLOAT;
    d.width = d.height = kSize;
    d.mipLevels = kMips;
    d.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::Storage | rhi::TextureUsage::CopySrc;
    d.debugName = "chain";
    rhi::TextureHandle chainTexture = dev().createTexture(d);
    ASSERT_TRUE(chainTexture.isValid());
    GpuCache cache(dev());
    rhi::SamplerDesc nearest;
    nearest.minFilter = nearest.magFilter = rhi::Filter::Nearest;
    const rhi::SamplerHandle sampler = cache.sampler(nearest);

    FrameGraph graph(dev());
    struct Step {
        TextureRef chain;
    };
    const TextureRef chain =
        graph.importTexture("chain", chainTexture, rhi::Access::None, rhi::Access::CopySrc);
    graph.addPass<Step>(
        "fill", PassKind::Compute,
        [&](PassBuilder& b, Step& s) {
            s.chain = b.write(chain, rhi::Access::ShaderWrite, Subresource::mips(0));
        },
        [&](const Step& s, PassContext& ctx) {
            const rhi::ShaderDesc& cs = penumbra::shaders::fg_mip_fill::compute();
            const rhi::PipelineHandle pipeline = cache.computePipeline(cs);
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.setStorage("dst", ctx.texture(s.chain), 0);
            ASSERT_TRUE(params.bind(ctx.cmd, cache, pipeline)) << params.error();
            penumbra::render::dispatchOver(ctx.cmd, cs, kSize, kSize);
        });
    for (uint32_t mip = 1; mip < kMips; ++mip)
        graph.addPass<Step>(
            "down" + std::to_string(mip), PassKind::Compute,
            [&](PassBuilder& b, Step& s) {
                b.read(chain, rhi::Access::ShaderSampled, Subresource::mips(mip - 1));
                s.chain = b.write(chain, rhi::Access::ShaderWrite, Subresource::mips(mip));
            },
            [&, mip](const Step& s, PassContext& ctx) {
                const rhi::ShaderDesc& cs = penumbra::shaders::fg_mip_down::compute();
                const rhi::PipelineHandle pipeline = cache.computePipeline(cs);
                ctx.cmd.bindPipeline(pipeline);
                ShaderParams params(cs);
                params.set("src", ctx.texture(s.chain), sampler, mip - 1, 1)
                    .setStorage("dst", ctx.texture(s.chain), mip);
                ASSERT_TRUE(params.bind(ctx.cmd, cache, pipeline)) << params.error();
                penumbra::render::dispatchOver(ctx.cmd, cs, kSize >> mip, kSize >> mip);
            });
    ASSERT_TRUE(graph.compile());
    // Every step's barriers name only the two mips it touches.
    for (uint32_t mip = 1; mip < kMips; ++mip) {
        const auto* pass = graph.compiled().findPass("down" + std::to_string(mip));
        ASSERT_NE(pass, nullptr);
        ASSERT_EQ(pass->barriers.size(), 2u);
        EXPECT_EQ(pass->barriers[0].range.baseMip, mip - 1);
        EXPECT_EQ(pass->barriers[1].range.baseMip, mip);
    }
    rhi::CommandList& cmd = dev().beginCommandList("mip chain");
    graph.execute(cmd);
    dev().submit(cmd);

    for (uint32_t mip = 0; mip < kMips; ++mip) {
        std::vector<uint8_t> bytes;
        ASSERT_TRUE(dev().readTexture(chainTexture, {mip, 0}, rhi::Access::CopySrc, bytes)) << "mip " << mip;
        const uint32_t size = kSize >> mip, block = 1u << mip;
        ASSERT_EQ(bytes.size(), size_t(size) * size * 4) << "mip " << mip;
        std::vector<float> texels(size_t(size) * size);
        std::memcpy(texels.data(), bytes.data(), bytes.size());
        int wrong = 0;
        for (uint32_t y = 0; y < size; ++y)
            for (uint32_t x = 0; x < size; ++x) {
                // Mean of x' + kSize * y' over the block: exact in float (multiples of 0.5 below 2^10).
                const float expected = float(x * block) + 0.5f * float(block - 1) +
                                       float(kSize) * (float(y * block) + 0.5f * float(block - 1));
                if (texels[y * size + x] != expected && wrong++ < 3)
                    ADD_FAILURE() << "mip " << mip << " (" << x << ", " << y << "): " << texels[y * size + x]
                                  << " != " << expected;
            }
        EXPECT_EQ(wrong, 0) << "mip " << mip;
    }
    dev().waitIdle();
    dev().destroy(chainTexture);
}

INSTANTIATE_TEST_SUITE_P(Backends, FrameGraphGpu, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
