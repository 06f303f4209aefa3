// RHI conformance: object lifetime — destroying objects that in-flight work still uses is safe
// (deferred destruction), and stale or forged handles are rejected by validation with exactly one
// error per misuse, without crashing.
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include <shaders/conf_copy_buffer.h>
#include <shaders/conf_in_flight.h>

#include "conformance_common.h"

namespace {

using namespace rhi;
using penumbra::conformance::ConformanceTest;
using penumbra::conformance::Rng;

class ConformanceLifetime : public ConformanceTest {};

// Work that reads buffer A, samples texture T through sampler S, uses bind group G and pipeline P
// (from shader H) to write B is submitted; A, T, S, G, P and H are destroyed right after submit(),
// before any wait. The result in B must still be correct and the handles must be dead at once.
TEST_P(ConformanceLifetime, DestroyWhileInFlightIsSafe) {
    constexpr uint32_t kCount = 16384;
    constexpr uint32_t kTex = 16;
    std::vector<uint32_t> a(kCount);
    Rng rng(0xD1E5u);
    for (auto& v : a) v = rng.next() >> 3;
    std::vector<float> texels(kTex * kTex);
    for (uint32_t i = 0; i < kTex * kTex; ++i) texels[i] = float((i * 7) % 256);

    // Created directly (not tracked by the fixture): this test destroys them itself.
    BufferDesc aDesc;
    aDesc.size = kCount * 4;
    aDesc.usage = BufferUsage::Storage | BufferUsage::CopyDst;
    aDesc.debugName = "in-flight A";
    BufferHandle bufA = dev().createBuffer(aDesc, a.data());
    TextureDesc tDesc;
    tDesc.format = Format::R32_FLOAT;
    tDesc.width = tDesc.height = kTex;
    tDesc.usage = TextureUsage::Sampled | TextureUsage::CopyDst;
    tDesc.debugName = "in-flight T";
    TextureHandle texT = dev().createTexture(tDesc);
    SamplerDesc sDesc;
    sDesc.minFilter = sDesc.magFilter = Filter::Nearest;
    SamplerHandle samplerS = dev().createSampler(sDesc);
    ShaderHandle shaderH = dev().createShader(penumbra::shaders::conf_in_flight::compute());
    ComputePipelineDesc pDesc;
    pDesc.shader = shaderH;
    PipelineHandle pipelineP = dev().createComputePipeline(pDesc);
    BufferHandle bufB = makeBuffer(kCount * 4, BufferUsage::Storage | BufferUsage::CopySrc);
    ASSERT_TRUE(bufA.isValid() && texT.isValid() && samplerS.isValid() && shaderH.isValid() &&
                pipelineP.isValid() && bufB.isValid());
    dev().writeTexture(texT, {}, texels.data(), texels.size() * 4);
    BindGroupDesc gDesc;
    gDesc.pipeline = pipelineP;
    gDesc.set = 0;
    gDesc.entries = {BindGroupEntry::makeBuffer(0, bufA), BindGroupEntry::makeSampled(1, texT, samplerS),
                     BindGroupEntry::makeBuffer(2, bufB)};
    BindGroupHandle groupG = dev().createBindGroup(gDesc);
    ASSERT_TRUE(groupG.isValid());

    CommandList& cmd = dev().beginCommandList("in flight");
    cmd.bindPipeline(pipelineP);
    cmd.bindGroup(0, groupG);
    cmd.dispatch(kCount / 64);
    cmd.barrier(Barrier::buf(bufB, Access::ShaderWrite, Access::HostRead));
    dev().submit(cmd);

    dev().destroy(groupG);
    dev().destroy(pipelineP);
    dev().destroy(shaderH);
    dev().destroy(bufA);
    dev().destroy(texT);
    dev().destroy(samplerS);
    // Metric: destroyed handles are dead immediately. Threshold: isAlive false for all six.
    EXPECT_FALSE(dev().isAlive(groupG));
    EXPECT_FALSE(dev().isAlive(pipelineP));
    EXPECT_FALSE(dev().isAlive(shaderH));
    EXPECT_FALSE(dev().isAlive(bufA));
    EXPECT_FALSE(dev().isAlive(texT));
    EXPECT_FALSE(dev().isAlive(samplerS));
    EXPECT_EQ(dev().describe(bufA), nullptr);
    EXPECT_EQ(dev().describe(texT), nullptr);

    // Garbage collection and a later submission must not release what the first one still uses.
    dev().collectGarbage();
    BufferHandle other = makeBuffer(256, BufferUsage::Storage | BufferUsage::CopyDst | BufferUsage::CopySrc);
    ASSERT_TRUE(other.isValid());
    CommandList& next = dev().beginCommandList("after destroy");
    next.fillBuffer(other, 0, 256, 0x5A5A5A5Au);
    next.barrier(Barrier::buf(other, Access::CopyDst, Access::HostRead));
    dev().submit(next);
    dev().collectGarbage();

    dev().waitIdle();
    const std::vector<uint32_t> result = readBuffer<uint32_t>(bufB, kCount);
    ASSERT_EQ(result.size(), kCount);
    for (uint32_t i = 0; i < kCount; ++i) {
        const uint32_t texel = uint32_t(texels[i % (kTex * kTex)]);
        // Metric: B[i] = A[i] * 3 + texel(i). Threshold: exact.
        ASSERT_EQ(result[i], a[i] * 3u + texel) << "element " << i;
    }
    // Metric: the second submission ran as well. Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(other, 64), std::vector<uint32_t>(64, 0x5A5A5A5Au));
    // Metric: no validation error was reported by any of the above. Threshold: 0 errors.
    consumeExpectedErrors(0);
}

// Using a destroyed buffer handle: every misuse is rejected with exactly one validation error, valid
// work around it still happens, and nothing crashes.
TEST_P(ConformanceLifetime, StaleHandleRejectedByValidation) {
    const BufferUsage usage =
        BufferUsage::Vertex | BufferUsage::Storage | BufferUsage::CopySrc | BufferUsage::CopyDst;
    BufferDesc desc;
    desc.size = 256;
    desc.usage = usage;
    desc.debugName = "doomed";
    BufferHandle doomed = dev().createBuffer(desc);
    BufferHandle dst = makeBuffer(256, usage);
    TextureHandle doomedTexture = dev().createTexture([] {
        TextureDesc t;
        t.width = t.height = 4;
        t.usage = TextureUsage::Sampled | TextureUsage::CopyDst | TextureUsage::CopySrc;
        return t;
    }());
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_copy_buffer::compute());
    ASSERT_TRUE(doomed.isValid() && dst.isValid() && doomedTexture.isValid() && pipeline.isValid());
    dev().destroy(doomed);
    dev().destroy(doomedTexture);

