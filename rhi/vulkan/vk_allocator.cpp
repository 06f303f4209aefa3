#include "rhi/vulkan/vk_allocator.h"

#include <algorithm>

#include "rhi/vulkan/vk_common.h"

namespace rhi::vk {

MemoryAllocator::~MemoryAllocator() { shutdown(); }

void MemoryAllocator::init(VkPhysicalDevice physicalDevice, VkDevice device) {
    m_device = device;
    vkGetPhysicalDeviceMemoryProperties(physicalDevice, &m_props);
}

void MemoryAllocator::shutdown() {
    for (auto& b : m_blocks) {
        if (b->mapped) vkUnmapMemory(m_device, b->memory);
        vkFreeMemory(m_device, b->memory, nullptr);
    }
    m_blocks.clear();
    m_reservedBytes = 0;
    m_allocatedBytes = 0;
}

int MemoryAllocator::findMemoryType(uint32_t typeBits, VkMemoryPropertyFlags required,
                                    VkMemoryPropertyFlags preferred) const {
    const VkMemoryPropertyFlags want[2] = {required | preferred, required};
    for (VkMemoryPropertyFlags flags : want) {
        for (uint32_t i = 0; i < m_props.memoryTypeCount; ++i) {
            if (!(typeBits & (1u << i))) continue;
            if ((m_props.memoryTypes[i].propertyFlags & flags) == flags) return int(i);
        }
    }
    return -1;
}

int MemoryAllocator::chooseMemoryType(uint32_t typeBits, MemoryType type) const {
    switch (type) {
        case MemoryType::GpuOnly: {
            int t = findMemoryType(typeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0);
            return t >= 0 ? t : findMemoryType(typeBits, 0, 0);
        }
        case MemoryType::Upload:
            return findMemoryType(
                typeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, 0);
        case MemoryType::Readback: {
            // Cached for fast CPU reads; coherent as well when possible, so mappedPointer() needs
            // no invalidation. Fallback: plain host-visible coherent memory.
            int t = findMemoryType(typeBits,
                                   VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_CACHED_BIT,
                                   VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
            return t >= 0
                       ? t
                       : findMemoryType(
                             typeBits,
                             VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, 0);
        }
    }
    return -1;
}

bool MemoryAllocator::allocate(const VkMemoryRequirements& req, MemoryType type, bool linear,
                               VkBuffer dedicatedBuffer, VkImage dedicatedImage, Allocation& out,
                               std::string& error) {
    out = {};
    int typeIndex = chooseMemoryType(req.memoryTypeBits, type);
    if (typeIndex < 0) {
        static const char* kNames[] = {"GpuOnly", "Upload", "Readback"};
        error = std::string("no Vulkan memory type fits a ") + kNames[int(type)] +
                " resource (memoryTypeBits " + std::to_string(req.memoryTypeBits) + ")";
        return false;
    }
    if (req.size >= kBlockSize / 2)
        return allocateDedicated(req, uint32_t(typeIndex), dedicatedBuffer, dedicatedImage, out, error);

    MemoryBlock* chosen = nullptr;
    VkDeviceSize offset = 0;
    for (auto& b : m_blocks) {
        if (b->memoryTypeIndex != uint32_t(typeIndex) || b->linear != linear) continue;
        if (b->size - b->used < req.size) continue;
        if (allocateFromBlock(*b, req.size, req.alignment, offset)) {
            chosen = b.get();
            break;
        }
    }
    if (!chosen) {
        chosen = createBlock(uint32_t(typeIndex), linear, error);
        if (!chosen) return false;
        if (!allocateFromBlock(*chosen, req.size, req.alignment, offset)) {
            error = "allocation does not fit in a fresh memory block";
            return false;
        }
    }
    chosen->used += req.size;
    m_allocatedBytes += req.size;
    out.memory = chosen->memory;
    out.offset = offset;
    out.size = req.size;
    out.mapped = chosen->mapped ? static_cast<uint8_t*>(chosen->mapped) + offset : nullptr;
    out.block = chosen;
    out.memoryTypeIndex = chosen->memoryTypeIndex;
    out.coherent = chosen->coherent;
    return true;
}

bool MemoryAllocator::allocateDedicated(const VkMemoryRequirements& req, uint32_t typeIndex, VkBuffer buffer,
                                        VkImage image, Allocation& out, std::string& error) {
    auto dedicated = vkInit<VkMemoryDedicatedAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_DEDICATED_ALLOCATE_INFO);
    dedicated.buffer = buffer;
    dedicated.image = image;
    auto info = vkInit<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
    info.pNext = (buffer != VK_NULL_HANDLE || image != VK_NULL_HANDLE) ? &dedicated : nullptr;
    info.allocationSize = req.size;
    info.memoryTypeIndex = typeIndex;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkResult r = vkAllocateMemory(m_device, &info, nullptr, &memory);
    if (r != VK_SUCCESS) {
        error = std::string("vkAllocateMemory(") + std::to_string(req.size) +
                " bytes) failed: " + resultString(r);
        return false;
    }
    const VkMemoryPropertyFlags flags = m_props.memoryTypes[typeIndex].propertyFlags;
    void* mapped = nullptr;
    if (flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) {
        r = vkMapMemory(m_device, memory, 0, VK_WHOLE_SIZE, 0, &mapped);
        if (r != VK_SUCCESS) {
            vkFreeMemory(m_device, memory, nullptr);
            error = std::string("vkMapMemory failed: ") + resultString(r);
            return false;
        }
    }
    out.memory = memory;
    out.offset = 0;
    out.size = req.size;
    out.mapped = mapped;
    out.block = nullptr;
    out.memoryTypeIndex = typeIndex;
    out.coherent = (flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) != 0;
    m_allocatedBytes += req.size;
    m_reservedBytes += req.size;
    return true;
}

MemoryBlock* MemoryAllocator::createBlock(uint32_t typeIndex, bool linear, std::string& error) {
    auto info = vkInit<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
    info.allocationSize = kBlockSize;
    info.memoryTypeIndex = typeIndex;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkResult r = vkAllocateMemory(m_device, &info, nullptr, &memory);
    if (r != VK_SUCCESS) {
        error = std::string("vkAllocateMemory(64 MiB block) failed: ") + resultString(r);
        return nullptr;
    }
    const VkMemoryPropertyFlags flags = m_props.memoryTypes[typeIndex].propertyFlags;
    void* mapped = nullptr;
    if (flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) {
        r = vkMapMemory(m_device, memory, 0, VK_WHOLE_SIZE, 0, &mapped);
        if (r != VK_SUCCESS) {
            vkFreeMemory(m_device, memory, nullptr);
            error = std::string("vkMapMemory failed: ") + resultString(r);
            return nullptr;
        }
    }
    auto block = std::make_unique<MemoryBlock>();
    block->memory = memory;
    block->size = kBlockSize;
    block->mapped = mapped;
    block->memoryTypeIndex = typeIndex;
    block->linear = linear;
    block->coherent = (flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) != 0;
    block->freeRanges[0] = kBlockSize;
    m_reservedBytes += kBlockSize;
    m_blocks.push_back(std::move(block));
    return m_blocks.back().get();
}

bool MemoryAllocator::allocateFromBlock(MemoryBlock& block, VkDeviceSize size, VkDeviceSize alignment,
                                        VkDeviceSize& offset) {
    for (auto it = block.freeRanges.begin(); it != block.freeRanges.end(); ++it) {
        const VkDeviceSize start = it->first;
        const VkDeviceSize end = it->first + it->second;
        const VkDeviceSize aligned = alignUp(start, std::max<VkDeviceSize>(alignment, 1));
        if (aligned > end || end - aligned < size) continue;
        block.freeRanges.erase(it);
        if (aligned > start) block.freeRanges[start] = aligned - start;
        if (aligned + size < end) block.freeRanges[aligned + size] = end - (aligned + size);
        offset = aligned;
        return true;
    }
    return false;
}

void MemoryAllocator::free(Allocation& a) {
    if (!a.valid()) return;
    m_allocatedBytes -= a.size;
    if (!a.block) {
        if (a.mapped) vkUnmapMemory(m_device, a.memory);
        vkFreeMemory(m_device, a.memory, nullptr);
        m_reservedBytes -= a.size;
        a = {};
        return;
    }
    MemoryBlock& b = *a.block;
    b.used -= a.size;
    VkDeviceSize start = a.offset;
    VkDeviceSize end = a.offset + a.size;
    // Merge with the following and the preceding free range.
    auto next = b.freeRanges.lower_bound(start);
    if (next != b.freeRanges.end() && next->first == end) {
        end += next->second;
        next = b.freeRanges.erase(next);
    }
    if (next != b.freeRanges.begin()) {
        auto prev = std::prev(next);
        if (prev->first + prev->second == start) {
            start = prev->first;
            b.freeRanges.erase(prev);
        }
    }
    b.freeRanges[start] = end - start;

    // Give an empty block back to the driver unless it is the last one of its kind.
    if (b.used == 0) {
        size_t sameKind = 0;
        for (auto& blk : m_blocks)
            if (blk->memoryTypeIndex == b.memoryTypeIndex && blk->linear == b.linear) ++sameKind;
        if (sameKind > 1) {
            if (b.mapped) vkUnmapMemory(m_device, b.memory);
            vkFreeMemory(m_device, b.memory, nullptr);
            m_reservedBytes -= b.size;
            m_blocks.erase(
                std::find_if(m_blocks.begin(), m_blocks.end(),
                             [&](const std::unique_ptr<MemoryBlock>& p) { return p.get() == &b; }));
        }
    }
    a = {};
}

}  // namespace rhi::vk
