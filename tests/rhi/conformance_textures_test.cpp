// RHI conformance: textures and samplers — 3D trilinear filtering against a CPU reference, texel
// round trips of every format through writeTexture/readTexture, mips / array layers / volumes,
// depth clears, 2D array layer selection, and filter / address modes.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include <shaders/conf_sample3d.h>
#include <shaders/conf_sample_array.h>
#include <shaders/conf_sample_modes.h>

#include "conformance_common.h"

namespace {

using namespace rhi;
using penumbra::conformance::ConformanceTest;
using penumbra::conformance::CpuVolume;
using penumbra::conformance::floatToHalf;
using penumbra::conformance::halfToFloat;
using penumbra::conformance::Rng;

class ConformanceTextures : public ConformanceTest {
protected:
    // Fills a 17x13x11 volume of `format` (R32_FLOAT or RGBA16_FLOAT) with values in [0, 1], samples
    // it with a linear clamp-to-edge sampler at 1000 points in a compute shader and compares every
    // channel with a CPU trilinear reference built from the values the texture actually holds.
    void runTrilinear(Format format) {
        const int kW = 17, kH = 13, kD = 11;
        const uint32_t kPoints = 1000;
        const bool half = format == Format::RGBA16_FLOAT;
        const int channels = half ? 4 : 1;

        CpuVolume volume;
        volume.width = kW;
        volume.height = kH;
        volume.depth = kD;
        volume.channels = channels;
        volume.texels.resize(size_t(kW) * kH * kD * channels);
        std::vector<uint16_t> halfData;
        Rng rng(0xBEEF1234u);
        for (float& t : volume.texels) t = rng.unit();
        if (half) {
            halfData.resize(volume.texels.size());
            for (size_t i = 0; i < halfData.size(); ++i) {
                halfData[i] = floatToHalf(volume.texels[i]);
                volume.texels[i] = halfToFloat(halfData[i]);  // reference uses the stored values
            }
        }

        TextureDesc desc;
        desc.dimension = TextureDimension::Tex3D;
        desc.format = format;
        desc.width = kW;
        desc.height = kH;
        desc.depthOrLayers = kD;
        desc.usage = TextureUsage::Sampled | TextureUsage::CopyDst;
        desc.debugName = "conf volume";
        TextureHandle texture = makeTexture(desc);
        ASSERT_TRUE(texture.isValid());
        if (half) {
            dev().writeTexture(texture, {}, halfData.data(), halfData.size() * 2);
        } else {
            dev().writeTexture(texture, {}, volume.texels.data(), volume.texels.size() * 4);
        }

        // Points: the 8 corners of [0,1]^3 (pure clamp-to-edge) then uniform random points.
        std::vector<float> points(kPoints * 4, 0.0f);
        Rng prng(0x5EED0003u);
        for (uint32_t i = 0; i < kPoints; ++i) {
            for (int c = 0; c < 3; ++c) points[i * 4 + c] = i < 8 ? float((i >> c) & 1u) : prng.unit();
        }
        BufferHandle pointBuf = makeBufferFrom(points, BufferUsage::Storage | BufferUsage::CopyDst);
        BufferHandle resultBuf = makeBuffer(kPoints * 16, BufferUsage::Storage | BufferUsage::CopySrc);
        SamplerHandle sampler = makeSampler(Filter::Linear, AddressMode::ClampToEdge);
        PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_sample3d::compute());
        ASSERT_TRUE(pointBuf.isValid() && resultBuf.isValid() && sampler.isValid() && pipeline.isValid());
        BindGroupHandle group = makeBindGroup(
            pipeline, 0,
            {BindGroupEntry::makeSampled(0, texture, sampler), BindGroupEntry::makeBuffer(1, pointBuf),
             BindGroupEntry::makeBuffer(2, resultBuf)});
        ASSERT_TRUE(group.isValid());

        CommandList& cmd = dev().beginCommandList("trilinear");
        cmd.bindPipeline(pipeline);
        cmd.bindGroup(0, group);
        cmd.pushConstants(&kPoints, sizeof(kPoints));
        cmd.dispatch((kPoints + 63) / 64);
        cmd.barrier(Barrier::buf(resultBuf, Access::ShaderWrite, Access::HostRead));
        submitAndWait(cmd);