    // Queries on a stale handle are not misuse.
    EXPECT_FALSE(dev().isAlive(doomed));
    EXPECT_EQ(dev().describe(doomed), nullptr);
    EXPECT_FALSE(dev().isAlive(doomedTexture));
    // Metric: queries report no error. Threshold: 0 errors.
    consumeExpectedErrors(0);

    BindGroupDesc groupDesc;
    groupDesc.pipeline = pipeline;
    groupDesc.entries = {BindGroupEntry::makeBuffer(0, doomed), BindGroupEntry::makeBuffer(1, dst)};
    const BindGroupHandle group = dev().createBindGroup(groupDesc);
    // Metric: createBindGroup with a stale buffer returns an invalid handle. Threshold: exactly 1 error.
    EXPECT_FALSE(group.isValid());
    consumeExpectedErrors(1);

    std::vector<uint8_t> bytes(16, 0xAB);
    // Metric: readBuffer of a stale buffer fails. Threshold: exactly 1 error.
    EXPECT_FALSE(dev().readBuffer(doomed, 0, 16, bytes.data()));
    consumeExpectedErrors(1);

    dev().writeBuffer(doomed, 0, bytes.data(), 16);
    // Metric: writeBuffer to a stale buffer is dropped. Threshold: exactly 1 error.
    consumeExpectedErrors(1);

    std::vector<uint8_t> texels;
    // Metric: readTexture of a stale texture fails. Threshold: exactly 1 error.
    EXPECT_FALSE(dev().readTexture(doomedTexture, {}, Access::ShaderSampled, texels));
    consumeExpectedErrors(1);

