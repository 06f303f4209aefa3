// Vulkan backend — resource creation and destruction, uploads and readback.
#include <algorithm>
#include <cstring>
#include <map>

#include "rhi/vulkan/vk_common.h"
#include "rhi/vulkan/vk_device.h"

namespace rhi::vk {

namespace {

std::string quoted(std::string_view name) {
    return name.empty() ? std::string() : " '" + std::string(name) + "'";
}

const char* usageName(TextureUsage u) {
    switch (u) {
        case TextureUsage::Sampled:
            return "Sampled";
        case TextureUsage::Storage:
            return "Storage";
        case TextureUsage::ColorTarget:
            return "ColorTarget";
        case TextureUsage::DepthTarget:
            return "DepthTarget";
        case TextureUsage::CopySrc:
            return "CopySrc";
        case TextureUsage::CopyDst:
            return "CopyDst";
        default:
            break;
    }
    return "?";
}

uint32_t mipExtent(uint32_t size, uint32_t mip) { return std::max(1u, size >> mip); }

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Lookup helpers
// ---------------------------------------------------------------------------------------------------
BufferRes* VulkanDevice::buffer(BufferHandle h, const char* what) {
    BufferRes* b = m_buffers.get(h);
    if (!b)
        logError(std::string(what) + ": " + (h ? "stale or foreign" : "invalid (null)") + " buffer handle");
    return b;
}

TextureRes* VulkanDevice::texture(TextureHandle h, const char* what) {
    TextureRes* t = m_textures.get(h);
    if (!t)
        logError(std::string(what) + ": " + (h ? "stale or foreign" : "invalid (null)") + " texture handle");
    return t;
}

const BufferDesc* VulkanDevice::describe(BufferHandle h) const {
    const BufferRes* b = m_buffers.get(h);
    return b ? &b->desc : nullptr;
}

const TextureDesc* VulkanDevice::describe(TextureHandle h) const {
    const TextureRes* t = m_textures.get(h);
    return t ? &t->desc : nullptr;
}

void* VulkanDevice::mappedPointer(BufferHandle h) {
    BufferRes* b = buffer(h, "mappedPointer");
    if (!b || b->desc.memory == MemoryType::GpuOnly) return nullptr;
    return b->alloc.mapped;
}

// ---------------------------------------------------------------------------------------------------
// Buffers
// ---------------------------------------------------------------------------------------------------
bool VulkanDevice::createRawBuffer(VkDeviceSize size, VkBufferUsageFlags usage, MemoryType memory,
                                   VkBuffer& buf, Allocation& alloc, const char* what) {
    auto info = vkInit<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
    info.size = size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VkResult r = vkCreateBuffer(m_device, &info, nullptr, &buf);
    if (r != VK_SUCCESS) {
        logError(std::string(what) + ": vkCreateBuffer(" + std::to_string(size) +
                 " bytes) failed: " + resultString(r));
        buf = VK_NULL_HANDLE;
        return false;
    }
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(m_device, buf, &req);
    std::string err;
    if (!m_allocator.allocate(req, memory, true, buf, VK_NULL_HANDLE, alloc, err)) {
        logError(std::string(what) + ": " + err);
        vkDestroyBuffer(m_device, buf, nullptr);
        buf = VK_NULL_HANDLE;
        return false;
    }
    r = vkBindBufferMemory(m_device, buf, alloc.memory, alloc.offset);
    if (r != VK_SUCCESS) {
        logError(std::string(what) + ": vkBindBufferMemory failed: " + resultString(r));
        vkDestroyBuffer(m_device, buf, nullptr);
        m_allocator.free(alloc);
        buf = VK_NULL_HANDLE;
        return false;
    }
    return true;
}

BufferHandle VulkanDevice::createBuffer(const BufferDesc& desc, const void* initialData) {
    const std::string what = "createBuffer" + quoted(desc.debugName);
    if (desc.size == 0) {
        logError(what + ": size is 0");
        return {};
    }
    VkBufferUsageFlags usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    if (any(desc.usage & BufferUsage::Vertex)) usage |= VK_BUFFER_USAGE_VERTEX_BUFFER_BIT;
    if (any(desc.usage & BufferUsage::Index)) usage |= VK_BUFFER_USAGE_INDEX_BUFFER_BIT;
    if (any(desc.usage & BufferUsage::Uniform)) usage |= VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT;
    if (any(desc.usage & BufferUsage::Storage)) usage |= VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
    if (any(desc.usage & BufferUsage::Indirect)) usage |= VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT;

    BufferRes res;
    res.desc = desc;
    res.usage = usage;
    if (!createRawBuffer(desc.size, usage, desc.memory, res.buffer, res.alloc, what.c_str())) return {};
    setName(VK_OBJECT_TYPE_BUFFER, uint64_t(res.buffer), desc.debugName);

    BufferHandle h = m_buffers.insert(res);
    if (!h) {
        logError(what + ": too many live buffers");
        vkDestroyBuffer(m_device, res.buffer, nullptr);
        m_allocator.free(res.alloc);
        return {};
    }
    if (initialData) {
        BufferRes* b = m_buffers.get(h);
        // Not in use by the GPU yet: coherent mapped memory can be filled directly.
        if (b->alloc.mapped && b->alloc.coherent)
            std::memcpy(b->alloc.mapped, initialData, desc.size);
        else
            writeBuffer(h, 0, initialData, desc.size);
    }
    return h;
}

// ---------------------------------------------------------------------------------------------------
// Textures
// ---------------------------------------------------------------------------------------------------
VkImageView VulkanDevice::createView(TextureRes& t, VkImageViewType type, uint32_t baseMip, uint32_t mipCount,
                                     uint32_t baseLayer, uint32_t layerCount) {
    auto info = vkInit<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
    info.image = t.image;
    info.viewType = type;
    info.format = t.format;
    info.subresourceRange = {t.aspect, baseMip, mipCount, baseLayer, layerCount};
    VkImageView view = VK_NULL_HANDLE;
    VkResult r = vkCreateImageView(m_device, &info, nullptr, &view);
    if (r != VK_SUCCESS) {
        logError("vkCreateImageView for texture" + quoted(t.desc.debugName) + " failed: " + resultString(r));
        return VK_NULL_HANDLE;
    }
    setName(VK_OBJECT_TYPE_IMAGE_VIEW, uint64_t(view), t.desc.debugName);
    return view;
}

VkImageView VulkanDevice::attachmentView(TextureRes& t, uint32_t mip, uint32_t layer) {
    const uint32_t key = (mip << 16) | layer;
    auto it = t.attachmentViews.find(key);
    if (it != t.attachmentViews.end()) return it->second;
    // Tex3D: a 2D view of one depth slice (the image is created 2D_ARRAY_COMPATIBLE).
    VkImageView view = createView(t, VK_IMAGE_VIEW_TYPE_2D, mip, 1, layer, 1);
    if (view) t.attachmentViews[key] = view;
    return view;
}

VkImageView VulkanDevice::rangeView(TextureRes& t, const TextureRange& r) {
    const std::array<uint32_t, 4> key{r.baseMip, r.mipCount, r.baseLayer, r.layerCount};
    if (auto it = t.rangeViews.find(key); it != t.rangeViews.end()) return it->second;
    const VkImageViewType type = t.desc.dimension == TextureDimension::Tex3D ? VK_IMAGE_VIEW_TYPE_3D
                                 : t.desc.dimension == TextureDimension::Tex2DArray
                                     ? VK_IMAGE_VIEW_TYPE_2D_ARRAY
                                     : VK_IMAGE_VIEW_TYPE_2D;
    VkImageView v = createView(t, type, r.baseMip, r.mipCount, r.baseLayer, r.layerCount);
    if (v) t.rangeViews.emplace(key, v);
    return v;
}

void VulkanDevice::releaseTexture(TextureRes& t) {
    for (auto& [key, view] : t.attachmentViews) vkDestroyImageView(m_device, view, nullptr);
    for (auto& [key, view] : t.rangeViews) vkDestroyImageView(m_device, view, nullptr);
    t.rangeViews.clear();
    for (VkImageView v : t.storageViews) vkDestroyImageView(m_device, v, nullptr);
    if (t.sampledView) vkDestroyImageView(m_device, t.sampledView, nullptr);
    t.attachmentViews.clear();
    t.storageViews.clear();
    t.sampledView = VK_NULL_HANDLE;
    if (t.ownsImage) {
        if (t.image) vkDestroyImage(m_device, t.image, nullptr);
        m_allocator.free(t.alloc);
    }
    t.image = VK_NULL_HANDLE;
}

// createTexture's image usage: the requested usages, each checked against the format's features, plus
// transfers and sampling where the format allows them. False, with the error logged under `what`,
// when a requested usage is unsupported.
bool VulkanDevice::textureImageUsage(const TextureDesc& desc, VkFormat format, const std::string& what,
                                     VkImageUsageFlags& usage) {
    const FormatInfo& fi = formatInfo(desc.format);
    VkFormatProperties fp;
    vkGetPhysicalDeviceFormatProperties(m_physical, format, &fp);
    const VkFormatFeatureFlags feats = fp.optimalTilingFeatures;
    struct Need {
        TextureUsage usage;
        VkFormatFeatureFlags feature;
        VkImageUsageFlags imageUsage;
    };
    const Need needs[] = {
        {TextureUsage::Sampled, VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT, VK_IMAGE_USAGE_SAMPLED_BIT},
        {TextureUsage::Storage, VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT, VK_IMAGE_USAGE_STORAGE_BIT},
        {TextureUsage::ColorTarget, VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT,
         VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT},
        {TextureUsage::DepthTarget, VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT,
         VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT},
        {TextureUsage::CopySrc, VK_FORMAT_FEATURE_TRANSFER_SRC_BIT, VK_IMAGE_USAGE_TRANSFER_SRC_BIT},
        {TextureUsage::CopyDst, VK_FORMAT_FEATURE_TRANSFER_DST_BIT, VK_IMAGE_USAGE_TRANSFER_DST_BIT},
    };
    usage = 0;
    for (const Need& n : needs) {
        if (!any(desc.usage & n.usage)) continue;
        if (!(feats & n.feature)) {
            logError(what + ": format " + fi.name + " does not support " + usageName(n.usage) +
                     " usage on this device");
            return false;
        }
        usage |= n.imageUsage;
    }
    // Uploads and readback work on every texture; sampling-capable formats also get SAMPLED so
    // that writeTexture() can leave any texture in the ShaderSampled (read-only) layout.
    if (feats & VK_FORMAT_FEATURE_TRANSFER_SRC_BIT) usage |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    if (feats & VK_FORMAT_FEATURE_TRANSFER_DST_BIT) usage |= VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    if (feats & VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT) usage |= VK_IMAGE_USAGE_SAMPLED_BIT;
    return true;
}

TextureHandle VulkanDevice::createTexture(const TextureDesc& desc) {
    const std::string what = "createTexture" + quoted(desc.debugName);
    const FormatInfo& fi = formatInfo(desc.format);
    const VkFormat format = toVkFormat(desc.format);
    if (format == VK_FORMAT_UNDEFINED) {
        logError(what + ": format is Undefined");
        return {};
    }
    if (desc.width == 0 || desc.height == 0 || desc.depthOrLayers == 0 || desc.mipLevels == 0) {
        logError(what + ": width, height, depthOrLayers and mipLevels must be at least 1");
        return {};
    }
    if (desc.dimension == TextureDimension::Tex2D && desc.depthOrLayers != 1) {
        logError(what + ": a Tex2D texture has depthOrLayers = 1 (got " + std::to_string(desc.depthOrLayers) +
                 ")");
        return {};
    }
    const bool is3D = desc.dimension == TextureDimension::Tex3D;
    uint32_t largest = std::max(desc.width, desc.height);
    if (is3D) largest = std::max(largest, desc.depthOrLayers);
    uint32_t maxMips = 1;
    while ((largest >> maxMips) > 0) ++maxMips;
    if (desc.mipLevels > maxMips) {
        logError(what + ": " + std::to_string(desc.mipLevels) + " mip levels requested, at most " +
                 std::to_string(maxMips) + " fit");
        return {};
    }
    if (desc.usage == TextureUsage::None) {
        logError(what + ": usage is None");
        return {};
    }
    if (fi.isDepth && any(desc.usage & (TextureUsage::ColorTarget | TextureUsage::Storage))) {
        logError(what + ": depth format " + fi.name + " cannot be a colour target or storage image");
        return {};
    }
    if (!fi.isDepth && any(desc.usage & TextureUsage::DepthTarget)) {
        logError(what + ": DepthTarget usage needs a depth format (got " + fi.name + ")");
        return {};
    }

    VkImageUsageFlags usage = 0;
    if (!textureImageUsage(desc, format, what, usage)) return {};

    auto info = vkInit<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
    info.imageType = is3D ? VK_IMAGE_TYPE_3D : VK_IMAGE_TYPE_2D;
    info.format = format;
    info.extent = {desc.width, desc.height, is3D ? desc.depthOrLayers : 1};
    info.mipLevels = desc.mipLevels;
    info.arrayLayers = is3D ? 1 : desc.depthOrLayers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    if (is3D && any(desc.usage & TextureUsage::ColorTarget))
        info.flags |= VK_IMAGE_CREATE_2D_ARRAY_COMPATIBLE_BIT;

    VkImageFormatProperties ifp{};
    VkResult r = vkGetPhysicalDeviceImageFormatProperties(m_physical, format, info.imageType, info.tiling,
                                                          info.usage, info.flags, &ifp);
    if (r != VK_SUCCESS) {
        logError(what + ": format " + fi.name + " with this usage/dimension is unsupported (" +
                 resultString(r) + ")");
        return {};
    }
    if (info.extent.width > ifp.maxExtent.width || info.extent.height > ifp.maxExtent.height ||
        info.extent.depth > ifp.maxExtent.depth || info.arrayLayers > ifp.maxArrayLayers ||
        info.mipLevels > ifp.maxMipLevels) {
        logError(what + ": " + std::to_string(desc.width) + "x" + std::to_string(desc.height) + "x" +
                 std::to_string(desc.depthOrLayers) + " exceeds the device limits for " + fi.name + " (max " +
                 std::to_string(ifp.maxExtent.width) + "x" + std::to_string(ifp.maxExtent.height) + "x" +
                 std::to_string(is3D ? ifp.maxExtent.depth : ifp.maxArrayLayers) + ")");
        return {};
    }

    TextureRes t;
    t.desc = desc;
    t.format = format;
    t.aspect = aspectOf(desc.format);
    t.usage = usage;
    r = vkCreateImage(m_device, &info, nullptr, &t.image);
    if (r != VK_SUCCESS) {
        logError(what + ": vkCreateImage failed: " + resultString(r));
        return {};
    }
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(m_device, t.image, &req);
    std::string err;
    if (!m_allocator.allocate(req, MemoryType::GpuOnly, false, VK_NULL_HANDLE, t.image, t.alloc, err)) {
        logError(what + ": " + err);
        vkDestroyImage(m_device, t.image, nullptr);
        return {};
    }
    r = vkBindImageMemory(m_device, t.image, t.alloc.memory, t.alloc.offset);
    if (r != VK_SUCCESS) {
        logError(what + ": vkBindImageMemory failed: " + resultString(r));
        releaseTexture(t);
        return {};
    }
    setName(VK_OBJECT_TYPE_IMAGE, uint64_t(t.image), desc.debugName);

    const VkImageViewType fullType = is3D ? VK_IMAGE_VIEW_TYPE_3D
                                     : desc.dimension == TextureDimension::Tex2DArray
                                         ? VK_IMAGE_VIEW_TYPE_2D_ARRAY
                                         : VK_IMAGE_VIEW_TYPE_2D;
    const uint32_t layers = is3D ? 1 : desc.depthOrLayers;
    bool ok = true;
    if (usage & VK_IMAGE_USAGE_SAMPLED_BIT) {
        t.sampledView = createView(t, fullType, 0, desc.mipLevels, 0, layers);
        ok = t.sampledView != VK_NULL_HANDLE;
    }
    if (ok && any(desc.usage & TextureUsage::Storage)) {
        for (uint32_t m = 0; m < desc.mipLevels && ok; ++m) {
            VkImageView v = createView(t, fullType, m, 1, 0, layers);
            ok = v != VK_NULL_HANDLE;
            if (ok) t.storageViews.push_back(v);
        }
    }
    if (!ok) {
        releaseTexture(t);
        return {};
    }
    t.states = detail::SubresourceStates(desc);
    TextureHandle h = m_textures.insert(t);
    if (!h) {
        logError(what + ": too many live textures");
        releaseTexture(t);
    }
    return h;
}

// ---------------------------------------------------------------------------------------------------
// Samplers and shaders
// ---------------------------------------------------------------------------------------------------
SamplerHandle VulkanDevice::createSampler(const SamplerDesc& desc) {
    auto info = vkInit<VkSamplerCreateInfo>(VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO);
    info.magFilter = toVkFilter(desc.magFilter);
    info.minFilter = toVkFilter(desc.minFilter);
    info.mipmapMode =
        desc.mipFilter == Filter::Linear ? VK_SAMPLER_MIPMAP_MODE_LINEAR : VK_SAMPLER_MIPMAP_MODE_NEAREST;
    info.addressModeU = toVkAddress(desc.addressU);
    info.addressModeV = toVkAddress(desc.addressV);
    info.addressModeW = toVkAddress(desc.addressW);
    info.minLod = 0.0f;
    info.maxLod = std::max(0.0f, desc.maxLod);
    info.borderColor = VK_BORDER_COLOR_FLOAT_TRANSPARENT_BLACK;
    SamplerRes s;
    VkResult r = vkCreateSampler(m_device, &info, nullptr, &s.sampler);
    if (r != VK_SUCCESS) {
        logError("createSampler" + quoted(desc.debugName) + ": vkCreateSampler failed: " + resultString(r));
        return {};
    }
    setName(VK_OBJECT_TYPE_SAMPLER, uint64_t(s.sampler), desc.debugName);
    SamplerHandle h = m_samplers.insert(s);
    if (!h) {
        logError("createSampler: too many live samplers");
        vkDestroySampler(m_device, s.sampler, nullptr);
    }
    return h;
}

ShaderHandle VulkanDevice::createShader(const ShaderDesc& desc) {
    const std::string what = "createShader" + quoted(desc.debugName);
    if (desc.spirv.empty()) {
        logError(what + ": no SPIR-V code (ShaderDesc::spirv is empty)");
        return {};
    }
    if (desc.spirv[0] != 0x07230203u) {
        logError(what + ": ShaderDesc::spirv does not start with the SPIR-V magic number");
        return {};
    }
    if (desc.pushConstantSize > kMaxPushConstantSize) {
        logError(what + ": push constants of " + std::to_string(desc.pushConstantSize) + " bytes exceed " +
                 std::to_string(kMaxPushConstantSize));
        return {};
    }
    ShaderRes s;
    s.stage = desc.stage;
    s.pushConstantSize = desc.pushConstantSize;
    s.name = std::string(desc.debugName);
    for (const ShaderBinding& b : desc.bindings) {
        if (b.set >= kMaxBindGroups) {
            logError(what + ": binding '" + (b.name ? b.name : "") + "' uses set " + std::to_string(b.set) +
                     " (at most " + std::to_string(kMaxBindGroups - 1) + ")");
            return {};
        }
        s.bindings.push_back(
            {b.name ? b.name : "", b.set, b.binding, b.type, std::max(1u, b.count), b.textureDimension});
    }
    s.vertexInputs.assign(desc.vertexInputs.begin(), desc.vertexInputs.end());

    auto info = vkInit<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    info.codeSize = desc.spirv.size() * sizeof(uint32_t);
    info.pCode = desc.spirv.data();
    VkResult r = vkCreateShaderModule(m_device, &info, nullptr, &s.module);
    if (r != VK_SUCCESS) {
        logError(what + ": vkCreateShaderModule failed: " + resultString(r));
        return {};
    }
    setName(VK_OBJECT_TYPE_SHADER_MODULE, uint64_t(s.module), desc.debugName);
    ShaderHandle h = m_shaders.insert(s);
    if (!h) {
        logError(what + ": too many live shaders");
        vkDestroyShaderModule(m_device, s.module, nullptr);
    }
    return h;
}

// ---------------------------------------------------------------------------------------------------
// Pipelines
// ---------------------------------------------------------------------------------------------------
VkDescriptorSetLayout VulkanDevice::getSetLayout(const std::vector<SetLayoutBinding>& bindings) {
    std::string key;
    for (const SetLayoutBinding& b : bindings)
        key += std::to_string(b.binding) + ":" + std::to_string(int(toVkDescriptorType(b.type))) + ":" +
               std::to_string(b.count) + ":" + std::to_string(b.stages) + ";";
    auto it = m_setLayoutCache.find(key);
    if (it != m_setLayoutCache.end()) return it->second;

    std::vector<VkDescriptorSetLayoutBinding> vkb;
    for (const SetLayoutBinding& b : bindings) {
        VkDescriptorSetLayoutBinding lb{};
        lb.binding = b.binding;
        lb.descriptorType = toVkDescriptorType(b.type);
        lb.descriptorCount = b.count;
        lb.stageFlags = b.stages;
        vkb.push_back(lb);
    }
    auto info = vkInit<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    info.bindingCount = uint32_t(vkb.size());
    info.pBindings = vkb.data();
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
    if (!check(vkCreateDescriptorSetLayout(m_device, &info, nullptr, &layout), "vkCreateDescriptorSetLayout"))
        return VK_NULL_HANDLE;
    m_setLayoutCache.emplace(key, layout);
    return layout;
}

bool VulkanDevice::buildPipelineLayout(std::span<const ShaderRes* const> shaders, PipelineRes& out) {
    std::array<std::map<uint32_t, SetLayoutBinding>, kMaxBindGroups> sets;
    for (const ShaderRes* s : shaders) {
        const VkShaderStageFlags stage = toVkStage(s->stage);
        if (s->pushConstantSize > 0) {
            out.pushSize = std::max(out.pushSize, s->pushConstantSize);
            out.pushStages |= stage;
        }
        for (const ShaderRes::Binding& b : s->bindings) {
            auto it = sets[b.set].find(b.binding);
            if (it == sets[b.set].end()) {
                sets[b.set][b.binding] = {b.name, b.binding, b.type, b.count, stage, b.dimension};
                continue;
            }
            SetLayoutBinding& existing = it->second;
            if (toVkDescriptorType(existing.type) != toVkDescriptorType(b.type) ||
                existing.count != b.count) {
                logError("pipeline" + quoted(out.name) + ": set " + std::to_string(b.set) + " binding " +
                         std::to_string(b.binding) + " is declared differently by two shader stages");
                return false;
            }
            if (b.type == BindingType::StorageBuffer) existing.type = BindingType::StorageBuffer;
            existing.stages |= stage;
        }
    }
    for (uint32_t s = 0; s < kMaxBindGroups; ++s)
        if (!sets[s].empty()) out.setCount = s + 1;
    std::vector<VkDescriptorSetLayout> layouts;
    for (uint32_t s = 0; s < out.setCount; ++s) {
        for (auto& [binding, b] : sets[s]) out.sets[s].push_back(b);
        out.setLayouts[s] = getSetLayout(out.sets[s]);
        if (!out.setLayouts[s]) return false;
        layouts.push_back(out.setLayouts[s]);
    }
    VkPushConstantRange range{out.pushStages, 0, out.pushSize};
    auto info = vkInit<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    info.setLayoutCount = uint32_t(layouts.size());
    info.pSetLayouts = layouts.data();
    info.pushConstantRangeCount = out.pushSize > 0 ? 1 : 0;
    info.pPushConstantRanges = &range;
    VkResult r = vkCreatePipelineLayout(m_device, &info, nullptr, &out.layout);
    if (r != VK_SUCCESS) {
        logError("pipeline" + quoted(out.name) + ": vkCreatePipelineLayout failed: " + resultString(r));
        out.layout = VK_NULL_HANDLE;
        return false;
    }
    return true;
}

PipelineHandle VulkanDevice::createComputePipeline(const ComputePipelineDesc& desc) {
    const std::string what = "createComputePipeline" + quoted(desc.debugName);
    const ShaderRes* cs = m_shaders.get(desc.shader);
    if (!cs) {
        logError(what + ": invalid or stale shader handle");
        return {};
    }
    if (cs->stage != ShaderStage::Compute) {
        logError(what + ": shader '" + cs->name + "' is not a compute shader");
        return {};
    }
    PipelineRes p;
    p.name = desc.debugName.empty() ? cs->name : desc.debugName;
    p.bindPoint = VK_PIPELINE_BIND_POINT_COMPUTE;
    const ShaderRes* shaders[1] = {cs};
    if (!buildPipelineLayout(shaders, p)) return {};

    auto info = vkInit<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
    info.stage = vkInit<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = cs->module;
    info.stage.pName = "main";
    info.layout = p.layout;
    VkResult r = vkCreateComputePipelines(m_device, VK_NULL_HANDLE, 1, &info, nullptr, &p.pipeline);
    if (r != VK_SUCCESS) {
        logError(what + ": vkCreateComputePipelines failed: " + resultString(r));
        vkDestroyPipelineLayout(m_device, p.layout, nullptr);
        return {};
    }
    setName(VK_OBJECT_TYPE_PIPELINE, uint64_t(p.pipeline), p.name);
    PipelineHandle h = m_pipelines.insert(p);
    if (h) ++m_stats.pipelinesCreated;
    if (!h) {
        logError(what + ": too many live pipelines");
        vkDestroyPipeline(m_device, p.pipeline, nullptr);
        vkDestroyPipelineLayout(m_device, p.layout, nullptr);
    }
    return h;
}

bool VulkanDevice::graphicsVertexInput(const GraphicsPipelineDesc& desc, const ShaderRes& vs,
                                       const std::string& what,
                                       std::vector<VkVertexInputBindingDescription>& bindings,
                                       std::vector<VkVertexInputAttributeDescription>& attributes) {
    for (uint32_t i = 0; i < desc.vertexBuffers.size(); ++i)
        bindings.push_back({i, desc.vertexBuffers[i].stride,
                            desc.vertexBuffers[i].perInstance ? VK_VERTEX_INPUT_RATE_INSTANCE
                                                              : VK_VERTEX_INPUT_RATE_VERTEX});
    for (const VertexAttribute& a : desc.vertexAttributes) {
        if (a.bufferSlot >= desc.vertexBuffers.size()) {
            logError(what + ": vertex attribute at location " + std::to_string(a.location) +
                     " uses buffer slot " + std::to_string(a.bufferSlot) + " but only " +
                     std::to_string(desc.vertexBuffers.size()) + " vertex buffer layout(s) are given");
            return false;
        }
        VkFormat f = toVkFormat(a.format);
        VkFormatProperties fp;
        vkGetPhysicalDeviceFormatProperties(m_physical, f, &fp);
        if (f == VK_FORMAT_UNDEFINED || !(fp.bufferFeatures & VK_FORMAT_FEATURE_VERTEX_BUFFER_BIT)) {
            logError(what + ": format " + formatInfo(a.format).name + " cannot be a vertex attribute");
            return false;
        }
        attributes.push_back({a.location, a.bufferSlot, f, a.offset});
    }
    for (const VertexInputReflection& in : vs.vertexInputs) {
        bool found = std::any_of(desc.vertexAttributes.begin(), desc.vertexAttributes.end(),
                                 [&](const VertexAttribute& a) { return a.location == in.location; });
        if (!found) {
            logError(what + ": the vertex shader reads location " + std::to_string(in.location) +
                     " but no vertex attribute provides it");
            return false;
        }
    }
    return true;
}

bool VulkanDevice::graphicsColorTargets(const GraphicsPipelineDesc& desc, const std::string& what,
                                        std::vector<VkFormat>& colorFormats,
                                        std::vector<VkPipelineColorBlendAttachmentState>& blends) {
    for (Format f : desc.colorFormats) {
        VkFormat vf = toVkFormat(f);
        VkFormatProperties fp;
        vkGetPhysicalDeviceFormatProperties(m_physical, vf, &fp);
        if (vf == VK_FORMAT_UNDEFINED ||
            !(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT)) {
            logError(what + ": format " + formatInfo(f).name + " cannot be a colour target");
            return false;
        }
        colorFormats.push_back(vf);
    }
    for (size_t i = 0; i < desc.colorFormats.size(); ++i) {
        VkPipelineColorBlendAttachmentState s{};
        s.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT |
                           VK_COLOR_COMPONENT_A_BIT;
        if (!desc.blend.empty() && desc.blend[i].enable) {
            const BlendState& b = desc.blend[i];
            if (formatInfo(desc.colorFormats[i]).isInteger) {
                logError(what + ": blending enabled on integer colour target " + std::to_string(i));
                return false;
            }
            s.blendEnable = VK_TRUE;
            s.srcColorBlendFactor = toVkBlendFactor(b.srcColor);
            s.dstColorBlendFactor = toVkBlendFactor(b.dstColor);
            s.colorBlendOp = toVkBlendOp(b.colorOp);
            s.srcAlphaBlendFactor = toVkBlendFactor(b.srcAlpha);
            s.dstAlphaBlendFactor = toVkBlendFactor(b.dstAlpha);
            s.alphaBlendOp = toVkBlendOp(b.alphaOp);
        }
        if (!blends.empty() && !m_independentBlend && std::memcmp(&blends[0], &s, sizeof s) != 0) {
            logError(what + ": different blend states per colour target need the independentBlend feature");
            return false;
        }
        blends.push_back(s);
    }
    return true;
}

PipelineHandle VulkanDevice::createGraphicsPipeline(const GraphicsPipelineDesc& desc) {
    const std::string what = "createGraphicsPipeline" + quoted(desc.debugName);
    const ShaderRes* vs = m_shaders.get(desc.vertexShader);
    if (!vs || vs->stage != ShaderStage::Vertex) {
        logError(what +
                 (vs ? ": vertexShader is not a vertex shader" : ": invalid or stale vertex shader handle"));
        return {};
    }
    const ShaderRes* fs = nullptr;
    if (desc.fragmentShader) {
        fs = m_shaders.get(desc.fragmentShader);
        if (!fs || fs->stage != ShaderStage::Fragment) {
            logError(what + (fs ? ": fragmentShader is not a fragment shader"
                                : ": invalid or stale fragment shader handle"));
            return {};
        }
    }
    if (desc.colorFormats.size() > m_info.limits.maxColorTargets) {
        logError(what + ": " + std::to_string(desc.colorFormats.size()) +
                 " colour targets exceed the limit of " + std::to_string(m_info.limits.maxColorTargets));
        return {};
    }
    if (!desc.blend.empty() && desc.blend.size() != desc.colorFormats.size()) {
        logError(what + ": blend has " + std::to_string(desc.blend.size()) + " entries for " +
                 std::to_string(desc.colorFormats.size()) + " colour targets");
        return {};
    }
    if (desc.depthFormat != Format::Undefined && !formatInfo(desc.depthFormat).isDepth) {
        logError(what + ": depthFormat " + formatInfo(desc.depthFormat).name + " is not a depth format");
        return {};
    }
    if ((desc.depthTest || desc.depthWrite) && desc.depthFormat == Format::Undefined) {
        logError(what + ": depth test/write enabled without a depthFormat");
        return {};
    }

    std::vector<VkVertexInputBindingDescription> bindings;
    std::vector<VkVertexInputAttributeDescription> attributes;
    if (!graphicsVertexInput(desc, *vs, what, bindings, attributes)) return {};
    std::vector<VkFormat> colorFormats;
    std::vector<VkPipelineColorBlendAttachmentState> blends;
    if (!graphicsColorTargets(desc, what, colorFormats, blends)) return {};

    PipelineRes p;
    p.name = desc.debugName.empty() ? vs->name : desc.debugName;
    p.bindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    std::vector<const ShaderRes*> shaders{vs};
    if (fs) shaders.push_back(fs);
    if (!buildPipelineLayout(shaders, p)) return {};

    VkPipelineShaderStageCreateInfo stages[2]{};
    stages[0] = vkInit<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = vs->module;
    stages[0].pName = "main";
    if (fs) {
        stages[1] =
            vkInit<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
        stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
        stages[1].module = fs->module;
        stages[1].pName = "main";
    }
    auto vi = vkInit<VkPipelineVertexInputStateCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO);
    vi.vertexBindingDescriptionCount = uint32_t(bindings.size());
    vi.pVertexBindingDescriptions = bindings.data();
    vi.vertexAttributeDescriptionCount = uint32_t(attributes.size());
    vi.pVertexAttributeDescriptions = attributes.data();
    auto ia = vkInit<VkPipelineInputAssemblyStateCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO);
    ia.topology = toVkTopology(desc.topology);
    auto vp =
        vkInit<VkPipelineViewportStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO);
    vp.viewportCount = 1;
    vp.scissorCount = 1;
    auto rs = vkInit<VkPipelineRasterizationStateCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO);
    rs.polygonMode = VK_POLYGON_MODE_FILL;
    rs.cullMode = toVkCull(desc.cullMode);
    rs.frontFace = desc.frontFace == FrontFace::CounterClockwise ? VK_FRONT_FACE_COUNTER_CLOCKWISE
                                                                 : VK_FRONT_FACE_CLOCKWISE;
    rs.lineWidth = 1.0f;
    auto ms = vkInit<VkPipelineMultisampleStateCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO);
    ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    auto ds = vkInit<VkPipelineDepthStencilStateCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO);
    ds.depthTestEnable = desc.depthTest ? VK_TRUE : VK_FALSE;
    ds.depthWriteEnable = desc.depthWrite ? VK_TRUE : VK_FALSE;
    ds.depthCompareOp = desc.depthTest ? toVkCompare(desc.depthCompare) : VK_COMPARE_OP_ALWAYS;
    auto cb =
        vkInit<VkPipelineColorBlendStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO);
    cb.attachmentCount = uint32_t(blends.size());
    cb.pAttachments = blends.data();
    const VkDynamicState dynamicStates[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    auto dyn = vkInit<VkPipelineDynamicStateCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO);
    dyn.dynamicStateCount = 2;
    dyn.pDynamicStates = dynamicStates;
    auto rendering = vkInit<VkPipelineRenderingCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO);
    rendering.colorAttachmentCount = uint32_t(colorFormats.size());
    rendering.pColorAttachmentFormats = colorFormats.data();
    rendering.depthAttachmentFormat = toVkFormat(desc.depthFormat);

    auto info = vkInit<VkGraphicsPipelineCreateInfo>(VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO);
    info.pNext = &rendering;
    info.stageCount = fs ? 2 : 1;
    info.pStages = stages;
    info.pVertexInputState = &vi;
    info.pInputAssemblyState = &ia;
    info.pViewportState = &vp;
    info.pRasterizationState = &rs;
    info.pMultisampleState = &ms;
    info.pDepthStencilState = &ds;
    info.pColorBlendState = &cb;
    info.pDynamicState = &dyn;
    info.layout = p.layout;
    VkResult r = vkCreateGraphicsPipelines(m_device, VK_NULL_HANDLE, 1, &info, nullptr, &p.pipeline);
    if (r != VK_SUCCESS) {
        logError(what + ": vkCreateGraphicsPipelines failed: " + resultString(r));
        vkDestroyPipelineLayout(m_device, p.layout, nullptr);
        return {};
    }
    setName(VK_OBJECT_TYPE_PIPELINE, uint64_t(p.pipeline), p.name);
    PipelineHandle h = m_pipelines.insert(p);
    if (h) ++m_stats.pipelinesCreated;
    if (!h) {
        logError(what + ": too many live pipelines");
        vkDestroyPipeline(m_device, p.pipeline, nullptr);
        vkDestroyPipelineLayout(m_device, p.layout, nullptr);
    }
    return h;
}

