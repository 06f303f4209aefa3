// Internal: per-subresource access states of one texture (one entry per mip level and array
// layer; a Tex3D volume is one layer per mip), shared by the Vulkan backend (image layouts) and
// the validation wrapper (missing-barrier checks). Ranges are resolved against the texture first.
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "rhi/types.h"

namespace rhi::detail {

// Layers of a texture as barriers and states see them (Tex3D: 1, the whole volume).
inline uint32_t stateLayers(const TextureDesc& desc) {
    return desc.dimension == TextureDimension::Tex2DArray ? desc.depthOrLayers : 1u;
}

// Clamps kRemaining counts to the texture. False (out unchanged) if the range is empty or reaches
// past the last mip or layer.
inline bool resolveRange(const TextureDesc& desc, TextureRange in, TextureRange& out) {
    const uint32_t mips = desc.mipLevels, layers = stateLayers(desc);
    if (in.baseMip >= mips || in.baseLayer >= layers) return false;
    const uint32_t mipCount = in.mipCount == kRemaining ? mips - in.baseMip : in.mipCount;
    const uint32_t layerCount = in.layerCount == kRemaining ? layers - in.baseLayer : in.layerCount;
    if (mipCount == 0 || layerCount == 0 || mipCount > mips - in.baseMip ||
        layerCount > layers - in.baseLayer)
        return false;
    out = {in.baseMip, mipCount, in.baseLayer, layerCount};
    return true;
}

// "mips 1..2, layers 0..5" / "mip 1, layer 0"; for messages.
inline std::string describeRange(const TextureRange& r) {
    auto span = [](const char* one, const char* many, uint32_t base, uint32_t count) {
        return count == 1
                   ? std::string(one) + " " + std::to_string(base)
                   : std::string(many) + " " + std::to_string(base) + ".." + std::to_string(base + count - 1);
    };
    return span("mip", "mips", r.baseMip, r.mipCount) + ", " +
           span("layer", "layers", r.baseLayer, r.layerCount);
}

class SubresourceStates {
public:
    SubresourceStates() = default;
    SubresourceStates(uint32_t mips, uint32_t layers, Access initial = Access::None)
        : m_mips(mips), m_layers(layers), m_states(size_t(mips) * layers, initial) {}
    explicit SubresourceStates(const TextureDesc& desc, Access initial = Access::None)
        : SubresourceStates(desc.mipLevels, stateLayers(desc), initial) {}

    uint32_t mips() const { return m_mips; }
    uint32_t layers() const { return m_layers; }
    TextureRange whole() const { return {0, m_mips, 0, m_layers}; }

    Access get(uint32_t mip, uint32_t layer) const { return m_states[size_t(mip) * m_layers + layer]; }
    // `r` must be resolved (resolveRange).
    void set(const TextureRange& r, Access a) {
        for (uint32_t m = r.baseMip; m < r.baseMip + r.mipCount; ++m)
            for (uint32_t l = r.baseLayer; l < r.baseLayer + r.layerCount; ++l)
                m_states[size_t(m) * m_layers + l] = a;
    }
    void setAll(Access a) { std::fill(m_states.begin(), m_states.end(), a); }
    // Whether every subresource in `r` is in the same state; that state goes to `out`.
    bool uniform(const TextureRange& r, Access& out) const {
        out = get(r.baseMip, r.baseLayer);
        bool same = true;
        forEach(r, [&](uint32_t m, uint32_t l) { same = same && get(m, l) == out; });
        return same;
    }
    // Calls f(mip, layer) for every subresource of `r`.
    template <typename F>
    void forEach(const TextureRange& r, F&& f) const {
        for (uint32_t m = r.baseMip; m < r.baseMip + r.mipCount; ++m)
            for (uint32_t l = r.baseLayer; l < r.baseLayer + r.layerCount; ++l) f(m, l);
    }
    // Splits `r` into runs that share one state: the whole range if uniform, else one range per mip
    // when each mip is uniform across the layers of `r`, else one range per subresource.
    template <typename F>
    void forEachRun(const TextureRange& r, F&& f) const {
        Access a;
        if (uniform(r, a)) {
            f(r, a);
            return;
        }
        for (uint32_t m = r.baseMip; m < r.baseMip + r.mipCount; ++m) {
            const TextureRange mipRange{m, 1, r.baseLayer, r.layerCount};
            if (uniform(mipRange, a)) {
                f(mipRange, a);
                continue;
            }
            for (uint32_t l = r.baseLayer; l < r.baseLayer + r.layerCount; ++l)
                f(TextureRange{m, 1, l, 1}, get(m, l));
        }
    }

private:
    uint32_t m_mips = 0;
    uint32_t m_layers = 0;
    std::vector<Access> m_states;
};

}  // namespace rhi::detail
