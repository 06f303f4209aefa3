// RHI conformance: rasterisation — depth testing with indexed vertex buffers, blending, conservative
// depth output, sRGB targets, LoadOp::Load, indirect and instanced draws, multiple render targets and
// fragment-stage resources. Vulkan conventions on both backends: NDC y = -1 is image row 0, depth
// 0..1, readTexture returns row 0 first.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include <shaders/conf_instanced.h>
#include <shaders/conf_mesh.h>
#include <shaders/conf_mrt.h>
#include <shaders/conf_rect.h>
#include <shaders/conf_rect_depth.h>
#include <shaders/conf_textured.h>

#include "conformance_common.h"

namespace {

using namespace rhi;
using penumbra::conformance::ConformanceTest;
using penumbra::conformance::ndcX;
using penumbra::conformance::ndcY;
using penumbra::conformance::pixelFloat;
using penumbra::conformance::pixelRgba8;
using penumbra::conformance::RectPush;
using penumbra::conformance::Rng;
using penumbra::conformance::srgbEncode;
using penumbra::conformance::toUnorm8;

using Rgba8 = std::array<int, 4>;

Rgba8 pixel(const std::vector<uint8_t>& image, uint32_t width, uint32_t x, uint32_t y) {
    const auto p = pixelRgba8(image, width, x, y);
    return {p[0], p[1], p[2], p[3]};
}

RectPush rect(float x0, float y0, float x1, float y1, std::array<float, 4> color, float z = 0.5f,
              float depthOffset = 0.0f, float extra = 0.0f) {
    RectPush p;
    p.rect[0] = x0;
    p.rect[1] = y0;
    p.rect[2] = x1;
    p.rect[3] = y1;
    for (int i = 0; i < 4; ++i) p.color[i] = color[i];
    p.depth[0] = z;
    p.depth[1] = depthOffset;
    p.depth[2] = extra;
    return p;
}

ColorAttachment colorAttachment(TextureHandle texture, LoadOp load,
                                std::array<float, 4> clear = {0, 0, 0, 0}) {
    ColorAttachment a;
    a.texture = texture;
    a.load = load;
    a.store = StoreOp::Store;
    a.clearColor = clear;
    return a;
}

// Expects |got - expected| <= tolerance on every channel.
void expectRgbaNear(const Rgba8& got, const Rgba8& expected, int tolerance, uint32_t x, uint32_t y) {
    for (int c = 0; c < 4; ++c) {
        EXPECT_LE(std::abs(got[c] - expected[c]), tolerance)
            << "pixel (" << x << ", " << y << ") channel " << c << ": got " << got[c] << ", expected "
            << expected[c];
    }
}

class ConformanceRaster : public ConformanceTest {
protected:
    GraphicsPipelineDesc rectPipelineDesc(std::vector<Format> colorFormats,
                                          Format depthFormat = Format::Undefined) {
        GraphicsPipelineDesc desc;
        desc.colorFormats = std::move(colorFormats);
        desc.depthFormat = depthFormat;
        desc.cullMode = CullMode::None;
        return desc;
    }
};

// Two overlapping indexed triangles (A far/red at z 0.75, B near/green at z 0.25) with depth LESS +
// depth write, drawn far-first (16-bit indices) and near-first (32-bit indices, vertexOffset): the
// nearer colour wins in the overlap in both orders and the D32 target holds the expected depths.
TEST_P(ConformanceRaster, DepthTestNearerTriangleWinsInBothOrders) {
    const uint32_t kW = 32, kH = 32;
    struct Vertex {
        float pos[3];
        float color[4];
    };
    static_assert(sizeof(Vertex) == 28);
    const float triA[3][2] = {{-1.0f, -1.0f}, {1.0f, -1.0f}, {-1.0f, 1.0f}};
    const float triB[3][2] = {{-0.5f, -1.0f}, {1.0f, -1.0f}, {1.0f, 0.5f}};
    std::vector<Vertex> vertices;
    for (auto& v : triA) vertices.push_back({{v[0], v[1], 0.75f}, {1, 0, 0, 1}});
    for (auto& v : triB) vertices.push_back({{v[0], v[1], 0.25f}, {0, 1, 0, 1}});
    const std::vector<uint16_t> indices16 = {0, 1, 2, 3, 4, 5};
    const std::vector<uint32_t> indices32 = {0, 1, 2};

    BufferHandle vb = makeBufferFrom(vertices, BufferUsage::Vertex | BufferUsage::CopyDst);
    BufferHandle ib16 = makeBufferFrom(indices16, BufferUsage::Index | BufferUsage::CopyDst);
    BufferHandle ib32 = makeBufferFrom(indices32, BufferUsage::Index | BufferUsage::CopyDst);
    ASSERT_TRUE(vb.isValid() && ib16.isValid() && ib32.isValid());

    GraphicsPipelineDesc desc = rectPipelineDesc({Format::RGBA8_UNORM}, Format::D32_FLOAT);
    desc.vertexBuffers = {{sizeof(Vertex), false}};
    desc.vertexAttributes = {{0, 0, Format::RGB32_FLOAT, 0}, {1, 0, Format::RGBA32_FLOAT, 12}};
    desc.depthTest = true;
    desc.depthWrite = true;
    desc.depthCompare = CompareOp::Less;
    PipelineHandle pipeline = makeGraphicsPipeline(desc, penumbra::shaders::conf_mesh::vertex(),
                                                   penumbra::shaders::conf_mesh::fragment());
    ASSERT_TRUE(pipeline.isValid());

    for (int order = 0; order < 2; ++order) {
        SCOPED_TRACE(order == 0 ? "far first, 16-bit indices" : "near first, 32-bit indices");
        TextureHandle color = makeColorTarget(kW, kH);
        TextureHandle depth = makeDepthTarget(kW, kH);
        ASSERT_TRUE(color.isValid() && depth.isValid());

        CommandList& cmd = dev().beginCommandList("depth test");
        const Barrier begin[] = {Barrier::tex(color, Access::None, Access::ColorTarget),
                                 Barrier::tex(depth, Access::None, Access::DepthTargetWrite)};
        cmd.barrier(begin);
        RenderPassDesc pass;
        pass.colorAttachments = {colorAttachment(color, LoadOp::Clear, {0, 0, 0, 1})};
        pass.depthAttachment.texture = depth;
        pass.depthAttachment.clearDepth = 1.0f;
        cmd.beginRenderPass(pass);
        setFullViewport(cmd, kW, kH);
        cmd.bindPipeline(pipeline);
        cmd.bindVertexBuffer(0, vb);
        if (order == 0) {
            cmd.bindIndexBuffer(ib16, IndexType::Uint16);
            cmd.drawIndexed(3, 1, 0, 0);  // A (far)
            cmd.drawIndexed(3, 1, 3, 0);  // B (near)
        } else {
            cmd.bindIndexBuffer(ib32, IndexType::Uint32);
            cmd.drawIndexed(3, 1, 0, 3);  // B (near) through vertexOffset 3
            cmd.drawIndexed(3, 1, 0, 0);  // A (far)
        }
        cmd.endRenderPass();
        const Barrier end[] = {Barrier::tex(color, Access::ColorTarget, Access::CopySrc),
                               Barrier::tex(depth, Access::DepthTargetWrite, Access::CopySrc)};
        cmd.barrier(end);
        submitAndWait(cmd);

        const std::vector<uint8_t> image = readTexture(color, {}, Access::CopySrc);
        const std::vector<uint8_t> depthBytes = readTexture(depth, {}, Access::CopySrc);
        ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
        ASSERT_EQ(depthBytes.size(), size_t(kW) * kH * 4);
        int classCount[4] = {0, 0, 0, 0};  // none, A only, B only, both
        for (uint32_t y = 0; y < kH; ++y) {
            for (uint32_t x = 0; x < kW; ++x) {
                const int a = penumbra::conformance::triangleCoverage(triA, x, y, kW, kH);
                const int b = penumbra::conformance::triangleCoverage(triB, x, y, kW, kH);
                if (a < 0 || b < 0) continue;  // centre within 0.75 px of an edge
                ++classCount[a + 2 * b];
                const Rgba8 expected = b   ? Rgba8{0, 255, 0, 255}
                                       : a ? Rgba8{255, 0, 0, 255}
                                           : Rgba8{0, 0, 0, 255};
                const float expectedDepth = b ? 0.25f : a ? 0.75f : 1.0f;
                // Metric: pixel colour (nearer triangle wins). Threshold: exact.
                expectRgbaNear(pixel(image, kW, x, y), expected, 0, x, y);
                // Metric: depth texel. Threshold: +-1e-6.
                EXPECT_NEAR(pixelFloat(depthBytes, kW, x, y), expectedDepth, 1e-6)
                    << "pixel (" << x << ", " << y << ")";
            }
        }
        for (int c = 0; c < 4; ++c) EXPECT_GE(classCount[c], 20) << "too few pixels in coverage class " << c;
    }
}

// SrcAlpha / OneMinusSrcAlpha blending (two overlapping draws) over a cleared RGBA8 target.
TEST_P(ConformanceRaster, BlendSrcAlphaOneMinusSrcAlpha) {
    const uint32_t kW = 16, kH = 16;
    TextureHandle target = makeColorTarget(kW, kH);
    GraphicsPipelineDesc desc = rectPipelineDesc({Format::RGBA8_UNORM});
    BlendState blend;
    blend.enable = true;
    blend.srcColor = BlendFactor::SrcAlpha;
    blend.dstColor = BlendFactor::OneMinusSrcAlpha;
    blend.srcAlpha = BlendFactor::One;
    blend.dstAlpha = BlendFactor::OneMinusSrcAlpha;
    desc.blend = {blend};
    PipelineHandle pipeline = makeGraphicsPipeline(desc, penumbra::shaders::conf_rect::vertex(),
                                                   penumbra::shaders::conf_rect::fragment());
    ASSERT_TRUE(target.isValid() && pipeline.isValid());

    const std::array<float, 4> clear = {0.2f, 0.4f, 0.6f, 1.0f};
    const std::array<float, 4> first = {1.0f, 0.5f, 0.0f, 0.25f};  // left half
    const std::array<float, 4> second = {0.0f, 0.0f, 1.0f, 0.5f};  // top half (rows 0..7)
    CommandList& cmd = dev().beginCommandList("blend alpha");
    cmd.barrier(Barrier::tex(target, Access::None, Access::ColorTarget));
    RenderPassDesc pass;
    pass.colorAttachments = {colorAttachment(target, LoadOp::Clear, clear)};
    cmd.beginRenderPass(pass);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(pipeline);
    pushRect(cmd, rect(-1, -1, 0, 1, first));
    cmd.draw(6);
    pushRect(cmd, rect(-1, -1, 1, 0, second));
    cmd.draw(6);
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(target, Access::ColorTarget, Access::CopySrc));
    submitAndWait(cmd);