// ---------------------------------------------------------------------------------------------------
// Bind groups
// ---------------------------------------------------------------------------------------------------
BindGroupHandle VulkanDevice::createBindGroup(const BindGroupDesc& desc) {
    const std::string what = "createBindGroup" + quoted(desc.debugName);
    const PipelineRes* p = m_pipelines.get(desc.pipeline);
    if (!p) {
        logError(what + ": invalid or stale pipeline handle");
        return {};
    }
    if (desc.set >= p->setCount) {
        logError(what + ": pipeline '" + p->name + "' has no bindings in set " + std::to_string(desc.set));
        return {};
    }
    const VkDescriptorSetLayout layout = p->setLayouts[desc.set];
    const std::vector<SetLayoutBinding> layoutBindings = p->sets[desc.set];

    // Validate the entries and gather descriptor infos before allocating anything.
    BindGroupRes g;
    g.setIndex = desc.set;
    g.layout = layout;
    g.name = desc.debugName;
    for (const BindGroupEntry& e : desc.entries) {
        const std::string where = what + " binding " + std::to_string(e.binding);
        auto lb = std::find_if(layoutBindings.begin(), layoutBindings.end(),
                               [&](const SetLayoutBinding& b) { return b.binding == e.binding; });
        if (lb == layoutBindings.end()) {
            logError(where + ": pipeline '" + p->name + "' has no such binding in set " +
                     std::to_string(desc.set));
            return {};
        }
        if (e.arrayElement >= lb->count) {
            logError(where + ": array element " + std::to_string(e.arrayElement) + " out of range (" +
                     std::to_string(lb->count) + ")");
            return {};
        }
        BindGroupRes::Write w;
        w.binding = e.binding;
        w.arrayElement = e.arrayElement;
        w.type = toVkDescriptorType(lb->type);
        switch (lb->type) {
            case BindingType::UniformBuffer:
            case BindingType::StorageBuffer:
            case BindingType::ReadOnlyStorageBuffer: {
                const BufferRes* b = m_buffers.get(e.buffer);
                if (!b) {
                    logError(where + " ('" + lb->name + "'): invalid or stale buffer handle");
                    return {};
                }
                const bool uniform = lb->type == BindingType::UniformBuffer;
                const VkBufferUsageFlags need =
                    uniform ? VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT : VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
                if (!(b->usage & need)) {
                    logError(where + " ('" + lb->name + "'): buffer '" + b->desc.debugName + "' lacks " +
                             (uniform ? "Uniform" : "Storage") + " usage");
                    return {};
                }
                const uint64_t align = uniform ? m_props.limits.minUniformBufferOffsetAlignment
                                               : m_props.limits.minStorageBufferOffsetAlignment;
                if (align > 1 && e.offset % align != 0) {
                    logError(where + ": offset " + std::to_string(e.offset) + " is not a multiple of " +
                             std::to_string(align));
                    return {};
                }
                if (e.offset >= b->desc.size || e.size > b->desc.size - e.offset) {
                    logError(where + ": range [" + std::to_string(e.offset) + ", +" + std::to_string(e.size) +
                             ") exceeds the buffer size " + std::to_string(b->desc.size));
                    return {};
                }
                const uint64_t range = e.size ? e.size : b->desc.size - e.offset;
                const uint64_t maxRange =
                    uniform ? m_props.limits.maxUniformBufferRange : m_props.limits.maxStorageBufferRange;
                if (range > maxRange) {
                    logError(where + ": range of " + std::to_string(range) +
                             " bytes exceeds the device limit " + std::to_string(maxRange));
                    return {};
                }
                w.buffer = {b->buffer, e.offset, e.size ? e.size : VK_WHOLE_SIZE};
                break;
            }
            case BindingType::SampledTexture:
            case BindingType::StorageTexture: {
                TextureRes* t = m_textures.get(e.texture);
                if (!t) {
                    logError(where + " ('" + lb->name + "'): invalid or stale texture handle");
                    return {};
                }
                if (t->desc.dimension != lb->dimension) {
                    logError(where + " ('" + lb->name + "'): texture '" + t->desc.debugName +
                             "' has a different dimension than the shader declares");
                    return {};
                }
                VkDescriptorImageInfo ii{};
                TextureRange range;
                std::string why;
                if (!detail::entryRange(t->desc, e, lb->type == BindingType::StorageTexture, range, why)) {
                    logError(where + " ('" + lb->name + "'): texture '" + t->desc.debugName + "': " + why);
                    return {};
                }
                const bool allLayers = range.baseLayer == 0 && range.layerCount == t->states.layers();
                if (lb->type == BindingType::SampledTexture) {
                    const SamplerRes* s = m_samplers.get(e.sampler);
                    if (!s) {
                        logError(where + " ('" + lb->name + "'): invalid or stale sampler handle");
                        return {};
                    }
                    if (!t->sampledView) {
                        logError(where + " ('" + lb->name + "'): texture '" + t->desc.debugName +
                                 "' was not created with Sampled usage");
                        return {};
                    }
                    ii.sampler = s->sampler;
                    ii.imageView = range == t->states.whole() ? t->sampledView : rangeView(*t, range);
                    if (!ii.imageView) return {};
                    ii.imageLayout = kSampledLayout;
                    w.sampledTexture = e.texture;
                    w.sampledRange = range;
                } else {
                    if (t->storageViews.empty()) {
                        logError(where + " ('" + lb->name + "'): texture '" + t->desc.debugName +
                                 "' was not created with Storage usage");
                        return {};
                    }
                    if (e.mip >= t->storageViews.size()) {
                        logError(where + ": mip " + std::to_string(e.mip) + " out of range (" +
                                 std::to_string(t->storageViews.size()) + " levels)");
                        return {};
                    }
                    ii.imageView = allLayers ? t->storageViews[e.mip] : rangeView(*t, range);
                    if (!ii.imageView) return {};
                    ii.imageLayout = VK_IMAGE_LAYOUT_GENERAL;
                }
                w.image = ii;
                break;
            }
        }
        g.writes.push_back(w);
    }

    if (!allocateDescriptorSet(layout, g.set, g.poolIndex, what)) return {};
    writeDescriptors(g, g.set, 0);
    setName(VK_OBJECT_TYPE_DESCRIPTOR_SET, uint64_t(g.set), desc.debugName);
    BindGroupHandle h = m_bindGroups.insert(g);
    if (h) ++m_stats.bindGroupsCreated;
    if (!h) {
        logError(what + ": too many live bind groups");
        freeBindGroup(g);
    }
    return h;
}

