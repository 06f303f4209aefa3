// Internal: the interface of devices that wrap another device (the validation layer), so that
// backend-specific inspection functions (rhi::null::recordedCommands) can see through them.
#pragma once

#include "rhi/device.h"

namespace rhi::detail {

class WrappingDevice : public Device {
public:
    virtual Device& inner() = 0;
    virtual const Device& inner() const = 0;
};

// Follows WrappingDevice::inner() until a device that wraps nothing.
inline const Device& innermostDevice(const Device& device) {
    const Device* d = &device;
    while (const auto* w = dynamic_cast<const WrappingDevice*>(d)) d = &w->inner();
    return *d;
}
inline Device& innermostDevice(Device& device) {
    Device* d = &device;
    while (auto* w = dynamic_cast<WrappingDevice*>(d)) d = &w->inner();
    return *d;
}

}  // namespace rhi::detail
