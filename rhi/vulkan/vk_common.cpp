#include "rhi/vulkan/vk_common.h"

namespace rhi::vk {

const char* resultString(VkResult r) {
    switch (r) {
        case VK_SUCCESS:
            return "VK_SUCCESS";
        case VK_NOT_READY:
            return "VK_NOT_READY";
        case VK_TIMEOUT:
            return "VK_TIMEOUT";
        case VK_EVENT_SET:
            return "VK_EVENT_SET";
        case VK_EVENT_RESET:
            return "VK_EVENT_RESET";
        case VK_INCOMPLETE:
            return "VK_INCOMPLETE";
        case VK_ERROR_OUT_OF_HOST_MEMORY:
            return "VK_ERROR_OUT_OF_HOST_MEMORY";
        case VK_ERROR_OUT_OF_DEVICE_MEMORY:
            return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
        case VK_ERROR_INITIALIZATION_FAILED:
            return "VK_ERROR_INITIALIZATION_FAILED";
        case VK_ERROR_DEVICE_LOST:
            return "VK_ERROR_DEVICE_LOST";
        case VK_ERROR_MEMORY_MAP_FAILED:
            return "VK_ERROR_MEMORY_MAP_FAILED";
        case VK_ERROR_LAYER_NOT_PRESENT:
            return "VK_ERROR_LAYER_NOT_PRESENT";
        case VK_ERROR_EXTENSION_NOT_PRESENT:
            return "VK_ERROR_EXTENSION_NOT_PRESENT";
        case VK_ERROR_FEATURE_NOT_PRESENT:
            return "VK_ERROR_FEATURE_NOT_PRESENT";
        case VK_ERROR_INCOMPATIBLE_DRIVER:
            return "VK_ERROR_INCOMPATIBLE_DRIVER";
        case VK_ERROR_TOO_MANY_OBJECTS:
            return "VK_ERROR_TOO_MANY_OBJECTS";
        case VK_ERROR_FORMAT_NOT_SUPPORTED:
            return "VK_ERROR_FORMAT_NOT_SUPPORTED";
        case VK_ERROR_FRAGMENTED_POOL:
            return "VK_ERROR_FRAGMENTED_POOL";
        case VK_ERROR_OUT_OF_POOL_MEMORY:
            return "VK_ERROR_OUT_OF_POOL_MEMORY";
        case VK_ERROR_SURFACE_LOST_KHR:
            return "VK_ERROR_SURFACE_LOST_KHR";
        case VK_ERROR_NATIVE_WINDOW_IN_USE_KHR:
            return "VK_ERROR_NATIVE_WINDOW_IN_USE_KHR";
        case VK_SUBOPTIMAL_KHR:
            return "VK_SUBOPTIMAL_KHR";
        case VK_ERROR_OUT_OF_DATE_KHR:
            return "VK_ERROR_OUT_OF_DATE_KHR";
        default:
            break;
    }
    return "VkResult(unknown)";
}

VkFormat toVkFormat(Format f) {
    switch (f) {
        case Format::Undefined:
            return VK_FORMAT_UNDEFINED;
        case Format::R8_UNORM:
            return VK_FORMAT_R8_UNORM;
        case Format::R8_UINT:
            return VK_FORMAT_R8_UINT;
        case Format::R16_FLOAT:
            return VK_FORMAT_R16_SFLOAT;
        case Format::R32_FLOAT:
            return VK_FORMAT_R32_SFLOAT;
        case Format::R32_UINT:
            return VK_FORMAT_R32_UINT;
        case Format::RG16_FLOAT:
            return VK_FORMAT_R16G16_SFLOAT;
        case Format::RG32_FLOAT:
            return VK_FORMAT_R32G32_SFLOAT;
        case Format::RGBA8_UNORM:
            return VK_FORMAT_R8G8B8A8_UNORM;
        case Format::RGBA8_SRGB:
            return VK_FORMAT_R8G8B8A8_SRGB;
        case Format::RGBA16_FLOAT:
            return VK_FORMAT_R16G16B16A16_SFLOAT;
        case Format::RGBA32_FLOAT:
            return VK_FORMAT_R32G32B32A32_SFLOAT;
        case Format::D32_FLOAT:
            return VK_FORMAT_D32_SFLOAT;
        case Format::RGB32_FLOAT:
            return VK_FORMAT_R32G32B32_SFLOAT;
        case Format::Count:
            break;
    }
    return VK_FORMAT_UNDEFINED;
}

VkImageAspectFlags aspectOf(Format f) {
    return formatInfo(f).isDepth ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
}

namespace {
constexpr VkPipelineStageFlags2 kShaderStages = VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                                                VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT |
                                                VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
constexpr VkPipelineStageFlags2 kDepthStages =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
}  // namespace

AccessScope accessScope(Access a, bool asSource) {
    AccessScope s;
    if (a == Access::None) {
        // "Discard": the contents are not needed, but the transition (or the reuse of a pooled or
        // aliased resource) must still wait for every earlier use (write-after-read) and order
        // itself after earlier writes (write-after-write), so as a source it covers all commands
        // and all memory writes. As a destination nothing waits.
        if (asSource) {
            s.stages = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
            s.access = VK_ACCESS_2_MEMORY_WRITE_BIT;
        }
        return s;
    }
    auto add = [&](Access bit, VkPipelineStageFlags2 stages, VkAccessFlags2 access) {
        if (any(a & bit)) {
            s.stages |= stages;
            s.access |= access;
        }
    };
    add(Access::ShaderSampled, kShaderStages, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
    add(Access::ShaderRead, kShaderStages, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    add(Access::ShaderWrite, kShaderStages, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    add(Access::UniformRead, kShaderStages, VK_ACCESS_2_UNIFORM_READ_BIT);
    add(Access::VertexRead, VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT,
        VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT);
    add(Access::IndexRead, VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT, VK_ACCESS_2_INDEX_READ_BIT);
    add(Access::IndirectRead, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT, VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
    add(Access::ColorTarget, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
        VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
    add(Access::DepthTargetWrite, kDepthStages,
        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
    add(Access::DepthTargetRead, kDepthStages, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT);
    add(Access::CopySrc, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    add(Access::CopyDst, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    add(Access::HostRead, VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
    add(Access::HostWrite, VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_WRITE_BIT);
    if (any(a & Access::Present)) {
        // Presentation is ordered by semaphores; as a source it still has to wait for the
        // previous frame's use of the image to finish.
        if (asSource) s.stages |= VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    }
    if (asSource) {
        // Reads need no availability operation: only writes stay in the source access mask.
        s.access &= VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT |
                    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT |
                    VK_ACCESS_2_HOST_WRITE_BIT;
    }
    return s;
}

// Texture state -> image layout:
//   None -> UNDEFINED; Present -> PRESENT_SRC_KHR; any ShaderRead/ShaderWrite -> GENERAL;
//   ShaderSampled (alone or with DepthTargetRead) -> READ_ONLY_OPTIMAL; ColorTarget ->
//   COLOR_ATTACHMENT_OPTIMAL; DepthTargetWrite -> DEPTH_ATTACHMENT_OPTIMAL; DepthTargetRead ->
//   DEPTH_READ_ONLY_OPTIMAL; CopySrc / CopyDst -> TRANSFER_SRC / TRANSFER_DST_OPTIMAL; any other
//   combination -> GENERAL. Buffer-only bits (uniform, vertex, index, indirect, host) are ignored.
VkImageLayout layoutFor(Access a, bool isDepth, bool separateDepthLayouts) {
    const Access imageBits = Access::ShaderSampled | Access::ShaderRead | Access::ShaderWrite |
                             Access::ColorTarget | Access::DepthTargetWrite | Access::DepthTargetRead |
                             Access::CopySrc | Access::CopyDst | Access::Present;
    a = a & imageBits;
    if (a == Access::None) return VK_IMAGE_LAYOUT_UNDEFINED;
    if (a == Access::Present) return VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    if (any(a & (Access::ShaderRead | Access::ShaderWrite))) return VK_IMAGE_LAYOUT_GENERAL;
    if (a == Access::ShaderSampled || a == (Access::ShaderSampled | Access::DepthTargetRead))
        return VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL;
    if (a == Access::ColorTarget) return VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    if (a == Access::DepthTargetWrite || a == (Access::DepthTargetWrite | Access::DepthTargetRead)) {
        if (!isDepth) return VK_IMAGE_LAYOUT_GENERAL;
        return separateDepthLayouts ? VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL
                                    : VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    }
    if (a == Access::DepthTargetRead) {
        if (!isDepth) return VK_IMAGE_LAYOUT_GENERAL;
        return separateDepthLayouts ? VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL
                                    : VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
    }
    if (a == Access::CopySrc) return VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    if (a == Access::CopyDst) return VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    return VK_IMAGE_LAYOUT_GENERAL;
}

void cmdMemoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStages, VkAccessFlags2 srcAccess,
                      VkPipelineStageFlags2 dstStages, VkAccessFlags2 dstAccess) {
    auto mb = vkInit<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
    mb.srcStageMask = srcStages;
    mb.srcAccessMask = srcAccess;
    mb.dstStageMask = dstStages;
    mb.dstAccessMask = dstAccess;
    auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
    dep.memoryBarrierCount = 1;
    dep.pMemoryBarriers = &mb;
    vkCmdPipelineBarrier2(cmd, &dep);
}

VkCompareOp toVkCompare(CompareOp op) {
    switch (op) {
        case CompareOp::Never:
            return VK_COMPARE_OP_NEVER;
        case CompareOp::Less:
            return VK_COMPARE_OP_LESS;
        case CompareOp::LessEqual:
            return VK_COMPARE_OP_LESS_OR_EQUAL;
        case CompareOp::Greater:
            return VK_COMPARE_OP_GREATER;
        case CompareOp::GreaterEqual:
            return VK_COMPARE_OP_GREATER_OR_EQUAL;
        case CompareOp::Equal:
            return VK_COMPARE_OP_EQUAL;
        case CompareOp::NotEqual:
            return VK_COMPARE_OP_NOT_EQUAL;
        case CompareOp::Always:
            return VK_COMPARE_OP_ALWAYS;
    }
    return VK_COMPARE_OP_ALWAYS;
}

VkBlendFactor toVkBlendFactor(BlendFactor f) {
    switch (f) {
        case BlendFactor::Zero:
            return VK_BLEND_FACTOR_ZERO;
        case BlendFactor::One:
            return VK_BLEND_FACTOR_ONE;
        case BlendFactor::SrcColor:
            return VK_BLEND_FACTOR_SRC_COLOR;
        case BlendFactor::OneMinusSrcColor:
            return VK_BLEND_FACTOR_ONE_MINUS_SRC_COLOR;
        case BlendFactor::SrcAlpha:
            return VK_BLEND_FACTOR_SRC_ALPHA;
        case BlendFactor::OneMinusSrcAlpha:
            return VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
        case BlendFactor::DstColor:
            return VK_BLEND_FACTOR_DST_COLOR;
        case BlendFactor::OneMinusDstColor:
            return VK_BLEND_FACTOR_ONE_MINUS_DST_COLOR;
        case BlendFactor::DstAlpha:
            return VK_BLEND_FACTOR_DST_ALPHA;
        case BlendFactor::OneMinusDstAlpha:
            return VK_BLEND_FACTOR_ONE_MINUS_DST_ALPHA;
    }
    return VK_BLEND_FACTOR_ONE;
}

VkBlendOp toVkBlendOp(BlendOp op) {
    switch (op) {
        case BlendOp::Add:
            return VK_BLEND_OP_ADD;
        case BlendOp::Subtract:
            return VK_BLEND_OP_SUBTRACT;
        case BlendOp::ReverseSubtract:
            return VK_BLEND_OP_REVERSE_SUBTRACT;
        case BlendOp::Min:
            return VK_BLEND_OP_MIN;
        case BlendOp::Max:
            return VK_BLEND_OP_MAX;
    }
    return VK_BLEND_OP_ADD;
}

VkPrimitiveTopology toVkTopology(PrimitiveTopology t) {
    switch (t) {
        case PrimitiveTopology::TriangleList:
            return VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
        case PrimitiveTopology::TriangleStrip:
            return VK_PRIMITIVE_TOPOLOGY_TRIANGLE_STRIP;
        case PrimitiveTopology::LineList:
            return VK_PRIMITIVE_TOPOLOGY_LINE_LIST;
        case PrimitiveTopology::PointList:
            return VK_PRIMITIVE_TOPOLOGY_POINT_LIST;
    }
    return VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
}

VkCullModeFlags toVkCull(CullMode c) {
    switch (c) {
        case CullMode::None:
            return VK_CULL_MODE_NONE;
        case CullMode::Front:
            return VK_CULL_MODE_FRONT_BIT;
        case CullMode::Back:
            return VK_CULL_MODE_BACK_BIT;
    }
    return VK_CULL_MODE_NONE;
}

VkFilter toVkFilter(Filter f) { return f == Filter::Linear ? VK_FILTER_LINEAR : VK_FILTER_NEAREST; }

VkSamplerAddressMode toVkAddress(AddressMode a) {
    switch (a) {
        case AddressMode::ClampToEdge:
            return VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
        case AddressMode::Repeat:
            return VK_SAMPLER_ADDRESS_MODE_REPEAT;
        case AddressMode::MirroredRepeat:
            return VK_SAMPLER_ADDRESS_MODE_MIRRORED_REPEAT;
    }
    return VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
}

VkDescriptorType toVkDescriptorType(BindingType t) {
    switch (t) {
        case BindingType::UniformBuffer:
            return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        case BindingType::StorageBuffer:
        case BindingType::ReadOnlyStorageBuffer:
            return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        case BindingType::SampledTexture:
            return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
        case BindingType::StorageTexture:
            return VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    }
    return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
}

VkShaderStageFlags toVkStages(ShaderStageFlags s) {
    VkShaderStageFlags out = 0;
    if (any(s & ShaderStageFlags::Vertex)) out |= VK_SHADER_STAGE_VERTEX_BIT;
    if (any(s & ShaderStageFlags::Fragment)) out |= VK_SHADER_STAGE_FRAGMENT_BIT;
    if (any(s & ShaderStageFlags::Compute)) out |= VK_SHADER_STAGE_COMPUTE_BIT;
    return out;
}

VkShaderStageFlagBits toVkStage(ShaderStage s) {
    switch (s) {
        case ShaderStage::Vertex:
            return VK_SHADER_STAGE_VERTEX_BIT;
        case ShaderStage::Fragment:
            return VK_SHADER_STAGE_FRAGMENT_BIT;
        case ShaderStage::Compute:
            return VK_SHADER_STAGE_COMPUTE_BIT;
    }
    return VK_SHADER_STAGE_COMPUTE_BIT;
}

std::string versionString(uint32_t v) {
    return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." +
           std::to_string(VK_API_VERSION_PATCH(v));
}

}  // namespace rhi::vk
