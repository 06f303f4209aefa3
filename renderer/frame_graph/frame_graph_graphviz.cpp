// Frame graph: Graphviz dump (`dot -Tsvg`). Passes are boxes coloured by kind, culled passes
// dashed and grey; imported resources are bold double ellipses, transients plain ellipses naming
// the physical resource behind them and the transients aliased with it; read edges go resource ->
// pass, write edges pass -> resource, both labelled with the declared access.
#include <string>

#include "renderer/frame_graph/frame_graph.h"

namespace penumbra::fg {

namespace {

std::string escape(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (char c : text) {
        if (c == '"' || c == '\\') out += '\\';
        if (c == '\n') {
            out += "\\n";
            continue;
        }
        out += c;
    }
    return out;
}

const char* kindColour(PassKind kind) {
    switch (kind) {
        case PassKind::Compute:
            return "#cfe2ff";
        case PassKind::Raster:
            return "#d1e7dd";
        case PassKind::Transfer:
            return "#e2e3e5";
    }
    return "#ffffff";
}

std::string describeTexture(const rhi::TextureDesc& d) {
    std::string s = std::to_string(d.width) + "x" + std::to_string(d.height);
    if (d.dimension != rhi::TextureDimension::Tex2D) s += "x" + std::to_string(d.depthOrLayers);
    s += std::string(" ") + rhi::formatInfo(d.format).name;
    if (d.mipLevels > 1) s += " mips " + std::to_string(d.mipLevels);
    return s;
}

}  // namespace

std::string FrameGraph::toGraphviz() const {
    const bool compiled = m_compiled && !m_failed;
    std::string out = "digraph FrameGraph {\n";
    out += "  rankdir=LR;\n";
    out += "  node [fontname=\"Helvetica\", fontsize=10];\n";
    out += "  edge [fontname=\"Helvetica\", fontsize=9];\n";

    for (uint32_t pi = 0; pi < m_passes.size(); ++pi) {
        const PassNode& p = m_passes[pi];
        const bool culled = compiled && p.culled;
        std::string label = escape(p.name) + "\\n" + toString(p.kind);
        if (p.sideEffect) label += "\\nside effect";
        if (culled) label += "\\n(culled)";
        out += "  p" + std::to_string(pi) + " [shape=box, label=\"" + label + "\", ";
        if (culled)
            out += "style=\"dashed\", color=\"grey60\", fontcolor=\"grey60\"];\n";
        else
            out += std::string("style=\"filled\", fillcolor=\"") + kindColour(p.kind) + "\"];\n";
    }

    for (uint32_t ri = 0; ri < m_resources.size(); ++ri) {
        const ResourceNode& r = m_resources[ri];
        const bool isTexture = r.type == ResourceType::Texture;
        std::string label = escape(r.name) + "\\n";
        label += isTexture ? describeTexture(r.textureDesc) : std::to_string(r.bufferDesc.size) + " bytes";
        out += "  r" + std::to_string(ri) + " [";
        if (r.imported) {
            label += "\\nimported " + rhi::toString(r.initialState) + " -> " + rhi::toString(r.finalState);
            out += "shape=ellipse, peripheries=2, style=\"bold,filled\", fillcolor=\"#fff3cd\", label=\"" +
                   label + "\"];\n";
            continue;
        }
        label += "\\ntransient";
        if (r.output) label += ", output";
        bool unallocated = compiled && r.slot == kInvalidIndex;
        if (compiled && r.slot != kInvalidIndex) {
            label += "\\nphysical #" + std::to_string(r.slot - m_firstTransientSlot);
            std::string aliases;
            for (uint32_t other : m_slots[r.slot].resources) {
                if (other == ri) continue;
                if (!aliases.empty()) aliases += ", ";
                aliases += escape(m_resources[other].name);
            }
            if (!aliases.empty()) label += "\\naliased with " + aliases;
        } else if (unallocated) {
            label += "\\n(not allocated)";
        }
        out += "shape=ellipse, label=\"" + label + "\", ";
        if (unallocated)
            out += "style=\"dashed\", color=\"grey60\", fontcolor=\"grey60\"];\n";
        else
            out += "style=\"filled\", fillcolor=\"#f8f9fa\"];\n";
    }

    for (uint32_t pi = 0; pi < m_passes.size(); ++pi) {
        const PassNode& p = m_passes[pi];
        const std::string pass = "p" + std::to_string(pi);
        const std::string culledStyle = (compiled && p.culled) ? ", style=\"dashed\", color=\"grey60\"" : "";
        for (const ResourceUse& u : p.uses) {
            const std::string res = "r" + std::to_string(u.resource);
            // One edge per declared part; whole-resource parts carry no subresource text.
            for (const Part& part : u.parts) {
                const std::string where = part.range.isWhole() ? "" : "\\n" + toString(part.range);
                const rhi::Access read = part.access & ~rhi::kWriteAccesses;
                const rhi::Access write = part.access & rhi::kWriteAccesses;
                if (any(read))
                    out += "  " + res + " -> " + pass + " [label=\"" + rhi::toString(read) + where + "\"" +
                           culledStyle + "];\n";
                if (any(write))
                    out += "  " + pass + " -> " + res + " [label=\"" + rhi::toString(write) + where + "\"" +
                           (culledStyle.empty() ? std::string(", color=\"#b02a37\"") : culledStyle) + "];\n";
            }
        }
    }
    out += "}\n";
    return out;
}

}  // namespace penumbra::fg
