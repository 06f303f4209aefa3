#include "renderer/features/debug_field_slice.h"

#include <shaders/debug_field_slice.h>

#include "renderer/features/fullscreen.h"
#include "renderer/features/sdf_scene.h"

namespace penumbra::render {

void addDebugFieldSlice(FrameContext& fc, const FieldSliceDesc& desc) {
    namespace program = shaders::debug_field_slice;
    struct Data {
        SceneBuffers scene;
        SdfSceneBuffers sdf;
        fg::TextureRef output;
    };
    if (!fc.board.has<SdfSceneBuffers>()) {
        static const SdfSceneData kNoObjects;  // one zero record and object; objectCount 0
        addSdfSceneUpload(fc, kNoObjects);
    }
    const SdfSceneBuffers& sdfScene = *fc.board.find<SdfSceneBuffers>();
    const bool fields = sdfScene.atlas.isValid();
    const auto variant = fields ? program::Variant::SdfFields : program::Variant::Default;
    const FullscreenProgram prog =
        fullscreenProgram(fc, program::vertex(variant), program::fragment(variant));
    const rhi::SamplerHandle sampler = sdfAtlasSampler(fc.cache, sdfScene);
    const program::PushConstants push{
        glm::uvec4(sdfScene.objectCount, 0, 0, 0), desc.plane,
        glm::vec4(kFieldSliceIsoSpacing, desc.fieldSafety, desc.nearPlane, desc.farPlane)};
    fc.graph.addPass<Data>(
        "debug_field_slice", fg::PassKind::Raster,
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.sdf = sdfScene;
            d.output = b.write(fc.board.find<Output>()->color, rhi::Access::ColorTarget);
            b.read(d.scene.view, rhi::Access::UniformRead);
            readSdfScene(b, d.sdf);
        },
        [&cache = fc.cache, prog, sampler, push](const Data& d, fg::PassContext& ctx) {
            beginFullscreen(ctx, d.output, prog.pipeline, "debug_field_slice");
            ShaderParams params(*prog.vertex, *prog.fragment);
            params.set("View", ctx.buffer(d.scene.view));
            setSdfScene(params, ctx, d.sdf, sampler);
            ctx.cmd.pushConstants(&push, sizeof(push));
            drawFullscreen(ctx, params, cache, prog.pipeline);
        });
}

}  // namespace penumbra::render
