// Support types of the headers penumbra-shaderc generates (tools/shaderc/README.md): named slots
// and the lookup of a stage's reflected binding by name or slot. Header-only; needs only the RHI's
// value types.
#pragma once

#include <rhi/types.h>

#include <cstdint>
#include <string_view>

namespace penumbra::shaders {

// A named resource slot of a shader program: what its GLSL declares with
// `layout(set = S, binding = B)`. Generated as `penumbra::shaders::X::slot::<name>`.
struct SlotRef {
    const char* name = "";  // the reflected name (block type name for buffers, variable name otherwise)
    uint32_t set = 0;
    uint32_t binding = 0;
    rhi::BindingType type = rhi::BindingType::UniformBuffer;
    uint32_t count = 1;  // array size
};

// The binding of `desc` called `name`, or nullptr when this stage does not declare it.
inline const rhi::ShaderBinding* findBinding(const rhi::ShaderDesc& desc, std::string_view name) {
    for (const rhi::ShaderBinding& b : desc.bindings) {
        if (name == b.name) return &b;
    }
    return nullptr;
}

// The binding of `desc` at the slot's (set, binding), or nullptr when this stage does not use it
// (a slot of the program may belong to the other stage or to another variant).
inline const rhi::ShaderBinding* findBinding(const rhi::ShaderDesc& desc, const SlotRef& slot) {
    for (const rhi::ShaderBinding& b : desc.bindings) {
        if (b.set == slot.set && b.binding == slot.binding) return &b;
    }
    return nullptr;
}

}  // namespace penumbra::shaders