bool VulkanDevice::allocateDescriptorSet(VkDescriptorSetLayout layout, VkDescriptorSet& set,
                                         uint32_t& poolIndex, const std::string& what) {
    // Allocate from the newest pool; grow when it is exhausted.
    auto alloc = vkInit<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    alloc.descriptorSetCount = 1;
    alloc.pSetLayouts = &layout;
    VkResult r = VK_ERROR_OUT_OF_POOL_MEMORY;
    if (!m_descriptorPools.empty()) {
        alloc.descriptorPool = m_descriptorPools.back();
        r = vkAllocateDescriptorSets(m_device, &alloc, &set);
    }
    if (r == VK_ERROR_OUT_OF_POOL_MEMORY || r == VK_ERROR_FRAGMENTED_POOL) {
        const VkDescriptorPoolSize sizes[] = {
            {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 512},
            {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1024},
            {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1024},
            {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 512},
        };
        auto pi = vkInit<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
        pi.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
        pi.maxSets = 256;
        pi.poolSizeCount = uint32_t(std::size(sizes));
        pi.pPoolSizes = sizes;
        VkDescriptorPool pool = VK_NULL_HANDLE;
        r = vkCreateDescriptorPool(m_device, &pi, nullptr, &pool);
        if (r != VK_SUCCESS) {
            logError(what + ": vkCreateDescriptorPool failed: " + resultString(r));
            return false;
        }
        m_descriptorPools.push_back(pool);
        alloc.descriptorPool = pool;
        r = vkAllocateDescriptorSets(m_device, &alloc, &set);
    }
    if (r != VK_SUCCESS) {
        logError(what + ": vkAllocateDescriptorSets failed: " + resultString(r));
        set = VK_NULL_HANDLE;
        return false;
    }
    poolIndex = uint32_t(m_descriptorPools.size() - 1);
    return true;
}

