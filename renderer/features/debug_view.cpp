#include "renderer/features/debug_view.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <string>

#include <shaders/debug_view.h>
#include <glm/geometric.hpp>

#include "renderer/features/debug_field_slice.h"
#include "renderer/features/effects.h"
#include "renderer/features/fullscreen.h"
#include "renderer/features/sdf_cull.h"

namespace penumbra::render {

DebugView frameDebugView(DebugView requested, const scene::RenderSettings& settings) {
    return requested != DebugView::None ? requested : settings.debugView;
}

bool frameNeedsAux(bool requested, DebugView view) {
    return requested || view == DebugView::Ids || view == DebugView::Steps;
}

bool parseSlicePlane(std::string_view text, glm::vec4& out, std::string& error) {
    auto number = [](std::string_view s, float& v) {
        while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
        while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
        if (!s.empty() && s.front() == '+') s.remove_prefix(1);
        const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
        return !s.empty() && ec == std::errc() && end == s.data() + s.size() && std::isfinite(v);
    };
    const std::string usage =
        "expected AXIS=OFFSET (x, y or z, e.g. y=0.5) or NX,NY,NZ,OFFSET (e.g. 0,1,0,0.5)";
    glm::vec3 n(0.0f);
    float offset = 0.0f;
    if (text.size() >= 2 && text[1] == '=' && (text[0] == 'x' || text[0] == 'y' || text[0] == 'z')) {
        if (!number(text.substr(2), offset)) {
            error = "--slice '" + std::string(text) + "': " + usage;
            return false;
        }
        n[text[0] - 'x'] = 1.0f;
    } else {
        float v[4];
        size_t start = 0;
        for (int i = 0; i < 4; ++i) {
            const size_t comma = i < 3 ? text.find(',', start) : text.size();
            if (comma == std::string_view::npos || !number(text.substr(start, comma - start), v[i]) ||
                (i == 3 && text.find(',', start) != std::string_view::npos)) {
                error = "--slice '" + std::string(text) + "': " + usage;
                return false;
            }
            start = comma + 1;
        }
        n = glm::vec3(v[0], v[1], v[2]);
        offset = v[3];
        if (!(glm::length(n) > 1e-20f) || !std::isfinite(glm::length(n))) {
            error = "--slice '" + std::string(text) + "': the normal is zero or too large";
            return false;
        }
    }
    out = glm::vec4(glm::normalize(n), offset);
    return true;
}

// The effect target a view shows (invalid: not an effect view, or the effect did not run).
fg::TextureRef effectTarget(const FrameContext& fc, DebugView view) {
    const Effects* fx = fc.board.find<Effects>();
    if (!fx) return {};
    switch (view) {
        case DebugView::Ao:
        case DebugView::BentNormal:
            return fx->ao;
        case DebugView::Shadow:
            return fx->shadowLayers > 0 ? fx->shadow : fg::TextureRef{};
        case DebugView::Thickness:
            return fx->thickness;
        default:
            return {};
    }
}

// The primary tile lists the tiles view shows (null: not built this frame).
const SdfTileLists* tileLists(const FrameContext& fc, DebugView view) {
    const SdfCullLists* lists = view == DebugView::Tiles ? fc.board.find<SdfCullLists>() : nullptr;
    return lists && lists->primary.valid() ? &lists->primary : nullptr;
}

// Steps and ids (modes 3, 4) read gbuffer.aux: variant AUX; albedo (mode 2) the albedo target; the
// effect views (modes 6..9) their effect's target: variant EFFECTS; tiles (mode 10) the primary
// tile lists: variant TILES.
void addDebugView(FrameContext& fc, const DebugViewDesc& desc) {
    if (desc.view == DebugView::FieldSlice) {
        addDebugFieldSlice(fc, {desc.slice, desc.fieldSafety, desc.nearPlane, desc.farPlane});
        return;
    }
    namespace program = shaders::debug_view;
    struct Data {
        SceneBuffers scene;
        GBuffer gb;
        fg::TextureRef effect;
        SdfTileLists tiles;
        fg::TextureRef output;
    };
    // 1. Choose the shader variant; the program's pipeline and sampler come from the cache.
    const GBuffer& gbuffer = *fc.board.find<GBuffer>();
    const bool aux = (desc.view == DebugView::Steps || desc.view == DebugView::Ids) && gbuffer.aux.isValid();
    const fg::TextureRef effect = effectTarget(fc, desc.view);
    const SdfTileLists* tiles = tileLists(fc, desc.view);
    const SdfSceneBuffers* sdf = fc.board.find<SdfSceneBuffers>();
    using V = program::Variant;
    const V variant = tiles                      ? V::Tiles
                      : effect.isValid()         ? V::Effects
                      : gbuffer.albedo.isValid() ? (aux ? V::AlbedoAux : V::Albedo)
                                                 : (aux ? V::Aux : V::Default);
    const FullscreenProgram prog =
        fullscreenProgram(fc, program::vertex(variant), program::fragment(variant));
    // 2. The push-constant block, through the struct shaderc generated from the shader.
    const program::PushConstants push{
        glm::uvec4(uint32_t(desc.view) - 1, tiles ? tiles->tilesX : 0, sdf ? sdf->tracedCount : 0, 0),
        glm::vec4(desc.depthRange, float(std::max(desc.stepLimit, 1u)), 0, 0)};
    fc.graph.addPass<Data>(
        "debug_view", fg::PassKind::Raster,
        // 3. Declare what the pass reads and writes; the graph places the barriers.
        [&](fg::PassBuilder& b, Data& d) {
            d.scene = *fc.board.find<SceneBuffers>();
            d.gb = gbuffer;
            if (effect.isValid() || tiles) d.gb.albedo = {};  // EFFECTS and TILES do not read albedo
            d.effect = effect;
            if (tiles) {
                d.tiles = *tiles;
                readSdfTileLists(b, d.tiles);
            }
            d.output = b.write(fc.board.find<Output>()->color, rhi::Access::ColorTarget);
            b.read(d.scene.view, rhi::Access::UniformRead);
            b.read(d.scene.scene, rhi::Access::UniformRead);
            b.read(d.scene.materials, rhi::Access::ShaderRead);
            readGBuffer(b, d.gb);
            if (aux) b.read(d.gb.aux, rhi::Access::ShaderSampled);
            if (effect.isValid()) b.read(d.effect, rhi::Access::ShaderSampled);
        },
        // 4. Record: bind parameters by name, push constants, draw the full-screen triangle.
        [&cache = fc.cache, prog, push, aux](const Data& d, fg::PassContext& ctx) {
            beginFullscreen(ctx, d.output, prog.pipeline, "debug_view");
            ShaderParams params(*prog.vertex, *prog.fragment);
            params.set("View", ctx.buffer(d.scene.view))
                .set("Scene", ctx.buffer(d.scene.scene))
                .set("Materials", ctx.buffer(d.scene.materials));
            setGBuffer(params, ctx, d.gb, prog.nearest);
            if (aux) params.set("gbufferAux", ctx.texture(d.gb.aux), prog.nearest);
            if (d.effect.isValid()) params.set("effectTexture", ctx.texture(d.effect), prog.nearest);
            if (d.tiles.valid()) setSdfTileLists(params, ctx, d.tiles);
            ctx.cmd.pushConstants(&push, sizeof(push));
            drawFullscreen(ctx, params, cache, prog.pipeline);
        });
}

}  // namespace penumbra::render
