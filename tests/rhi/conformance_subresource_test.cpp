// RHI conformance: subresources. Barriers on a mip range (a mip chain written one level at a time
// with barriers on single mips), region writes to 2D / array / 3D textures, texture-to-texture and
// buffer-to-texture copies with regions, mip- and layer-range views in bind groups.
#include <algorithm>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include <shaders/conf_layer_view.h>
#include <shaders/conf_mip_chain.h>
#include <shaders/conf_mip_view.h>

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

// CPU model of one subresource of 32-bit texels (x fastest, then y, then z).
struct Box3 {
    uint32_t w, h, d;
    std::vector<uint32_t> texels;
    Box3(uint32_t w_, uint32_t h_, uint32_t d_, uint32_t seed)
        : w(w_), h(h_), d(d_), texels(size_t(w_) * h_ * d_) {
        Rng rng(seed);
        for (auto& v : texels) v = rng.next();
    }
    uint32_t& at(uint32_t x, uint32_t y, uint32_t z) { return texels[(size_t(z) * h + y) * w + x]; }
    // Writes `packed` (region-sized, tightly packed) at the region's offset.
    void write(const TextureRegion& r, const std::vector<uint32_t>& packed) {
        for (uint32_t z = 0; z < r.depth; ++z)
            for (uint32_t y = 0; y < r.height; ++y)
                for (uint32_t x = 0; x < r.width; ++x)
                    at(r.x + x, r.y + y, r.z + z) = packed[(size_t(z) * r.height + y) * r.width + x];
    }
    std::vector<uint32_t> read(const TextureRegion& r) {
        std::vector<uint32_t> out;
        for (uint32_t z = 0; z < r.depth; ++z)
            for (uint32_t y = 0; y < r.height; ++y)
                for (uint32_t x = 0; x < r.width; ++x) out.push_back(at(r.x + x, r.y + y, r.z + z));
        return out;
    }
};

std::vector<uint32_t> randomWords(size_t n, uint32_t seed) {
    std::vector<uint32_t> v(n);
    Rng rng(seed);
    for (auto& x : v) x = rng.next();
    return v;
}

TextureDesc wordTexture(TextureDimension dim, uint32_t w, uint32_t h, uint32_t depthOrLayers, uint32_t mips) {
    TextureDesc d;
    d.dimension = dim;
    d.format = Format::R32_UINT;
    d.width = w;
    d.height = h;
    d.depthOrLayers = depthOrLayers;
    d.mipLevels = mips;
    d.usage = TextureUsage::Sampled | TextureUsage::CopyDst | TextureUsage::CopySrc;
    d.debugName = "conf region texture";
    return d;
}