void VulkanDevice::writeDescriptors(const BindGroupRes& g, VkDescriptorSet set, uint64_t generalMask) {
    std::vector<VkDescriptorImageInfo> images(g.writes.size());
    std::vector<VkWriteDescriptorSet> writes;
    uint32_t sampledIndex = 0;
    for (size_t i = 0; i < g.writes.size(); ++i) {
        const BindGroupRes::Write& src = g.writes[i];
        auto w = vkInit<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
        w.dstSet = set;
        w.dstBinding = src.binding;
        w.dstArrayElement = src.arrayElement;
        w.descriptorCount = 1;
        w.descriptorType = src.type;
        if (src.type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER || src.type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER) {
            w.pBufferInfo = &src.buffer;
        } else {
            images[i] = src.image;
            if (src.sampledTexture) {
                if (sampledIndex < 64 && (generalMask >> sampledIndex) & 1u)
                    images[i].imageLayout = VK_IMAGE_LAYOUT_GENERAL;
                ++sampledIndex;
            }
            w.pImageInfo = &images[i];
        }
        writes.push_back(w);
    }
    vkUpdateDescriptorSets(m_device, uint32_t(writes.size()), writes.data(), 0, nullptr);
}

VkDescriptorSet VulkanDevice::descriptorSetFor(BindGroupRes& g) {
    uint64_t mask = 0;
    uint32_t sampledIndex = 0;
    for (const BindGroupRes::Write& w : g.writes) {
        if (!w.sampledTexture) continue;
        const TextureRes* t = m_textures.get(w.sampledTexture);
        // The viewed subresources share one layout when the group is bound correctly (the
        // validation wrapper checks that); the first one decides.
        const Access state =
            t ? t->states.get(w.sampledRange.baseMip, w.sampledRange.baseLayer) : Access::None;
        if (sampledIndex < 64 && t && layoutOf(*t, state) == VK_IMAGE_LAYOUT_GENERAL)
            mask |= uint64_t(1) << sampledIndex;
        ++sampledIndex;
    }
    if (mask == 0) return g.set;
    for (const BindGroupRes::Variant& v : g.variants)
        if (v.generalMask == mask) return v.set;
    BindGroupRes::Variant v;
    v.generalMask = mask;
    if (!allocateDescriptorSet(g.layout, v.set, v.poolIndex, "bindGroup('" + g.name + "')")) return g.set;
    writeDescriptors(g, v.set, mask);
    setName(VK_OBJECT_TYPE_DESCRIPTOR_SET, uint64_t(v.set), g.name + " (GENERAL layouts)");
    g.variants.push_back(v);
    return v.set;
}

