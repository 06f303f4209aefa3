// Vulkan backend — presentation to a GLFW window surface.
//
// backbufferFormat() is always RGBA8_UNORM. When the surface offers VK_FORMAT_R8G8B8A8_UNORM the
// swapchain images themselves are the backbuffer textures. Most X11/Wayland surfaces only offer
// BGRA8 formats, which rhi::Format cannot name; then each swapchain image gets a device-owned
// RGBA8 texture that the caller renders into, and present() blits it (with the channel swizzle)
// into the swapchain image. For the caller both look the same: acquire, transition None ->
// ColorTarget, render, transition -> Present, present().
#include <algorithm>

#include "rhi/vulkan/vk_common.h"
#include "rhi/vulkan/vk_device.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

namespace rhi::vk {

Format VulkanDevice::backbufferFormat() const {
    return m_desc.headless ? Format::Undefined : Format::RGBA8_UNORM;
}

void VulkanDevice::destroySwapchainImages() {
    for (TextureHandle h : m_swapchain.handles) {
        if (auto t = m_textures.remove(h)) releaseTexture(*t);
    }
    m_swapchain.handles.clear();
    m_swapchain.images.clear();
}

void VulkanDevice::destroySwapchain() {
    destroySwapchainImages();
    if (m_swapchain.swapchain) vkDestroySwapchainKHR(m_device, m_swapchain.swapchain, nullptr);
    m_swapchain.swapchain = VK_NULL_HANDLE;
    for (VkSemaphore s : m_swapchain.renderFinished) vkDestroySemaphore(m_device, s, nullptr);
    for (VkSemaphore s : m_swapchain.acquireSemaphores) vkDestroySemaphore(m_device, s, nullptr);
    m_swapchain.renderFinished.clear();
    m_swapchain.acquireSemaphores.clear();
    m_swapchain.acquireSerials.clear();
    m_swapchain.pendingAcquire = VK_NULL_HANDLE;
    m_swapchain.currentImage = -1;
}

void VulkanDevice::consumePendingAcquire() {
    if (!m_swapchain.pendingAcquire) return;
    // An acquire semaphore must be waited on before it can be reused or destroyed.
    const SemaphoreWait wait{m_swapchain.pendingAcquire, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT};
    uint64_t serial = submitBatch({}, std::span<const SemaphoreWait>(&wait, 1), VK_NULL_HANDLE);
    if (serial) m_swapchain.acquireSerials[m_swapchain.pendingAcquireSlot] = serial;
    m_swapchain.pendingAcquire = VK_NULL_HANDLE;
}

bool VulkanDevice::createSwapchain(uint32_t width, uint32_t height) {
    Swapchain& sc = m_swapchain;
    VkSurfaceCapabilitiesKHR caps;
    if (!check(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(m_physical, sc.surface, &caps),
               "vkGetPhysicalDeviceSurfaceCapabilitiesKHR"))
        return false;
    VkExtent2D extent = caps.currentExtent;
    if (extent.width == UINT32_MAX) {
        extent.width = std::clamp(width, caps.minImageExtent.width, caps.maxImageExtent.width);
        extent.height = std::clamp(height, caps.minImageExtent.height, caps.maxImageExtent.height);
    }
    sc.requestedWidth = width;
    sc.requestedHeight = height;
    if (extent.width == 0 || extent.height == 0) {
        // Minimised window: no swapchain until it has a size again.
        log(LogSeverity::Debug, "window has no area; swapchain creation postponed");
        destroySwapchain();
        sc.outOfDate = true;
        return true;
    }

    uint32_t count = 0;
    vkGetPhysicalDeviceSurfaceFormatsKHR(m_physical, sc.surface, &count, nullptr);
    std::vector<VkSurfaceFormatKHR> formats(count);
    vkGetPhysicalDeviceSurfaceFormatsKHR(m_physical, sc.surface, &count, formats.data());
    if (formats.empty()) {
        logError("the window surface reports no formats");
        return false;
    }
    auto findFormat = [&](VkFormat f) {
        return std::find_if(formats.begin(), formats.end(), [&](const VkSurfaceFormatKHR& s) {
            return s.format == f && s.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
        });
    };
    VkSurfaceFormatKHR chosen = formats.front();
    bool blit = true;
    if (auto it = findFormat(VK_FORMAT_R8G8B8A8_UNORM); it != formats.end()) {
        chosen = *it;
        blit = false;
    } else if (auto it2 = findFormat(VK_FORMAT_B8G8R8A8_UNORM); it2 != formats.end()) {
        chosen = *it2;
    }
    if (blit) {
        VkFormatProperties fp;
        vkGetPhysicalDeviceFormatProperties(m_physical, chosen.format, &fp);
        if (!(fp.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT)) {
            logError("the window surface offers no RGBA8 format and its format cannot be a blit destination");
            return false;
        }
    }

    vkGetPhysicalDeviceSurfacePresentModesKHR(m_physical, sc.surface, &count, nullptr);
    std::vector<VkPresentModeKHR> modes(count);
    vkGetPhysicalDeviceSurfacePresentModesKHR(m_physical, sc.surface, &count, modes.data());
    VkPresentModeKHR mode = VK_PRESENT_MODE_FIFO_KHR;
    if (!m_desc.vsync) {
        for (VkPresentModeKHR want : {VK_PRESENT_MODE_MAILBOX_KHR, VK_PRESENT_MODE_IMMEDIATE_KHR}) {
            if (std::find(modes.begin(), modes.end(), want) != modes.end()) {
                mode = want;
                break;
            }
        }
    }

    uint32_t imageCount = std::max(caps.minImageCount + 1, 3u);
    if (caps.maxImageCount > 0) imageCount = std::min(imageCount, caps.maxImageCount);
    const VkImageUsageFlags wanted =
        blit ? VK_IMAGE_USAGE_TRANSFER_DST_BIT
             : VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    if ((caps.supportedUsageFlags & wanted) != wanted) {
        logError("the window surface does not support the swapchain image usage penumbra needs");
        return false;
    }
    VkImageUsageFlags usage = wanted | (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
    VkCompositeAlphaFlagBitsKHR alpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
    if (!(caps.supportedCompositeAlpha & alpha)) {
        for (VkCompositeAlphaFlagBitsKHR a :
             {VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR, VK_COMPOSITE_ALPHA_PRE_MULTIPLIED_BIT_KHR,
              VK_COMPOSITE_ALPHA_POST_MULTIPLIED_BIT_KHR}) {
            if (caps.supportedCompositeAlpha & a) {
                alpha = a;
                break;
            }
        }
    }

    VkSwapchainKHR old = sc.swapchain;
    auto info = vkInit<VkSwapchainCreateInfoKHR>(VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR);
    info.surface = sc.surface;
    info.minImageCount = imageCount;
    info.imageFormat = chosen.format;
    info.imageColorSpace = chosen.colorSpace;
    info.imageExtent = extent;
    info.imageArrayLayers = 1;
    info.imageUsage = usage;
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.preTransform = caps.currentTransform;
    info.compositeAlpha = alpha;
    info.presentMode = mode;
    info.clipped = VK_TRUE;
    info.oldSwapchain = old;
    VkSwapchainKHR swapchain = VK_NULL_HANDLE;
    VkResult r = vkCreateSwapchainKHR(m_device, &info, nullptr, &swapchain);
    destroySwapchainImages();
    if (old) vkDestroySwapchainKHR(m_device, old, nullptr);
    sc.swapchain = VK_NULL_HANDLE;
    if (r != VK_SUCCESS) {
        logError(std::string("vkCreateSwapchainKHR failed: ") + resultString(r));
        return false;
    }
    sc.swapchain = swapchain;
    sc.format = chosen.format;
    sc.colorSpace = chosen.colorSpace;
    sc.presentMode = mode;
    sc.extent = extent;
    sc.blit = blit;
    sc.outOfDate = false;
    sc.currentImage = -1;

    vkGetSwapchainImagesKHR(m_device, swapchain, &count, nullptr);
    sc.images.resize(count);
    vkGetSwapchainImagesKHR(m_device, swapchain, &count, sc.images.data());

    for (uint32_t i = 0; i < count; ++i) {
        const std::string name = "backbuffer " + std::to_string(i);
        setName(VK_OBJECT_TYPE_IMAGE, uint64_t(sc.images[i]), "swapchain image " + std::to_string(i));
        TextureHandle h;
        if (blit) {
            TextureDesc d;
            d.format = Format::RGBA8_UNORM;
            d.width = extent.width;
            d.height = extent.height;
            d.usage = TextureUsage::ColorTarget | TextureUsage::CopySrc | TextureUsage::CopyDst |
                      TextureUsage::Sampled;
            d.debugName = name;
            h = createTexture(d);
            if (!h) return false;
            m_textures.get(h)->backbuffer = true;
        } else {
            TextureRes t;
            t.image = sc.images[i];
            t.ownsImage = false;
            t.backbuffer = true;
            t.format = chosen.format;
            t.aspect = VK_IMAGE_ASPECT_COLOR_BIT;
            t.usage = usage;
            t.desc.format = Format::RGBA8_UNORM;
            t.desc.width = extent.width;
            t.desc.height = extent.height;
            t.desc.usage = TextureUsage::ColorTarget | TextureUsage::CopyDst;
            if (usage & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) t.desc.usage |= TextureUsage::CopySrc;
            t.desc.debugName = name;
            t.states = detail::SubresourceStates(t.desc);
            h = m_textures.insert(t);
            if (!h) {
                logError("too many live textures for the swapchain images");
                return false;
            }
        }
        sc.handles.push_back(h);
    }

    auto makeSemaphores = [&](std::vector<VkSemaphore>& v, size_t n, const char* what) {
        while (v.size() < n) {
            auto si = vkInit<VkSemaphoreCreateInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO);
            VkSemaphore s = VK_NULL_HANDLE;
            if (!check(vkCreateSemaphore(m_device, &si, nullptr, &s), "vkCreateSemaphore")) return false;
            setName(VK_OBJECT_TYPE_SEMAPHORE, uint64_t(s),
                    std::string(what) + " " + std::to_string(v.size()));
            v.push_back(s);
        }
        return true;
    };
    if (!makeSemaphores(sc.renderFinished, count, "render finished")) return false;
    if (!makeSemaphores(sc.acquireSemaphores, count + 1, "image acquired")) return false;
    sc.acquireSerials.resize(sc.acquireSemaphores.size(), 0);
    sc.acquireCursor %= uint32_t(sc.acquireSemaphores.size());

    static const char* kModeNames[] = {"IMMEDIATE", "MAILBOX", "FIFO", "FIFO_RELAXED"};
    log(LogSeverity::Debug, "swapchain " + std::to_string(extent.width) + "x" +
                                std::to_string(extent.height) + ", " + std::to_string(count) +
                                " images, present mode " + (mode < 4 ? kModeNames[mode] : "other") +
                                (blit ? ", RGBA8 backbuffers blitted to the BGRA8 surface" : ""));
    return true;
}

void VulkanDevice::resizeBackbuffer(uint32_t width, uint32_t height) {
    if (m_desc.headless) {
        logError("resizeBackbuffer: headless devices have no backbuffer");
        return;
    }
    consumePendingAcquire();
    if (m_uploadCmd) submitBatch({}, {}, VK_NULL_HANDLE);
    if (!m_deviceLost) vkDeviceWaitIdle(m_device);
    m_lastCompleted = std::max(m_lastCompleted, m_lastSubmitted);
    recycle();
    if (!createSwapchain(width, height)) logError("resizeBackbuffer: could not re-create the swapchain");
}

TextureHandle VulkanDevice::acquireBackbuffer() {
    if (m_desc.headless) {
        logError("acquireBackbuffer: headless devices have no backbuffer");
        return {};
    }
    Swapchain& sc = m_swapchain;
    if (sc.currentImage >= 0) {
        logError("acquireBackbuffer: the previous backbuffer was not presented yet");
        return sc.handles[size_t(sc.currentImage)];
    }
    for (int attempt = 0; attempt < 2; ++attempt) {
        // Not every WSI reports a resized window as out of date (Mesa's X11 one scales instead),
        // so compare with the window's framebuffer size as well.
        int w = 0, h = 0;
        glfwGetFramebufferSize(static_cast<GLFWwindow*>(m_desc.window), &w, &h);
        const bool resized =
            uint32_t(std::max(w, 0)) != sc.requestedWidth || uint32_t(std::max(h, 0)) != sc.requestedHeight;
        if (sc.outOfDate || !sc.swapchain || resized) {
            resizeBackbuffer(uint32_t(std::max(w, 0)), uint32_t(std::max(h, 0)));
            if (!sc.swapchain) return {};  // minimised (or failed, already logged)
        }
        const uint32_t slot = sc.acquireCursor;
        if (!waitSerial(sc.acquireSerials[slot])) return {};
        VkSemaphore sem = sc.acquireSemaphores[slot];
        uint32_t index = 0;
        VkResult r = vkAcquireNextImageKHR(m_device, sc.swapchain, UINT64_MAX, sem, VK_NULL_HANDLE, &index);
        if (r == VK_ERROR_OUT_OF_DATE_KHR) {
            sc.outOfDate = true;
            continue;
        }
        if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR) {
            if (r == VK_ERROR_DEVICE_LOST) m_deviceLost = true;
            logError(std::string("vkAcquireNextImageKHR failed: ") + resultString(r));
            return {};
        }
        if (r == VK_SUBOPTIMAL_KHR) sc.outOfDate = true;  // still usable; re-created next frame
        sc.pendingAcquire = sem;
        sc.pendingAcquireSlot = slot;
        sc.acquireCursor = (slot + 1) % uint32_t(sc.acquireSemaphores.size());
        sc.currentImage = int32_t(index);
        TextureRes* t = m_textures.get(sc.handles[index]);
        t->states.setAll(Access::None);
        return sc.handles[index];
    }
    logError("acquireBackbuffer: the swapchain stays out of date");
    return {};
}