// writeTextureRegion changes exactly the texels of the box (2D mip 0 and 1, one array layer, a 3D
// sub-volume of mip 0 and 1, zero extents reaching the end of the mip) and keeps the others.
TEST_P(ConformanceSubresource, RegionWrites2DArrayAnd3D) {
    struct Case {
        TextureDimension dim;
        uint32_t w, h, d;
        std::vector<TextureRegion> regions;
    };
    const Case cases[] = {
        {TextureDimension::Tex2D, 16, 8, 1, {{0, 0, 3, 2, 0, 5, 4, 1}, {1, 0, 1, 1, 0, 0, 2, 0}}},
        {TextureDimension::Tex2DArray, 8, 8, 3, {{0, 2, 2, 3, 0, 4, 4, 1}, {0, 0, 7, 7, 0, 1, 1, 1}}},
        {TextureDimension::Tex3D, 8, 8, 8, {{0, 0, 2, 1, 3, 3, 4, 2}, {1, 0, 0, 1, 1, 0, 2, 0}}},
    };
    uint32_t seed = 1;
    for (const Case& c : cases) {
        const uint32_t mips = 2, layers = c.dim == TextureDimension::Tex2DArray ? c.d : 1;
        TextureHandle t = makeTexture(wordTexture(c.dim, c.w, c.h, c.d, mips));
        ASSERT_TRUE(t.isValid());
        std::vector<Box3> model;  // [mip * layers + layer]
        for (uint32_t m = 0; m < mips; ++m)
            for (uint32_t l = 0; l < layers; ++l) {
                const uint32_t depth = c.dim == TextureDimension::Tex3D ? std::max(1u, c.d >> m) : 1;
                model.emplace_back(std::max(1u, c.w >> m), std::max(1u, c.h >> m), depth, ++seed);
                dev().writeTexture(t, {m, l}, model.back().texels.data(), model.back().texels.size() * 4);
            }
        for (TextureRegion r : c.regions) {
            Box3& sub = model[r.mip * layers + r.layer];
            const TextureRegion asked = r;
            if (!r.width) r.width = sub.w - r.x;
            if (!r.height) r.height = sub.h - r.y;
            if (!r.depth) r.depth = sub.d - r.z;
            const std::vector<uint32_t> packed = randomWords(size_t(r.width) * r.height * r.depth, ++seed);
            dev().writeTextureRegion(t, asked, packed.data(), packed.size() * 4);
            sub.write(r, packed);
        }
        for (uint32_t m = 0; m < mips; ++m)
            for (uint32_t l = 0; l < layers; ++l) {
                // Metric: every texel of every subresource equals the CPU model. Threshold: exact.
                EXPECT_EQ(readTextureAs<uint32_t>(t, {m, l}, Access::ShaderSampled),
                          model[m * layers + l].texels)
                    << "dimension " << int(c.dim) << " mip " << m << " layer " << l;
            }
    }
}

// copyTexture between two textures (2D -> array layer), between two mips of one texture (mip 0
// in CopySrc, mip 1 in CopyDst at once) and copyBufferToTexture into a 3D box at a buffer offset.
TEST_P(ConformanceSubresource, TextureAndBufferCopiesWithRegions) {
    TextureHandle src = makeTexture(wordTexture(TextureDimension::Tex2D, 16, 16, 1, 2));
    TextureHandle arr = makeTexture(wordTexture(TextureDimension::Tex2DArray, 8, 8, 3, 1));
    TextureHandle vol = makeTexture(wordTexture(TextureDimension::Tex3D, 8, 4, 4, 1));
    ASSERT_TRUE(src.isValid() && arr.isValid() && vol.isValid());
    Box3 src0(16, 16, 1, 11), src1(8, 8, 1, 12), layer1(8, 8, 1, 13), volume(8, 4, 4, 14);
    dev().writeTexture(src, {0, 0}, src0.texels.data(), src0.texels.size() * 4);
    dev().writeTexture(src, {1, 0}, src1.texels.data(), src1.texels.size() * 4);
    for (uint32_t l = 0; l < 3; ++l) {
        Box3 other(8, 8, 1, 20 + l);
        dev().writeTexture(arr, {0, l}, l == 1 ? layer1.texels.data() : other.texels.data(), 8 * 8 * 4);
    }
    dev().writeTexture(vol, {}, volume.texels.data(), volume.texels.size() * 4);
    const uint64_t kOffset = 16;
    const TextureRegion volBox{0, 0, 5, 1, 1, 3, 2, 3};
    const std::vector<uint32_t> words = randomWords(kOffset / 4 + 3 * 2 * 3, 15);
    BufferHandle staging = makeBufferFrom(words, BufferUsage::CopySrc);
    ASSERT_TRUE(staging.isValid());

    CommandList& cmd = dev().beginCommandList("region copies");
    const Barrier before[] = {
        Barrier::tex(src, Access::ShaderSampled, Access::CopySrc, TextureRange{0, 1}),
        Barrier::tex(src, Access::ShaderSampled, Access::CopyDst, TextureRange{1, 1}),
        Barrier::tex(arr, Access::ShaderSampled, Access::CopyDst, TextureRange{0, 1, 1, 1}),
        Barrier::tex(vol, Access::ShaderSampled, Access::CopyDst)};
    cmd.barrier(before);
    const TextureRegion fromSrc{0, 0, 4, 4, 0, 6, 5, 1}, toLayer{0, 1, 1, 2, 0, 0, 0, 0};
    cmd.copyTexture(src, fromSrc, arr, toLayer);
    const TextureRegion mip0Box{0, 0, 8, 8, 0, 8, 8, 1}, mip1At{1, 0, 0, 0, 0, 0, 0, 0};
    cmd.copyTexture(src, mip0Box, src, mip1At);
    cmd.copyBufferToTexture(staging, kOffset, vol, volBox);
    const Barrier after[] = {
        Barrier::tex(src, Access::CopyDst, Access::CopySrc, TextureRange{1, 1}),
        Barrier::tex(arr, Access::CopyDst, Access::ShaderSampled, TextureRange{0, 1, 1, 1}),
        Barrier::tex(vol, Access::CopyDst, Access::CopySrc)};
    cmd.barrier(after);
    submitAndWait(cmd);

    layer1.write({0, 1, 1, 2, 0, 6, 5, 1}, src0.read(fromSrc));
    src1.write({1, 0, 0, 0, 0, 8, 8, 1}, src0.read(mip0Box));
    volume.write(volBox, std::vector<uint32_t>(words.begin() + kOffset / 4, words.end()));
    // Metric: the copied boxes equal their sources and every other texel kept its value. Threshold: exact.
    EXPECT_EQ(readTextureAs<uint32_t>(arr, {0, 1}, Access::ShaderSampled), layer1.texels);
    EXPECT_EQ(readTextureAs<uint32_t>(src, {1, 0}, Access::CopySrc), src1.texels);
    EXPECT_EQ(readTextureAs<uint32_t>(src, {0, 0}, Access::CopySrc), src0.texels);
    EXPECT_EQ(readTextureAs<uint32_t>(vol, {}, Access::CopySrc), volume.texels);
}

