// SPIRV-Cross side: reflection of one stage, per-program OpenGL binding flattening, and emission of
// GLSL 4.50 core for the OpenGL backend.
#include "internal.h"

#include <spirv_cross/spirv_glsl.hpp>

#include <algorithm>
#include <map>
#include <tuple>

namespace penumbra::shaderc::detail {
namespace {

std::string where(const StageOutput& stage) { return stage.path; }

std::string describe(rhi::BindingType type) {
    switch (type) {
        case rhi::BindingType::UniformBuffer:
            return "uniform buffer";
        case rhi::BindingType::StorageBuffer:
            return "storage buffer";
        case rhi::BindingType::ReadOnlyStorageBuffer:
            return "readonly storage buffer";
        case rhi::BindingType::SampledTexture:
            return "combined image sampler";
        case rhi::BindingType::StorageTexture:
            return "storage image";
    }
    return "resource";
}

// OpenGL binding namespaces: UBO binding points, SSBO binding points, texture units, image units.
enum class GlClass { Ubo, Ssbo, Texture, Image };

GlClass glClassOf(rhi::BindingType type) {
    switch (type) {
        case rhi::BindingType::UniformBuffer:
            return GlClass::Ubo;
        case rhi::BindingType::StorageBuffer:
        case rhi::BindingType::ReadOnlyStorageBuffer:
            return GlClass::Ssbo;
        case rhi::BindingType::SampledTexture:
            return GlClass::Texture;
        case rhi::BindingType::StorageTexture:
            return GlClass::Image;
    }
    return GlClass::Ubo;
}

uint32_t glClassBase(GlClass c) {
    // UBO binding 0 is reserved for the push-constant block on OpenGL.
    return c == GlClass::Ubo ? rhi::kGlPushConstantBinding + 1 : 0;
}

bool arrayCount(const spirv_cross::SPIRType& type, const StageOutput& stage, const std::string& name,
                uint32_t& count, std::vector<std::string>& diagnostics) {
    count = 1;
    for (size_t i = 0; i < type.array.size(); ++i) {
        if (!type.array_size_literal[i] || type.array[i] == 0) {
            diagnostics.push_back(
                where(stage) + ": error: resource '" + name +
                "': runtime-sized or specialization-sized resource arrays are not supported");
            return false;
        }
        count *= type.array[i];
    }
    return true;
}

bool textureDimension(const spirv_cross::SPIRType& type, const StageOutput& stage, const std::string& name,
                      rhi::TextureDimension& out, std::vector<std::string>& diagnostics) {
    if (type.image.dim == spv::Dim2D && !type.image.arrayed) {
        out = rhi::TextureDimension::Tex2D;
    } else if (type.image.dim == spv::Dim2D && type.image.arrayed) {
        out = rhi::TextureDimension::Tex2DArray;
    } else if (type.image.dim == spv::Dim3D && !type.image.arrayed) {
        out = rhi::TextureDimension::Tex3D;
    } else {
        diagnostics.push_back(where(stage) + ": error: texture '" + name +
                              "': only 2D, 2D-array and 3D textures are supported by the RHI");
        return false;
    }
    if (type.image.ms) {
        diagnostics.push_back(where(stage) + ": error: texture '" + name +
                              "': multisampled textures are not supported");
        return false;
    }
    return true;
}

bool storageFormat(spv::ImageFormat format, rhi::Format& out) {
    switch (format) {
        case spv::ImageFormatRgba8:
            out = rhi::Format::RGBA8_UNORM;
            return true;
        case spv::ImageFormatRgba16f:
            out = rhi::Format::RGBA16_FLOAT;
            return true;
        case spv::ImageFormatRgba32f:
            out = rhi::Format::RGBA32_FLOAT;
            return true;
        case spv::ImageFormatR32f:
            out = rhi::Format::R32_FLOAT;
            return true;
        case spv::ImageFormatR16f:
            out = rhi::Format::R16_FLOAT;
            return true;
        case spv::ImageFormatRg16f:
            out = rhi::Format::RG16_FLOAT;
            return true;
        case spv::ImageFormatRg32f:
            out = rhi::Format::RG32_FLOAT;
            return true;
        case spv::ImageFormatR32ui:
            out = rhi::Format::R32_UINT;
            return true;
        case spv::ImageFormatR8ui:
            out = rhi::Format::R8_UINT;
            return true;
        case spv::ImageFormatR8:
            out = rhi::Format::R8_UNORM;
            return true;
        default:
            return false;
    }
}

bool vertexFormat(const spirv_cross::SPIRType& type, rhi::Format& out) {
    if (type.columns != 1 || !type.array.empty()) return false;
    if (type.basetype == spirv_cross::SPIRType::Float) {
        switch (type.vecsize) {
            case 1:
                out = rhi::Format::R32_FLOAT;
                return true;
            case 2:
                out = rhi::Format::RG32_FLOAT;
                return true;
            case 3:
                out = rhi::Format::RGB32_FLOAT;
                return true;
            case 4:
                out = rhi::Format::RGBA32_FLOAT;
                return true;
            default:
                return false;
        }
    }
    if (type.basetype == spirv_cross::SPIRType::UInt && type.vecsize == 1) {
        out = rhi::Format::R32_UINT;
        return true;
    }
    return false;
}

const char* stageSuffix(rhi::ShaderStage stage) {
    switch (stage) {
        case rhi::ShaderStage::Vertex:
            return "_vs";
        case rhi::ShaderStage::Fragment:
            return "_fs";
        case rhi::ShaderStage::Compute:
            return "";
    }
    return "";
}

}  // namespace

bool reflectStage(StageOutput& stage, std::vector<std::string>& diagnostics) {
    try {
        spirv_cross::Compiler compiler(stage.spirv);
        const spirv_cross::ShaderResources resources = compiler.get_shader_resources();
        bool ok = true;

        auto unsupported = [&](const spirv_cross::SmallVector<spirv_cross::Resource>& list,
                               const char* what) {
            for (const spirv_cross::Resource& r : list) {
                diagnostics.push_back(where(stage) + ": error: '" + r.name + "': " + what +
                                      " are not supported (use combined image samplers such as sampler2D)");
                ok = false;
            }
        };
        unsupported(resources.separate_images, "separate texture objects");
        unsupported(resources.separate_samplers, "separate sampler objects");
        unsupported(resources.subpass_inputs, "subpass inputs");
        unsupported(resources.atomic_counters, "atomic counters");
        unsupported(resources.acceleration_structures, "acceleration structures");
        unsupported(resources.shader_record_buffers, "shader record buffers");

        auto base = [&](const spirv_cross::Resource& r, rhi::BindingType type, Binding& b) {
            b.name = r.name.empty() ? compiler.get_fallback_name(r.id) : r.name;
            b.set = compiler.get_decoration(r.id, spv::DecorationDescriptorSet);
            b.binding = compiler.get_decoration(r.id, spv::DecorationBinding);
            b.type = type;
            if (!compiler.has_decoration(r.id, spv::DecorationBinding)) {
                diagnostics.push_back(where(stage) + ": error: resource '" + b.name +
                                      "' needs an explicit layout(set = S, binding = B)");
                return false;
            }
            if (b.set >= rhi::kMaxBindGroups) {
                diagnostics.push_back(where(stage) + ": error: resource '" + b.name + "' uses set " +
                                      std::to_string(b.set) + "; the RHI supports sets 0.." +
                                      std::to_string(rhi::kMaxBindGroups - 1));
                return false;
            }
            return arrayCount(compiler.get_type(r.type_id), stage, b.name, b.count, diagnostics);
        };

        std::vector<Binding> bindings;
        for (const spirv_cross::Resource& r : resources.uniform_buffers) {
            Binding b;
            if (!base(r, rhi::BindingType::UniformBuffer, b)) {
                ok = false;
                continue;
            }
            bindings.push_back(b);
        }
        for (const spirv_cross::Resource& r : resources.storage_buffers) {
            const bool readOnly = compiler.get_buffer_block_flags(r.id).get(spv::DecorationNonWritable);
            Binding b;
            if (!base(r, readOnly ? rhi::BindingType::ReadOnlyStorageBuffer : rhi::BindingType::StorageBuffer,
                      b)) {
                ok = false;
                continue;
            }
            b.writes = !readOnly;
            bindings.push_back(b);
        }
        for (const spirv_cross::Resource& r : resources.sampled_images) {
            Binding b;
            if (!base(r, rhi::BindingType::SampledTexture, b) ||
                !textureDimension(compiler.get_type(r.type_id), stage, b.name, b.textureDimension,
                                  diagnostics)) {
                ok = false;
                continue;
            }
            bindings.push_back(b);
        }
        for (const spirv_cross::Resource& r : resources.storage_images) {
            Binding b;
            const spirv_cross::SPIRType& type = compiler.get_type(r.type_id);
            if (!base(r, rhi::BindingType::StorageTexture, b) ||
                !textureDimension(type, stage, b.name, b.textureDimension, diagnostics)) {
                ok = false;
                continue;
            }
            if (!storageFormat(type.image.format, b.storageFormat)) {
                diagnostics.push_back(where(stage) + ": error: storage image '" + b.name +
                                      "' needs a format layout qualifier the RHI supports (rgba8, rgba16f, "
                                      "rgba32f, r32f, r16f, rg16f, rg32f, r32ui, r8ui, r8)");
                ok = false;
                continue;
            }
            b.writes = !compiler.has_decoration(r.id, spv::DecorationNonWritable);
            bindings.push_back(b);
        }
        std::sort(bindings.begin(), bindings.end(), [](const Binding& a, const Binding& b) {
            return std::tie(a.set, a.binding) < std::tie(b.set, b.binding);
        });
        for (size_t i = 1; i < bindings.size(); ++i) {
            if (bindings[i].set == bindings[i - 1].set && bindings[i].binding == bindings[i - 1].binding) {
                diagnostics.push_back(where(stage) + ": error: '" + bindings[i - 1].name + "' and '" +
                                      bindings[i].name + "' both use set " + std::to_string(bindings[i].set) +
                                      ", binding " + std::to_string(bindings[i].binding));
                ok = false;
            }
        }
        stage.bindings = std::move(bindings);

        stage.pushConstantSize = 0;
        for (const spirv_cross::Resource& r : resources.push_constant_buffers) {
            const spirv_cross::SPIRType& type = compiler.get_type(r.base_type_id);
            const size_t size = compiler.get_declared_struct_size(type);
            if (size > rhi::kMaxPushConstantSize) {
                diagnostics.push_back(where(stage) + ": error: push-constant block '" + r.name + "' is " +
                                      std::to_string(size) + " bytes; the limit is " +
                                      std::to_string(rhi::kMaxPushConstantSize));
                ok = false;
            }
            stage.pushConstantSize = static_cast<uint32_t>(size);
        }

        stage.workgroupSize = {1, 1, 1};
        if (stage.stage == rhi::ShaderStage::Compute) {
            for (uint32_t i = 0; i < 3; ++i) {
                stage.workgroupSize[i] = compiler.get_execution_mode_argument(spv::ExecutionModeLocalSize, i);
            }
            spirv_cross::SpecializationConstant x, y, z;
            compiler.get_work_group_size_specialization_constants(x, y, z);
            if (x.id || y.id || z.id) {
                diagnostics.push_back(where(stage) +
                                      ": error: specialization-constant workgroup sizes are not supported");
                ok = false;
            }
        }

        stage.vertexInputs.clear();
        if (stage.stage == rhi::ShaderStage::Vertex) {
            for (const spirv_cross::Resource& r : resources.stage_inputs) {
                rhi::VertexInputReflection input;
                input.location = compiler.get_decoration(r.id, spv::DecorationLocation);
                if (!compiler.has_decoration(r.id, spv::DecorationLocation)) {
                    diagnostics.push_back(where(stage) + ": error: vertex input '" + r.name +
                                          "' needs layout(location = N)");
                    ok = false;
                    continue;
                }
                if (!vertexFormat(compiler.get_type(r.type_id), input.format)) {
                    diagnostics.push_back(where(stage) + ": error: vertex input '" + r.name +
                                          "' must be float, vec2, vec3, vec4 or uint");
                    ok = false;
                    continue;
                }
                stage.vertexInputs.push_back(input);
            }
            std::sort(stage.vertexInputs.begin(), stage.vertexInputs.end(),
                      [](const auto& a, const auto& b) { return a.location < b.location; });
        }
        return ok;
    } catch (const std::exception& e) {
        diagnostics.push_back(where(stage) + ": error: SPIR-V reflection failed: " + e.what());
        return false;
    }
}

bool assignGlBindings(std::vector<StageOutput>& stages, std::vector<std::string>& diagnostics) {
    struct Slot {
        const Binding* first = nullptr;
        const StageOutput* firstStage = nullptr;
        uint32_t glBinding = 0;
    };
    std::map<std::pair<uint32_t, uint32_t>, Slot> slots;
    bool ok = true;
    for (const StageOutput& stage : stages) {
        for (const Binding& b : stage.bindings) {
            Slot& slot = slots[{b.set, b.binding}];
            if (!slot.first) {
                slot.first = &b;
                slot.firstStage = &stage;
                continue;
            }
            const Binding& a = *slot.first;
            const bool textureMismatch =
                (b.type == rhi::BindingType::SampledTexture || b.type == rhi::BindingType::StorageTexture) &&
                (a.textureDimension != b.textureDimension || a.storageFormat != b.storageFormat);
            if (a.type != b.type || a.count != b.count || textureMismatch) {
                diagnostics.push_back(stage.path + ": error: set " + std::to_string(b.set) + ", binding " +
                                      std::to_string(b.binding) + " ('" + b.name + "', " + describe(b.type) +
                                      ") is declared differently in " + slot.firstStage->path + " ('" +
                                      a.name + "', " + describe(a.type) + ")");
                ok = false;
            }
        }
    }
    if (!ok) return false;

    // Compact per class, in (set, binding) order; arrays take `count` consecutive GL bindings.
    std::map<GlClass, uint32_t> next;
    for (auto& [key, slot] : slots) {
        const GlClass c = glClassOf(slot.first->type);
        auto it = next.find(c);
        if (it == next.end()) it = next.emplace(c, glClassBase(c)).first;
        slot.glBinding = it->second;
        it->second += slot.first->count;
    }
    for (StageOutput& stage : stages) {
        for (Binding& b : stage.bindings) b.glBinding = slots.at({b.set, b.binding}).glBinding;
    }
    return true;
}

bool emitDesktopGlsl(StageOutput& stage, std::vector<std::string>& diagnostics) {
    try {
        spirv_cross::CompilerGLSL compiler(stage.spirv);
        spirv_cross::CompilerGLSL::Options options;
        options.version = 450;
        options.es = false;
        options.vulkan_semantics = false;
        options.emit_push_constant_as_uniform_buffer = true;
        options.separate_shader_objects = false;
        options.vertex.fixup_clipspace = false;  // GL uses glClipControl(LOWER_LEFT, ZERO_TO_ONE)
        options.vertex.flip_vert_y = false;
        options.vertex.support_nonzero_base_instance = false;  // no hidden SPIRV_Cross_BaseInstance uniform
        compiler.set_common_options(options);

        const spirv_cross::ShaderResources resources = compiler.get_shader_resources();
        const std::string suffix = stageSuffix(stage.stage);

        // Look up each reflected binding by its Vulkan (set, binding).
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> glBindings;
        for (const Binding& b : stage.bindings) glBindings[{b.set, b.binding}] = b.glBinding;

        auto remap = [&](const spirv_cross::SmallVector<spirv_cross::Resource>& list, bool isBlock) {
            for (const spirv_cross::Resource& r : list) {
                const uint32_t set = compiler.get_decoration(r.id, spv::DecorationDescriptorSet);
                const uint32_t binding = compiler.get_decoration(r.id, spv::DecorationBinding);
                compiler.unset_decoration(r.id, spv::DecorationDescriptorSet);
                compiler.set_decoration(r.id, spv::DecorationBinding, glBindings.at({set, binding}));
                // Per-stage names keep OpenGL from matching same-named blocks/uniforms of the vertex
                // and fragment shader by name (which Vulkan never does).
                if (!suffix.empty()) {
                    if (isBlock) {
                        compiler.set_name(r.base_type_id, compiler.get_name(r.base_type_id) + suffix);
                    } else {
                        compiler.set_name(r.id, compiler.get_name(r.id) + suffix);
                    }
                }
            }
        };
        remap(resources.uniform_buffers, true);
        remap(resources.storage_buffers, true);
        remap(resources.sampled_images, false);
        remap(resources.storage_images, false);
        for (const spirv_cross::Resource& r : resources.push_constant_buffers) {
            compiler.set_decoration(r.id, spv::DecorationBinding, rhi::kGlPushConstantBinding);
            compiler.unset_decoration(r.id, spv::DecorationDescriptorSet);
            if (!suffix.empty())
                compiler.set_name(r.base_type_id, compiler.get_name(r.base_type_id) + suffix);
        }

        stage.glsl = compiler.compile();
        return true;
    } catch (const std::exception& e) {
        std::string message =
            where(stage) + ": error: cannot express this shader as OpenGL GLSL 4.50: " + e.what();
        if (message.find("Buffer block cannot be expressed") != std::string::npos) {
            message +=
                " (on OpenGL the push-constant block becomes a std140 uniform block: keep its members "
                "std140-compatible, e.g. vec4 or scalars instead of arrays of float/vec2)";
        }
        diagnostics.push_back(message);
        return false;
    }
}

}  // namespace penumbra::shaderc::detail
