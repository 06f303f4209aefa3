// The "sdf_surface" pass (renderer/features/sdf_surface.h): one dispatch per textured SDF material.
#include "renderer/features/sdf_surface.h"

#include <shaders/sdf_surface.h>

#include "renderer/core/shader_params.h"
#include "renderer/features/sdf_scene.h"

namespace penumbra::render {

void addSdfSurface(FrameContext& fc, std::vector<SdfSurfaceMaterial> materials) {
    namespace program = shaders::sdf_surface;
    if (materials.empty()) return;
    struct Data {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        GBuffer gb;
        std::vector<SdfSurfaceMaterial> materials;
    };
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const uint32_t traced = fc.board.find<SdfSceneBuffers>()->tracedCount;
    // Textures repeat across the object; bilinear within the single mip level.
    rhi::SamplerDesc repeat;
    repeat.addressU = repeat.addressV = repeat.addressW = rhi::AddressMode::Repeat;
    repeat.debugName = "sdf_surface.repeat";
    const rhi::SamplerHandle sampler = fc.cache.sampler(repeat);
    const uint32_t width = fc.width, height = fc.height;
    fc.graph.addPass<Data>(
        "sdf_surface", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = *fc.board.find<SdfSceneBuffers>();
            d.gb = gbuffer;
            d.materials = std::move(materials);
            bool albedo = false;
            for (const SdfSurfaceMaterial& m : d.materials) {
                if (m.baseColor.isValid()) b.read(m.baseColor, rhi::Access::ShaderSampled);
                if (m.normal.isValid()) b.read(m.normal, rhi::Access::ShaderSampled);
                albedo = albedo || (m.baseColor.isValid() && d.gb.albedo.isValid());
            }
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.materials, rhi::Access::ShaderRead);
            b.read(d.sdf.objects, rhi::Access::ShaderRead);
            b.read(d.sdf.records, rhi::Access::ShaderRead);
            b.read(d.gb.depth, rhi::Access::ShaderRead);
            b.read(d.gb.material, rhi::Access::ShaderRead);
            // The normal is read at every pixel (the local normal weighs the projections) and
            // written where a normal map applies.
            b.write(d.gb.normal, rhi::Access::ShaderRead | rhi::Access::ShaderWrite);
            if (albedo) b.write(d.gb.albedo, rhi::Access::ShaderWrite);
        },
        [&cache = fc.cache, sampler, traced, width, height](const Data& d, fg::PassContext& ctx) {
            using V = program::Variant;
            for (const SdfSurfaceMaterial& m : d.materials) {
                const bool albedo = m.baseColor.isValid() && d.gb.albedo.isValid();
                const bool normal = m.normal.isValid();
                if (!albedo && !normal) continue;
                const V variant = albedo && normal ? V::AlbedoNormalMap : albedo ? V::Albedo : V::NormalMap;
                const rhi::ShaderDesc& cs = program::compute(variant);
                const rhi::PipelineHandle pipeline = cache.computePipeline(cs);
                ctx.cmd.bindPipeline(pipeline);
                ShaderParams params(cs);
                params.set("View", ctx.buffer(d.scene.view))
                    .set("Materials", ctx.buffer(d.scene.materials))
                    .set("SdfObjects", ctx.buffer(d.sdf.objects))
                    .set("ShapeRecords", ctx.buffer(d.sdf.records))
                    .setStorage("gbufferDepthImage", ctx.texture(d.gb.depth))
                    .setStorage("gbufferNormalImage", ctx.texture(d.gb.normal))
                    .setStorage("gbufferMaterialImage", ctx.texture(d.gb.material));
                if (albedo)
                    params.setStorage("gbufferAlbedoImage", ctx.texture(d.gb.albedo))
                        .set("baseColorTexture", ctx.texture(m.baseColor), sampler);
                if (normal) params.set("normalTexture", ctx.texture(m.normal), sampler);
                if (!params.bind(ctx.cmd, cache, pipeline)) return;
                const program::PushConstants push{glm::uvec4(m.material, traced, 0u, 0u)};
                ctx.cmd.pushConstants(&push, sizeof(push));
                dispatchOver(ctx.cmd, cs, width, height);
            }
        });
}

}  // namespace penumbra::render
