#include "renderer/features/mesh_gbuffer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>

#include <shaders/gbuffer_mesh.h>

#include "renderer/core/shader_params.h"
#include "renderer/core/targets.h"
#include "renderer/features/gpu_scene.h"

namespace penumbra::render {
namespace {

namespace program = shaders::gbuffer_mesh;

rhi::GraphicsPipelineDesc pipelineDesc(bool albedo, bool aux) {
    rhi::GraphicsPipelineDesc d;
    d.vertexBuffers = {{sizeof(GpuVertex), false}};
    d.vertexAttributes = {{0, 0, rhi::Format::RGB32_FLOAT, offsetof(GpuVertex, position)},
                          {1, 0, rhi::Format::RGB32_FLOAT, offsetof(GpuVertex, normal)},
                          {2, 0, rhi::Format::RG32_FLOAT, offsetof(GpuVertex, uv)}};
    // Meshes are drawn two-sided with their authored normals (open meshes and files with
    // inconsistent winding stay visible); closed meshes hide their back faces by the depth test.
    d.cullMode = rhi::CullMode::None;
    d.depthTest = true;
    d.depthWrite = true;
    d.depthCompare = rhi::CompareOp::Less;
    d.colorFormats = {rhi::Format::R32_FLOAT, rhi::Format::RG16_FLOAT, rhi::Format::RGBA8_UNORM,
                      rhi::Format::RG16_FLOAT};
    if (albedo) d.colorFormats.push_back(rhi::Format::RGBA8_UNORM);
    if (aux) d.colorFormats.push_back(rhi::Format::RG32_FLOAT);
    d.depthFormat = rhi::Format::D32_FLOAT;
    d.debugName = std::string("gbuffer_mesh") + (albedo ? "[Albedo]" : "") + (aux ? "[Aux]" : "");
    return d;
}

rhi::ColorAttachment cleared(rhi::TextureHandle texture, std::array<float, 4> value) {
    rhi::ColorAttachment a;
    a.texture = texture;
    a.load = rhi::LoadOp::Clear;
    a.clearColor = value;
    return a;
}

}  // namespace

uint64_t addMeshGBuffer(FrameContext& fc, std::vector<MeshDraw> draws, bool keepDepth) {
    struct Data {
        GBuffer gb;
        SceneBuffers scene;
        fg::TextureRef depth;
        std::vector<MeshDraw> draws;
    };
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const bool albedo = gbuffer.albedo.isValid(), aux = gbuffer.aux.isValid();
    using V = program::Variant;
    const V variant = aux ? (albedo ? V::AlbedoAux : V::Aux) : (albedo ? V::Albedo : V::Default);
    const rhi::ShaderDesc& vs = program::vertex(variant);
    const rhi::ShaderDesc& fs = program::fragment(variant);
    const rhi::PipelineHandle pipeline = fc.cache.graphicsPipeline(vs, fs, pipelineDesc(albedo, aux));
    rhi::SamplerDesc samplerDesc;
    samplerDesc.addressU = samplerDesc.addressV = samplerDesc.addressW = rhi::AddressMode::Repeat;
    const rhi::SamplerHandle sampler = albedo ? fc.cache.sampler(samplerDesc) : rhi::SamplerHandle{};
    const rhi::TextureDesc depthDesc = renderTargetDesc(rhi::Format::D32_FLOAT, fc.width, fc.height, "depth");
    fc.graph.addPass<Data>(
        "gbuffer_mesh", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) {
            d.gb = gbuffer;
            d.scene = *fc.board.find<SceneBuffers>();
            d.draws = std::move(draws);
            for (fg::TextureRef t :
                 {d.gb.depth, d.gb.normal, d.gb.material, d.gb.velocity, d.gb.albedo, d.gb.aux})
                if (t.isValid()) b.write(t, rhi::Access::ColorTarget);
            d.depth = b.write(b.createTexture("depth", depthDesc), rhi::Access::DepthTargetWrite);
            if (keepDepth) fc.board.add<MeshDepth>().depth = d.depth;
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.objects, rhi::Access::ShaderRead);
            if (albedo) b.read(d.scene.materials, rhi::Access::ShaderRead);
            for (const MeshDraw& draw : d.draws) {  // repeated reads of one mesh merge
                b.read(draw.vertices, rhi::Access::VertexRead);
                b.read(draw.indices, rhi::Access::IndexRead);
                if (albedo) b.read(draw.baseColor, rhi::Access::ShaderSampled);
            }
        },
        [&cache = fc.cache, &vs, &fs, pipeline, sampler, albedo, keepDepth](const Data& d,
                                                                            fg::PassContext& ctx) {
            rhi::RenderPassDesc rp;
            rp.colorAttachments = {
                cleared(ctx.texture(d.gb.depth), {0, 0, 0, 0}),  // depth 0: nothing hit
                cleared(ctx.texture(d.gb.normal), {0, 0, 0, 0}),
                cleared(ctx.texture(d.gb.material), {0, 0, 1, 1}),  // unshadowed, unoccluded
                cleared(ctx.texture(d.gb.velocity), {0, 0, 0, 0})};
            if (albedo) rp.colorAttachments.push_back(cleared(ctx.texture(d.gb.albedo), {0, 0, 0, 0}));
            if (d.gb.aux.isValid())
                rp.colorAttachments.push_back(
                    cleared(ctx.texture(d.gb.aux), {-1, 0, 0, 0}));  // background id
            rp.depthAttachment.texture = ctx.texture(d.depth);
            rp.depthAttachment.load = rhi::LoadOp::Clear;
            rp.depthAttachment.store = keepDepth ? rhi::StoreOp::Store : rhi::StoreOp::DontCare;
            rp.depthAttachment.clearDepth = 1.0f;
            rp.debugName = "gbuffer_mesh";
            const rhi::TextureDesc& size = ctx.textureDesc(d.depth);
            ctx.cmd.beginRenderPass(rp);
            ctx.cmd.setViewport({0, 0, float(size.width), float(size.height), 0, 1});
            ctx.cmd.setScissor({0, 0, size.width, size.height});
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(vs, fs);
            params.set("View", ctx.buffer(d.scene.view)).set("Objects", ctx.buffer(d.scene.objects));
            if (albedo) params.set("Materials", ctx.buffer(d.scene.materials));
            for (const MeshDraw& draw : d.draws) {
                // Per draw: the material's texture (set 3); unchanged groups are not rebound.
                if (albedo) params.set("baseColorTexture", ctx.texture(draw.baseColor), sampler);
                if (!params.bind(ctx.cmd, cache, pipeline)) break;
                const program::PushConstants push{glm::uvec4(draw.objectIndex, 0, 0, 0)};
                ctx.cmd.pushConstants(&push, sizeof(push));
                ctx.cmd.bindVertexBuffer(0, ctx.buffer(draw.vertices));
                ctx.cmd.bindIndexBuffer(ctx.buffer(draw.indices), rhi::IndexType::Uint32);
                ctx.cmd.drawIndexed(draw.indexCount);
            }
            ctx.cmd.endRenderPass();
        });
    return rhi::textureBytes(depthDesc);
}

}  // namespace penumbra::render
