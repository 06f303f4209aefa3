// Binding a pass's shader parameters by name. A ShaderParams is made for one program (a compute
// shader, or a vertex + fragment pair); set() looks each name up in the program's reflection
// (block type name for uniform/storage buffers, variable name for textures and images), and
// bind() creates — through the GpuCache, so only on the first frame — one bind group per set the
// program declares and binds them. No binding numbers appear in pass code.
//
//     ShaderParams params(shaders::deferred_lighting::vertex(), shaders::deferred_lighting::fragment());
//     params.set("View", ctx.buffer(view)).set("gbufferDepth", ctx.texture(depth), sampler);
//     params.bind(ctx.cmd, cache, pipeline);
//
// Mistakes are reported, never guessed around: an unknown name, a resource of the wrong kind
// (a buffer for a texture, a sampled texture for a storage image), or a binding of the program
// left unset makes bind() log one error naming the program and the parameter and return false.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "renderer/core/gpu_cache.h"
#include "rhi/command_list.h"
#include "rhi/device.h"

namespace penumbra::render {

class ShaderParams {
public:
    explicit ShaderParams(const rhi::ShaderDesc& compute);
    ShaderParams(const rhi::ShaderDesc& vertex, const rhi::ShaderDesc& fragment);

    // Uniform and storage buffers: `size` bytes from `offset` (0: the whole buffer from offset).
    ShaderParams& set(std::string_view name, rhi::BufferHandle buffer, uint64_t offset = 0,
                      uint64_t size = 0);
    // Sampled textures; `mips` / `mipCount` select a mip range view (0: to the last mip).
    ShaderParams& set(std::string_view name, rhi::TextureHandle texture, rhi::SamplerHandle sampler,
                      uint32_t baseMip = 0, uint32_t mipCount = 0);
    // Storage images (one mip level).
    ShaderParams& setStorage(std::string_view name, rhi::TextureHandle texture, uint32_t mip = 0);

    // Creates or reuses the bind groups of every set and binds them; false after logging an error.
    // Within one ShaderParams (one pass, one pipeline) a set whose group did not change since the
    // last bind() is not bound again, so per-draw parameters cost one bind of their own set.
    bool bind(rhi::CommandList& cmd, GpuCache& cache, rhi::PipelineHandle pipeline);
    // The first error (empty when none).
    const std::string& error() const { return m_error; }

private:
    struct Param {
        rhi::ShaderBinding binding;
        rhi::BindGroupEntry entry;
        bool isSet = false;
    };
    Param* find(std::string_view name, const char* what);
    void fail(std::string message);

    std::string m_program;
    std::vector<Param> m_params;  // every binding of the program, sorted by (set, binding)
    std::string m_error;
    rhi::BindGroupHandle m_bound[rhi::kMaxBindGroups];
    rhi::PipelineHandle m_boundPipeline;
};

// Workgroups covering `width` x `height` (x `depth`) invocations with the shader's local size.
void dispatchOver(rhi::CommandList& cmd, const rhi::ShaderDesc& compute, uint32_t width, uint32_t height,
                  uint32_t depth = 1);

// A generated program's variants (shaders::X::Variant) indexed by a bit set: bit k of the index
// adds parts[k], the PascalCase of one macro, to the enumerator's name after `prefix` (an
// exclusive choice such as "MultiRay", or ""); the enumerator names its macros in the order the
// shader's #pragma penumbra_variants lists them, and no part at all is "Default". Built once per
// pass from the generated kVariantNames; a combination the shader does not declare throws
// std::logic_error naming `program`.
template <class Variant, std::size_t Parts>
std::array<Variant, (std::size_t(1) << Parts)> variantTable(const char* program, const char* const* names,
                                                            uint32_t count,
                                                            const std::array<const char*, Parts>& parts,
                                                            const char* prefix = "") {
    std::array<Variant, (std::size_t(1) << Parts)> table{};
    for (uint32_t bits = 0; bits < table.size(); ++bits) {
        std::string name = prefix;
        for (uint32_t k = 0; k < Parts; ++k)
            if ((bits >> k) & 1u) name += parts[k];
        if (name.empty()) name = "Default";
        uint32_t found = count;
        for (uint32_t v = 0; v < count && found == count; ++v)
            if (name == names[v]) found = v;
        if (found == count) throw std::logic_error(std::string(program) + " has no variant " + name);
        table[bits] = Variant(found);
    }
    return table;
}

}  // namespace penumbra::render