void VulkanDevice::freeBindGroup(const BindGroupRes& g) {
    vkFreeDescriptorSets(m_device, m_descriptorPools[g.poolIndex], 1, &g.set);
    for (const BindGroupRes::Variant& v : g.variants)
        vkFreeDescriptorSets(m_device, m_descriptorPools[v.poolIndex], 1, &v.set);
}

// ---------------------------------------------------------------------------------------------------
// Query pools
// ---------------------------------------------------------------------------------------------------
QueryPoolHandle VulkanDevice::createQueryPool(const QueryPoolDesc& desc) {
    const std::string what = "createQueryPool" + quoted(desc.debugName);
    if (!m_info.limits.timestamps) {
        logError(what + ": the device does not support timestamps on its graphics+compute queue");
        return {};
    }
    if (desc.count == 0) {
        logError(what + ": count is 0");
        return {};
    }
    auto info = vkInit<VkQueryPoolCreateInfo>(VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO);
    info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    info.queryCount = desc.count;
    QueryPoolRes q;
    q.count = desc.count;
    VkResult r = vkCreateQueryPool(m_device, &info, nullptr, &q.pool);
    if (r != VK_SUCCESS) {
        logError(what + ": vkCreateQueryPool failed: " + resultString(r));
        return {};
    }
    setName(VK_OBJECT_TYPE_QUERY_POOL, uint64_t(q.pool), desc.debugName);
    // Queries start in an undefined state: reset them once, ahead of any use.
    VkCommandBuffer cmd = uploadCommands();
    if (cmd) vkCmdResetQueryPool(cmd, q.pool, 0, q.count);
    QueryPoolHandle h = m_queryPools.insert(q);
    if (!h) {
        logError(what + ": too many live query pools");
        m_deferred.push(m_nextSerial,
                        [this, pool = q.pool]() { vkDestroyQueryPool(m_device, pool, nullptr); });
    }
    return h;
}

