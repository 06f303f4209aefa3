#include "renderer/passes/deferred_lighting.h"

#include <shaders/deferred_lighting.h>
#include <shaders/deferred_lighting_albedo.h>

#include "renderer/passes/pass_common.h"

namespace penumbra::render {

DeferredLightingPass::DeferredLightingPass(rhi::Device& device) : m_device(device) {}

DeferredLightingPass::~DeferredLightingPass() {
    for (Variant& v : m_variants) {
        if (v.pipeline) m_device.destroy(v.pipeline);
        if (v.vs) m_device.destroy(v.vs);
        if (v.fs) m_device.destroy(v.fs);
    }
    if (m_sampler) m_device.destroy(m_sampler);
}

bool DeferredLightingPass::prepare(bool albedo, bool srgbTarget, std::string& error) {
    Variant& v = m_variants[variantIndex(albedo, srgbTarget)];
    if (v.pipeline) return true;
    if (!v.vs)
        v.vs = m_device.createShader(albedo ? shaders::deferred_lighting_albedo::vertex()
                                            : shaders::deferred_lighting::vertex());
    if (!v.fs)
        v.fs = m_device.createShader(albedo ? shaders::deferred_lighting_albedo::fragment()
                                            : shaders::deferred_lighting::fragment());
    if (!v.vs || !v.fs) {
        error = "lighting: creating the shaders failed";
        return false;
    }
    rhi::GraphicsPipelineDesc d;
    d.vertexShader = v.vs;
    d.fragmentShader = v.fs;
    d.colorFormats = {srgbTarget ? rhi::Format::RGBA8_SRGB : rhi::Format::RGBA8_UNORM};
    d.debugName = albedo ? "deferred_lighting_albedo" : "deferred_lighting";
    v.pipeline = m_device.createGraphicsPipeline(d);
    if (!v.pipeline) {
        error = std::string("lighting: creating the pipeline '") + d.debugName + "' failed";
        return false;
    }
    if (!m_sampler) {
        rhi::SamplerDesc s;
        s.minFilter = s.magFilter = rhi::Filter::Nearest;
        s.debugName = "lighting.gbuffer";
        m_sampler = m_device.createSampler(s);
        if (!m_sampler) {
            error = "lighting: creating the G-buffer sampler failed";
            return false;
        }
    }
    return true;
}

void DeferredLightingPass::add(fg::FrameGraph& graph, const SceneBuffers& scene,
                               const GBufferTargets& gbuffer, fg::TextureRef output, bool srgbTarget,
                               uint32_t width, uint32_t height) {
    struct Data {
        SceneBuffers scene;
        GBufferTargets gb;
        fg::TextureRef output;
    };
    const bool albedo = gbuffer.albedo.isValid();
    const rhi::PipelineHandle pipeline = m_variants[variantIndex(albedo, srgbTarget)].pipeline;
    const rhi::SamplerHandle sampler = m_sampler;
    graph.addPass<Data>(
        "lighting", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = scene;
            d.gb = gbuffer;
            d.output = b.write(output, rhi::Access::ColorTarget);
            b.read(d.scene.frame, rhi::Access::UniformRead);
            b.read(d.scene.materials, rhi::Access::ShaderRead);
            b.read(d.scene.lights, rhi::Access::ShaderRead);
            b.read(d.gb.depth, rhi::Access::ShaderSampled);
            b.read(d.gb.normal, rhi::Access::ShaderSampled);
            b.read(d.gb.material, rhi::Access::ShaderSampled);
            if (albedo) b.read(d.gb.albedo, rhi::Access::ShaderSampled);
        },
        [pipeline, sampler, albedo, width, height](const Data& d, fg::PassContext& ctx) {
            rhi::BindGroupHandle sceneGroup =
                makeBindGroup(ctx.device, pipeline, 0,
                              {rhi::BindGroupEntry::makeBuffer(0, ctx.buffer(d.scene.frame)),
                               rhi::BindGroupEntry::makeBuffer(1, ctx.buffer(d.scene.materials)),
                               rhi::BindGroupEntry::makeBuffer(2, ctx.buffer(d.scene.lights))},
                              "lighting.scene");
            std::vector<rhi::BindGroupEntry> gbEntries = {
                rhi::BindGroupEntry::makeSampled(0, ctx.texture(d.gb.depth), sampler),
                rhi::BindGroupEntry::makeSampled(1, ctx.texture(d.gb.normal), sampler),
                rhi::BindGroupEntry::makeSampled(2, ctx.texture(d.gb.material), sampler)};
            if (albedo)
                gbEntries.push_back(rhi::BindGroupEntry::makeSampled(3, ctx.texture(d.gb.albedo), sampler));
            rhi::BindGroupHandle gbGroup =
                makeBindGroup(ctx.device, pipeline, 1, std::move(gbEntries), "lighting.gbuffer");
            rhi::RenderPassDesc rp;
            rhi::ColorAttachment a;
            a.texture = ctx.texture(d.output);
            a.load = rhi::LoadOp::DontCare;  // every pixel is written
            rp.colorAttachments = {a};
            rp.debugName = "lighting";
            ctx.cmd.beginRenderPass(rp);
            ctx.cmd.setViewport({0, 0, float(width), float(height), 0, 1});
            ctx.cmd.setScissor({0, 0, width, height});
            ctx.cmd.bindPipeline(pipeline);
            ctx.cmd.bindGroup(0, sceneGroup);
            ctx.cmd.bindGroup(1, gbGroup);
            ctx.cmd.draw(3);
            ctx.cmd.endRenderPass();
            ctx.device.destroy(sceneGroup);
            ctx.device.destroy(gbGroup);
        });
}

void DeferredLightingPass::addBackground(fg::FrameGraph& graph, fg::TextureRef output,
                                         std::array<float, 4> encoded) {
    struct Data {
        fg::TextureRef output;
    };
    graph.addPass<Data>(
        "lighting", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) { d.output = b.write(output, rhi::Access::ColorTarget); },
        [encoded](const Data& d, fg::PassContext& ctx) {
            rhi::RenderPassDesc rp;
            rhi::ColorAttachment a;
            a.texture = ctx.texture(d.output);
            a.load = rhi::LoadOp::Clear;
            a.clearColor = encoded;
            rp.colorAttachments = {a};
            rp.debugName = "lighting.background";
            ctx.cmd.beginRenderPass(rp);
            ctx.cmd.endRenderPass();
        });
}

}  // namespace penumbra::render
