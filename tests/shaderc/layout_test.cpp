// Generated parameter structs (tests/shaderc/programs/params.comp): every member offset and every
// block size equals glslang's own reflection of the GLSL source (an implementation independent
// of the SPIRV-Cross reflection that shaderc uses), known std140/std430 answers, the glm types,
// the shared View struct, named slots and findBinding.
#include "shaderc_test_util.h"

#include <shaders/params.h>
#include <shaders/reflect_all.h>
#include <shaders/view.h>

#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <gtest/gtest.h>

#include <cstddef>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>

namespace fs = std::filesystem;
namespace params = penumbra::shaders::params;

namespace {

// Resolves #include against the given folders (what penumbra_add_shader_dir passes with -I).
class FolderIncluder final : public glslang::TShader::Includer {
public:
    explicit FolderIncluder(std::vector<std::string> dirs) : m_dirs(std::move(dirs)) {}
    IncludeResult* includeLocal(const char* name, const char*, size_t) override { return find(name); }
    IncludeResult* includeSystem(const char* name, const char*, size_t) override { return find(name); }
    void releaseInclude(IncludeResult* result) override {
        if (!result) return;
        delete static_cast<std::string*>(result->userData);
        delete result;
    }

private:
    IncludeResult* find(const char* name) {
        for (const std::string& dir : m_dirs) {
            const fs::path path = fs::path(dir) / name;
            if (!fs::exists(path)) continue;
            auto* text = new std::string(shaderc_test::readFile(path.string()));
            return new IncludeResult(path.string(), text->data(), text->size(), text);
        }
        return nullptr;
    }
    std::vector<std::string> m_dirs;
};

struct GlslangReflection {
    std::map<std::string, int> offsets;     // "Block.member" -> byte offset
    std::map<std::string, int> blockSizes;  // block name -> declared size
    std::map<std::string, int> topStrides;  // block member -> stride of its top-level array
    std::string error;
};

// glslang's reflection of a compute shader, with every block member (active or not).
GlslangReflection reflectWithGlslang(const std::string& path) {
    static std::once_flag once;
    std::call_once(once, [] { glslang::InitializeProcess(); });
    GlslangReflection out;
    const std::string source = shaderc_test::readFile(path);
    const char* text = source.c_str();
    glslang::TShader shader(EShLangCompute);
    shader.setStrings(&text, 1);
    shader.setPreamble("#extension GL_GOOGLE_include_directive : require\n");
    shader.setEnvInput(glslang::EShSourceGlsl, EShLangCompute, glslang::EShClientVulkan, 100);
    shader.setEnvClient(glslang::EShClientVulkan, glslang::EShTargetVulkan_1_3);
    shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_6);
    const auto messages = static_cast<EShMessages>(EShMsgSpvRules | EShMsgVulkanRules);
    FolderIncluder includer({fs::path(path).parent_path().string(), SHADERC_RENDERER_SHADERS});
    if (!shader.parse(GetDefaultResources(), 450, ECoreProfile, false, false, messages, includer)) {
        out.error = shader.getInfoLog();
        return out;
    }
    glslang::TProgram program;
    program.addShader(&shader);
    if (!program.link(messages) || !program.buildReflection(EShReflectionAllBlockVariables)) {
        out.error = program.getInfoLog();
        return out;
    }
    for (int i = 0; i < program.getNumUniformVariables(); ++i) {
        const glslang::TObjectReflection& u = program.getUniform(i);
        out.offsets[u.name] = u.offset;
        out.topStrides[u.name] = u.topLevelArrayStride;
    }
    for (int i = 0; i < program.getNumBufferVariables(); ++i) {
        const glslang::TObjectReflection& b = program.getBufferVariable(i);
        out.offsets[b.name] = b.offset;
        out.topStrides[b.name] = b.topLevelArrayStride;
    }
    for (int i = 0; i < program.getNumUniformBlocks(); ++i) {
        out.blockSizes[program.getUniformBlock(i).name] = program.getUniformBlock(i).size;
    }
    for (int i = 0; i < program.getNumBufferBlocks(); ++i) {
        out.blockSizes[program.getBufferBlock(i).name] = program.getBufferBlock(i).size;
    }
    return out;
}

std::string listed(const std::map<std::string, int>& map) {
    std::string text;
    for (const auto& [name, value] : map) text += name + "=" + std::to_string(value) + " ";
    return text;
}