// ---------------------------------------------------------------------------------------------------
// Deferred destruction
// ---------------------------------------------------------------------------------------------------
void VulkanDevice::destroy(BufferHandle h) {
    if (!h) return;
    auto v = m_buffers.remove(h);
    if (!v) {
        logError("destroy(BufferHandle): stale or foreign handle");
        return;
    }
    m_deferred.push(m_nextSerial, [this, b = std::move(*v)]() mutable {
        vkDestroyBuffer(m_device, b.buffer, nullptr);
        m_allocator.free(b.alloc);
    });
}

void VulkanDevice::destroy(TextureHandle h) {
    if (!h) return;
    const TextureRes* t = m_textures.get(h);
    if (!t) {
        logError("destroy(TextureHandle): stale or foreign handle");
        return;
    }
    if (t->backbuffer) {
        logError("destroy(TextureHandle): backbuffers belong to the swapchain and cannot be destroyed");
        return;
    }
    auto v = m_textures.remove(h);
    m_deferred.push(m_nextSerial, [this, t = std::move(*v)]() mutable { releaseTexture(t); });
}

void VulkanDevice::destroy(SamplerHandle h) {
    if (!h) return;
    auto v = m_samplers.remove(h);
    if (!v) {
        logError("destroy(SamplerHandle): stale or foreign handle");
        return;
    }
    m_deferred.push(m_nextSerial, [this, s = *v]() { vkDestroySampler(m_device, s.sampler, nullptr); });
}

