// Vulkan backend — inspection for tests and tools (sees through the validation wrapper).
#pragma once

#include <cstddef>
#include <cstdint>

#include "rhi/device.h"

namespace rhi::vulkan {

struct Inspection {
    bool isVulkan = false;                 // false: not a Vulkan device (everything else is zero)
    bool validationLayerEnabled = false;   // VK_LAYER_KHRONOS_validation is active on the instance
    bool debugMessengerInstalled = false;  // VK_EXT_debug_utils messenger routes messages to the log
    size_t liveObjects = 0;                // live handles of every kind (swapchain backbuffers included)
    size_t pendingReleases = 0;            // destroyed objects whose release waits for the GPU
    uint64_t allocatedBytes = 0;           // device memory handed out by the allocator
    size_t memoryBlocks = 0;               // shared 64 MiB blocks currently reserved
    uint64_t lastSubmittedSerial = 0;
};

Inspection inspect(const rhi::Device& device);

}  // namespace rhi::vulkan
