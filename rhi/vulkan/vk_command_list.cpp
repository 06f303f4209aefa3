// Vulkan backend — command recording straight into a VkCommandBuffer.
#include <algorithm>
#include <cstring>

#include "rhi/vulkan/vk_common.h"
#include "rhi/vulkan/vk_device.h"

namespace rhi::vk {

void VulkanCommandList::reset(VkCommandBuffer cmd, std::string_view name) {
    m_cmd = cmd;
    m_open = true;
    m_inRenderPass = false;
    m_skippingPass = false;
    m_passLabel = false;
    m_debugDepth = 0;
    m_name = std::string(name);
    m_hasPipeline = false;
    m_graphics = false;
    m_layout = VK_NULL_HANDLE;
    m_setLayouts = {};
    m_pushStages = 0;
    m_pushSize = 0;
}

void VulkanCommandList::error(const std::string& message) {
    m_dev.logError("command list" + (m_name.empty() ? std::string() : " '" + m_name + "'") + ": " + message);
}

bool VulkanCommandList::checkOpen(const char* what) {
    if (!m_open) {
        error(std::string(what) + ": the list was already submitted");
        return false;
    }
    if (!m_cmd) {
        error(std::string(what) + ": the list has no command buffer (beginCommandList failed)");
        return false;
    }
    return true;
}

bool VulkanCommandList::checkOutsideRenderPass(const char* what) {
    if (!checkOpen(what)) return false;
    if (m_inRenderPass || m_skippingPass) {
        error(std::string(what) + " inside a render pass");
        return false;
    }
    return true;
}

bool VulkanCommandList::checkInsideRenderPass(const char* what) {
    if (!checkOpen(what)) return false;
    if (m_skippingPass) return false;  // beginRenderPass failed and said why
    if (!m_inRenderPass) {
        error(std::string(what) + " outside a render pass");
        return false;
    }
    return true;
}

bool VulkanCommandList::checkPipeline(const char* what, bool graphics) {
    if (!m_hasPipeline) {
        error(std::string(what) + ": no pipeline bound");
        return false;
    }
    if (m_graphics != graphics) {
        error(std::string(what) + ": the bound pipeline is a " + (m_graphics ? "graphics" : "compute") +
              " pipeline");
        return false;
    }
    return true;
}

// ---------------------------------------------------------------------------------------------------
// Synchronisation
// ---------------------------------------------------------------------------------------------------
void VulkanCommandList::barrier(std::span<const Barrier> barriers) {
    if (!checkOutsideRenderPass("barrier")) return;
    std::vector<VkBufferMemoryBarrier2> bufferBarriers;
    std::vector<VkImageMemoryBarrier2> imageBarriers;
    auto global = vkInit<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
    bool useGlobal = false;
    auto flush = [&] {
        if (bufferBarriers.empty() && imageBarriers.empty() && !useGlobal) return;
        auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
        dep.memoryBarrierCount = useGlobal ? 1 : 0;
        dep.pMemoryBarriers = &global;
        dep.bufferMemoryBarrierCount = uint32_t(bufferBarriers.size());
        dep.pBufferMemoryBarriers = bufferBarriers.data();
        dep.imageMemoryBarrierCount = uint32_t(imageBarriers.size());
        dep.pImageMemoryBarriers = imageBarriers.data();
        vkCmdPipelineBarrier2(m_cmd, &dep);
        bufferBarriers.clear();
        imageBarriers.clear();
        global = vkInit<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
        useGlobal = false;
    };
    for (const Barrier& b : barriers) {
        if (b.buffer.isValid() == b.texture.isValid()) {
            error("barrier: exactly one of buffer / texture must be set");
            continue;
        }
        const AccessScope src = accessScope(b.before, true);
        const AccessScope dst = accessScope(b.after, false);
        if (b.buffer) {
            BufferRes* buf = m_dev.buffer(b.buffer, "barrier");
            if (!buf) continue;
            auto bb = vkInit<VkBufferMemoryBarrier2>(VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2);
            bb.srcStageMask = src.stages;
            bb.srcAccessMask = src.access;
            bb.dstStageMask = dst.stages;
            bb.dstAccessMask = dst.access;
            bb.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            bb.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            bb.buffer = buf->buffer;
            bb.offset = 0;
            bb.size = VK_WHOLE_SIZE;
            bufferBarriers.push_back(bb);
            continue;
        }
        TextureRes* t = m_dev.texture(b.texture, "barrier");
        if (!t) continue;
        TextureRange range;
        if (!detail::resolveRange(t->desc, b.range, range)) {
            error("barrier: texture '" + t->desc.debugName + "' has no subresource range (base mip " +
                  std::to_string(b.range.baseMip) + ", base layer " + std::to_string(b.range.baseLayer) +
                  ") of that size");
            continue;
        }
        // Barriers of one vkCmdPipelineBarrier2 are unordered: a second transition of the same
        // image in this call goes into a following one.
        if (std::any_of(imageBarriers.begin(), imageBarriers.end(),
                        [&](const VkImageMemoryBarrier2& ib) { return ib.image == t->image; }))
            flush();
        const VkImageLayout oldLayout = m_dev.layoutOf(*t, b.before);
        const VkImageLayout newLayout = m_dev.layoutOf(*t, b.after);
        if (newLayout == VK_IMAGE_LAYOUT_UNDEFINED) {
            // after = None: no layout to go to; just order the accesses.
            global.srcStageMask |= src.stages;
            global.srcAccessMask |= src.access;
            useGlobal = true;
        } else {
            auto ib = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
            ib.srcStageMask = src.stages;
            ib.srcAccessMask = src.access;
            ib.dstStageMask = dst.stages;
            ib.dstAccessMask = dst.access;
            ib.oldLayout = oldLayout;
            ib.newLayout = newLayout;
            ib.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            ib.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            ib.image = t->image;
            ib.subresourceRange = {t->aspect, range.baseMip, range.mipCount, range.baseLayer,
                                   range.layerCount};
            imageBarriers.push_back(ib);
        }
        t->states.set(range, b.after);
    }
    flush();
}

// ---------------------------------------------------------------------------------------------------
// Transfers
// ---------------------------------------------------------------------------------------------------
void VulkanCommandList::updateBuffer(BufferHandle dst, uint64_t offset, const void* data, uint64_t size) {
    if (!checkOutsideRenderPass("updateBuffer")) return;
    BufferRes* b = m_dev.buffer(dst, "updateBuffer");
    if (!b || size == 0) return;
    if (!data) {
        error("updateBuffer: data is null");
        return;
    }
    if (offset % 4 != 0 || size % 4 != 0) {
        error("updateBuffer: offset and size must be multiples of 4");
        return;
    }
    if (offset > b->desc.size || size > b->desc.size - offset) {
        error("updateBuffer: range exceeds buffer '" + b->desc.debugName + "'");
        return;
    }
    constexpr uint64_t kMaxUpdate = 65536;
    const uint8_t* bytes = static_cast<const uint8_t*>(data);
    for (uint64_t done = 0; done < size; done += kMaxUpdate) {
        const uint64_t n = std::min(kMaxUpdate, size - done);
        vkCmdUpdateBuffer(m_cmd, b->buffer, offset + done, n, bytes + done);
    }
}

void VulkanCommandList::copyBuffer(BufferHandle src, uint64_t srcOffset, BufferHandle dst, uint64_t dstOffset,
                                   uint64_t size) {
    if (!checkOutsideRenderPass("copyBuffer")) return;
    BufferRes* s = m_dev.buffer(src, "copyBuffer (source)");
    BufferRes* d = m_dev.buffer(dst, "copyBuffer (destination)");
    if (!s || !d || size == 0) return;
    if (srcOffset > s->desc.size || size > s->desc.size - srcOffset || dstOffset > d->desc.size ||
        size > d->desc.size - dstOffset) {
        error("copyBuffer: range exceeds a buffer");
        return;
    }
    if (s == d && srcOffset < dstOffset + size && dstOffset < srcOffset + size) {
        error("copyBuffer: source and destination ranges overlap");
        return;
    }
    VkBufferCopy region{srcOffset, dstOffset, size};
    vkCmdCopyBuffer(m_cmd, s->buffer, d->buffer, 1, &region);
}

void VulkanCommandList::fillBuffer(BufferHandle dst, uint64_t offset, uint64_t size, uint32_t value) {
    if (!checkOutsideRenderPass("fillBuffer")) return;
    BufferRes* b = m_dev.buffer(dst, "fillBuffer");
    if (!b || size == 0) return;
    if (offset % 4 != 0) {
        error("fillBuffer: offset must be a multiple of 4");
        return;
    }
    if (offset > b->desc.size || size > b->desc.size - offset) {
        error("fillBuffer: range exceeds buffer '" + b->desc.debugName + "'");
        return;
    }
    VkDeviceSize vkSize = size;
    if (size % 4 != 0) {
        if (offset + size != b->desc.size) {
            error("fillBuffer: size must be a multiple of 4 unless it reaches the end of the buffer");
            return;
        }
        vkSize = VK_WHOLE_SIZE;
    }
    vkCmdFillBuffer(m_cmd, b->buffer, offset, vkSize, value);
}

void VulkanCommandList::copyTexture(TextureHandle src, const TextureRegion& srcRegion, TextureHandle dst,
                                    const TextureRegion& dstRegion) {
    if (!checkOutsideRenderPass("copyTexture")) return;
    TextureRes* s = m_dev.texture(src, "copyTexture (source)");
    TextureRes* d = m_dev.texture(dst, "copyTexture (destination)");
    if (!s || !d) return;
    TextureRegion a, b;
    std::string why;
    if (!detail::checkTextureCopy(s->desc, srcRegion, d->desc, dstRegion, s == d, a, b, why)) {
        error("copyTexture '" + s->desc.debugName + "' -> '" + d->desc.debugName + "': " + why);
        return;
    }
    if (!(s->usage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) || !(d->usage & VK_IMAGE_USAGE_TRANSFER_DST_BIT)) {
        error("copyTexture: the source needs CopySrc usage and the destination CopyDst usage");
        return;
    }
    VkImageCopy region{};
    region.srcSubresource = {s->aspect, a.mip, a.layer, 1};
    region.srcOffset = {int32_t(a.x), int32_t(a.y), int32_t(a.z)};
    region.dstSubresource = {d->aspect, b.mip, b.layer, 1};
    region.dstOffset = {int32_t(b.x), int32_t(b.y), int32_t(b.z)};
    region.extent = {a.width, a.height, a.depth};
    vkCmdCopyImage(m_cmd, s->image, m_dev.layoutOf(*s, Access::CopySrc), d->image,
                   m_dev.layoutOf(*d, Access::CopyDst), 1, &region);
}

void VulkanCommandList::copyBufferToTexture(BufferHandle src, uint64_t srcOffset, TextureHandle dst,
                                            const TextureRegion& dstRegion) {
    if (!checkOutsideRenderPass("copyBufferToTexture")) return;
    BufferRes* b = m_dev.buffer(src, "copyBufferToTexture (source)");
    TextureRes* t = m_dev.texture(dst, "copyBufferToTexture (destination)");
    if (!b || !t) return;
    TextureRegion box;
    std::string why;
    if (!detail::checkBufferToTexture(b->desc.size, srcOffset, t->desc, dstRegion, box, why)) {
        error("copyBufferToTexture '" + b->desc.debugName + "' -> '" + t->desc.debugName + "': " + why);
        return;
    }
    if (!(b->usage & VK_BUFFER_USAGE_TRANSFER_SRC_BIT) || !(t->usage & VK_IMAGE_USAGE_TRANSFER_DST_BIT)) {
        error("copyBufferToTexture: the buffer needs CopySrc usage and the texture CopyDst usage");
        return;
    }
    const VkBufferImageCopy region = imageCopyRegion(*t, box, srcOffset);
    vkCmdCopyBufferToImage(m_cmd, b->buffer, t->image, m_dev.layoutOf(*t, Access::CopyDst), 1, &region);
}

// ---------------------------------------------------------------------------------------------------
// Pipelines and resources
// ---------------------------------------------------------------------------------------------------
void VulkanCommandList::bindPipeline(PipelineHandle pipeline) {
    if (!checkOpen("bindPipeline")) return;
    const PipelineRes* p = m_dev.m_pipelines.get(pipeline);
    if (!p) {
        error("bindPipeline: invalid or stale pipeline handle");
        return;
    }
    const bool graphics = p->bindPoint == VK_PIPELINE_BIND_POINT_GRAPHICS;
    if (!graphics && (m_inRenderPass || m_skippingPass)) {
        error("bindPipeline: compute pipeline '" + p->name + "' bound inside a render pass");
        return;
    }
    vkCmdBindPipeline(m_cmd, p->bindPoint, p->pipeline);
    m_hasPipeline = true;
    m_graphics = graphics;
    m_layout = p->layout;
    m_setLayouts = p->setLayouts;
    m_setCount = p->setCount;
    m_pushStages = p->pushStages;
    m_pushSize = p->pushSize;
}

void VulkanCommandList::bindGroup(uint32_t set, BindGroupHandle group) {
    if (!checkOpen("bindGroup")) return;
    if (!m_hasPipeline) {
        error("bindGroup: bind a pipeline first (the bind group uses its layout)");
        return;
    }
    BindGroupRes* g = m_dev.m_bindGroups.get(group);
    if (!g) {
        error("bindGroup: invalid or stale bind group handle");
        return;
    }
    if (set >= m_setCount) {
        error("bindGroup: the bound pipeline has no set " + std::to_string(set));
        return;
    }
    if (g->setIndex != set || g->layout != m_setLayouts[set]) {
        error("bindGroup: the bind group (created for set " + std::to_string(g->setIndex) +
              ") does not match the bound pipeline's layout of set " + std::to_string(set));
        return;
    }
    // Sampled textures currently in a GENERAL-layout state need a descriptor saying so.
    const VkDescriptorSet ds = m_dev.descriptorSetFor(*g);
    vkCmdBindDescriptorSets(m_cmd,
                            m_graphics ? VK_PIPELINE_BIND_POINT_GRAPHICS : VK_PIPELINE_BIND_POINT_COMPUTE,
                            m_layout, set, 1, &ds, 0, nullptr);
}

void VulkanCommandList::pushConstants(const void* data, uint32_t size, uint32_t offset) {
    if (!checkOpen("pushConstants")) return;
    if (!m_hasPipeline) {
        error("pushConstants: no pipeline bound");
        return;
    }
    if (size == 0) return;
    if (!data) {
        error("pushConstants: data is null");
        return;
    }
    if (m_pushSize == 0) {
        error("pushConstants: the bound pipeline declares no push constants");
        return;
    }
    if (offset % 4 != 0 || size % 4 != 0) {
        error("pushConstants: offset and size must be multiples of 4");
        return;
    }
    if (offset > m_pushSize || size > m_pushSize - offset) {
        error("pushConstants: " + std::to_string(size) + " bytes at offset " + std::to_string(offset) +
              " exceed the pipeline's " + std::to_string(m_pushSize) + " bytes of push constants");
        return;
    }
    vkCmdPushConstants(m_cmd, m_layout, m_pushStages, offset, size, data);
}

// ---------------------------------------------------------------------------------------------------
// Compute
// ---------------------------------------------------------------------------------------------------
void VulkanCommandList::dispatch(uint32_t groupsX, uint32_t groupsY, uint32_t groupsZ) {
    if (!checkOutsideRenderPass("dispatch") || !checkPipeline("dispatch", false)) return;
    const auto& maxCount = m_dev.m_info.limits.maxComputeWorkgroupCount;
    if (groupsX > maxCount[0] || groupsY > maxCount[1] || groupsZ > maxCount[2]) {
        error("dispatch: " + std::to_string(groupsX) + "x" + std::to_string(groupsY) + "x" +
              std::to_string(groupsZ) + " workgroups exceed the device limit");
        return;
    }
    vkCmdDispatch(m_cmd, groupsX, groupsY, groupsZ);
}

void VulkanCommandList::dispatchIndirect(BufferHandle args, uint64_t offset) {
    if (!checkOutsideRenderPass("dispatchIndirect") || !checkPipeline("dispatchIndirect", false)) return;
    BufferRes* b = m_dev.buffer(args, "dispatchIndirect");
    if (!b) return;
    if (!(b->usage & VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT)) {
        error("dispatchIndirect: buffer '" + b->desc.debugName + "' lacks Indirect usage");
        return;
    }
    if (offset % 4 != 0 || offset > b->desc.size ||
        b->desc.size - offset < sizeof(VkDispatchIndirectCommand)) {
        error("dispatchIndirect: offset must be a multiple of 4 with 12 bytes of arguments after it");
        return;
    }
    vkCmdDispatchIndirect(m_cmd, b->buffer, offset);
}

// ---------------------------------------------------------------------------------------------------
// Render passes
// ---------------------------------------------------------------------------------------------------
void VulkanCommandList::beginRenderPass(const RenderPassDesc& desc) {
    if (!checkOpen("beginRenderPass")) return;
    if (m_inRenderPass || m_skippingPass) {
        error("beginRenderPass: the previous render pass was not ended");
        return;
    }
    // If anything is wrong the pass is skipped: draws until endRenderPass() are ignored.
    m_skippingPass = true;
    const std::string what =
        "beginRenderPass" + (desc.debugName.empty() ? std::string() : "('" + desc.debugName + "')");
    if (desc.colorAttachments.empty() && !desc.depthAttachment.texture) {
        error(what + ": no attachments");
        return;
    }
    if (desc.colorAttachments.size() > m_dev.m_info.limits.maxColorTargets) {
        error(what + ": too many colour attachments");
        return;
    }
    uint32_t width = UINT32_MAX, height = UINT32_MAX;
    std::vector<VkRenderingAttachmentInfo> colors;
    for (size_t i = 0; i < desc.colorAttachments.size(); ++i) {
        const ColorAttachment& ca = desc.colorAttachments[i];
        TextureRes* t = m_dev.texture(ca.texture, "beginRenderPass (colour attachment)");
        if (!t) return;
        const std::string att =
            what + ": colour attachment " + std::to_string(i) + " ('" + t->desc.debugName + "')";
        if (!(t->usage & VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT)) {
            error(att + " lacks ColorTarget usage");
            return;
        }
        if (ca.mip >= t->desc.mipLevels) {
            error(att + ": mip " + std::to_string(ca.mip) + " out of range");
            return;
        }
        const uint32_t layers = t->desc.dimension == TextureDimension::Tex3D
                                    ? std::max(1u, t->desc.depthOrLayers >> ca.mip)
                                    : t->desc.depthOrLayers;
        if (ca.layer >= layers) {
            error(att + ": layer " + std::to_string(ca.layer) + " out of range");
            return;
        }
        // A Tex3D attachment is a depth slice of the mip's volume (one state per mip).
        const Access state =
            t->states.get(ca.mip, t->desc.dimension == TextureDimension::Tex3D ? 0 : ca.layer);
        const VkImageLayout layout = m_dev.layoutOf(*t, state);
        if (layout != VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL && layout != VK_IMAGE_LAYOUT_GENERAL) {
            error(att + " is in state " + toString(state) + "; transition it to ColorTarget first");
            return;
        }
        VkImageView view = m_dev.attachmentView(*t, ca.mip, ca.layer);
        if (!view) return;
        auto ai = vkInit<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
        ai.imageView = view;
        ai.imageLayout = layout;
        ai.loadOp = ca.load == LoadOp::Clear  ? VK_ATTACHMENT_LOAD_OP_CLEAR
                    : ca.load == LoadOp::Load ? VK_ATTACHMENT_LOAD_OP_LOAD
                                              : VK_ATTACHMENT_LOAD_OP_DONT_CARE;
        ai.storeOp =
            ca.store == StoreOp::Store ? VK_ATTACHMENT_STORE_OP_STORE : VK_ATTACHMENT_STORE_OP_DONT_CARE;
        if (formatInfo(t->desc.format).isInteger) {
            for (int c = 0; c < 4; ++c)
                ai.clearValue.color.uint32[c] = uint32_t(std::max(0.0f, ca.clearColor[c]));
        } else {
            for (int c = 0; c < 4; ++c) ai.clearValue.color.float32[c] = ca.clearColor[c];
        }
        colors.push_back(ai);
        width = std::min(width, std::max(1u, t->desc.width >> ca.mip));
        height = std::min(height, std::max(1u, t->desc.height >> ca.mip));
    }
    auto depth = vkInit<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
    const DepthAttachment& da = desc.depthAttachment;
    if (da.texture) {
        TextureRes* t = m_dev.texture(da.texture, "beginRenderPass (depth attachment)");
        if (!t) return;
        const std::string att = what + ": depth attachment ('" + t->desc.debugName + "')";
        if (!(t->usage & VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT)) {
            error(att + " lacks DepthTarget usage");
            return;
        }
        const Access state = t->states.get(0, 0);
        const VkImageLayout layout = m_dev.layoutOf(*t, state);
        const bool writable = layout == VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL ||
                              layout == VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL ||
                              layout == VK_IMAGE_LAYOUT_GENERAL;
        const bool readable = writable || layout == VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL ||
                              layout == VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL ||
                              layout == VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL;
        if (da.readOnly ? !readable : !writable) {
            error(att + " is in state " + toString(state) + "; transition it to " +
                  (da.readOnly ? "DepthTargetRead" : "DepthTargetWrite") + " first");
            return;
        }
        VkImageView view = m_dev.attachmentView(*t, 0, 0);
        if (!view) return;
        depth.imageView = view;
        depth.imageLayout = layout;
        if (da.readOnly) {
            depth.loadOp =
                da.load == LoadOp::DontCare ? VK_ATTACHMENT_LOAD_OP_DONT_CARE : VK_ATTACHMENT_LOAD_OP_LOAD;
            depth.storeOp = VK_ATTACHMENT_STORE_OP_NONE;
        } else {
            depth.loadOp = da.load == LoadOp::Clear  ? VK_ATTACHMENT_LOAD_OP_CLEAR
                           : da.load == LoadOp::Load ? VK_ATTACHMENT_LOAD_OP_LOAD
                                                     : VK_ATTACHMENT_LOAD_OP_DONT_CARE;
            depth.storeOp =
                da.store == StoreOp::Store ? VK_ATTACHMENT_STORE_OP_STORE : VK_ATTACHMENT_STORE_OP_DONT_CARE;
        }
        depth.clearValue.depthStencil = {da.clearDepth, 0};
        width = std::min(width, t->desc.width);
        height = std::min(height, t->desc.height);
    }

    auto info = vkInit<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
    info.renderArea = {{0, 0}, {width, height}};
    info.layerCount = 1;
    info.colorAttachmentCount = uint32_t(colors.size());
    info.pColorAttachments = colors.data();
    info.pDepthAttachment = da.texture ? &depth : nullptr;
    if (!desc.debugName.empty() && m_dev.m_vkCmdBeginLabel) {
        auto label = vkInit<VkDebugUtilsLabelEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT);
        label.pLabelName = desc.debugName.c_str();
        m_dev.m_vkCmdBeginLabel(m_cmd, &label);
        m_passLabel = true;
    }
    vkCmdBeginRendering(m_cmd, &info);
    m_skippingPass = false;
    m_inRenderPass = true;
    // Defaults covering the whole render area; setViewport / setScissor override them.
    VkViewport vp{0.0f, 0.0f, float(width), float(height), 0.0f, 1.0f};
    VkRect2D sc{{0, 0}, {width, height}};
    vkCmdSetViewport(m_cmd, 0, 1, &vp);
    vkCmdSetScissor(m_cmd, 0, 1, &sc);
}