    auto over = [](const Rgba8& dst, const std::array<float, 4>& src) {
        Rgba8 out;
        for (int c = 0; c < 3; ++c) out[c] = toUnorm8(src[c] * src[3] + dst[c] / 255.0 * (1.0 - src[3]));
        out[3] = toUnorm8(src[3] + dst[3] / 255.0 * (1.0 - src[3]));
        return out;
    };
    const Rgba8 cleared = {toUnorm8(clear[0]), toUnorm8(clear[1]), toUnorm8(clear[2]), toUnorm8(clear[3])};
    const std::vector<uint8_t> image = readTexture(target, {}, Access::CopySrc);
    ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            Rgba8 expected = cleared;
            if (x < kW / 2) expected = over(expected, first);
            if (y < kH / 2) expected = over(expected, second);
            // Metric: blended RGBA8 value vs. CPU blend of the quantised destination. Threshold: +-1/255.
            expectRgbaNear(pixel(image, kW, x, y), expected, 1, x, y);
        }
    }
}

// Additive blending (One/One, drawn twice) and BlendOp::Max.
TEST_P(ConformanceRaster, BlendAdditiveAndMax) {
    const uint32_t kW = 16, kH = 8;
    TextureHandle target = makeColorTarget(kW, kH);
    GraphicsPipelineDesc addDesc = rectPipelineDesc({Format::RGBA8_UNORM});
    BlendState add;
    add.enable = true;
    add.srcColor = add.dstColor = add.srcAlpha = add.dstAlpha = BlendFactor::One;
    addDesc.blend = {add};
    GraphicsPipelineDesc maxDesc = addDesc;
    maxDesc.blend[0].colorOp = BlendOp::Max;
    maxDesc.blend[0].alphaOp = BlendOp::Max;
    PipelineHandle addPipeline = makeGraphicsPipeline(addDesc, penumbra::shaders::conf_rect::vertex(),
                                                      penumbra::shaders::conf_rect::fragment());
    PipelineHandle maxPipeline = makeGraphicsPipeline(maxDesc, penumbra::shaders::conf_rect::vertex(),
                                                      penumbra::shaders::conf_rect::fragment());
    ASSERT_TRUE(target.isValid() && addPipeline.isValid() && maxPipeline.isValid());

    const std::array<float, 4> clear = {0.2f, 0.4f, 0.6f, 0.5f};
    const std::array<float, 4> addColor = {0.25f, 0.5f, 0.5f, 0.25f};
    const std::array<float, 4> maxColor = {0.1f, 0.9f, 0.3f, 0.7f};
    CommandList& cmd = dev().beginCommandList("blend add max");
    cmd.barrier(Barrier::tex(target, Access::None, Access::ColorTarget));
    RenderPassDesc pass;
    pass.colorAttachments = {colorAttachment(target, LoadOp::Clear, clear)};
    cmd.beginRenderPass(pass);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(addPipeline);
    pushRect(cmd, rect(-1, -1, 0, 1, addColor));
    cmd.draw(6);
    cmd.draw(6);
    cmd.bindPipeline(maxPipeline);
    pushRect(cmd, rect(0, -1, 1, 1, maxColor));
    cmd.draw(6);
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(target, Access::ColorTarget, Access::CopySrc));
    submitAndWait(cmd);

    Rgba8 cleared, added = {}, maxed;
    for (int c = 0; c < 4; ++c) {
        cleared[c] = toUnorm8(clear[c]);
        const int once = toUnorm8(cleared[c] / 255.0 + addColor[c]);
        added[c] = toUnorm8(once / 255.0 + addColor[c]);
        maxed[c] = std::max(cleared[c], toUnorm8(maxColor[c]));
    }
    const std::vector<uint8_t> image = readTexture(target, {}, Access::CopySrc);
    ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            // Metric: clear + 2 * colour (saturated) on the left, max(clear, colour) on the right.
            // Threshold: +-1/255.
            expectRgbaNear(pixel(image, kW, x, y), x < kW / 2 ? added : maxed, 1, x, y);
        }
    }
}

