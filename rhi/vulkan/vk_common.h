// Vulkan backend — shared helpers: format and access mappings, VkResult strings.
#pragma once

#include <vulkan/vulkan.h>

#include <string>

#include "rhi/types.h"

namespace rhi::vk {

const char* resultString(VkResult r);

// A zero-initialised Vulkan structure with its sType set.
template <typename T>
inline T vkInit(VkStructureType type) {
    T value{};
    value.sType = type;
    return value;
}

// rhi::Format -> VkFormat (VK_FORMAT_UNDEFINED for Format::Undefined / out of range).
VkFormat toVkFormat(Format f);
VkImageAspectFlags aspectOf(Format f);

// Synchronization2 scopes implied by a set of accesses (see rhi::Access).
struct AccessScope {
    VkPipelineStageFlags2 stages = VK_PIPELINE_STAGE_2_NONE;
    VkAccessFlags2 access = VK_ACCESS_2_NONE;
};
// `asSource`: scope for the first half of a dependency (Access::None then waits for all prior work).
AccessScope accessScope(Access a, bool asSource);

// Image layout for a texture in state `a` (see the table in the backend's README comment in
// vk_common.cpp). `separateDepthLayouts`: separateDepthStencilLayouts is enabled.
VkImageLayout layoutFor(Access a, bool isDepth, bool separateDepthLayouts);
// The layout that Access::ShaderSampled maps to (used by sampled-texture descriptors).
inline constexpr VkImageLayout kSampledLayout = VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL;

// Records one global memory dependency (no resource, no layout transition) into `cmd`.
void cmdMemoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStages, VkAccessFlags2 srcAccess,
                      VkPipelineStageFlags2 dstStages, VkAccessFlags2 dstAccess);

VkCompareOp toVkCompare(CompareOp op);
VkBlendFactor toVkBlendFactor(BlendFactor f);
VkBlendOp toVkBlendOp(BlendOp op);
VkPrimitiveTopology toVkTopology(PrimitiveTopology t);
VkCullModeFlags toVkCull(CullMode c);
VkFilter toVkFilter(Filter f);
VkSamplerAddressMode toVkAddress(AddressMode a);
VkDescriptorType toVkDescriptorType(BindingType t);
VkShaderStageFlags toVkStages(ShaderStageFlags s);
VkShaderStageFlagBits toVkStage(ShaderStage s);

std::string versionString(uint32_t apiVersion);

inline uint64_t alignUp(uint64_t v, uint64_t a) { return a <= 1 ? v : (v + a - 1) / a * a; }

}  // namespace rhi::vk