void VulkanCommandList::endRenderPass() {
    if (!checkOpen("endRenderPass")) return;
    if (m_skippingPass) {
        m_skippingPass = false;
        return;
    }
    if (!m_inRenderPass) {
        error("endRenderPass without beginRenderPass");
        return;
    }
    vkCmdEndRendering(m_cmd);
    m_inRenderPass = false;
    if (m_passLabel) {
        m_dev.m_vkCmdEndLabel(m_cmd);
        m_passLabel = false;
    }
}

void VulkanCommandList::setViewport(const Viewport& v) {
    if (!checkOpen("setViewport") || m_skippingPass) return;
    if (!(v.width > 0.0f) || v.height == 0.0f) {
        error("setViewport: width must be > 0 and height non-zero");
        return;
    }
    VkViewport vp{v.x, v.y, v.width, v.height, v.minDepth, v.maxDepth};
    vkCmdSetViewport(m_cmd, 0, 1, &vp);
}

void VulkanCommandList::setScissor(const Rect& r) {
    if (!checkOpen("setScissor") || m_skippingPass) return;
    // Vulkan forbids negative offsets: clip the rectangle to the positive quadrant.
    int64_t x0 = r.x, y0 = r.y;
    int64_t x1 = x0 + int64_t(r.width), y1 = y0 + int64_t(r.height);
    x0 = std::max<int64_t>(x0, 0);
    y0 = std::max<int64_t>(y0, 0);
    VkRect2D sc{{int32_t(x0), int32_t(y0)},
                {uint32_t(std::max<int64_t>(0, x1 - x0)), uint32_t(std::max<int64_t>(0, y1 - y0))}};
    vkCmdSetScissor(m_cmd, 0, 1, &sc);
}