// A fragment shader declaring layout(depth_greater) gl_FragDepth writes gl_FragCoord.z + offset; the
// depth buffer holds the written values and later depth tests compare against them.
TEST_P(ConformanceRaster, ConservativeDepthOutput) {
    ASSERT_TRUE(dev().info().limits.conservativeDepth) << "conservative depth is expected on both backends";
    const uint32_t kW = 32, kH = 16;
    TextureHandle color = makeColorTarget(kW, kH);
    TextureHandle depth = makeDepthTarget(kW, kH);
    GraphicsPipelineDesc desc = rectPipelineDesc({Format::RGBA8_UNORM}, Format::D32_FLOAT);
    desc.depthTest = true;
    desc.depthWrite = true;
    desc.depthCompare = CompareOp::Less;
    PipelineHandle pipeline = makeGraphicsPipeline(desc, penumbra::shaders::conf_rect_depth::vertex(),
                                                   penumbra::shaders::conf_rect_depth::fragment());
    ASSERT_TRUE(color.isValid() && depth.isValid() && pipeline.isValid());

    auto readBoth = [&](std::vector<uint8_t>& image, std::vector<uint8_t>& depthBytes) {
        image = readTexture(color, {}, Access::CopySrc);
        depthBytes = readTexture(depth, {}, Access::CopySrc);
        ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
        ASSERT_EQ(depthBytes.size(), size_t(kW) * kH * 4);
    };
    auto check = [&](const std::vector<uint8_t>& image, const std::vector<uint8_t>& depthBytes,
                     const Rgba8& left, float leftDepth, const Rgba8& right, float rightDepth) {
        for (uint32_t y = 0; y < kH; ++y) {
            for (uint32_t x = 0; x < kW; ++x) {
                const bool isLeft = x < kW / 2;
                // Metric: colour of the surviving draw. Threshold: exact.
                expectRgbaNear(pixel(image, kW, x, y), isLeft ? left : right, 0, x, y);
                // Metric: depth texel = value written by the fragment shader. Threshold: +-1e-6.
                EXPECT_NEAR(pixelFloat(depthBytes, kW, x, y), isLeft ? leftDepth : rightDepth, 1e-6)
                    << "pixel (" << x << ", " << y << ")";
            }
        }
    };

    // Pass 1: red on the left half at z = 0.25, shader depth 0.25 + 0.5 = 0.75.
    {
        CommandList& cmd = dev().beginCommandList("conservative depth 1");
        const Barrier begin[] = {Barrier::tex(color, Access::None, Access::ColorTarget),
                                 Barrier::tex(depth, Access::None, Access::DepthTargetWrite)};
        cmd.barrier(begin);
        RenderPassDesc pass;
        pass.colorAttachments = {colorAttachment(color, LoadOp::Clear, {0, 0, 0, 1})};
        pass.depthAttachment.texture = depth;
        pass.depthAttachment.clearDepth = 1.0f;
        cmd.beginRenderPass(pass);
        setFullViewport(cmd, kW, kH);
        cmd.bindPipeline(pipeline);
        pushRect(cmd, rect(-1, -1, 0, 1, {1, 0, 0, 1}, 0.25f, 0.5f));
        cmd.draw(6);
        cmd.endRenderPass();
        const Barrier end[] = {Barrier::tex(color, Access::ColorTarget, Access::CopySrc),
                               Barrier::tex(depth, Access::DepthTargetWrite, Access::CopySrc)};
        cmd.barrier(end);
        submitAndWait(cmd);
        std::vector<uint8_t> image, depthBytes;
        readBoth(image, depthBytes);
        SCOPED_TRACE("after pass 1");
        check(image, depthBytes, {255, 0, 0, 255}, 0.75f, {0, 0, 0, 255}, 1.0f);
    }
    // Pass 2 (LoadOp::Load): green on the left at z = 0.5 (offset 0) passes only because the stored
    // depth is 0.75, not 0.25; blue everywhere at z = 0.3 with offset 0.3 (depth 0.6) fails on the
    // left (0.6 > 0.5) although its clip z would pass, and passes on the right (0.6 < 1).
    {
        CommandList& cmd = dev().beginCommandList("conservative depth 2");
        const Barrier begin[] = {Barrier::tex(color, Access::CopySrc, Access::ColorTarget),
                                 Barrier::tex(depth, Access::CopySrc, Access::DepthTargetWrite)};
        cmd.barrier(begin);
        RenderPassDesc pass;
        pass.colorAttachments = {colorAttachment(color, LoadOp::Load)};
        pass.depthAttachment.texture = depth;
        pass.depthAttachment.load = LoadOp::Load;
        cmd.beginRenderPass(pass);
        setFullViewport(cmd, kW, kH);
        cmd.bindPipeline(pipeline);
        pushRect(cmd, rect(-1, -1, 0, 1, {0, 1, 0, 1}, 0.5f, 0.0f));
        cmd.draw(6);
        pushRect(cmd, rect(-1, -1, 1, 1, {0, 0, 1, 1}, 0.3f, 0.3f));
        cmd.draw(6);
        cmd.endRenderPass();
        const Barrier end[] = {Barrier::tex(color, Access::ColorTarget, Access::CopySrc),
                               Barrier::tex(depth, Access::DepthTargetWrite, Access::CopySrc)};
        cmd.barrier(end);
        submitAndWait(cmd);
        std::vector<uint8_t> image, depthBytes;
        readBoth(image, depthBytes);
        SCOPED_TRACE("after pass 2");
        check(image, depthBytes, {0, 255, 0, 255}, 0.5f, {0, 0, 255, 255}, 0.3f + 0.3f);
    }
}

