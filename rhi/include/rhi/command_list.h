// penumbra RHI — command recording. A CommandList is obtained from Device::beginCommandList(),
// recorded on one thread, and handed back with Device::submit(). Commands execute in recording
// order on the single graphics+compute queue. Each method says what it maps to per backend.
#pragma once

#include "rhi/types.h"

namespace rhi {

class CommandList {
public:
    virtual ~CommandList() = default;

    // The methods, declared once in rhi/command_list_api.inc (with their Vulkan / OpenGL mapping).
#define RHI_COMMAND_LIST_METHOD(ret, name, params, qualifiers) virtual ret name params qualifiers = 0;
#include "rhi/command_list_api.inc"
#undef RHI_COMMAND_LIST_METHOD

    void barrier(const Barrier& b) { barrier(std::span<const Barrier>(&b, 1)); }
};

}  // namespace rhi