// Criterion: offsetof of every generated member == glslang's offset of that GLSL member.
TEST(ShadercLayout, EveryMemberOffsetEqualsGlslangReflection) {
    const GlslangReflection r = reflectWithGlslang(std::string(SHADERC_PROGRAMS) + "/params.comp");
    ASSERT_EQ(r.error, "");
    const std::map<std::string, size_t> generated = {
        {"Params.scale", offsetof(params::Params, scale)},
        {"Params.axis", offsetof(params::Params, axis)},
        {"Params.extent", offsetof(params::Params, extent)},
        {"Params.count", offsetof(params::Params, count)},
        {"Params.mask", offsetof(params::Params, mask)},
        {"Params.cell", offsetof(params::Params, cell)},
        {"Params.dims", offsetof(params::Params, dims)},
        {"Params.enabled", offsetof(params::Params, enabled)},
        {"Params.transform", offsetof(params::Params, transform)},
        {"Params.rotation", offsetof(params::Params, rotation)},
        {"Params.basis", offsetof(params::Params, basis)},
        {"Params.colors", offsetof(params::Params, colors)},
        {"Params.inners.direction", offsetof(params::Params, inners) + offsetof(params::Inner, direction)},
        {"Params.inners.weight", offsetof(params::Params, inners) + offsetof(params::Inner, weight)},
        {"Params.inners.uv", offsetof(params::Params, inners) + offsetof(params::Inner, uv)},
        {"Params.single.direction", offsetof(params::Params, single) + offsetof(params::Inner, direction)},
        {"Params.single.weight", offsetof(params::Params, single) + offsetof(params::Inner, weight)},
        {"Params.single.uv", offsetof(params::Params, single) + offsetof(params::Inner, uv)},
        {"Params.tail", offsetof(params::Params, tail)},
        {"Stats.range", offsetof(params::Stats, range)},
        {"Stats.samples", offsetof(params::Stats, samples)},
        {"Stats.last.direction", offsetof(params::Stats, last) + offsetof(params::Inner, direction)},
        {"Stats.last.weight", offsetof(params::Stats, last) + offsetof(params::Inner, weight)},
        {"Stats.last.uv", offsetof(params::Stats, last) + offsetof(params::Inner, uv)},
        {"Stats.total", offsetof(params::Stats, total)},
        {"Push.tint", offsetof(params::Push, tint)},
        {"Push.frame", offsetof(params::Push, frame)},
        {"View.viewMatrix", offsetof(penumbra::shaders::View, viewMatrix)},
        {"View.invViewProj", offsetof(penumbra::shaders::View, invViewProj)},
        {"View.viewport", offsetof(penumbra::shaders::View, viewport)},
        {"View.jitter", offsetof(penumbra::shaders::View, jitter)},
        {"View.time", offsetof(penumbra::shaders::View, time)},
        {"View.deltaTime", offsetof(penumbra::shaders::View, deltaTime)},
        {"View.frameIndex", offsetof(penumbra::shaders::View, frameIndex)},
    };
    for (const auto& [name, offset] : generated) {
        // glslang names array-of-struct members "Params.inners[0].weight".
        std::string key = name;
        if (!r.offsets.count(key)) {
            const size_t dot = key.find('.', key.find('.') + 1);
            if (dot != std::string::npos) key = key.substr(0, dot) + "[0]" + key.substr(dot);
        }
        if (!r.offsets.count(key) && name.rfind("Params.colors", 0) == 0) key = name + "[0]";
        if (!r.offsets.count(key) && name.rfind("Stats.samples", 0) == 0) key = name + "[0]";
        ASSERT_TRUE(r.offsets.count(key))
            << name << " not reflected by glslang; it has: " << listed(r.offsets);
        EXPECT_EQ(static_cast<int>(offset), r.offsets.at(key)) << name;
    }
    // Block sizes: the C++ struct covers the declared block exactly (Params and Push end in a
    // scalar, so there is no tail padding).
    EXPECT_EQ(static_cast<int>(sizeof(params::Params)), r.blockSizes.at("Params")) << listed(r.blockSizes);
    EXPECT_EQ(static_cast<int>(sizeof(params::Push)), r.blockSizes.at("Push")) << listed(r.blockSizes);
    EXPECT_EQ(static_cast<int>(sizeof(penumbra::shaders::View)), r.blockSizes.at("View"))
        << listed(r.blockSizes);
}

// Criterion: a struct used as the element of a runtime-sized array has the array's stride as its
// C++ size (so a std::vector of it uploads as is), per glslang's reflection (members of a block
// without an instance name are reflected without the block name).
TEST(ShadercLayout, RuntimeArrayElementSizeEqualsTheStride) {
    const GlslangReflection r = reflectWithGlslang(std::string(SHADERC_PROGRAMS) + "/params.comp");
    ASSERT_EQ(r.error, "");
    ASSERT_TRUE(r.topStrides.count("probes[0].position")) << listed(r.topStrides);
    ASSERT_TRUE(r.topStrides.count("items[0].direction")) << listed(r.topStrides);
    EXPECT_EQ(static_cast<int>(sizeof(params::Probe)), r.topStrides.at("probes[0].position"));
    EXPECT_EQ(static_cast<int>(sizeof(params::Inner)), r.topStrides.at("items[0].direction"));
    EXPECT_EQ(sizeof(params::Probe), 32u);  // declared 24 bytes; std430 aligns the vec3 to 16
    EXPECT_EQ(static_cast<int>(offsetof(params::Probe, uv)), r.offsets.at("probes[0].uv"));
}