// An RGBA8_SRGB colour target stores sRGB-encoded values of the linear shader output and clear colour.
TEST_P(ConformanceRaster, SrgbColorTargetEncodes) {
    const uint32_t kW = 8, kH = 8;
    TextureHandle target = makeColorTarget(kW, kH, Format::RGBA8_SRGB);
    PipelineHandle pipeline =
        makeGraphicsPipeline(rectPipelineDesc({Format::RGBA8_SRGB}), penumbra::shaders::conf_rect::vertex(),
                             penumbra::shaders::conf_rect::fragment());
    ASSERT_TRUE(target.isValid() && pipeline.isValid());
    const std::array<float, 4> clear = {0.5f, 0.0f, 1.0f, 1.0f};
    const std::array<float, 4> drawn = {0.25f, 0.5f, 0.0f, 0.5f};

    CommandList& cmd = dev().beginCommandList("srgb");
    cmd.barrier(Barrier::tex(target, Access::None, Access::ColorTarget));
    RenderPassDesc pass;
    pass.colorAttachments = {colorAttachment(target, LoadOp::Clear, clear)};
    cmd.beginRenderPass(pass);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(pipeline);
    pushRect(cmd, rect(-1, -1, 0, 1, drawn));
    cmd.draw(6);
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(target, Access::ColorTarget, Access::CopySrc));
    submitAndWait(cmd);

    auto encode = [](const std::array<float, 4>& c) {
        return Rgba8{toUnorm8(srgbEncode(c[0])), toUnorm8(srgbEncode(c[1])), toUnorm8(srgbEncode(c[2])),
                     toUnorm8(c[3])};  // alpha is stored linearly
    };
    EXPECT_EQ(encode(clear)[0], 188);  // 0.5 linear -> 188 in sRGB
    const std::vector<uint8_t> image = readTexture(target, {}, Access::CopySrc);
    ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            // Metric: stored byte vs. round(255 * sRGB(linear)) (0.5 -> 188). Threshold: +-1.
            expectRgbaNear(pixel(image, kW, x, y), x < kW / 2 ? encode(drawn) : encode(clear), 1, x, y);
        }
    }
}