    CommandList& cmd = dev().beginCommandList("stale commands");
    cmd.fillBuffer(dst, 0, 256, 7u);
    cmd.barrier(Barrier::buf(dst, Access::CopyDst, Access::CopyDst));
    cmd.bindVertexBuffer(0, doomed);        // dropped
    cmd.copyBuffer(doomed, 0, dst, 0, 64);  // dropped
    cmd.barrier(Barrier::buf(dst, Access::CopyDst, Access::HostRead));
    submitAndWait(cmd);
    // Metric: bindVertexBuffer and copyBuffer with the stale buffer are dropped. Threshold: exactly 2 errors.
    consumeExpectedErrors(2);
    // Metric: the valid fill in the same list ran and the dropped copy did not overwrite it. Threshold:
    // exact.
    EXPECT_EQ(readBuffer<uint32_t>(dst, 64), std::vector<uint32_t>(64, 7u));

    dev().destroy(doomed);
    // Metric: destroying an already destroyed handle is reported. Threshold: exactly 1 error.
    consumeExpectedErrors(1);
}

// After a slot is reused, the old handle (older generation) and a forged handle (generation never
// issued) are rejected while the new object with the bumped generation works.
TEST_P(ConformanceLifetime, ReusedSlotRejectsOldGeneration) {
    const BufferUsage usage = BufferUsage::Storage | BufferUsage::CopySrc | BufferUsage::CopyDst;
    const std::vector<uint32_t> oldData(16, 0x01010101u);
    BufferDesc desc;
    desc.size = 64;
    desc.usage = usage;
    BufferHandle old = dev().createBuffer(desc, oldData.data());
    ASSERT_TRUE(old.isValid());
    dev().destroy(old);
    dev().waitIdle();  // every deferred release is done: the slot is free for reuse

    BufferHandle reused;
    std::vector<uint32_t> newData;
    for (uint32_t attempt = 0; attempt < 32 && !reused.isValid(); ++attempt) {
        std::vector<uint32_t> data(16, 0x02000000u + attempt);
        BufferHandle h = makeBuffer(64, usage, MemoryType::GpuOnly, data.data());
        ASSERT_TRUE(h.isValid());
        if (h.index() == old.index()) {
            reused = h;
            newData = data;
        }
    }
    // Metric: a freed slot is reused within 32 creations. Threshold: found.
    ASSERT_TRUE(reused.isValid()) << "slot " << old.index() << " was never reused";
    // Metric: the reused slot carries a different generation. Threshold: generations differ.
    EXPECT_NE(reused.generation(), old.generation());
    EXPECT_NE(reused, old);
    EXPECT_FALSE(dev().isAlive(old));
    EXPECT_TRUE(dev().isAlive(reused));
    consumeExpectedErrors(0);

    std::vector<uint32_t> out(16, 0);
    // Metric: the old generation is rejected. Threshold: readBuffer false, exactly 1 error.
    EXPECT_FALSE(dev().readBuffer(old, 0, 64, out.data()));
    consumeExpectedErrors(1);
    // Metric: the new object works. Threshold: exact data, 0 errors.
    EXPECT_EQ(readBuffer<uint32_t>(reused, 16), newData);
    consumeExpectedErrors(0);

    const BufferHandle forged = BufferHandle::make(reused.index(), uint16_t(reused.generation() + 5));
    EXPECT_FALSE(dev().isAlive(forged));
    // Metric: a generation never issued is rejected. Threshold: readBuffer false, exactly 1 error.
    EXPECT_FALSE(dev().readBuffer(forged, 0, 64, out.data()));
    consumeExpectedErrors(1);

    const BufferHandle outOfRange = BufferHandle::make(0xfff0, 1);
    EXPECT_FALSE(dev().isAlive(outOfRange));
    // Metric: an index never allocated is rejected. Threshold: readBuffer false, exactly 1 error.
    EXPECT_FALSE(dev().readBuffer(outOfRange, 0, 64, out.data()));
    consumeExpectedErrors(1);

    // Metric: the default (invalid) handle is rejected. Threshold: readBuffer false, exactly 1 error.
    EXPECT_FALSE(dev().readBuffer(BufferHandle{}, 0, 64, out.data()));
    consumeExpectedErrors(1);

    // Metric: the reused object still reads back after all the rejected calls. Threshold: exact.
    EXPECT_EQ(readBuffer<uint32_t>(reused, 16), newData);
}

INSTANTIATE_TEST_SUITE_P(Backends, ConformanceLifetime, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