        const std::vector<float> result = readBuffer<float>(resultBuf, kPoints * 4);
        ASSERT_EQ(result.size(), kPoints * 4);
        double maxError = 0.0;
        uint32_t worst = 0;
        for (uint32_t i = 0; i < kPoints; ++i) {
            for (int c = 0; c < 4; ++c) {
                double expected;
                if (c < channels) {
                    expected =
                        penumbra::conformance::sampleLinear(volume, points[i * 4], points[i * 4 + 1],
                                                            points[i * 4 + 2], c, AddressMode::ClampToEdge);
                } else {
                    expected = c == 3 ? 1.0 : 0.0;  // missing channels read as (0, 0, 1)
                }
                const double err = std::fabs(double(result[i * 4 + c]) - expected);
                if (err > maxError) {
                    maxError = err;
                    worst = i;
                }
                // Metric: |GPU sample - CPU trilinear reference| per channel. Threshold: 1e-3 absolute.
                EXPECT_NEAR(result[i * 4 + c], expected, 1e-3)
                    << "point " << i << " (" << points[i * 4] << ", " << points[i * 4 + 1] << ", "
                    << points[i * 4 + 2] << ") channel " << c;
            }
        }
        std::printf("[ %s ] trilinear %s: max abs error %.3g over %u points (worst point %u)\n",
                    toString(GetParam()), formatInfo(format).name, maxError, kPoints, worst);
    }
};

TEST_P(ConformanceTextures, Trilinear3DR32Float) { runTrilinear(Format::R32_FLOAT); }

TEST_P(ConformanceTextures, Trilinear3DRgba16Float) { runTrilinear(Format::RGBA16_FLOAT); }

// Texel bytes of a 7x5 texture (odd row pitch: tightly packed rows) that are valid, normal values
// for the format, so that no conversion can alter them.
std::vector<uint8_t> makeTexelBytes(Format format, uint32_t texelCount, uint32_t seed) {
    const FormatInfo& info = formatInfo(format);
    std::vector<uint8_t> bytes(size_t(texelCount) * info.bytesPerTexel);
    Rng rng(seed);
    switch (format) {
        case Format::R16_FLOAT:
        case Format::RG16_FLOAT:
        case Format::RGBA16_FLOAT:
            for (size_t i = 0; i < bytes.size(); i += 2) {
                const uint16_t h = floatToHalf(rng.range(-4.0f, 4.0f));
                std::memcpy(&bytes[i], &h, 2);
            }
            break;
        case Format::R32_FLOAT:
        case Format::RG32_FLOAT:
        case Format::RGBA32_FLOAT:
        case Format::D32_FLOAT:
            for (size_t i = 0; i < bytes.size(); i += 4) {
                const float f = rng.range(-100.0f, 100.0f);
                std::memcpy(&bytes[i], &f, 4);
            }
            break;
        default:
            for (auto& b : bytes) b = uint8_t(rng.next() >> 24);
            break;
    }
    return bytes;
}

// Every colour format of types.h round-trips bit-exactly through writeTexture / readTexture.
TEST_P(ConformanceTextures, EveryColorFormatRoundTrips) {
    const Format formats[] = {Format::R8_UNORM,     Format::R8_UINT,     Format::R16_FLOAT,
                              Format::R32_FLOAT,    Format::R32_UINT,    Format::RG16_FLOAT,
                              Format::RG32_FLOAT,   Format::RGBA8_UNORM, Format::RGBA8_SRGB,
                              Format::RGBA16_FLOAT, Format::RGBA32_FLOAT};
    const uint32_t kW = 7, kH = 5;
    uint32_t seed = 100;
    for (Format format : formats) {
        SCOPED_TRACE(formatInfo(format).name);
        TextureHandle texture = makeTexture2D(
            format, kW, kH, TextureUsage::Sampled | TextureUsage::CopyDst | TextureUsage::CopySrc);
        ASSERT_TRUE(texture.isValid());
        const std::vector<uint8_t> bytes = makeTexelBytes(format, kW * kH, ++seed);
        dev().writeTexture(texture, {}, bytes.data(), bytes.size());
        // Metric: bytes read back (writeTexture leaves the texture ShaderSampled) equal the bytes
        // written. Threshold: exact.
        EXPECT_EQ(readTexture(texture, {}, Access::ShaderSampled), bytes);
    }
}