// A mip chain through sampled views of one mip (BindGroupEntry::makeSampledMips): mip N is sampled
// (in ShaderSampled) while mip N + 1 is written (in ShaderWrite). The shader checks that the view's
// level 0 is mip N and that it has one level.
TEST_P(ConformanceSubresource, SampledMipViewsBuildAMipChain) {
    const uint32_t kSize = 16, kMips = 3;
    TextureHandle chain = makeTexture2D(
        Format::R32_FLOAT, kSize, kSize,
        TextureUsage::Sampled | TextureUsage::Storage | TextureUsage::CopyDst | TextureUsage::CopySrc, kMips);
    SamplerHandle sampler = makeSampler(Filter::Nearest, AddressMode::ClampToEdge);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_mip_view::compute());
    ASSERT_TRUE(chain.isValid() && sampler.isValid() && pipeline.isValid());
    std::vector<float> level0(kSize * kSize);
    Rng rng(99);
    for (auto& v : level0) v = float(rng.next() % 1000);  // small integers: the sums are exact
    dev().writeTexture(chain, {0, 0}, level0.data(), level0.size() * 4);  // every mip: ShaderSampled
    BindGroupHandle steps[2];
    for (uint32_t n = 0; n < 2; ++n) {
        steps[n] = makeBindGroup(pipeline, 0,
                                 {BindGroupEntry::makeSampledMips(0, chain, sampler, n, 1),
                                  BindGroupEntry::makeStorage(1, chain, n + 1)});
        ASSERT_TRUE(steps[n].isValid());
    }
    CommandList& cmd = dev().beginCommandList("sampled mip chain");
    cmd.barrier(Barrier::tex(chain, Access::ShaderSampled, Access::ShaderWrite, TextureRange{1, kRemaining}));
    cmd.bindPipeline(pipeline);
    for (uint32_t n = 0; n < 2; ++n) {
        if (n == 1)
            cmd.barrier(Barrier::tex(chain, Access::ShaderWrite, Access::ShaderSampled, TextureRange{1, 1}));
        const uint32_t dstSize = kSize >> (n + 1);
        const uint32_t size[4] = {dstSize, dstSize, 0, 0};
        cmd.bindGroup(0, steps[n]);
        cmd.pushConstants(size, sizeof(size));
        cmd.dispatch(1, 1);
    }
    const Barrier end[] = {Barrier::tex(chain, Access::ShaderSampled, Access::CopySrc, TextureRange{0, 2}),
                           Barrier::tex(chain, Access::ShaderWrite, Access::CopySrc, TextureRange{2, 1})};
    cmd.barrier(end);
    submitAndWait(cmd);

    std::vector<float> expected = level0;
    for (uint32_t n = 0; n < 2; ++n) {
        const uint32_t src = kSize >> n, dst = src / 2;
        std::vector<float> next(size_t(dst) * dst);
        for (uint32_t y = 0; y < dst; ++y)
            for (uint32_t x = 0; x < dst; ++x)
                next[y * dst + x] = expected[2 * y * src + 2 * x] + expected[2 * y * src + 2 * x + 1] +
                                    expected[(2 * y + 1) * src + 2 * x] +
                                    expected[(2 * y + 1) * src + 2 * x + 1];
        expected = next;
        // Metric: mip n + 1 equals the CPU sums (-1 / -2 flag a view with the wrong base or level
        // count). Threshold: exact (integer-valued floats).
        EXPECT_EQ(readTextureAs<float>(chain, {n + 1, 0}, Access::CopySrc), expected) << "mip " << n + 1;
    }
}

