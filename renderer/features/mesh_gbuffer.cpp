#include "renderer/passes/gbuffer_mesh.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <glm/geometric.hpp>

#include <shaders/gbuffer_mesh.h>
#include <shaders/gbuffer_mesh_albedo.h>

#include "renderer/passes/pass_common.h"
#include "renderer/scene_renderer.h"

namespace penumbra::render {

// The octahedral encoding of renderer/shaders/gbuffer.glsl, in C++.
glm::vec2 octEncode(glm::vec3 n) {
    const float l1 = std::abs(n.x) + std::abs(n.y) + std::abs(n.z);
    glm::vec2 p = glm::vec2(n.x, n.y) / l1;
    if (n.z >= 0.0f) return p;
    return glm::vec2((1.0f - std::abs(p.y)) * (p.x >= 0.0f ? 1.0f : -1.0f),
                     (1.0f - std::abs(p.x)) * (p.y >= 0.0f ? 1.0f : -1.0f));
}

glm::vec3 octDecode(glm::vec2 e) {
    glm::vec3 n(e.x, e.y, 1.0f - std::abs(e.x) - std::abs(e.y));
    const float t = std::max(-n.z, 0.0f);
    n.x += n.x >= 0.0f ? -t : t;
    n.y += n.y >= 0.0f ? -t : t;
    return glm::normalize(n);
}

GBufferMeshPass::GBufferMeshPass(rhi::Device& device) : m_device(device) {}

GBufferMeshPass::~GBufferMeshPass() {
    for (Variant& v : m_variants) {
        if (v.pipeline) m_device.destroy(v.pipeline);
        if (v.vs) m_device.destroy(v.vs);
        if (v.fs) m_device.destroy(v.fs);
    }
    if (m_sampler) m_device.destroy(m_sampler);
}

bool GBufferMeshPass::prepare(bool albedo, std::string& error) {
    Variant& v = m_variants[albedo ? 1 : 0];
    if (v.pipeline) return true;
    if (!v.vs)
        v.vs = m_device.createShader(albedo ? shaders::gbuffer_mesh_albedo::vertex()
                                            : shaders::gbuffer_mesh::vertex());
    if (!v.fs)
        v.fs = m_device.createShader(albedo ? shaders::gbuffer_mesh_albedo::fragment()
                                            : shaders::gbuffer_mesh::fragment());
    if (!v.vs || !v.fs) {
        error = "gbuffer_mesh: creating the shaders failed";
        return false;
    }
    rhi::GraphicsPipelineDesc d;
    d.vertexShader = v.vs;
    d.fragmentShader = v.fs;
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
    if (albedo) d.colorFormats.push_back(rhi::Format::RGBA8_SRGB);
    d.depthFormat = rhi::Format::D32_FLOAT;
    d.debugName = albedo ? "gbuffer_mesh_albedo" : "gbuffer_mesh";
    v.pipeline = m_device.createGraphicsPipeline(d);
    if (!v.pipeline) {
        error = std::string("gbuffer_mesh: creating the pipeline '") + d.debugName + "' failed";
        return false;
    }
    if (albedo && !m_sampler) {
        rhi::SamplerDesc s;
        s.addressU = s.addressV = s.addressW = rhi::AddressMode::Repeat;
        s.debugName = "gbuffer_mesh.base_color";
        m_sampler = m_device.createSampler(s);
        if (!m_sampler) {
            error = "gbuffer_mesh: creating the texture sampler failed";
            return false;
        }
    }
    return true;
}

uint64_t GBufferMeshPass::add(fg::FrameGraph& graph, const SceneBuffers& scene, const GBufferTargets& targets,
                              std::vector<MeshDraw> draws, uint32_t width, uint32_t height) {
    struct Data {
        GBufferTargets gb;
        fg::TextureRef depth;
        SceneBuffers scene;
        std::vector<MeshDraw> draws;
    };
    const bool albedo = targets.albedo.isValid();
    const rhi::PipelineHandle pipeline = m_variants[albedo ? 1 : 0].pipeline;
    const rhi::SamplerHandle sampler = m_sampler;
    const rhi::TextureDesc depthDesc = renderTargetDesc(rhi::Format::D32_FLOAT, width, height, "depth");
    graph.addPass<Data>(
        "gbuffer_mesh", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) {
            d.gb = targets;
            d.scene = scene;
            d.draws = std::move(draws);
            b.write(d.gb.depth, rhi::Access::ColorTarget);
            b.write(d.gb.normal, rhi::Access::ColorTarget);
            b.write(d.gb.material, rhi::Access::ColorTarget);
            b.write(d.gb.velocity, rhi::Access::ColorTarget);
            if (albedo) b.write(d.gb.albedo, rhi::Access::ColorTarget);
            d.depth = b.write(b.createTexture("depth", depthDesc), rhi::Access::DepthTargetWrite);
            b.read(d.scene.frame, rhi::Access::UniformRead);
            b.read(d.scene.objects, rhi::Access::ShaderRead);
            if (albedo) b.read(d.scene.materials, rhi::Access::ShaderRead);
            for (const MeshDraw& draw : d.draws) {
                // A mesh drawn several times is declared once (repeated reads merge).
                b.read(draw.vertices, rhi::Access::VertexRead);
                b.read(draw.indices, rhi::Access::IndexRead);
                if (albedo) b.read(draw.baseColor, rhi::Access::ShaderSampled);
            }
        },
        [pipeline, sampler, albedo, width, height](const Data& d, fg::PassContext& ctx) {
            std::vector<rhi::BindGroupEntry> sceneEntries = {
                rhi::BindGroupEntry::makeBuffer(0, ctx.buffer(d.scene.frame)),
                rhi::BindGroupEntry::makeBuffer(1, ctx.buffer(d.scene.objects))};
            if (albedo)
                sceneEntries.push_back(rhi::BindGroupEntry::makeBuffer(2, ctx.buffer(d.scene.materials)));
            rhi::BindGroupHandle sceneGroup =
                makeBindGroup(ctx.device, pipeline, 0, std::move(sceneEntries), "gbuffer_mesh.scene");
            // One bind group per distinct base-colour texture of the frame.
            std::unordered_map<uint32_t, rhi::BindGroupHandle> textureGroups;
            if (albedo) {
                for (const MeshDraw& draw : d.draws) {
                    rhi::TextureHandle tex = ctx.texture(draw.baseColor);
                    if (textureGroups.count(tex.value)) continue;
                    textureGroups[tex.value] = makeBindGroup(
                        ctx.device, pipeline, 1, {rhi::BindGroupEntry::makeSampled(0, tex, sampler)},
                        "gbuffer_mesh.base_color");
                }
            }

            rhi::RenderPassDesc rp;
            auto clear = [&](fg::TextureRef ref, std::array<float, 4> value) {
                rhi::ColorAttachment a;
                a.texture = ctx.texture(ref);
                a.load = rhi::LoadOp::Clear;
                a.clearColor = value;
                rp.colorAttachments.push_back(a);
            };
            clear(d.gb.depth, {0, 0, 0, 0});  // linear depth 0: nothing hit
            clear(d.gb.normal, {0, 0, 0, 0});
            clear(d.gb.material, {0, 0, 1, 1});  // index 0, unshadowed, unoccluded
            clear(d.gb.velocity, {0, 0, 0, 0});
            if (albedo) clear(d.gb.albedo, {0, 0, 0, 0});
            rp.depthAttachment.texture = ctx.texture(d.depth);
            rp.depthAttachment.load = rhi::LoadOp::Clear;
            rp.depthAttachment.store = rhi::StoreOp::DontCare;
            rp.depthAttachment.clearDepth = 1.0f;
            rp.debugName = "gbuffer_mesh";
            ctx.cmd.beginRenderPass(rp);
            ctx.cmd.setViewport({0, 0, float(width), float(height), 0, 1});
            ctx.cmd.setScissor({0, 0, width, height});
            ctx.cmd.bindPipeline(pipeline);
            ctx.cmd.bindGroup(0, sceneGroup);
            rhi::BindGroupHandle boundTexture;
            for (const MeshDraw& draw : d.draws) {
                if (albedo) {
                    rhi::BindGroupHandle g = textureGroups[ctx.texture(draw.baseColor).value];
                    if (g != boundTexture) {
                        ctx.cmd.bindGroup(1, g);
                        boundTexture = g;
                    }
                }
                GpuDrawPush push{glm::uvec4(draw.objectIndex, 0, 0, 0)};
                ctx.cmd.pushConstants(&push, sizeof(push));
                ctx.cmd.bindVertexBuffer(0, ctx.buffer(draw.vertices));
                ctx.cmd.bindIndexBuffer(ctx.buffer(draw.indices), rhi::IndexType::Uint32);
                ctx.cmd.drawIndexed(draw.indexCount);
            }
            ctx.cmd.endRenderPass();
            ctx.device.destroy(sceneGroup);
            for (auto& [tex, g] : textureGroups) ctx.device.destroy(g);
        });
    return textureBytes(depthDesc);
}

}  // namespace penumbra::render
