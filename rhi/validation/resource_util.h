// Internal helpers shared by the null backend and the validation wrapper: texture subresource
// arithmetic and an owned copy of a shader's reflection (ShaderDesc only borrows its arrays).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rhi/types.h"

// Names live in rhi::detail::resutil so they cannot collide with other backends' helpers.
namespace rhi::detail::resutil {

inline uint32_t mipExtent(uint32_t base, uint32_t mip) { return mip >= 32 ? 1u : std::max(1u, base >> mip); }

// Number of levels of the full mip chain of a texture described by `desc`.
inline uint32_t fullMipChain(const TextureDesc& desc) {
    uint32_t largest = std::max(desc.width, desc.height);
    if (desc.dimension == TextureDimension::Tex3D) largest = std::max(largest, desc.depthOrLayers);
    uint32_t levels = 1;
    while (largest > 1) {
        largest >>= 1;
        ++levels;
    }
    return levels;
}

inline uint32_t arrayLayers(const TextureDesc& desc) {
    return desc.dimension == TextureDimension::Tex2DArray ? desc.depthOrLayers : 1u;
}

// Whether `sub` names an existing subresource of the texture.
inline bool subresourceExists(const TextureDesc& desc, TextureSubresource sub) {
    return sub.mip < desc.mipLevels && sub.layer < arrayLayers(desc);
}

// Tightly packed byte size of one subresource (Tex3D: the whole mip volume).
inline uint64_t subresourceSize(const TextureDesc& desc, uint32_t mip) {
    uint64_t w = mipExtent(desc.width, mip);
    uint64_t h = mipExtent(desc.height, mip);
    uint64_t d = desc.dimension == TextureDimension::Tex3D ? mipExtent(desc.depthOrLayers, mip) : 1u;
    return w * h * d * formatInfo(desc.format).bytesPerTexel;
}

// Overflow-safe "[offset, offset + size) lies inside [0, total)".
inline bool rangeInside(uint64_t offset, uint64_t size, uint64_t total) {
    return offset <= total && size <= total - offset;
}

inline const char* toString(TextureDimension d) {
    switch (d) {
        case TextureDimension::Tex2D:
            return "Tex2D";
        case TextureDimension::Tex2DArray:
            return "Tex2DArray";
        case TextureDimension::Tex3D:
            return "Tex3D";
    }
    return "?";
}

inline const char* toString(BindingType t) {
    switch (t) {
        case BindingType::UniformBuffer:
            return "UniformBuffer";
        case BindingType::StorageBuffer:
            return "StorageBuffer";
        case BindingType::ReadOnlyStorageBuffer:
            return "ReadOnlyStorageBuffer";
        case BindingType::SampledTexture:
            return "SampledTexture";
        case BindingType::StorageTexture:
            return "StorageTexture";
    }
    return "?";
}

inline const char* toString(ShaderStage s) {
    switch (s) {
        case ShaderStage::Vertex:
            return "vertex";
        case ShaderStage::Fragment:
            return "fragment";
        case ShaderStage::Compute:
            return "compute";
    }
    return "?";
}

inline bool isBufferBinding(BindingType t) {
    return t == BindingType::UniformBuffer || t == BindingType::StorageBuffer ||
           t == BindingType::ReadOnlyStorageBuffer;
}

// Owned copy of the reflection part of a ShaderDesc. Binding names point into `names`, so an
// instance must not be copied or moved after construction (hold it through a pointer).
struct OwnedReflection {
    ShaderStage stage = ShaderStage::Compute;
    std::vector<std::string> names;
    std::vector<ShaderBinding> bindings;
    std::vector<VertexInputReflection> vertexInputs;
    uint32_t pushConstantSize = 0;
    std::array<uint32_t, 3> workgroupSize{1, 1, 1};
    std::string debugName;

    OwnedReflection() = default;
    OwnedReflection(const OwnedReflection&) = delete;
    OwnedReflection& operator=(const OwnedReflection&) = delete;

    static std::shared_ptr<const OwnedReflection> capture(const ShaderDesc& desc) {
        auto r = std::make_shared<OwnedReflection>();
        r->stage = desc.stage;
        r->names.reserve(desc.bindings.size());
        for (const ShaderBinding& b : desc.bindings) r->names.emplace_back(b.name ? b.name : "");
        r->bindings.assign(desc.bindings.begin(), desc.bindings.end());
        for (size_t i = 0; i < r->bindings.size(); ++i) r->bindings[i].name = r->names[i].c_str();
        r->vertexInputs.assign(desc.vertexInputs.begin(), desc.vertexInputs.end());
        r->pushConstantSize = desc.pushConstantSize;
        r->workgroupSize = desc.workgroupSize;
        r->debugName = std::string(desc.debugName);
        return r;
    }

    const ShaderBinding* find(uint32_t set, uint32_t binding) const {
        for (const ShaderBinding& b : bindings)
            if (b.set == set && b.binding == binding) return &b;
        return nullptr;
    }
};

}  // namespace rhi::detail::resutil