bool VulkanDevice::present() {
    if (m_desc.headless) {
        logError("present: headless devices cannot present");
        return false;
    }
    Swapchain& sc = m_swapchain;
    if (sc.currentImage < 0 || !sc.swapchain) {
        logError("present: no backbuffer was acquired");
        return false;
    }
    const uint32_t index = uint32_t(sc.currentImage);
    sc.currentImage = -1;
    TextureRes* t = m_textures.get(sc.handles[index]);
    if (t->states.get(0, 0) != Access::Present)
        logError("present: the backbuffer is in state " + toString(t->states.get(0, 0)) +
                 ", not Present; transition it with a barrier before present()");

    std::vector<VkCommandBuffer> cbs;
    if (sc.blit || t->states.get(0, 0) != Access::Present) {
        VkCommandBuffer cmd = beginInternalCommands();
        if (!cmd) return false;
        if (sc.blit) {
            recordImageBarrier(cmd, *t, t->states.get(0, 0), Access::CopySrc, true);
            auto ib = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
            ib.srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
            ib.dstStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
            ib.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
            ib.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
            ib.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
            ib.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            ib.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            ib.image = sc.images[index];
            ib.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
            auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
            dep.imageMemoryBarrierCount = 1;
            dep.pImageMemoryBarriers = &ib;
            vkCmdPipelineBarrier2(cmd, &dep);

            VkImageBlit region{};
            region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
            region.srcOffsets[1] = {int32_t(sc.extent.width), int32_t(sc.extent.height), 1};
            region.dstSubresource = region.srcSubresource;
            region.dstOffsets[1] = region.srcOffsets[1];
            vkCmdBlitImage(cmd, t->image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, sc.images[index],
                           VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region, VK_FILTER_NEAREST);

            ib.srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
            ib.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
            ib.dstStageMask = VK_PIPELINE_STAGE_2_NONE;
            ib.dstAccessMask = VK_ACCESS_2_NONE;
            ib.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
            ib.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
            vkCmdPipelineBarrier2(cmd, &dep);
        } else {
            recordImageBarrier(cmd, *t, t->states.get(0, 0), Access::Present, true);
        }
        if (!check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer(present)")) {
            m_freeCommandBuffers.push_back(cmd);
            return false;
        }
        cbs.push_back(cmd);
    }

    std::vector<SemaphoreWait> waits;
    if (sc.pendingAcquire) waits.push_back({sc.pendingAcquire, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT});
    uint64_t serial = submitBatch(cbs, waits, sc.renderFinished[index]);
    if (sc.pendingAcquire) {
        sc.acquireSerials[sc.pendingAcquireSlot] = serial;
        sc.pendingAcquire = VK_NULL_HANDLE;
    }
    if (!serial) return false;

    auto info = vkInit<VkPresentInfoKHR>(VK_STRUCTURE_TYPE_PRESENT_INFO_KHR);
    info.waitSemaphoreCount = 1;
    info.pWaitSemaphores = &sc.renderFinished[index];
    info.swapchainCount = 1;
    info.pSwapchains = &sc.swapchain;
    info.pImageIndices = &index;
    VkResult r = vkQueuePresentKHR(m_queue, &info);
    collectGarbage();
    if (r == VK_SUCCESS) return true;
    if (r == VK_SUBOPTIMAL_KHR || r == VK_ERROR_OUT_OF_DATE_KHR) {
        // The window changed size: the swapchain is re-created on the next acquire.
        sc.outOfDate = true;
        return true;
    }
    if (r == VK_ERROR_DEVICE_LOST) m_deviceLost = true;
    logError(std::string("vkQueuePresentKHR failed: ") + resultString(r));
    return false;
}

}  // namespace rhi::vk