// Mip levels of a 2D texture, layers of a 2D array and mips of a 3D volume round-trip separately.
TEST_P(ConformanceTextures, MipLayerAndVolumeSubresourcesRoundTrip) {
    const TextureUsage usage = TextureUsage::Sampled | TextureUsage::CopyDst | TextureUsage::CopySrc;
    {
        SCOPED_TRACE("RGBA8 2D mips");
        TextureHandle t = makeTexture2D(Format::RGBA8_UNORM, 16, 8, usage, 4);
        ASSERT_TRUE(t.isValid());
        std::vector<std::vector<uint8_t>> levels;
        for (uint32_t mip = 0; mip < 4; ++mip) {
            levels.push_back(makeTexelBytes(Format::RGBA8_UNORM, (16u >> mip) * (8u >> mip), 200 + mip));
            dev().writeTexture(t, {mip, 0}, levels.back().data(), levels.back().size());
        }
        for (uint32_t mip = 0; mip < 4; ++mip) {
            // Metric: each mip reads back its own bytes (16x8, 8x4, 4x2, 2x1). Threshold: exact.
            EXPECT_EQ(readTexture(t, {mip, 0}, Access::ShaderSampled), levels[mip]) << "mip " << mip;
        }
    }
    {
        SCOPED_TRACE("R32F 2D array layers");
        TextureDesc desc;
        desc.dimension = TextureDimension::Tex2DArray;
        desc.format = Format::R32_FLOAT;
        desc.width = 6;
        desc.height = 3;
        desc.depthOrLayers = 3;
        desc.usage = usage;
        TextureHandle t = makeTexture(desc);
        ASSERT_TRUE(t.isValid());
        std::vector<std::vector<uint8_t>> layers;
        for (uint32_t layer = 0; layer < 3; ++layer) {
            layers.push_back(makeTexelBytes(Format::R32_FLOAT, 18, 300 + layer));
            dev().writeTexture(t, {0, layer}, layers.back().data(), layers.back().size());
        }
        for (uint32_t layer = 0; layer < 3; ++layer) {
            // Metric: each layer reads back its own bytes. Threshold: exact.
            EXPECT_EQ(readTexture(t, {0, layer}, Access::ShaderSampled), layers[layer]) << "layer " << layer;
        }
    }
    {
        SCOPED_TRACE("RG16F 3D volume mips");
        TextureDesc desc;
        desc.dimension = TextureDimension::Tex3D;
        desc.format = Format::RG16_FLOAT;
        desc.width = 5;
        desc.height = 4;
        desc.depthOrLayers = 3;
        desc.mipLevels = 2;
        desc.usage = usage;
        TextureHandle t = makeTexture(desc);
        ASSERT_TRUE(t.isValid());
        const std::vector<uint8_t> mip0 = makeTexelBytes(Format::RG16_FLOAT, 5 * 4 * 3, 400);
        const std::vector<uint8_t> mip1 = makeTexelBytes(Format::RG16_FLOAT, 2 * 2 * 1, 401);
        dev().writeTexture(t, {0, 0}, mip0.data(), mip0.size());
        dev().writeTexture(t, {1, 0}, mip1.data(), mip1.size());
        // Metric: the 5x4x3 volume and its 2x2x1 mip read back unchanged. Threshold: exact.
        EXPECT_EQ(readTexture(t, {0, 0}, Access::ShaderSampled), mip0);
        EXPECT_EQ(readTexture(t, {1, 0}, Access::ShaderSampled), mip1);
    }
}

// A D32_FLOAT target cleared by a render pass with no colour attachments reads back the clear value.
TEST_P(ConformanceTextures, DepthClearReadsBack) {
    const uint32_t kW = 9, kH = 7;
    TextureHandle depth = makeDepthTarget(kW, kH);
    ASSERT_TRUE(depth.isValid());

    CommandList& cmd = dev().beginCommandList("depth clear");
    cmd.barrier(Barrier::tex(depth, Access::None, Access::DepthTargetWrite));
    RenderPassDesc pass;
    pass.depthAttachment.texture = depth;
    pass.depthAttachment.load = LoadOp::Clear;
    pass.depthAttachment.clearDepth = 0.375f;
    pass.debugName = "depth clear";
    cmd.beginRenderPass(pass);
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(depth, Access::DepthTargetWrite, Access::CopySrc));
    submitAndWait(cmd);

    const std::vector<float> values = readTextureAs<float>(depth, {}, Access::CopySrc);
    ASSERT_EQ(values.size(), size_t(kW) * kH);
    for (size_t i = 0; i < values.size(); ++i) {
        // Metric: every depth texel equals the clear value 0.375. Threshold: exact (representable).
        EXPECT_EQ(values[i], 0.375f) << "texel " << i;
    }
}

