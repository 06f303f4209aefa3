#include "renderer/core/shader_params.h"

#include <algorithm>

#include <fmt/format.h>

#include "engine/core/log.h"

namespace penumbra::render {
namespace {

bool isBuffer(rhi::BindingType t) {
    return t == rhi::BindingType::UniformBuffer || t == rhi::BindingType::StorageBuffer ||
           t == rhi::BindingType::ReadOnlyStorageBuffer;
}

}  // namespace

ShaderParams::ShaderParams(const rhi::ShaderDesc& compute) : m_program(compute.debugName) {
    for (const rhi::ShaderBinding& b : compute.bindings) m_params.push_back(Param{b, {}, false});
}

ShaderParams::ShaderParams(const rhi::ShaderDesc& vertex, const rhi::ShaderDesc& fragment)
    : m_program(std::string(vertex.debugName) + "+" + std::string(fragment.debugName)) {
    for (const rhi::ShaderDesc* stage : {&vertex, &fragment})
        for (const rhi::ShaderBinding& b : stage->bindings) {
            // A binding both stages declare is one parameter (shaderc checks they agree).
            const bool known = std::any_of(m_params.begin(), m_params.end(), [&](const Param& p) {
                return p.binding.set == b.set && p.binding.binding == b.binding;
            });
            if (!known) m_params.push_back(Param{b, {}, false});
        }
    std::sort(m_params.begin(), m_params.end(), [](const Param& a, const Param& b) {
        return a.binding.set != b.binding.set ? a.binding.set < b.binding.set
                                              : a.binding.binding < b.binding.binding;
    });
}

void ShaderParams::fail(std::string message) {
    if (m_error.empty()) m_error = fmt::format("{}: {}", m_program, message);
}

ShaderParams::Param* ShaderParams::find(std::string_view name, const char* what) {
    for (Param& p : m_params)
        if (name == p.binding.name) return &p;
    fail(fmt::format("no parameter named '{}' (set as {})", name, what));
    return nullptr;
}

ShaderParams& ShaderParams::set(std::string_view name, rhi::BufferHandle buffer, uint64_t offset,
                                uint64_t size) {
    Param* p = find(name, "a buffer");
    if (!p) return *this;
    if (!isBuffer(p->binding.type)) {
        fail(fmt::format("parameter '{}' is not a buffer", name));
        return *this;
    }
    p->entry = rhi::BindGroupEntry::makeBuffer(p->binding.binding, buffer, offset, size);
    p->isSet = true;
    return *this;
}

ShaderParams& ShaderParams::set(std::string_view name, rhi::TextureHandle texture, rhi::SamplerHandle sampler,
                                uint32_t baseMip, uint32_t mipCount) {
    Param* p = find(name, "a sampled texture");
    if (!p) return *this;
    if (p->binding.type != rhi::BindingType::SampledTexture) {
        fail(fmt::format("parameter '{}' is not a sampled texture", name));
        return *this;
    }
    p->entry = rhi::BindGroupEntry::makeSampled(p->binding.binding, texture, sampler);
    p->entry.mip = baseMip;
    p->entry.mipCount = mipCount;
    p->isSet = true;
    return *this;
}

ShaderParams& ShaderParams::setStorage(std::string_view name, rhi::TextureHandle texture, uint32_t mip) {
    Param* p = find(name, "a storage image");
    if (!p) return *this;
    if (p->binding.type != rhi::BindingType::StorageTexture) {
        fail(fmt::format("parameter '{}' is not a storage image", name));
        return *this;
    }
    p->entry = rhi::BindGroupEntry::makeStorage(p->binding.binding, texture, mip);
    p->isSet = true;
    return *this;
}

bool ShaderParams::bind(rhi::CommandList& cmd, GpuCache& cache, rhi::PipelineHandle pipeline) {
    std::string error = m_error;
    for (const Param& p : m_params)
        if (error.empty() && !p.isSet)
            error = fmt::format("{}: parameter '{}' (set {}, binding {}) was not set", m_program,
                                p.binding.name, p.binding.set, p.binding.binding);
    if (!error.empty()) {
        log::error("shader parameters: {}", error);
        return false;
    }
    if (pipeline != m_boundPipeline)
        std::fill(std::begin(m_bound), std::end(m_bound), rhi::BindGroupHandle{});
    m_boundPipeline = pipeline;
    std::vector<rhi::BindGroupEntry> entries;
    for (size_t i = 0; i < m_params.size();) {
        const uint32_t set = m_params[i].binding.set;
        entries.clear();
        for (; i < m_params.size() && m_params[i].binding.set == set; ++i)
            entries.push_back(m_params[i].entry);
        rhi::BindGroupHandle group = cache.bindGroup(pipeline, set, entries, m_program);
        if (!group) {
            log::error("shader parameters: {}: creating the bind group of set {} failed", m_program, set);
            return false;
        }
        if (set < rhi::kMaxBindGroups && m_bound[set] == group) continue;
        cmd.bindGroup(set, group);
        if (set < rhi::kMaxBindGroups) m_bound[set] = group;
    }
    return true;
}

void dispatchOver(rhi::CommandList& cmd, const rhi::ShaderDesc& compute, uint32_t width, uint32_t height,
                  uint32_t depth) {
    auto groups = [](uint32_t n, uint32_t size) { return (n + std::max(size, 1u) - 1) / std::max(size, 1u); };
    cmd.dispatch(groups(width, compute.workgroupSize[0]), groups(height, compute.workgroupSize[1]),
                 groups(depth, compute.workgroupSize[2]));
}

}  // namespace penumbra::render
