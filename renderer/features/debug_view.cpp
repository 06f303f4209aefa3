#include "renderer/features/debug_view.h"

#include <shaders/debug_view.h>

#include "renderer/core/shader_params.h"
#include "renderer/features/lighting.h"

namespace penumbra::render {

namespace {
constexpr const char* kNames[] = {"none", "normals", "depth", "albedo"};
}

const char* toString(DebugView view) { return kNames[uint32_t(view) < 4 ? uint32_t(view) : 0]; }

bool parseDebugView(std::string_view text, DebugView& out) {
    for (uint32_t i = 0; i < 4; ++i)
        if (text == kNames[i]) {
            out = DebugView(i);
            return true;
        }
    return false;
}

void addDebugView(FrameContext& fc, DebugView view, float depthRange) {
    namespace program = shaders::debug_view;
    struct Data {
        SceneBuffers scene;
        GBuffer gb;
        fg::TextureRef output;
    };
    // 1. Choose the shader variant and get the cached pipeline and sampler.
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const bool albedo = gbuffer.albedo.isValid();
    const auto variant = albedo ? program::Variant::Albedo : program::Variant::Default;
    const rhi::ShaderDesc& vs = program::vertex(variant);
    const rhi::ShaderDesc& fs = program::fragment(variant);
    rhi::GraphicsPipelineDesc pd;
    pd.colorFormats = {fc.board.find<Output>()->srgbTarget ? rhi::Format::RGBA8_SRGB
                                                           : rhi::Format::RGBA8_UNORM};
    const rhi::PipelineHandle pipeline = fc.cache.graphicsPipeline(vs, fs, pd);
    rhi::SamplerDesc nearest;
    nearest.minFilter = nearest.magFilter = rhi::Filter::Nearest;
    const rhi::SamplerHandle sampler = fc.cache.sampler(nearest);
    // 2. The push-constant block, through the struct shaderc generated from the shader.
    const program::PushConstants push{glm::uvec4(uint32_t(view) - 1, 0, 0, 0),
                                      glm::vec4(depthRange, 0, 0, 0)};
    fc.graph.addPass<Data>(
        "debug_view", fg::PassKind::Raster,
        // 3. Declare what the pass reads and writes; the graph places the barriers.
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.gb = gbuffer;
            d.output = b.write(fc.board.find<Output>()->color, rhi::Access::ColorTarget);
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.scene, rhi::Access::UniformRead);
            b.read(d.scene.materials, rhi::Access::ShaderRead);
            for (fg::TextureRef t : {d.gb.depth, d.gb.normal, d.gb.material, d.gb.albedo})
                if (t.isValid()) b.read(t, rhi::Access::ShaderSampled);
        },
        // 4. Record: bind parameters by name, push constants, draw the full-screen triangle.
        [&cache = fc.cache, &vs, &fs, pipeline, sampler, albedo, push](const Data& d, fg::PassContext& ctx) {
            beginFullscreen(ctx, d.output, pipeline, "debug_view");
            ShaderParams params(vs, fs);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Scene", ctx.buffer(d.scene.scene))
                .set("Materials", ctx.buffer(d.scene.materials))
                .set("gbufferDepth", ctx.texture(d.gb.depth), sampler)
                .set("gbufferNormal", ctx.texture(d.gb.normal), sampler)
                .set("gbufferMaterial", ctx.texture(d.gb.material), sampler);
            if (albedo) params.set("gbufferAlbedo", ctx.texture(d.gb.albedo), sampler);
            ctx.cmd.pushConstants(&push, sizeof(push));
            drawFullscreen(ctx, params, cache, pipeline);
        });
}

}  // namespace penumbra::render