// A second render pass with LoadOp::Load keeps the first pass's contents.
TEST_P(ConformanceRaster, LoadOpLoadKeepsContents) {
    const uint32_t kW = 16, kH = 16;
    TextureHandle target = makeColorTarget(kW, kH);
    PipelineHandle pipeline =
        makeGraphicsPipeline(rectPipelineDesc({Format::RGBA8_UNORM}), penumbra::shaders::conf_rect::vertex(),
                             penumbra::shaders::conf_rect::fragment());
    ASSERT_TRUE(target.isValid() && pipeline.isValid());

    CommandList& cmd = dev().beginCommandList("load op");
    cmd.barrier(Barrier::tex(target, Access::None, Access::ColorTarget));
    RenderPassDesc first;
    first.colorAttachments = {colorAttachment(target, LoadOp::Clear, {1, 0, 0, 1})};
    cmd.beginRenderPass(first);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(pipeline);
    pushRect(cmd, rect(-1, -1, 0, 1, {0, 1, 0, 1}));  // left half green
    cmd.draw(6);
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(target, Access::ColorTarget, Access::ColorTarget));
    RenderPassDesc second;
    second.colorAttachments = {colorAttachment(target, LoadOp::Load)};
    cmd.beginRenderPass(second);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(pipeline);
    pushRect(cmd, rect(-1, -1, 1, 0, {0, 0, 1, 1}));  // top half (rows 0..7) blue
    cmd.draw(6);
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(target, Access::ColorTarget, Access::CopySrc));
    submitAndWait(cmd);

    const std::vector<uint8_t> image = readTexture(target, {}, Access::CopySrc);
    ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            const Rgba8 expected = y < kH / 2   ? Rgba8{0, 0, 255, 255}
                                   : x < kW / 2 ? Rgba8{0, 255, 0, 255}
                                                : Rgba8{255, 0, 0, 255};
            // Metric: top half blue (pass 2), bottom-left green and bottom-right red (pass 1 kept).
            // Threshold: exact.
            expectRgbaNear(pixel(image, kW, x, y), expected, 0, x, y);
        }
    }
}