// Criterion: the std140 / std430 rules, worked out by hand, hold for the generated structs.
TEST(ShadercLayout, KnownStd140AndStd430Answers) {
    EXPECT_EQ(offsetof(params::Params, axis), 16u);       // vec3 aligns to 16
    EXPECT_EQ(offsetof(params::Params, extent), 32u);     // vec2 after a vec3 (12 bytes) at 16
    EXPECT_EQ(offsetof(params::Params, dims), 64u);       // uvec3 aligns to 16
    EXPECT_EQ(offsetof(params::Params, enabled), 76u);    // a scalar fills the uvec3's last 4 bytes
    EXPECT_EQ(offsetof(params::Params, rotation), 144u);  // after the mat4 at 80
    EXPECT_EQ(offsetof(params::Params, basis), 192u);     // mat3: 3 columns of 16 bytes
    EXPECT_EQ(offsetof(params::Params, colors), 224u);    // std140 mat2: 2 columns of 16 bytes
    EXPECT_EQ(sizeof(params::Inner), 32u);                // array stride of Inner: 24 rounded up to 16
    EXPECT_EQ(offsetof(params::Params, single), 336u);
    EXPECT_EQ(offsetof(params::Params, tail), 368u);  // after a struct: its padded size
    EXPECT_EQ(offsetof(params::Stats, samples), 8u);  // std430: float[] has a 4-byte stride
    EXPECT_EQ(offsetof(params::Stats, last), 32u);
    EXPECT_EQ(sizeof(params::Params), 372u);
    // The C++ types: glm, with std140 matrices padded to vec4 columns; bool is 32 bits.
    static_assert(std::is_same_v<decltype(params::Params::axis), glm::vec3>);
    static_assert(std::is_same_v<decltype(params::Params::cell), glm::ivec2>);
    static_assert(std::is_same_v<decltype(params::Params::dims), glm::uvec3>);
    static_assert(std::is_same_v<decltype(params::Params::enabled), uint32_t>);
    static_assert(std::is_same_v<decltype(params::Params::rotation), glm::mat3x4>);
    static_assert(std::is_same_v<decltype(params::Params::basis), glm::mat2x4>);
    static_assert(std::is_same_v<decltype(params::Params::colors), glm::vec4[3]>);
    static_assert(std::is_same_v<decltype(params::Params::inners), params::Inner[2]>);
    static_assert(std::is_same_v<decltype(params::Stats::samples), float[4]>);
}

// Criterion: PushConstants is the push-constant struct and has the reflected size; the program
// uses the one shared View struct.
TEST(ShadercLayout, PushConstantsAndSharedView) {
    static_assert(std::is_same_v<params::PushConstants, params::Push>);
    EXPECT_EQ(sizeof(params::PushConstants), params::compute().pushConstantSize);
    static_assert(std::is_same_v<params::View, penumbra::shaders::View>);
    EXPECT_EQ(penumbra::shaders::kViewSlot.set, 0u);
    EXPECT_EQ(penumbra::shaders::kViewSlot.binding, 0u);
    // A storage block ending in a runtime-sized array gets no struct, but its element struct does.
    EXPECT_EQ(params::slot::Items.type, rhi::BindingType::ReadOnlyStorageBuffer);
}

// Criterion: every slot names the (set, binding) of the reflected binding of the same name, and
// findBinding finds it by name and by slot.
TEST(ShadercLayout, NamedSlotsMatchReflection) {
    const rhi::ShaderDesc& desc = params::compute();
    for (const penumbra::shaders::SlotRef& slot :
         {params::slot::View, params::slot::Params, params::slot::Stats, params::slot::Items,
          params::slot::Probes}) {
        SCOPED_TRACE(slot.name);
        const rhi::ShaderBinding* byName = penumbra::shaders::findBinding(desc, slot.name);
        ASSERT_NE(byName, nullptr);
        EXPECT_EQ(byName, penumbra::shaders::findBinding(desc, slot));
        EXPECT_EQ(byName->set, slot.set);
        EXPECT_EQ(byName->binding, slot.binding);
        EXPECT_EQ(byName->type, slot.type);
        EXPECT_EQ(byName->count, slot.count);
    }
    EXPECT_EQ(params::slot::Params.set, 1u);
    EXPECT_EQ(params::slot::Stats.binding, 1u);
    EXPECT_EQ(penumbra::shaders::findBinding(desc, "nothing"), nullptr);
    // reflect_all: textures and images are found by their variable names.
    namespace ra = penumbra::shaders::reflect_all;
    const rhi::ShaderBinding* volume = penumbra::shaders::findBinding(ra::compute(), "volume");
    ASSERT_NE(volume, nullptr);
    EXPECT_EQ(volume->set, ra::slot::volume.set);
    EXPECT_EQ(volume->binding, ra::slot::volume.binding);
    EXPECT_EQ(ra::slot::target.type, rhi::BindingType::StorageTexture);
    const rhi::ShaderBinding* target = penumbra::shaders::findBinding(ra::compute(), ra::slot::target);
    ASSERT_NE(target, nullptr);
    EXPECT_EQ(target->storageFormat, rhi::Format::RGBA16_FLOAT);
}

}  // namespace