// A storage entry with a layer range (layers [1, 2) of an array) writes array layer 1 through the
// view's layer 0; layers 0 and 2 keep their contents.
TEST_P(ConformanceSubresource, StorageLayerRangeView) {
    TextureDesc desc = wordTexture(TextureDimension::Tex2DArray, 8, 8, 3, 1);
    desc.usage = TextureUsage::Storage | TextureUsage::CopyDst | TextureUsage::CopySrc;
    TextureHandle arr = makeTexture(desc);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_layer_view::compute());
    ASSERT_TRUE(arr.isValid() && pipeline.isValid());
    std::vector<Box3> layers;
    for (uint32_t l = 0; l < 3; ++l) {
        layers.emplace_back(8, 8, 1, 50 + l);
        dev().writeTexture(arr, {0, l}, layers.back().texels.data(), 8 * 8 * 4);
    }
    BindGroupEntry entry = BindGroupEntry::makeStorage(0, arr, 0);
    entry.baseLayer = 1;
    entry.layerCount = 1;
    BindGroupHandle group = makeBindGroup(pipeline, 0, {entry});
    ASSERT_TRUE(group.isValid());
    CommandList& cmd = dev().beginCommandList("layer view");
    cmd.barrier(Barrier::tex(arr, Access::ShaderSampled, Access::ShaderWrite, TextureRange{0, 1, 1, 1}));
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.dispatch(1, 1);
    cmd.barrier(Barrier::tex(arr, Access::ShaderWrite, Access::ShaderSampled, TextureRange{0, 1, 1, 1}));
    submitAndWait(cmd);
    for (uint32_t y = 0; y < 8; ++y)
        for (uint32_t x = 0; x < 8; ++x) layers[1].at(x, y, 0) = 0xC0DE0000u | (y << 8) | x;
    for (uint32_t l = 0; l < 3; ++l) {
        // Metric: layer 1 holds the shader's pattern, layers 0 and 2 their uploads. Threshold: exact.
        EXPECT_EQ(readTextureAs<uint32_t>(arr, {0, l}, Access::ShaderSampled), layers[l].texels)
            << "layer " << l;
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, ConformanceSubresource, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