// drawIndirect with two draw records written by updateBuffer in the same command list.
TEST_P(ConformanceRaster, DrawIndirectTwoDraws) {
    const uint32_t kW = 16, kH = 8;
    struct Vertex {
        float pos[3];
        float color[4];
    };
    std::vector<Vertex> vertices;
    auto quad = [&](float x0, float x1, std::array<float, 4> c) {
        const float corners[6][2] = {{x0, -1}, {x1, -1}, {x0, 1}, {x0, 1}, {x1, -1}, {x1, 1}};
        for (auto& p : corners) vertices.push_back({{p[0], p[1], 0.5f}, {c[0], c[1], c[2], c[3]}});
    };
    quad(-1.0f, -0.25f, {1, 0, 0, 1});  // columns 0..5 red
    quad(0.25f, 1.0f, {0, 1, 0, 1});    // columns 10..15 green
    BufferHandle vb = makeBufferFrom(vertices, BufferUsage::Vertex | BufferUsage::CopyDst);
    BufferHandle args = makeBuffer(64, BufferUsage::Indirect | BufferUsage::CopyDst);
    TextureHandle target = makeColorTarget(kW, kH);
    GraphicsPipelineDesc desc = rectPipelineDesc({Format::RGBA8_UNORM});
    desc.vertexBuffers = {{sizeof(Vertex), false}};
    desc.vertexAttributes = {{0, 0, Format::RGB32_FLOAT, 0}, {1, 0, Format::RGBA32_FLOAT, 12}};
    PipelineHandle pipeline = makeGraphicsPipeline(desc, penumbra::shaders::conf_mesh::vertex(),
                                                   penumbra::shaders::conf_mesh::fragment());
    ASSERT_TRUE(vb.isValid() && args.isValid() && target.isValid() && pipeline.isValid());

    // {vertexCount, instanceCount, firstVertex, firstInstance} x 2, at byte offset 16.
    const uint32_t records[8] = {6, 1, 0, 0, 6, 1, 6, 0};
    CommandList& cmd = dev().beginCommandList("draw indirect");
    cmd.updateBuffer(args, 16, records, sizeof(records));
    cmd.barrier(Barrier::buf(args, Access::CopyDst, Access::IndirectRead));
    cmd.barrier(Barrier::tex(target, Access::None, Access::ColorTarget));
    RenderPassDesc pass;
    pass.colorAttachments = {colorAttachment(target, LoadOp::Clear, {0, 0, 0, 1})};
    cmd.beginRenderPass(pass);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(pipeline);
    cmd.bindVertexBuffer(0, vb);
    cmd.drawIndirect(args, 16, 2);
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(target, Access::ColorTarget, Access::CopySrc));
    submitAndWait(cmd);

    const std::vector<uint8_t> image = readTexture(target, {}, Access::CopySrc);
    ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            const Rgba8 expected = x < 6     ? Rgba8{255, 0, 0, 255}
                                   : x >= 10 ? Rgba8{0, 255, 0, 255}
                                             : Rgba8{0, 0, 0, 255};
            // Metric: both indirect draws rendered their quad, nothing in between. Threshold: exact.
            expectRgbaNear(pixel(image, kW, x, y), expected, 0, x, y);
        }
    }
}

// drawIndexedIndirect with two 20-byte records (firstIndex and vertexOffset differ) written by
// updateBuffer at a non-zero offset in the same command list.
TEST_P(ConformanceRaster, DrawIndexedIndirectTwoDraws) {
    const uint32_t kW = 16, kH = 8;
    struct Vertex {
        float pos[3];
        float color[4];
    };
    std::vector<Vertex> vertices;
    auto quad = [&](float x0, float x1, std::array<float, 4> c) {
        const float corners[4][2] = {{x0, -1}, {x1, -1}, {x0, 1}, {x1, 1}};
        for (auto& p : corners) vertices.push_back({{p[0], p[1], 0.5f}, {c[0], c[1], c[2], c[3]}});
    };
    quad(-1.0f, -0.25f, {0, 0, 1, 1});  // columns 0..5 blue
    quad(0.25f, 1.0f, {1, 1, 0, 1});    // columns 10..15 yellow
    const std::vector<uint16_t> indices = {0, 1, 2, 2, 1, 3, 0, 1, 2, 2, 1, 3};
    BufferHandle vb = makeBufferFrom(vertices, BufferUsage::Vertex);
    BufferHandle ib = makeBufferFrom(indices, BufferUsage::Index);
    BufferHandle args = makeBuffer(64, BufferUsage::Indirect | BufferUsage::CopyDst);
    TextureHandle target = makeColorTarget(kW, kH);
    GraphicsPipelineDesc desc = rectPipelineDesc({Format::RGBA8_UNORM});
    desc.vertexBuffers = {{sizeof(Vertex), false}};
    desc.vertexAttributes = {{0, 0, Format::RGB32_FLOAT, 0}, {1, 0, Format::RGBA32_FLOAT, 12}};
    PipelineHandle pipeline = makeGraphicsPipeline(desc, penumbra::shaders::conf_mesh::vertex(),
                                                   penumbra::shaders::conf_mesh::fragment());
    ASSERT_TRUE(vb.isValid() && ib.isValid() && args.isValid() && target.isValid() && pipeline.isValid());

    // {indexCount, instanceCount, firstIndex, vertexOffset, firstInstance} x 2, at byte offset 20.
    const uint32_t records[10] = {6, 1, 0, 0, 0, 6, 1, 6, 4, 0};
    CommandList& cmd = dev().beginCommandList("draw indexed indirect");
    cmd.updateBuffer(args, 20, records, sizeof(records));
    cmd.barrier(Barrier::buf(args, Access::CopyDst, Access::IndirectRead));
    cmd.barrier(Barrier::tex(target, Access::None, Access::ColorTarget));
    RenderPassDesc pass;
    pass.colorAttachments = {colorAttachment(target, LoadOp::Clear, {0, 0, 0, 1})};
    cmd.beginRenderPass(pass);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(pipeline);
    cmd.bindVertexBuffer(0, vb);
    cmd.bindIndexBuffer(ib, IndexType::Uint16);
    cmd.drawIndexedIndirect(args, 20, 2);
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(target, Access::ColorTarget, Access::CopySrc));
    submitAndWait(cmd);

    const std::vector<uint8_t> image = readTexture(target, {}, Access::CopySrc);
    ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            const Rgba8 expected = x < 6     ? Rgba8{0, 0, 255, 255}
                                   : x >= 10 ? Rgba8{255, 255, 0, 255}
                                             : Rgba8{0, 0, 0, 255};
            // Metric: both indexed indirect draws rendered their quad, nothing in between. Threshold: exact.
            expectRgbaNear(pixel(image, kW, x, y), expected, 0, x, y);
        }
    }
}

