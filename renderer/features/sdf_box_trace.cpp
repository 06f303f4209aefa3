#include "renderer/features/sdf_box_trace.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <shaders/sdf_box_trace.h>

#include "renderer/core/shader_params.h"
#include "renderer/core/targets.h"
#include "renderer/features/mesh_gbuffer.h"
#include "renderer/features/sdf_trace.h"

namespace penumbra::render {

namespace {

namespace program = shaders::sdf_box_trace;

// trace.accel.x in sdf_march.glsl.
enum : uint32_t { kCullFlag = 1, kCountEvalsFlag = 16 };

// The near-plane classification keeps a margin so a corner just beyond the near plane (and its
// rounding in clipping) never clips a front face.
constexpr float kNearMargin = 1.01f;

rhi::GraphicsPipelineDesc pipelineDesc(bool albedo, bool aux) {
    rhi::GraphicsPipelineDesc d;
    // The box's triangles are counter-clockwise seen from outside (sdf_box_trace.vert): back-face
    // culling keeps the faces towards the camera, on which depth_greater holds.
    d.cullMode = rhi::CullMode::Back;
    d.frontFace = rhi::FrontFace::CounterClockwise;
    d.depthTest = true;
    d.depthWrite = true;
    d.depthCompare = rhi::CompareOp::Less;
    d.colorFormats = {rhi::Format::R32_FLOAT, rhi::Format::RG16_FLOAT, rhi::Format::RGBA8_UNORM,
                      rhi::Format::RG16_FLOAT};
    if (albedo) d.colorFormats.push_back(rhi::Format::RGBA8_UNORM);
    if (aux) d.colorFormats.push_back(rhi::Format::RG32_FLOAT);
    d.depthFormat = rhi::Format::D32_FLOAT;
    d.debugName = std::string("sdf_box_trace") + (albedo ? "[Albedo]" : "") + (aux ? "[Aux]" : "");
    return d;
}

rhi::ColorAttachment attachment(rhi::TextureHandle texture, bool load, std::array<float, 4> clear) {
    rhi::ColorAttachment a;
    a.texture = texture;
    a.load = load ? rhi::LoadOp::Load : rhi::LoadOp::Clear;
    a.clearColor = clear;
    return a;
}

}  // namespace

BoxDraw classifyBoxDraw(const GpuSdfObject& object, const glm::mat4& view, const glm::mat4& proj,
                        float nearPlane, float farPlane, double* coverage) {
    if (coverage) *coverage = 1.0;
    const glm::vec3 lo(object.boundsMin), hi(object.boundsMax);
    for (int k = 0; k < 3; ++k)
        if (std::abs(lo[k]) >= 0.5f * kSdfUnbounded || std::abs(hi[k]) >= 0.5f * kSdfUnbounded)
            return BoxDraw::Near;
    float nearest = 3.0e38f, farthest = -3.0e38f;
    glm::vec2 rmin(1.0f), rmax(-1.0f);
    for (uint32_t c = 0; c < 8; ++c) {
        const glm::vec3 local((c & 1u) ? hi.x : lo.x, (c & 2u) ? hi.y : lo.y, (c & 4u) ? hi.z : lo.z);
        const glm::vec4 v = view * (object.model * glm::vec4(local, 1.0f));
        const float depth = -v.z;  // linear view depth
        nearest = std::min(nearest, depth);
        farthest = std::max(farthest, depth);
        const glm::vec4 clip = proj * v;
        if (clip.w > 0.0f) {
            const glm::vec2 ndc = glm::vec2(clip) / clip.w;
            rmin = glm::min(rmin, ndc);
            rmax = glm::max(rmax, ndc);
        }
    }
    if (farthest < nearPlane || nearest > farPlane) {
        if (coverage) *coverage = 0.0;
        return BoxDraw::Skip;
    }
    if (nearest <= kNearMargin * nearPlane) return BoxDraw::Near;
    if (coverage) {
        const glm::vec2 a = glm::clamp(rmin, glm::vec2(-1.0f), glm::vec2(1.0f));
        const glm::vec2 b = glm::clamp(rmax, glm::vec2(-1.0f), glm::vec2(1.0f));
        *coverage = double(std::max(b.x - a.x, 0.0f)) * double(std::max(b.y - a.y, 0.0f)) / 4.0;
    }
    return BoxDraw::Box;
}

std::vector<const rhi::ShaderDesc*> sdfBoxTraceFragmentStages() {
    std::vector<const rhi::ShaderDesc*> out;
    for (uint32_t v = 0; v < program::kVariantCount; ++v)
        out.push_back(&program::fragment(program::Variant(v)));
    return out;
}

double boxCoverage(std::span<const GpuSdfObject> objects, const glm::mat4& view, const glm::mat4& proj,
                   float nearPlane, float farPlane) {
    double coverage = 0.0;
    for (const GpuSdfObject& o : objects) {
        double c = 0.0;
        classifyBoxDraw(o, view, proj, nearPlane, farPlane, &c);
        coverage += c;
    }
    return coverage;
}

scene::TraceMode resolveTraceMode(scene::TraceMode requested, uint32_t objects, double coverage) {
    if (requested != scene::TraceMode::Auto) return requested;
    return objects <= kAutoBoxMaxObjects && coverage <= kAutoBoxMaxCoverage ? scene::TraceMode::Box
                                                                            : scene::TraceMode::Fullscreen;
}

SdfBoxTraceReport addSdfBoxTrace(FrameContext& fc, const SdfBoxTraceDesc& desc) {
    struct Data {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        GBuffer gb;
        fg::TextureRef depth;
    };
    struct Draw {
        uint32_t object;
        bool nearPlane;
    };
    SdfBoxTraceReport report;
    std::vector<Draw> draws;
    draws.reserve(desc.objects.size());
    for (uint32_t i = 0; i < desc.objects.size(); ++i) {
        double coverage = 0.0;
        const BoxDraw how =
            classifyBoxDraw(desc.objects[i], desc.view, desc.proj, desc.nearPlane, desc.farPlane, &coverage);
        report.coverage += coverage;
        if (how == BoxDraw::Skip) {
            ++report.skipped;
            continue;
        }
        (how == BoxDraw::Near ? report.nearDraws : report.boxes) += 1;
        draws.push_back({i, how == BoxDraw::Near});
    }

    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    const bool albedo = gbuffer.albedo.isValid(), aux = gbuffer.aux.isValid();
    const auto variant = traceVariant<program::Variant>(gbuffer, sdfScene);
    const rhi::ShaderDesc& vs = program::vertex(variant);
    const rhi::ShaderDesc& fs = program::fragment(variant);
    const rhi::PipelineHandle pipeline = fc.cache.graphicsPipeline(vs, fs, pipelineDesc(albedo, aux));
    const rhi::SamplerHandle sampler = sdfAtlasSampler(fc.cache, sdfScene);
    const scene::TraceSettings& s = desc.settings;
    const program::PushConstants push{
        glm::uvec4(uint32_t(desc.objects.size()), 0u, s.maxSteps, s.refineSteps),
        glm::vec4(s.hitEpsilon, s.normalEpsilon, s.overRelaxation, s.fieldSafety),
        glm::vec4(desc.nearPlane, desc.farPlane, desc.footprint, 0.0f),
        glm::uvec4(kCullFlag | (desc.countEvaluations ? kCountEvalsFlag : 0u), 0u, 0u, 0u), glm::uvec4(0u)};
    const MeshDepth* meshDepth = desc.raster ? fc.board.find<MeshDepth>() : nullptr;
    const bool load = meshDepth != nullptr;
    const rhi::TextureDesc depthDesc =
        renderTargetDesc(rhi::Format::D32_FLOAT, fc.width, fc.height, "sdf_box.depth");
    fc.graph.addPass<Data>(
        "sdf_box_trace", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = sdfScene;
            d.gb = gbuffer;
            for (fg::TextureRef t :
                 {d.gb.depth, d.gb.normal, d.gb.material, d.gb.velocity, d.gb.albedo, d.gb.aux})
                if (t.isValid()) b.write(t, rhi::Access::ColorTarget);
            d.depth = b.write(load ? meshDepth->depth : b.createTexture("sdf_box.depth", depthDesc),
                              rhi::Access::DepthTargetWrite);
            b.read(d.scene.view, rhi::Access::UniformRead);
            if (albedo) b.read(d.scene.materials, rhi::Access::ShaderRead);
            readSdfScene(b, d.sdf);
        },
        [&cache = fc.cache, &vs, &fs, pipeline, sampler, push, albedo, load, draws = std::move(draws)](
            const Data& d, fg::PassContext& ctx) {
            rhi::RenderPassDesc rp;
            // Without meshes: the values sdf_trace writes where nothing is hit.
            rp.colorAttachments = {attachment(ctx.texture(d.gb.depth), load, {0, 0, 0, 0}),
                                   attachment(ctx.texture(d.gb.normal), load, {0, 0, 0, 0}),
                                   attachment(ctx.texture(d.gb.material), load, {0, 0, 0, 0}),
                                   attachment(ctx.texture(d.gb.velocity), load, {0, 0, 0, 0})};
            if (albedo)
                rp.colorAttachments.push_back(attachment(ctx.texture(d.gb.albedo), load, {0, 0, 0, 0}));
            if (d.gb.aux.isValid())
                rp.colorAttachments.push_back(attachment(ctx.texture(d.gb.aux), load, {-1, 0, 0, 0}));
            rp.depthAttachment.texture = ctx.texture(d.depth);
            rp.depthAttachment.load = load ? rhi::LoadOp::Load : rhi::LoadOp::Clear;
            rp.depthAttachment.store = rhi::StoreOp::DontCare;
            rp.depthAttachment.clearDepth = 1.0f;
            rp.debugName = "sdf_box_trace";
            const rhi::TextureDesc& size = ctx.textureDesc(d.depth);
            ctx.cmd.beginRenderPass(rp);
            ctx.cmd.setViewport({0, 0, float(size.width), float(size.height), 0, 1});
            ctx.cmd.setScissor({0, 0, size.width, size.height});
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(vs, fs);
            params.set("View", ctx.buffer(d.scene.view));
            if (albedo) params.set("Materials", ctx.buffer(d.scene.materials));
            setSdfScene(params, ctx, d.sdf, sampler);
            if (params.bind(ctx.cmd, cache, pipeline)) {
                for (const Draw& draw : draws) {
                    program::PushConstants p = push;
                    p.draw = glm::uvec4(draw.object, draw.nearPlane ? 1u : 0u, 0u, 0u);
                    ctx.cmd.pushConstants(&p, sizeof(p));
                    ctx.cmd.draw(draw.nearPlane ? 3u : 36u);
                }
            }
            ctx.cmd.endRenderPass();
        });
    return report;
}

}  // namespace penumbra::render