void VulkanCommandList::bindVertexBuffer(uint32_t slot, BufferHandle buffer, uint64_t offset) {
    if (!checkOpen("bindVertexBuffer") || m_skippingPass) return;
    BufferRes* b = m_dev.buffer(buffer, "bindVertexBuffer");
    if (!b) return;
    if (!(b->usage & VK_BUFFER_USAGE_VERTEX_BUFFER_BIT)) {
        error("bindVertexBuffer: buffer '" + b->desc.debugName + "' lacks Vertex usage");
        return;
    }
    if (offset >= b->desc.size) {
        error("bindVertexBuffer: offset beyond the buffer");
        return;
    }
    VkDeviceSize off = offset;
    vkCmdBindVertexBuffers(m_cmd, slot, 1, &b->buffer, &off);
}

void VulkanCommandList::bindIndexBuffer(BufferHandle buffer, IndexType type, uint64_t offset) {
    if (!checkOpen("bindIndexBuffer") || m_skippingPass) return;
    BufferRes* b = m_dev.buffer(buffer, "bindIndexBuffer");
    if (!b) return;
    if (!(b->usage & VK_BUFFER_USAGE_INDEX_BUFFER_BIT)) {
        error("bindIndexBuffer: buffer '" + b->desc.debugName + "' lacks Index usage");
        return;
    }
    const uint64_t indexSize = type == IndexType::Uint16 ? 2 : 4;
    if (offset >= b->desc.size || offset % indexSize != 0) {
        error("bindIndexBuffer: offset beyond the buffer or not a multiple of the index size");
        return;
    }
    vkCmdBindIndexBuffer(m_cmd, b->buffer, offset,
                         type == IndexType::Uint16 ? VK_INDEX_TYPE_UINT16 : VK_INDEX_TYPE_UINT32);
}