// Per-vertex and per-instance vertex buffers (bound at an offset), a normalised RGBA8 attribute and
// firstInstance.
TEST_P(ConformanceRaster, InstancedDrawWithPerInstanceAttributes) {
    const uint32_t kW = 16, kH = 16;
    std::vector<float> perVertex = {9, 9, 9, 9};  // 16 bytes skipped through the binding offset
    const float corners[6][2] = {{0, 0}, {1, 0}, {0, 1}, {0, 1}, {1, 0}, {1, 1}};
    for (auto& c : corners) perVertex.insert(perVertex.end(), {c[0], c[1]});
    struct Instance {
        float offset[2];
        uint8_t color[4];
    };
    static_assert(sizeof(Instance) == 12);
    const std::vector<Instance> instances = {{{-1, -1}, {255, 0, 0, 255}},
                                             {{0, -1}, {0, 255, 0, 255}},
                                             {{-1, 0}, {0, 0, 255, 255}},
                                             {{0, 0}, {255, 255, 0, 255}}};
    BufferHandle vertexBuf = makeBufferFrom(perVertex, BufferUsage::Vertex | BufferUsage::CopyDst);
    BufferHandle instanceBuf = makeBufferFrom(instances, BufferUsage::Vertex | BufferUsage::CopyDst);
    TextureHandle target = makeColorTarget(kW, kH);
    GraphicsPipelineDesc desc = rectPipelineDesc({Format::RGBA8_UNORM});
    desc.vertexBuffers = {{8, false}, {sizeof(Instance), true}};
    desc.vertexAttributes = {
        {0, 0, Format::RG32_FLOAT, 0}, {1, 1, Format::RG32_FLOAT, 0}, {2, 1, Format::RGBA8_UNORM, 8}};
    PipelineHandle pipeline = makeGraphicsPipeline(desc, penumbra::shaders::conf_instanced::vertex(),
                                                   penumbra::shaders::conf_instanced::fragment());
    ASSERT_TRUE(vertexBuf.isValid() && instanceBuf.isValid() && target.isValid() && pipeline.isValid());

    CommandList& cmd = dev().beginCommandList("instanced");
    cmd.barrier(Barrier::tex(target, Access::None, Access::ColorTarget));
    RenderPassDesc pass;
    pass.colorAttachments = {colorAttachment(target, LoadOp::Clear, {0, 0, 0, 0})};
    cmd.beginRenderPass(pass);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(pipeline);
    cmd.bindVertexBuffer(0, vertexBuf, 16);
    cmd.bindVertexBuffer(1, instanceBuf);
    cmd.draw(6, 2, 0, 0);  // instances 0, 1
    cmd.draw(6, 2, 0, 2);  // instances 2, 3
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(target, Access::ColorTarget, Access::CopySrc));
    submitAndWait(cmd);

    const std::vector<uint8_t> image = readTexture(target, {}, Access::CopySrc);
    ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            const Instance& inst = instances[(y < kH / 2 ? 0 : 2) + (x < kW / 2 ? 0 : 1)];
            const Rgba8 expected = {inst.color[0], inst.color[1], inst.color[2], inst.color[3]};
            // Metric: each quadrant has its instance's colour. Threshold: exact.
            expectRgbaNear(pixel(image, kW, x, y), expected, 0, x, y);
        }
    }
}

