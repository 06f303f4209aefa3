#include "renderer/features/debug_view.h"

#include <shaders/debug_view.h>

#include "renderer/features/fullscreen.h"

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
    // 1. Choose the shader variant; the program's pipeline and sampler come from the cache.
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const auto variant = gbuffer.albedo.isValid() ? program::Variant::Albedo : program::Variant::Default;
    const FullscreenProgram prog =
        fullscreenProgram(fc, program::vertex(variant), program::fragment(variant));
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
            readGBuffer(b, d.gb);
        },
        // 4. Record: bind parameters by name, push constants, draw the full-screen triangle.
        [&cache = fc.cache, prog, push](const Data& d, fg::PassContext& ctx) {
            beginFullscreen(ctx, d.output, prog.pipeline, "debug_view");
            ShaderParams params(*prog.vertex, *prog.fragment);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Scene", ctx.buffer(d.scene.scene))
                .set("Materials", ctx.buffer(d.scene.materials));
            setGBuffer(params, ctx, d.gb, prog.nearest);
            ctx.cmd.pushConstants(&push, sizeof(push));
            drawFullscreen(ctx, params, cache, prog.pipeline);
        });
}

}  // namespace penumbra::render