void VulkanCommandList::draw(uint32_t vertexCount, uint32_t instanceCount, uint32_t firstVertex,
                             uint32_t firstInstance) {
    if (!checkInsideRenderPass("draw") || !checkPipeline("draw", true)) return;
    vkCmdDraw(m_cmd, vertexCount, instanceCount, firstVertex, firstInstance);
}

void VulkanCommandList::drawIndexed(uint32_t indexCount, uint32_t instanceCount, uint32_t firstIndex,
                                    int32_t vertexOffset, uint32_t firstInstance) {
    if (!checkInsideRenderPass("drawIndexed") || !checkPipeline("drawIndexed", true)) return;
    vkCmdDrawIndexed(m_cmd, indexCount, instanceCount, firstIndex, vertexOffset, firstInstance);
}

void VulkanCommandList::drawIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) {
    if (!checkInsideRenderPass("drawIndirect") || !checkPipeline("drawIndirect", true)) return;
    BufferRes* b = m_dev.buffer(args, "drawIndirect");
    if (!b || drawCount == 0) return;
    if (!(b->usage & VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT)) {
        error("drawIndirect: buffer '" + b->desc.debugName + "' lacks Indirect usage");
        return;
    }
    constexpr uint64_t stride = sizeof(VkDrawIndirectCommand);
    if (offset % 4 != 0 || offset > b->desc.size || (b->desc.size - offset) / stride < drawCount) {
        error("drawIndirect: " + std::to_string(drawCount) + " draws at offset " + std::to_string(offset) +
              " exceed the buffer (or the offset is not a multiple of 4)");
        return;
    }
    if (drawCount > 1 && !m_dev.m_multiDrawIndirect) {
        for (uint32_t i = 0; i < drawCount; ++i)
            vkCmdDrawIndirect(m_cmd, b->buffer, offset + i * stride, 1, uint32_t(stride));
        return;
    }
    vkCmdDrawIndirect(m_cmd, b->buffer, offset, drawCount, uint32_t(stride));
}

