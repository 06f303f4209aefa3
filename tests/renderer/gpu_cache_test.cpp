// GpuCache and ShaderParams on both GPU backends under validation: pipelines and bind groups are
// created once and reused for identical content; bind groups nobody uses are released after the
// retain window; parameters are bound by reflected name, and naming mistakes are reported (never
// guessed around). The dispatch result is checked texel by texel.
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include <shaders/params_blur.h>

#include "renderer/core/blackboard.h"
#include "renderer/core/gpu_cache.h"
#include "renderer/core/shader_params.h"
#include "support/test_device.h"

namespace {

using penumbra::render::GpuCache;
using penumbra::render::ShaderParams;

class GpuCacheTest : public penumbra::test::GpuTest {
protected:
    rhi::TextureHandle texture(rhi::TextureUsage usage, const char* name) {
        rhi::TextureDesc d;
        d.format = rhi::Format::RGBA8_UNORM;
        d.width = 16;
        d.height = 8;
        d.usage = usage;
        d.debugName = name;
        return dev().createTexture(d);
    }
};

TEST_P(GpuCacheTest, CreatesOnceReusesAndBindsByName) {
    using TU = rhi::TextureUsage;
    const rhi::ShaderDesc& cs = penumbra::shaders::params_blur::compute();
    rhi::TextureHandle src = texture(TU::Sampled | TU::CopyDst, "src");
    rhi::TextureHandle dst = texture(TU::Storage | TU::CopySrc, "dst");
    std::vector<uint8_t> texels(16 * 8 * 4);
    for (size_t i = 0; i < texels.size(); ++i) texels[i] = uint8_t(i * 7);
    dev().writeTexture(src, {}, texels.data(), texels.size());
    rhi::BufferDesc bd;
    bd.size = 16;
    bd.usage = rhi::BufferUsage::Uniform | rhi::BufferUsage::CopyDst;
    const float scale[4] = {1.0f, 0.5f, 0.0f, 1.0f};
    rhi::BufferHandle ubo = dev().createBuffer(bd, scale);

    GpuCache cache(dev());
    const rhi::DeviceStats before = dev().stats();
    rhi::Access dstState = rhi::Access::None;
    for (int frame = 0; frame < 5; ++frame) {
        rhi::PipelineHandle pipeline = cache.computePipeline(cs);
        ASSERT_TRUE(pipeline.isValid());
        rhi::SamplerDesc sd;
        sd.minFilter = sd.magFilter = rhi::Filter::Nearest;
        rhi::SamplerHandle sampler = cache.sampler(sd);
        rhi::CommandList& cmd = dev().beginCommandList("frame");
        cmd.barrier(rhi::Barrier::tex(dst, dstState, rhi::Access::ShaderWrite));
        cmd.bindPipeline(pipeline);
        ShaderParams params(cs);
        params.set("BlurParams", ubo).set("src", src, sampler).setStorage("dst", dst);
        ASSERT_TRUE(params.bind(cmd, cache, pipeline)) << params.error();
        penumbra::render::dispatchOver(cmd, cs, 16, 8);
        cmd.barrier(rhi::Barrier::tex(dst, rhi::Access::ShaderWrite, rhi::Access::CopySrc));
        dstState = rhi::Access::CopySrc;
        dev().submit(cmd);
        cache.endFrame();
        // Frame 0 creates one pipeline and two bind groups (sets 0 and 1); later frames nothing.
        const rhi::DeviceStats now = dev().stats();
        EXPECT_EQ(now.pipelinesCreated - before.pipelinesCreated, 1u) << "frame " << frame;
        EXPECT_EQ(now.bindGroupsCreated - before.bindGroupsCreated, 2u) << "frame " << frame;
    }
    EXPECT_EQ(cache.bindGroupCount(), 2u);
    std::vector<uint8_t> out;
    ASSERT_TRUE(dev().readTexture(dst, {}, rhi::Access::CopySrc, out));
    ASSERT_EQ(out.size(), texels.size());
    for (size_t i = 0; i < texels.size(); i += 4) {
        EXPECT_EQ(out[i], texels[i]) << i;
        EXPECT_NEAR(out[i + 1], texels[i + 1] * 0.5, 1.0) << i;
        EXPECT_EQ(out[i + 2], 0) << i;
        EXPECT_EQ(out[i + 3], texels[i + 3]) << i;
    }

    // Unused groups go after the retain window; the pipeline stays.
    for (uint32_t f = 0; f < cache.bindGroupRetainFrames(); ++f) cache.endFrame();
    EXPECT_EQ(cache.bindGroupCount(), 0u);
    EXPECT_EQ(cache.pipelineCount(), 1u);
    dev().waitIdle();
    dev().destroy(src);
    dev().destroy(dst);
    dev().destroy(ubo);
}

TEST_P(GpuCacheTest, NamingMistakesAreReported) {
    const rhi::ShaderDesc& cs = penumbra::shaders::params_blur::compute();
    GpuCache cache(dev());
    rhi::PipelineHandle pipeline = cache.computePipeline(cs);
    ASSERT_TRUE(pipeline.isValid());
    rhi::TextureHandle tex = texture(rhi::TextureUsage::Sampled | rhi::TextureUsage::Storage, "t");
    rhi::BufferDesc bd;
    bd.size = 16;
    bd.usage = rhi::BufferUsage::Uniform;
    rhi::BufferHandle ubo = dev().createBuffer(bd);
    rhi::SamplerHandle sampler = cache.sampler({});
    rhi::CommandList& cmd = dev().beginCommandList("mistakes");
    cmd.bindPipeline(pipeline);

    ShaderParams unknown(cs);
    unknown.set("BlurParams", ubo).set("source", tex, sampler).setStorage("dst", tex);
    EXPECT_FALSE(unknown.bind(cmd, cache, pipeline));
    EXPECT_NE(unknown.error().find("no parameter named 'source'"), std::string::npos) << unknown.error();

    ShaderParams wrongKind(cs);
    wrongKind.set("BlurParams", ubo).set("dst", tex, sampler);
    EXPECT_FALSE(wrongKind.bind(cmd, cache, pipeline));
    EXPECT_NE(wrongKind.error().find("'dst' is not a sampled texture"), std::string::npos)
        << wrongKind.error();

    ShaderParams unset(cs);
    unset.set("BlurParams", ubo).set("src", tex, sampler);
    EXPECT_FALSE(unset.bind(cmd, cache, pipeline));
    EXPECT_EQ(cache.bindGroupCount(), 0u);  // nothing was created for a failed bind
    dev().submit(cmd);
    dev().waitIdle();
    dev().destroy(tex);
    dev().destroy(ubo);
}

INSTANTIATE_TEST_SUITE_P(Backends, GpuCacheTest, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

TEST(Blackboard, PublishesAndFindsByType) {
    struct GBuffer {
        int depth = 0;
    };
    struct Lit {
        float exposure = 1.0f;
    };
    penumbra::render::Blackboard bb;
    EXPECT_EQ(bb.find<GBuffer>(), nullptr);
    bb.add<GBuffer>({3});
    bb.add<Lit>({2.0f});
    ASSERT_NE(bb.find<GBuffer>(), nullptr);
    EXPECT_EQ(bb.find<GBuffer>()->depth, 3);
    bb.add<GBuffer>({4});  // replaces
    EXPECT_EQ(bb.find<GBuffer>()->depth, 4);
    EXPECT_FLOAT_EQ(bb.find<Lit>()->exposure, 2.0f);
    bb.clear();
    EXPECT_FALSE(bb.has<Lit>());
}

}  // namespace
