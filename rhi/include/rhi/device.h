// penumbra RHI — the device: resource creation, submission, readback and presentation.
// Create one with rhi::createDevice(). Every method says what it maps to on each backend.
//
// Lifetime rules
// - Creation functions return an invalid handle on failure and log one clear message.
// - destroy() invalidates the handle at once (any later use is a stale handle, which the
//   validation wrapper reports); the GPU object itself is released only after every submission
//   recorded before the destroy() has completed on the GPU (deferred destruction).
// - Readback functions block until the GPU is idle; they are meant for tests, screenshots and
//   tools, not for per-frame use.
#pragma once

#include <memory>

#include "rhi/command_list.h"
#include "rhi/types.h"

namespace rhi {

class Device {
public:
    virtual ~Device() = default;

    // The methods, declared once in rhi/device_api.inc (with their Vulkan / OpenGL mapping).
#define RHI_DEVICE_METHOD(ret, name, params, qualifiers) virtual ret name params qualifiers = 0;
#include "rhi/device_api.inc"
#undef RHI_DEVICE_METHOD
};

// Creates a device. Returns null (after logging why through desc.log) if the backend cannot be
// created. Backend::Auto tries Vulkan, then OpenGL. PENUMBRA_BACKEND overrides Auto.
// With desc.validation the device is wrapped in the validation layer (rhi/validation).
std::unique_ptr<Device> createDevice(const DeviceDesc& desc);

// Number of misuse reports the validation wrapper (and, when enabled, the Vulkan validation layer
// or GL debug output at error severity) has sent to the log since the device was created.
// Always 0 for devices created without validation.
uint64_t validationErrorCount(const Device& device);

}  // namespace rhi