void VulkanCommandList::drawIndexedIndirect(BufferHandle args, uint64_t offset, uint32_t drawCount) {
    if (!checkInsideRenderPass("drawIndexedIndirect") || !checkPipeline("drawIndexedIndirect", true)) return;
    BufferRes* b = m_dev.buffer(args, "drawIndexedIndirect");
    if (!b || drawCount == 0) return;
    if (!(b->usage & VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT)) {
        error("drawIndexedIndirect: buffer '" + b->desc.debugName + "' lacks Indirect usage");
        return;
    }
    constexpr uint64_t stride = sizeof(VkDrawIndexedIndirectCommand);
    if (offset % 4 != 0 || offset > b->desc.size || (b->desc.size - offset) / stride < drawCount) {
        error("drawIndexedIndirect: " + std::to_string(drawCount) + " draws at offset " +
              std::to_string(offset) + " exceed the buffer (or the offset is not a multiple of 4)");
        return;
    }
    if (drawCount > 1 && !m_dev.m_multiDrawIndirect) {
        for (uint32_t i = 0; i < drawCount; ++i)
            vkCmdDrawIndexedIndirect(m_cmd, b->buffer, offset + i * stride, 1, uint32_t(stride));
        return;
    }
    vkCmdDrawIndexedIndirect(m_cmd, b->buffer, offset, drawCount, uint32_t(stride));
}

