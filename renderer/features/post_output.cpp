#include "renderer/features/post_output.h"

#include <shaders/motion_blur_tiles.h>
#include <shaders/post_output.h>

#include "renderer/core/shader_params.h"
#include "renderer/core/targets.h"
#include "renderer/features/fullscreen.h"

namespace penumbra::render {
namespace {

// "motion_blur_tiles": the largest motion per kMotionBlurTile^2 block.
fg::TextureRef addMotionBlurTiles(FrameContext& fc) {
    namespace program = shaders::motion_blur_tiles;
    struct Data {
        fg::BufferRef view;
        fg::TextureRef velocity, tiles;
    };
    const rhi::ShaderDesc& cs = program::compute();
    const rhi::PipelineHandle pipeline = fc.cache.computePipeline(cs);
    const rhi::SamplerHandle nearest = gbufferSampler(fc.cache);
    const uint32_t tilesX = (fc.width + kMotionBlurTile - 1) / kMotionBlurTile;
    const uint32_t tilesY = (fc.height + kMotionBlurTile - 1) / kMotionBlurTile;
    const program::PushConstants push{glm::uvec4(kMotionBlurTile, tilesX, tilesY, 0)};
    fg::TextureRef tiles;
    fc.graph.addPass<Data>(
        "motion_blur_tiles", fg::PassKind::Compute,
        [&](fg::PassBuilder& b, Data& d) {
            using TU = rhi::TextureUsage;
            d.view = b.read(fc.board.find<SceneBuffers>()->view, rhi::Access::UniformRead);
            d.velocity = b.read(fc.board.find<GBuffer>()->velocity, rhi::Access::ShaderSampled);
            d.tiles =
                b.write(b.createTexture("motion_blur.tiles",
                                        renderTargetDesc(rhi::Format::RG16_FLOAT, tilesX, tilesY,
                                                         "motion_blur.tiles", TU::Storage | TU::Sampled)),
                        rhi::Access::ShaderWrite);
            tiles = d.tiles;
        },
        [&cache = fc.cache, &cs, pipeline, nearest, push, tilesX, tilesY](const Data& d,
                                                                          fg::PassContext& ctx) {
            ctx.cmd.bindPipeline(pipeline);
            ShaderParams params(cs);
            params.set("View", ctx.buffer(d.view))
                .set("gbufferVelocity", ctx.texture(d.velocity), nearest)
                .setStorage("velocityTilesImage", ctx.texture(d.tiles));
            if (!params.bind(ctx.cmd, cache, pipeline)) return;
            ctx.cmd.pushConstants(&push, sizeof(push));
            dispatchOver(ctx.cmd, cs, tilesX, tilesY);
        });
    return tiles;
}

}  // namespace

void addPostOutput(FrameContext& fc, fg::TextureRef color, const scene::MotionBlurSettings& blur,
                   bool supersampled) {
    namespace program = shaders::post_output;
    struct Data {
        fg::BufferRef view;
        fg::TextureRef color, depth, velocity, tiles, output;
    };
    const bool motionBlur = blur.enabled;
    const fg::TextureRef tiles = motionBlur ? addMotionBlurTiles(fc) : fg::TextureRef{};
    using V = program::Variant;
    const V variant = motionBlur ? V::MotionBlur : V::Default;
    const FullscreenProgram prog =
        fullscreenProgram(fc, program::vertex(variant), program::fragment(variant));
    const Output& out = *fc.board.find<Output>();
    rhi::SamplerDesc bilinear;
    bilinear.debugName = "post_output.bilinear";
    const rhi::SamplerHandle linear = supersampled ? fc.cache.sampler(bilinear) : prog.nearest;
    const program::PushConstants push{
        glm::uvec4(out.srgbTarget ? 1u : 0u, blur.samples, kMotionBlurTile, supersampled ? 1u : 0u),
        glm::vec4(blur.strength, 0.0f, 0.0f, 0.0f)};
    fc.graph.addPass<Data>(
        "post_output", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) {
            d.view = b.read(fc.board.find<SceneBuffers>()->view, rhi::Access::UniformRead);
            d.color = b.read(color, rhi::Access::ShaderSampled);
            if (motionBlur) {
                const GBuffer& gb = *fc.board.find<GBuffer>();
                d.depth = b.read(gb.depth, rhi::Access::ShaderSampled);
                d.velocity = b.read(gb.velocity, rhi::Access::ShaderSampled);
                d.tiles = b.read(tiles, rhi::Access::ShaderSampled);
            }
            d.output = b.write(out.color, rhi::Access::ColorTarget);
        },
        [&cache = fc.cache, prog, push, motionBlur, linear](const Data& d, fg::PassContext& ctx) {
            beginFullscreen(ctx, d.output, prog.pipeline, "post_output");
            ShaderParams params(*prog.vertex, *prog.fragment);
            params.set("View", ctx.buffer(d.view)).set("sceneColor", ctx.texture(d.color), linear);
            if (motionBlur)
                params.set("gbufferDepth", ctx.texture(d.depth), prog.nearest)
                    .set("gbufferVelocity", ctx.texture(d.velocity), prog.nearest)
                    .set("velocityTiles", ctx.texture(d.tiles), prog.nearest);
            ctx.cmd.pushConstants(&push, sizeof(push));
            drawFullscreen(ctx, params, cache, prog.pipeline);
        });
}

}  // namespace penumbra::render