// Sampling a 2D array: each layer is addressed by the third coordinate, rounded to the nearest
// integer and clamped to [0, layers - 1].
TEST_P(ConformanceTextures, ArrayLayerSelection) {
    const uint32_t kW = 4, kH = 4, kLayers = 3;
    TextureDesc desc;
    desc.dimension = TextureDimension::Tex2DArray;
    desc.format = Format::R32_FLOAT;
    desc.width = kW;
    desc.height = kH;
    desc.depthOrLayers = kLayers;
    desc.usage = TextureUsage::Sampled | TextureUsage::CopyDst;
    TextureHandle texture = makeTexture(desc);
    ASSERT_TRUE(texture.isValid());
    auto texel = [](uint32_t x, uint32_t y, uint32_t layer) { return float(layer * 100 + y * 4 + x); };
    for (uint32_t layer = 0; layer < kLayers; ++layer) {
        std::vector<float> data(kW * kH);
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) data[y * kW + x] = texel(x, y, layer);
        dev().writeTexture(texture, {0, layer}, data.data(), data.size() * 4);
    }

    struct Probe {
        uint32_t x, y;
        float layerCoord;
        uint32_t expectedLayer;
    };
    std::vector<Probe> probes;
    for (uint32_t layer = 0; layer < kLayers; ++layer)
        for (uint32_t y = 0; y < kH; ++y)
            for (uint32_t x = 0; x < kW; ++x) probes.push_back({x, y, float(layer), layer});
    probes.push_back({1, 2, 0.4f, 0});
    probes.push_back({2, 1, 1.6f, 2});
    probes.push_back({3, 3, 2.45f, 2});
    probes.push_back({0, 1, 1.3f, 1});
    probes.push_back({2, 2, -0.7f, 0});  // clamped
    probes.push_back({1, 0, 5.0f, 2});   // clamped
    std::vector<float> coords;
    for (const Probe& p : probes) {
        coords.insert(coords.end(), {(float(p.x) + 0.5f) / kW, (float(p.y) + 0.5f) / kH, p.layerCoord, 0.0f});
    }
    const uint32_t count = uint32_t(probes.size());

    BufferHandle coordBuf = makeBufferFrom(coords, BufferUsage::Storage | BufferUsage::CopyDst);
    BufferHandle resultBuf = makeBuffer(count * 16, BufferUsage::Storage | BufferUsage::CopySrc);
    SamplerHandle sampler = makeSampler(Filter::Nearest, AddressMode::ClampToEdge);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_sample_array::compute());
    ASSERT_TRUE(coordBuf.isValid() && resultBuf.isValid() && sampler.isValid() && pipeline.isValid());
    BindGroupHandle group =
        makeBindGroup(pipeline, 0,
                      {BindGroupEntry::makeSampled(0, texture, sampler),
                       BindGroupEntry::makeBuffer(1, coordBuf), BindGroupEntry::makeBuffer(2, resultBuf)});
    ASSERT_TRUE(group.isValid());

    CommandList& cmd = dev().beginCommandList("array layers");
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.pushConstants(&count, sizeof(count));
    cmd.dispatch((count + 63) / 64);
    cmd.barrier(Barrier::buf(resultBuf, Access::ShaderWrite, Access::HostRead));
    submitAndWait(cmd);

    const std::vector<float> result = readBuffer<float>(resultBuf, count * 4);
    ASSERT_EQ(result.size(), count * 4);
    for (uint32_t i = 0; i < count; ++i) {
        const Probe& p = probes[i];
        // Metric: nearest sample at texel (x, y) of the expected layer. Threshold: exact.
        EXPECT_EQ(result[i * 4], texel(p.x, p.y, p.expectedLayer))
            << "probe " << i << " texel (" << p.x << ", " << p.y << ") layer coordinate " << p.layerCoord;
    }
}

