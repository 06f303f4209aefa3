// Vulkan backend — a small device-memory allocator (VMA is not packaged on Debian 12).
//
// Per memory type, resources are sub-allocated from 64 MiB blocks with a first-fit free list;
// resources of half a block or more get a dedicated vkAllocateMemory. Linear resources (buffers)
// and optimal-tiling images never share a block, which satisfies bufferImageGranularity without
// padding. Host-visible blocks are mapped once, persistently.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "rhi/types.h"

namespace rhi::vk {

struct MemoryBlock;

struct Allocation {
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize offset = 0;
    VkDeviceSize size = 0;
    void* mapped = nullptr;        // host pointer of `offset` when the memory is host visible
    MemoryBlock* block = nullptr;  // null for dedicated allocations
    uint32_t memoryTypeIndex = 0;
    bool coherent = true;
    bool valid() const { return memory != VK_NULL_HANDLE; }
};

class MemoryAllocator {
public:
    static constexpr VkDeviceSize kBlockSize = 64ull << 20;

    MemoryAllocator() = default;
    MemoryAllocator(const MemoryAllocator&) = delete;
    MemoryAllocator& operator=(const MemoryAllocator&) = delete;
    ~MemoryAllocator();

    void init(VkPhysicalDevice physicalDevice, VkDevice device);
    // Frees every block (all allocations must have been freed or be abandoned with the device).
    void shutdown();

    // `dedicatedBuffer` / `dedicatedImage`: the resource, passed to VkMemoryDedicatedAllocateInfo
    // when a dedicated allocation is made. On failure returns false and sets `error`.
    bool allocate(const VkMemoryRequirements& req, MemoryType type, bool linear, VkBuffer dedicatedBuffer,
                  VkImage dedicatedImage, Allocation& out, std::string& error);
    void free(Allocation& a);

    // Bytes currently handed out / reserved from the driver (for memory reports).
    uint64_t allocatedBytes() const { return m_allocatedBytes; }
    uint64_t reservedBytes() const { return m_reservedBytes; }
    size_t blockCount() const { return m_blocks.size(); }

private:
    int findMemoryType(uint32_t typeBits, VkMemoryPropertyFlags required,
                       VkMemoryPropertyFlags preferred) const;
    int chooseMemoryType(uint32_t typeBits, MemoryType type) const;
    bool allocateDedicated(const VkMemoryRequirements& req, uint32_t typeIndex, VkBuffer buffer,
                           VkImage image, Allocation& out, std::string& error);
    MemoryBlock* createBlock(uint32_t typeIndex, bool linear, std::string& error);
    static bool allocateFromBlock(MemoryBlock& block, VkDeviceSize size, VkDeviceSize alignment,
                                  VkDeviceSize& offset);

    VkDevice m_device = VK_NULL_HANDLE;
    VkPhysicalDeviceMemoryProperties m_props{};
    std::vector<std::unique_ptr<MemoryBlock>> m_blocks;
    uint64_t m_allocatedBytes = 0;
    uint64_t m_reservedBytes = 0;
};

struct MemoryBlock {
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    VkDeviceSize used = 0;
    void* mapped = nullptr;
    uint32_t memoryTypeIndex = 0;
    bool linear = true;
    bool coherent = true;
    std::map<VkDeviceSize, VkDeviceSize> freeRanges;  // offset -> size, non-adjacent
};

}  // namespace rhi::vk
