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

// Replaces zero extents of `in` by the rest of the mip. False (with the reason in `why`) if the
// mip or layer does not exist or the box leaves the subresource.
inline bool resolveRegion(const TextureDesc& desc, const TextureRegion& in, TextureRegion& out,
                          std::string& why) {
    if (in.mip >= desc.mipLevels) {
        why =
            "mip " + std::to_string(in.mip) + " out of range (" + std::to_string(desc.mipLevels) + " levels)";
        return false;
    }
    if (in.layer >= stateLayers(desc)) {
        why = "layer " + std::to_string(in.layer) + " out of range (" + std::to_string(stateLayers(desc)) +
              " layers)";
        return false;
    }
    auto extent = [&](uint32_t base) { return std::max(1u, in.mip >= 32 ? 1u : base >> in.mip); };
    const uint32_t w = extent(desc.width), h = extent(desc.height);
    const uint32_t d = desc.dimension == TextureDimension::Tex3D ? extent(desc.depthOrLayers) : 1u;
    out = in;
    out.width = in.width ? in.width : (in.x < w ? w - in.x : 0);
    out.height = in.height ? in.height : (in.y < h ? h - in.y : 0);
    out.depth = in.depth ? in.depth : (in.z < d ? d - in.z : 0);
    if (in.x >= w || in.y >= h || in.z >= d || out.width > w - in.x || out.height > h - in.y ||
        out.depth > d - in.z) {
        why = "region at (" + std::to_string(in.x) + ", " + std::to_string(in.y) + ", " +
              std::to_string(in.z) + ") of " + std::to_string(out.width) + "x" + std::to_string(out.height) +
              "x" + std::to_string(out.depth) + " leaves mip " + std::to_string(in.mip) + " (" +
              std::to_string(w) + "x" + std::to_string(h) + "x" + std::to_string(d) + ")";
        return false;
    }
    return true;
}

// Tightly packed byte size of a resolved region.
inline uint64_t regionBytes(const TextureDesc& desc, const TextureRegion& r) {
    return uint64_t(r.width) * r.height * r.depth * formatInfo(desc.format).bytesPerTexel;
}

// The checks every backend applies to CommandList::copyTexture: both regions resolve, the formats
// match, the extents match and a copy inside one subresource does not overlap itself. On success
// `src` and `dst` hold the resolved regions (dst with the source extent).
inline bool checkTextureCopy(const TextureDesc& s, const TextureRegion& srcIn, const TextureDesc& d,
                             const TextureRegion& dstIn, bool sameTexture, TextureRegion& src,
                             TextureRegion& dst, std::string& why) {
    if (!resolveRegion(s, srcIn, src, why)) {
        why = "source " + why;
        return false;
    }
    TextureRegion dstBox = dstIn;
    if (!dstBox.width) dstBox.width = src.width;
    if (!dstBox.height) dstBox.height = src.height;
    if (!dstBox.depth) dstBox.depth = src.depth;
    if (!resolveRegion(d, dstBox, dst, why)) {
        why = "destination " + why;
        return false;
    }
    if (s.format != d.format) {
        why = std::string("formats differ (") + formatInfo(s.format).name + " -> " +
              formatInfo(d.format).name + ")";
        return false;
    }
    if (dst.width != src.width || dst.height != src.height || dst.depth != src.depth) {
        why = "the destination extent differs from the source extent";
        return false;
    }
    const bool overlap = sameTexture && src.mip == dst.mip && src.layer == dst.layer &&
                         src.x < dst.x + dst.width && dst.x < src.x + src.width &&
                         src.y < dst.y + dst.height && dst.y < src.y + src.height &&
                         src.z < dst.z + dst.depth && dst.z < src.z + src.depth;
    if (overlap) {
        why = "source and destination boxes overlap in one subresource";
        return false;
    }
    return true;
}

// The checks of CommandList::copyBufferToTexture: the region resolves, the offset is a multiple
// of the texel size and the tightly packed texels lie inside the buffer.
inline bool checkBufferToTexture(uint64_t bufferSize, uint64_t offset, const TextureDesc& d,
                                 const TextureRegion& in, TextureRegion& out, std::string& why) {
    if (!resolveRegion(d, in, out, why)) return false;
    const uint64_t texel = formatInfo(d.format).bytesPerTexel, bytes = regionBytes(d, out);
    if (offset % texel != 0) {
        why = "source offset " + std::to_string(offset) + " is not a multiple of the texel size " +
              std::to_string(texel);
        return false;
    }
    if (offset > bufferSize || bytes > bufferSize - offset) {
        why = std::to_string(bytes) + " bytes at offset " + std::to_string(offset) + " exceed the buffer's " +
              std::to_string(bufferSize) + " bytes";
        return false;
    }
    return true;
}

// The subresources a texture entry of a bind group views (see BindGroupEntry), resolved. False
// (with the reason) if the mips or layers do not exist, or a storage entry names several mips.
inline bool entryRange(const TextureDesc& desc, const BindGroupEntry& e, bool storage, TextureRange& out,
                       std::string& why) {
    const TextureRange asked{e.mip, storage ? 1u : (e.mipCount ? e.mipCount : kRemaining), e.baseLayer,
                             e.layerCount ? e.layerCount : kRemaining};
    if (storage && e.mipCount > 1) {
        why = "a storage image binds one mip (mipCount " + std::to_string(e.mipCount) + ")";
        return false;
    }
    if (resolveRange(desc, asked, out)) return true;
    why = "mips " + std::to_string(e.mip) + " +" + std::to_string(e.mipCount) + ", layers " +
          std::to_string(e.baseLayer) + " +" + std::to_string(e.layerCount) + " are outside the texture (" +
          std::to_string(desc.mipLevels) + " mips, " + std::to_string(stateLayers(desc)) + " layers)";
    return false;
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