// Nearest vs linear filtering and clamp / repeat / mirrored-repeat addressing on one 2D texture.
TEST_P(ConformanceTextures, SamplerFilterAndAddressModes) {
    const int kW = 5, kH = 4;
    CpuVolume image;
    image.width = kW;
    image.height = kH;
    image.texels.resize(kW * kH);
    Rng rng(0xF117E5u);
    for (float& t : image.texels) t = rng.unit();
    TextureHandle texture =
        makeTexture2D(Format::R32_FLOAT, kW, kH, TextureUsage::Sampled | TextureUsage::CopyDst);
    ASSERT_TRUE(texture.isValid());
    dev().writeTexture(texture, {}, image.texels.data(), image.texels.size() * 4);

    // Coordinates in [-1.5, 2.5]^2, kept at least 2 % of a texel away from texel edges so that
    // nearest filtering has one well-defined answer.
    std::vector<float> coords;
    Rng crng(0xC00Du);
    auto nearEdge = [](float c, int n) {
        const double x = double(c) * n;
        return std::fabs(x - std::round(x)) < 0.02;
    };
    while (coords.size() < 256 * 4) {
        const float u = crng.range(-1.5f, 2.5f), v = crng.range(-1.5f, 2.5f);
        if (nearEdge(u, kW) || nearEdge(v, kH)) continue;
        coords.insert(coords.end(), {u, v, 0.0f, 0.0f});
    }
    const uint32_t count = uint32_t(coords.size() / 4);

    struct Mode {
        Filter filter;
        AddressMode address;
        const char* name;
    };
    const Mode modes[5] = {{Filter::Nearest, AddressMode::ClampToEdge, "nearest clamp"},
                           {Filter::Linear, AddressMode::ClampToEdge, "linear clamp"},
                           {Filter::Nearest, AddressMode::Repeat, "nearest repeat"},
                           {Filter::Linear, AddressMode::Repeat, "linear repeat"},
                           {Filter::Linear, AddressMode::MirroredRepeat, "linear mirrored repeat"}};

    BufferHandle coordBuf = makeBufferFrom(coords, BufferUsage::Storage | BufferUsage::CopyDst);
    BufferHandle resultBuf = makeBuffer(count * 5 * 4, BufferUsage::Storage | BufferUsage::CopySrc);
    PipelineHandle pipeline = makeComputePipeline(penumbra::shaders::conf_sample_modes::compute());
    ASSERT_TRUE(coordBuf.isValid() && resultBuf.isValid() && pipeline.isValid());
    std::vector<BindGroupEntry> entries;
    for (uint32_t k = 0; k < 5; ++k) {
        SamplerHandle s = makeSampler(modes[k].filter, modes[k].address);
        ASSERT_TRUE(s.isValid());
        entries.push_back(BindGroupEntry::makeSampled(k, texture, s));
    }
    entries.push_back(BindGroupEntry::makeBuffer(5, coordBuf));
    entries.push_back(BindGroupEntry::makeBuffer(6, resultBuf));
    BindGroupHandle group = makeBindGroup(pipeline, 0, entries);
    ASSERT_TRUE(group.isValid());

    CommandList& cmd = dev().beginCommandList("sampler modes");
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    cmd.pushConstants(&count, sizeof(count));
    cmd.dispatch((count + 63) / 64);
    cmd.barrier(Barrier::buf(resultBuf, Access::ShaderWrite, Access::HostRead));
    submitAndWait(cmd);

    const std::vector<float> result = readBuffer<float>(resultBuf, count * 5);
    ASSERT_EQ(result.size(), count * 5);
    double maxLinearError = 0.0;
    for (uint32_t i = 0; i < count; ++i) {
        const double u = coords[i * 4], v = coords[i * 4 + 1];
        for (uint32_t k = 0; k < 5; ++k) {
            const Mode& m = modes[k];
            const float got = result[i * 5 + k];
            if (m.filter == Filter::Nearest) {
                // Metric: nearest sample equals the addressed texel. Threshold: exact.
                EXPECT_EQ(got, float(penumbra::conformance::sampleNearest2D(image, u, v, 0, m.address)))
                    << m.name << " at (" << u << ", " << v << ")";
            } else {
                const double expected = penumbra::conformance::sampleLinear(image, u, v, 0.0, 0, m.address);
                maxLinearError = std::max(maxLinearError, std::fabs(got - expected));
                // Metric: |bilinear sample - CPU reference|. Threshold: 1e-3 absolute.
                EXPECT_NEAR(got, expected, 1e-3) << m.name << " at (" << u << ", " << v << ")";
            }
        }
    }
    std::printf("[ %s ] sampler modes: max bilinear abs error %.3g over %u points\n", toString(GetParam()),
                maxLinearError, count);
}

INSTANTIATE_TEST_SUITE_P(Backends, ConformanceTextures, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