// Two colour targets (RGBA8 + R32F) written by one fragment shader.
TEST_P(ConformanceRaster, MultipleRenderTargets) {
    const uint32_t kW = 8, kH = 4;
    TextureHandle colorTarget = makeColorTarget(kW, kH);
    TextureHandle valueTarget = makeColorTarget(kW, kH, Format::R32_FLOAT);
    PipelineHandle pipeline =
        makeGraphicsPipeline(rectPipelineDesc({Format::RGBA8_UNORM, Format::R32_FLOAT}),
                             penumbra::shaders::conf_mrt::vertex(), penumbra::shaders::conf_mrt::fragment());
    ASSERT_TRUE(colorTarget.isValid() && valueTarget.isValid() && pipeline.isValid());

    const float kValue = 0.123f;
    CommandList& cmd = dev().beginCommandList("mrt");
    const Barrier begin[] = {Barrier::tex(colorTarget, Access::None, Access::ColorTarget),
                             Barrier::tex(valueTarget, Access::None, Access::ColorTarget)};
    cmd.barrier(begin);
    RenderPassDesc pass;
    pass.colorAttachments = {colorAttachment(colorTarget, LoadOp::Clear, {0, 0, 0, 0}),
                             colorAttachment(valueTarget, LoadOp::Clear, {-1, 0, 0, 0})};
    cmd.beginRenderPass(pass);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(pipeline);
    pushRect(cmd, rect(-1, -1, 0, 1, {0, 1, 0, 1}, 0.5f, 0.0f, kValue));
    cmd.draw(6);
    cmd.endRenderPass();
    const Barrier end[] = {Barrier::tex(colorTarget, Access::ColorTarget, Access::CopySrc),
                           Barrier::tex(valueTarget, Access::ColorTarget, Access::CopySrc)};
    cmd.barrier(end);
    submitAndWait(cmd);

    const std::vector<uint8_t> image = readTexture(colorTarget, {}, Access::CopySrc);
    const std::vector<uint8_t> values = readTexture(valueTarget, {}, Access::CopySrc);
    ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
    ASSERT_EQ(values.size(), size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            const bool inside = x < kW / 2;
            // Metric: target 0 colour and target 1 value (drawn or cleared). Threshold: exact.
            expectRgbaNear(pixel(image, kW, x, y), inside ? Rgba8{0, 255, 0, 255} : Rgba8{0, 0, 0, 0}, 0, x,
                           y);
            EXPECT_EQ(pixelFloat(values, kW, x, y), inside ? kValue : -1.0f)
                << "pixel (" << x << ", " << y << ")";
        }
    }
}

// A fragment shader samples a texture (nearest) and reads a uniform buffer from a bind group.
TEST_P(ConformanceRaster, FragmentShaderSamplesTextureAndReadsUniform) {
    const uint32_t kW = 16, kH = 16, kTex = 4;
    std::vector<uint8_t> texels(kTex * kTex * 4);
    Rng rng(0x7E47u);
    for (auto& t : texels) t = uint8_t(rng.next() >> 24);
    TextureHandle texture =
        makeTexture2D(Format::RGBA8_UNORM, kTex, kTex, TextureUsage::Sampled | TextureUsage::CopyDst);
    const float tint[4] = {1.0f, 0.5f, 0.25f, 1.0f};
    BufferHandle uniforms =
        makeBuffer(sizeof(tint), BufferUsage::Uniform | BufferUsage::CopyDst, MemoryType::GpuOnly, tint);
    SamplerHandle sampler = makeSampler(Filter::Nearest, AddressMode::ClampToEdge);
    TextureHandle target = makeColorTarget(kW, kH);
    PipelineHandle pipeline = makeGraphicsPipeline(rectPipelineDesc({Format::RGBA8_UNORM}),
                                                   penumbra::shaders::conf_textured::vertex(),
                                                   penumbra::shaders::conf_textured::fragment());
    ASSERT_TRUE(texture.isValid() && uniforms.isValid() && sampler.isValid() && target.isValid() &&
                pipeline.isValid());
    dev().writeTexture(texture, {}, texels.data(), texels.size());
    BindGroupHandle group = makeBindGroup(
        pipeline, 0,
        {BindGroupEntry::makeSampled(0, texture, sampler), BindGroupEntry::makeBuffer(1, uniforms)});
    ASSERT_TRUE(group.isValid());

    CommandList& cmd = dev().beginCommandList("textured");
    cmd.barrier(Barrier::tex(target, Access::None, Access::ColorTarget));
    RenderPassDesc pass;
    pass.colorAttachments = {colorAttachment(target, LoadOp::DontCare)};
    cmd.beginRenderPass(pass);
    setFullViewport(cmd, kW, kH);
    cmd.bindPipeline(pipeline);
    cmd.bindGroup(0, group);
    pushRect(cmd, rect(-1, -1, 1, 1, {0, 0, 0, 0}));
    cmd.draw(6);
    cmd.endRenderPass();
    cmd.barrier(Barrier::tex(target, Access::ColorTarget, Access::CopySrc));
    submitAndWait(cmd);

    const std::vector<uint8_t> image = readTexture(target, {}, Access::CopySrc);
    ASSERT_EQ(image.size(), size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y) {
        for (uint32_t x = 0; x < kW; ++x) {
            const uint8_t* t = &texels[((y / 4) * kTex + x / 4) * 4];
            const Rgba8 expected = {toUnorm8(t[0] / 255.0 * tint[0]), toUnorm8(t[1] / 255.0 * tint[1]),
                                    toUnorm8(t[2] / 255.0 * tint[2]), toUnorm8(t[3] / 255.0 * tint[3])};
            // Metric: texel (x/4, y/4) (uv (0,0) = texture row 0 at image row 0) times the tint.
            // Threshold: +-1/255.
            expectRgbaNear(pixel(image, kW, x, y), expected, 1, x, y);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, ConformanceRaster, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