// ---------------------------------------------------------------------------------------------------
// Queries and debugging
// ---------------------------------------------------------------------------------------------------
void VulkanCommandList::resetQueries(QueryPoolHandle pool, uint32_t first, uint32_t count) {
    if (!checkOutsideRenderPass("resetQueries")) return;
    const QueryPoolRes* q = m_dev.m_queryPools.get(pool);
    if (!q) {
        error("resetQueries: invalid or stale query pool handle");
        return;
    }
    if (first >= q->count || count > q->count - first) {
        error("resetQueries: range exceeds the pool");
        return;
    }
    if (count) vkCmdResetQueryPool(m_cmd, q->pool, first, count);
}

void VulkanCommandList::writeTimestamp(QueryPoolHandle pool, uint32_t index) {
    if (!checkOpen("writeTimestamp")) return;
    const QueryPoolRes* q = m_dev.m_queryPools.get(pool);
    if (!q) {
        error("writeTimestamp: invalid or stale query pool handle");
        return;
    }
    if (index >= q->count) {
        error("writeTimestamp: index " + std::to_string(index) + " exceeds the pool of " +
              std::to_string(q->count));
        return;
    }
    // lavapipe runs queued work and takes queued timestamps where it flushes, which it does at a
    // pipeline barrier: an execution dependency (no memory access) before the timestamp charges
    // the work recorded before it to the interval before, and one after takes it here instead of
    // after the next command's work.
    if (!m_dev.m_barriersAroundTimestamps || m_inRenderPass) {
        vkCmdWriteTimestamp2(m_cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, q->pool, index);
        return;
    }
    cmdMemoryBarrier(m_cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_NONE,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_NONE);
    vkCmdWriteTimestamp2(m_cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, q->pool, index);
    cmdMemoryBarrier(m_cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_NONE,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_NONE);
}

void VulkanCommandList::pushDebugGroup(std::string_view name) {
    if (!checkOpen("pushDebugGroup")) return;
    ++m_debugDepth;
    if (!m_dev.m_vkCmdBeginLabel) return;
    std::string n(name);
    auto label = vkInit<VkDebugUtilsLabelEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT);
    label.pLabelName = n.c_str();
    m_dev.m_vkCmdBeginLabel(m_cmd, &label);
}

void VulkanCommandList::popDebugGroup() {
    if (!checkOpen("popDebugGroup")) return;
    if (m_debugDepth == 0) {
        error("popDebugGroup without a matching pushDebugGroup");
        return;
    }
    --m_debugDepth;
    if (m_dev.m_vkCmdEndLabel) m_dev.m_vkCmdEndLabel(m_cmd);
}

}  // namespace rhi::vk