void VulkanDevice::destroy(ShaderHandle h) {
    if (!h) return;
    auto v = m_shaders.remove(h);
    if (!v) {
        logError("destroy(ShaderHandle): stale or foreign handle");
        return;
    }
    // Pipelines keep no reference to the module once created: release it now.
    vkDestroyShaderModule(m_device, v->module, nullptr);
}

void VulkanDevice::destroy(PipelineHandle h) {
    if (!h) return;
    auto v = m_pipelines.remove(h);
    if (!v) {
        logError("destroy(PipelineHandle): stale or foreign handle");
        return;
    }
    m_deferred.push(m_nextSerial, [this, pipeline = v->pipeline, layout = v->layout]() {
        vkDestroyPipeline(m_device, pipeline, nullptr);
        vkDestroyPipelineLayout(m_device, layout, nullptr);
    });
}

void VulkanDevice::destroy(BindGroupHandle h) {
    if (!h) return;
    auto v = m_bindGroups.remove(h);
    if (!v) {
        logError("destroy(BindGroupHandle): stale or foreign handle");
        return;
    }
    m_deferred.push(m_nextSerial, [this, g = std::move(*v)]() { freeBindGroup(g); });
}

void VulkanDevice::destroy(QueryPoolHandle h) {
    if (!h) return;
    auto v = m_queryPools.remove(h);
    if (!v) {
        logError("destroy(QueryPoolHandle): stale or foreign handle");
        return;
    }
    m_deferred.push(m_nextSerial, [this, q = *v]() { vkDestroyQueryPool(m_device, q.pool, nullptr); });
}

// ---------------------------------------------------------------------------------------------------
// Uploads
// ---------------------------------------------------------------------------------------------------
VkCommandBuffer VulkanDevice::uploadCommands() {
    if (m_uploadCmd) return m_uploadCmd;
    m_uploadCmd = beginInternalCommands();
    if (!m_uploadCmd) return VK_NULL_HANDLE;
    setName(VK_OBJECT_TYPE_COMMAND_BUFFER, uint64_t(m_uploadCmd), "penumbra uploads");
    // Earlier submissions may still read or write what the uploads overwrite.
    cmdMemoryBarrier(m_uploadCmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                     VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
    return m_uploadCmd;
}

void VulkanDevice::destroyStagingChunk(StagingChunk& c) {
    if (c.buffer) vkDestroyBuffer(m_device, c.buffer, nullptr);
    m_allocator.free(c.alloc);
    c = {};
}

bool VulkanDevice::allocateStaging(VkDeviceSize size, StagingSlice& out) {
    constexpr VkDeviceSize kAlign = 16;
    if (!m_uploadChunks.empty()) {
        StagingChunk& c = m_uploadChunks.back();
        const VkDeviceSize offset = alignUp(c.used, kAlign);
        if (offset <= c.size && c.size - offset >= size) {
            c.used = offset + size;
            out = {c.buffer, offset, static_cast<uint8_t*>(c.alloc.mapped) + offset};
            return true;
        }
    }
    StagingChunk c;
    if (size <= kStagingChunkSize && !m_freeChunks.empty()) {
        c = m_freeChunks.back();
        m_freeChunks.pop_back();
    } else {
        c.size = std::max(kStagingChunkSize, alignUp(size, kAlign));
        if (!createRawBuffer(c.size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryType::Upload, c.buffer, c.alloc,
                             "staging buffer"))
            return false;
        setName(VK_OBJECT_TYPE_BUFFER, uint64_t(c.buffer), "penumbra staging");
    }
    c.used = size;
    out = {c.buffer, 0, static_cast<uint8_t*>(c.alloc.mapped)};
    m_uploadChunks.push_back(c);
    return true;
}

void VulkanDevice::writeBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) {
    BufferRes* b = buffer(dst, "writeBuffer");
    if (!b || size == 0) return;
    if (!data) {
        logError("writeBuffer: data is null");
        return;
    }
    if (offset > b->desc.size || size > b->desc.size - offset) {
        logError("writeBuffer: range [" + std::to_string(offset) + ", +" + std::to_string(size) +
                 ") exceeds buffer '" + b->desc.debugName + "' of " + std::to_string(b->desc.size) +
                 " bytes");
        return;
    }
    StagingSlice s;
    VkCommandBuffer cmd = uploadCommands();
    if (!cmd || !allocateStaging(size, s)) return;
    std::memcpy(s.ptr, data, size);
    VkBufferCopy region{s.offset, offset, size};
    vkCmdCopyBuffer(cmd, s.buffer, b->buffer, 1, &region);
}

VkImageLayout VulkanDevice::layoutOf(const TextureRes& t, Access a) const {
    // Device-owned backbuffers (blitted to the swapchain at present()) wait in TRANSFER_SRC:
    // PRESENT_SRC_KHR is reserved for presentable images.
    if (t.backbuffer && t.ownsImage && a == Access::Present) return VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    return layoutFor(a, formatInfo(t.desc.format).isDepth, m_separateDepthLayouts);
}

void VulkanDevice::recordImageBarrier(VkCommandBuffer cmd, TextureRes& t, Access before, Access after,
                                      bool waitForAllWrites, const TextureRange* range) {
    const TextureRange r = range ? *range : t.states.whole();
    AccessScope src = accessScope(before, true);
    if (waitForAllWrites) {
        src.stages = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
        src.access = VK_ACCESS_2_MEMORY_WRITE_BIT;
    }
    const AccessScope dst = accessScope(after, false);
    auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
    auto ib = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
    auto mb = vkInit<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
    const VkImageLayout oldLayout = layoutOf(t, before);
    const VkImageLayout newLayout = layoutOf(t, after);
    if (newLayout == VK_IMAGE_LAYOUT_UNDEFINED) {
        // Nothing to transition to (after = None): only order the accesses.
        mb.srcStageMask = src.stages;
        mb.srcAccessMask = src.access;
        mb.dstStageMask = dst.stages;
        mb.dstAccessMask = dst.access;
        dep.memoryBarrierCount = 1;
        dep.pMemoryBarriers = &mb;
    } else {
        ib.srcStageMask = src.stages;
        ib.srcAccessMask = src.access;
        ib.dstStageMask = dst.stages;
        ib.dstAccessMask = dst.access;
        ib.oldLayout = oldLayout;
        ib.newLayout = newLayout;
        ib.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        ib.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        ib.image = t.image;
        ib.subresourceRange = {t.aspect, r.baseMip, r.mipCount, r.baseLayer, r.layerCount};
        dep.imageMemoryBarrierCount = 1;
        dep.pImageMemoryBarriers = &ib;
    }
    vkCmdPipelineBarrier2(cmd, &dep);
    t.states.set(r, after);
}

void VulkanDevice::transitionTracked(VkCommandBuffer cmd, TextureRes& t, Access after, bool waitForAllWrites,
                                     const TextureRange* range) {
    const TextureRange r = range ? *range : t.states.whole();
    t.states.forEachRun(r, [&](const TextureRange& run, Access before) {
        recordImageBarrier(cmd, t, before, after, waitForAllWrites, &run);
    });
}

namespace {
// Extent of one subresource and checks shared by writeTexture / readTexture.
bool subresourceExtent(const TextureDesc& d, TextureSubresource sub, VkExtent3D& extent, uint32_t& layer,
                       std::string& error) {
    if (sub.mip >= d.mipLevels) {
        error =
            "mip " + std::to_string(sub.mip) + " out of range (" + std::to_string(d.mipLevels) + " levels)";
        return false;
    }
    const bool isArray = d.dimension == TextureDimension::Tex2DArray;
    if (isArray ? sub.layer >= d.depthOrLayers : sub.layer != 0) {
        error = "layer " + std::to_string(sub.layer) + " out of range";
        return false;
    }
    extent = {mipExtent(d.width, sub.mip), mipExtent(d.height, sub.mip),
              d.dimension == TextureDimension::Tex3D ? mipExtent(d.depthOrLayers, sub.mip) : 1};
    layer = isArray ? sub.layer : 0;
    return true;
}
}  // namespace

void VulkanDevice::writeTexture(TextureHandle dst, TextureSubresource sub, const void* data, uint64_t size) {
    writeTextureImpl(dst, TextureRegion{sub.mip, sub.layer}, data, size, "writeTexture");
}

void VulkanDevice::writeTextureRegion(TextureHandle dst, const TextureRegion& region, const void* data,
                                      uint64_t size) {
    writeTextureImpl(dst, region, data, size, "writeTextureRegion");
}

