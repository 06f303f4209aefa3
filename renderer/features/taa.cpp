#include "renderer/features/taa.h"

#include <shaders/taa.h>

#include "renderer/core/shader_params.h"
#include "renderer/core/targets.h"
#include "renderer/features/fullscreen.h"  // gbufferSampler

namespace penumbra::render {
namespace {

float halton(uint32_t index, uint32_t base) {
    float f = 1.0f, r = 0.0f;
    for (uint32_t i = index; i > 0; i /= base) {
        f /= float(base);
        r += f * float(i % base);
    }
    return r;
}

}  // namespace

glm::vec2 taaJitter(uint32_t index) {
    const uint32_t i = index % kTaaJitterPhases + 1;
    return {halton(i, 2) - 0.5f, halton(i, 3) - 0.5f};
}

bool TaaHistory::begin(fg::FrameGraph& graph, uint32_t width, uint32_t height, bool reset,
                       std::string& error) {
    if (m_targets[0] && (width != m_width || height != m_height)) release(graph);
    if (!m_targets[0]) {
        using TU = rhi::TextureUsage;
        m_bytes = 0;
        static const char* const kNames[4] = {"taa.history0", "taa.history1", "taa.raw0", "taa.raw1"};
        for (uint32_t i = 0; i < 4; ++i) {
            // The resolved history at twice the size, the raw samples at 1x.
            const uint32_t scale = i < 2 ? kTaaHistoryScale : 1;
            const TU usage = TU::Storage | TU::Sampled;
            rhi::TextureDesc d =
                renderTargetDesc(rhi::Format::RGBA16_FLOAT, scale * width, scale * height, kNames[i], usage);
            m_targets[i] = m_device.createTexture(d);
            if (!m_targets[i]) {
                release(graph);
                error = "creating the " + std::to_string(width) + "x" + std::to_string(height) +
                        " TAA history failed";
                return false;
            }
            m_bytes += rhi::textureBytes(d);
        }
        m_width = width;
        m_height = height;
        reset = true;
    }
    if (reset) m_samples = 0;
    return true;
}

void TaaHistory::release(fg::FrameGraph& graph) {
    for (rhi::TextureHandle& t : m_targets) {
        if (t) {
            graph.forgetPersistent(t);
            m_device.destroy(t);
        }
        t = {};
    }
    m_width = m_height = 0;
    m_samples = 0;
    m_bytes = 0;
}

void TaaHistory::endFrame() {
    ++m_samples;
    m_write ^= 1u;
}

fg::TextureRef TaaHistory::add(FrameContext& fc, fg::TextureRef color) {
    namespace program = shaders::taa;
    struct Data {
        fg::BufferRef view;
        fg::TextureRef color, depth, velocity, history, rawHistory, out, rawOut;
    };
    const rhi::ShaderDesc& cs = program::compute();
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle nearest = gbufferSampler(fc.cache);
    rhi::SamplerDesc bilinear;
    bilinear.debugName = "taa.bilinear";
    const rhi::SamplerHandle linear = fc.cache.sampler(bilinear);
    const program::PushConstants push{
        glm::vec4(m_samples > 0 ? 1.0f : 0.0f, kTaaCurrentWeight, kTaaDepthTolerance, kTaaMovingWeight)};
    const fg::TextureRef history =
        fc.graph.importPersistent("taa.history", m_targets[m_write ^ 1u], rhi::Access::ShaderSampled);
    const fg::TextureRef target =
        fc.graph.importPersistent("taa.resolved", m_targets[m_write], rhi::Access::ShaderSampled);
    const fg::TextureRef rawHistory = fc.graph.importPersistent(
        "taa.rawHistory", m_targets[2 + (m_write ^ 1u)], rhi::Access::ShaderSampled);
    const fg::TextureRef rawTarget =
        fc.graph.importPersistent("taa.raw", m_targets[2 + m_write], rhi::Access::ShaderSampled);
    fg::TextureRef resolved;
    fc.graph.addPass<Data>(
        "taa", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            const GBuffer& gb = *fc.board.find<GBuffer>();
            d.view = b.read(fc.board.find<SceneBuffers>()->view, rhi::Access::UniformRead);
            d.color = b.read(color, rhi::Access::ShaderSampled);
            d.depth = b.read(gb.depth, rhi::Access::ShaderSampled);
            d.velocity = b.read(gb.velocity, rhi::Access::ShaderSampled);
            d.history = b.read(history, rhi::Access::ShaderSampled);
            d.rawHistory = b.read(rawHistory, rhi::Access::ShaderSampled);
            d.out = b.write(target, rhi::Access::ShaderWrite);
            d.rawOut = b.write(rawTarget, rhi::Access::ShaderWrite);
            resolved = d.out;
        },
        [&cache = fc.cache, &cs, pipeline, nearest, linear, push, w = m_width, h = m_height](
            const Data& d, fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.view))
                .set("sceneColor", ctx.texture(d.color), nearest)
                .set("gbufferDepth", ctx.texture(d.depth), nearest)
                .set("gbufferVelocity", ctx.texture(d.velocity), nearest)
                .set("history", ctx.texture(d.history), linear)
                .set("rawHistory", ctx.texture(d.rawHistory), nearest)
                .setStorage("historyOut", ctx.texture(d.out))
                .setStorage("rawOut", ctx.texture(d.rawOut));
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            dispatchOver(ctx.cmd, cs, w, h);
        });
    return resolved;
}

}  // namespace penumbra::render
