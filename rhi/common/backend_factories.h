// Internal entry points of the backends, called by rhi::createDevice().
#pragma once

#include <memory>

#include "rhi/device.h"

namespace rhi::detail {

// Each returns null after logging the reason through desc.log when the backend is unavailable.
std::unique_ptr<Device> createVulkanDevice(const DeviceDesc& desc);
std::unique_ptr<Device> createOpenGLDevice(const DeviceDesc& desc);
std::unique_ptr<Device> createNullDevice(const DeviceDesc& desc);

// Wraps a backend device in the validation layer (rhi/validation). `errorCounter` is shared with
// the log callback the backend was created with, so backend-reported errors count too.
std::unique_ptr<Device> createValidationDevice(std::unique_ptr<Device> inner, LogCallback log,
                                               std::shared_ptr<uint64_t> errorCounter);
uint64_t validationErrorCountOf(const Device& device);

// Log helper: routes to desc.log or stderr.
void logMessage(const LogCallback& log, LogSeverity severity, std::string_view message);

}  // namespace rhi::detail