void VulkanDevice::writeTextureImpl(TextureHandle dst, const TextureRegion& in, const void* data,
                                    uint64_t size, const char* fn) {
    TextureRes* t = texture(dst, fn);
    if (!t) return;
    const std::string what = std::string(fn) + "('" + t->desc.debugName + "')";
    TextureRegion box;
    std::string err;
    if (!detail::resolveRegion(t->desc, in, box, err)) {
        logError(what + ": " + err);
        return;
    }
    const uint64_t expected = detail::regionBytes(t->desc, box);
    if (!data || size != expected) {
        logError(what + ": expected " + std::to_string(expected) + " bytes of tightly packed texels, got " +
                 std::to_string(data ? size : 0));
        return;
    }
    if (!(t->usage & VK_IMAGE_USAGE_TRANSFER_DST_BIT)) {
        logError(what + ": the format does not support transfers");
        return;
    }
    StagingSlice s;
    VkCommandBuffer cmd = uploadCommands();
    if (!cmd || !allocateStaging(size, s)) return;
    std::memcpy(s.ptr, data, size);
    transitionTracked(cmd, *t, Access::CopyDst);
    const VkBufferImageCopy region = imageCopyRegion(*t, box, s.offset);
    vkCmdCopyBufferToImage(cmd, s.buffer, t->image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    recordImageBarrier(cmd, *t, Access::CopyDst, Access::ShaderSampled);
}

VkBufferImageCopy imageCopyRegion(const TextureRes& t, const TextureRegion& box, VkDeviceSize bufferOffset) {
    VkBufferImageCopy region{};
    region.bufferOffset = bufferOffset;
    region.imageSubresource = {t.aspect, box.mip, box.layer, 1};
    region.imageOffset = {int32_t(box.x), int32_t(box.y), int32_t(box.z)};
    region.imageExtent = {box.width, box.height, box.depth};
    return region;
}

// ---------------------------------------------------------------------------------------------------
// Readback
// ---------------------------------------------------------------------------------------------------
bool VulkanDevice::readBuffer(BufferHandle src, uint64_t offset, uint64_t size, void* out) {
    BufferRes* b = buffer(src, "readBuffer");
    if (!b) return false;
    if (offset > b->desc.size || size > b->desc.size - offset) {
        logError("readBuffer: range [" + std::to_string(offset) + ", +" + std::to_string(size) +
                 ") exceeds buffer '" + b->desc.debugName + "' of " + std::to_string(b->desc.size) +
                 " bytes");
        return false;
    }
    if (size == 0) return true;
    if (!out) {
        logError("readBuffer: out is null");
        return false;
    }
    VkBuffer staging = VK_NULL_HANDLE;
    Allocation alloc;
    if (!createRawBuffer(size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryType::Readback, staging, alloc,
                         "readBuffer"))
        return false;
    VkCommandBuffer cmd = beginInternalCommands();
    bool ok = cmd != VK_NULL_HANDLE;
    if (ok) {
        cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
        VkBufferCopy region{offset, 0, size};
        vkCmdCopyBuffer(cmd, b->buffer, staging, 1, &region);
        cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
        ok = submitInternalAndWait(cmd);
    }
    if (ok) {
        if (!alloc.coherent) {
            auto range = vkInit<VkMappedMemoryRange>(VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE);
            range.memory = alloc.memory;
            range.offset = 0;
            range.size = VK_WHOLE_SIZE;
            vkInvalidateMappedMemoryRanges(m_device, 1, &range);
        }
        std::memcpy(out, alloc.mapped, size);
    }
    vkDestroyBuffer(m_device, staging, nullptr);
    m_allocator.free(alloc);
    return ok;
}

bool VulkanDevice::readTexture(TextureHandle src, TextureSubresource sub, Access currentAccess,
                               std::vector<uint8_t>& out) {
    TextureRes* t = texture(src, "readTexture");
    if (!t) return false;
    const std::string what = "readTexture('" + t->desc.debugName + "')";
    VkExtent3D extent;
    uint32_t layer = 0;
    std::string err;
    if (!subresourceExtent(t->desc, sub, extent, layer, err)) {
        logError(what + ": " + err);
        return false;
    }
    if (!(t->usage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT)) {
        logError(what + ": the image cannot be a transfer source");
        return false;
    }
    const uint64_t size =
        uint64_t(extent.width) * extent.height * extent.depth * formatInfo(t->desc.format).bytesPerTexel;
    VkBuffer staging = VK_NULL_HANDLE;
    Allocation alloc;
    if (!createRawBuffer(size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryType::Readback, staging, alloc,
                         "readTexture"))
        return false;
    VkCommandBuffer cmd = beginInternalCommands();
    bool ok = cmd != VK_NULL_HANDLE;
    if (ok) {
        // Wait for every earlier write to the image, then copy; only the read subresource moves.
        const TextureRange one = TextureRange{sub.mip, 1, layer, 1};
        recordImageBarrier(cmd, *t, currentAccess, Access::CopySrc, true, &one);
        VkBufferImageCopy region{};
        region.imageSubresource = {t->aspect, sub.mip, layer, 1};
        region.imageExtent = extent;
        vkCmdCopyImageToBuffer(cmd, t->image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, staging, 1, &region);
        if (currentAccess != Access::None)
            recordImageBarrier(cmd, *t, Access::CopySrc, currentAccess, false, &one);
        else
            t->states.set(one, Access::None);  // contents were undefined; later barriers start from UNDEFINED
        cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
        ok = submitInternalAndWait(cmd);
    }
    if (ok) {
        if (!alloc.coherent) {
            auto range = vkInit<VkMappedMemoryRange>(VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE);
            range.memory = alloc.memory;
            range.offset = 0;
            range.size = VK_WHOLE_SIZE;
            vkInvalidateMappedMemoryRanges(m_device, 1, &range);
        }
        out.resize(size);
        std::memcpy(out.data(), alloc.mapped, size);
    }
    vkDestroyBuffer(m_device, staging, nullptr);
    m_allocator.free(alloc);
    return ok;
}

bool VulkanDevice::readTimestamps(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs) {
    ++m_stats.blockingTimestampReads;
    return readTimestampsImpl(pool, first, count, outNs, true, "readTimestamps");
}

bool VulkanDevice::tryReadTimestamps(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs) {
    return readTimestampsImpl(pool, first, count, outNs, false, "tryReadTimestamps");
}

bool VulkanDevice::readTimestampsImpl(QueryPoolHandle pool, uint32_t first, uint32_t count, uint64_t* outNs,
                                      bool wait, const char* fn) {
    QueryPoolRes* q = m_queryPools.get(pool);
    if (!q) {
        logError(std::string(fn) + ": invalid or stale query pool handle");
        return false;
    }
    if (first >= q->count || count > q->count - first) {
        logError(std::string(fn) + ": queries [" + std::to_string(first) + ", +" + std::to_string(count) +
                 ") exceed the pool of " + std::to_string(q->count));
        return false;
    }
    if (count == 0) return true;
    if (!outNs) {
        logError(std::string(fn) + ": outNs is null");
        return false;
    }
    if (wait) {
        // Everything submitted so far must finish; queries never written then stay unavailable
        // (reported below) instead of blocking forever.
        flushUploadsAndWait();
        if (!waitSerial(m_lastSubmitted)) return false;
    }
    std::vector<uint64_t> data(size_t(count) * 2);
    VkResult r = vkGetQueryPoolResults(m_device, q->pool, first, count, data.size() * sizeof(uint64_t),
                                       data.data(), 2 * sizeof(uint64_t),
                                       VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WITH_AVAILABILITY_BIT);
    if (r != VK_SUCCESS && r != VK_NOT_READY) {
        logError(std::string(fn) + ": vkGetQueryPoolResults failed: " + resultString(r));
        return false;
    }
    for (uint32_t i = 0; i < count; ++i) {
        if (data[2 * i + 1] != 0) continue;
        if (!wait) return false;  // not available yet
        logError(std::string(fn) + ": query " + std::to_string(first + i) +
                 " has no result (never written by a submitted command list)");
        return false;
    }
    const uint64_t mask =
        m_timestampValidBits >= 64 ? ~uint64_t(0) : ((uint64_t(1) << m_timestampValidBits) - 1);
    for (uint32_t i = 0; i < count; ++i)
        outNs[i] = uint64_t(double(data[2 * i] & mask) * double(m_props.limits.timestampPeriod));
    return true;
}

}  // namespace rhi::vk
