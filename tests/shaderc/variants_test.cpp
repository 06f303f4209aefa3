// Shader variants (tests/shaderc/programs/variants.vert/.frag): one source compiled with the
// defines of `#pragma penumbra_variants`, each variant a vertex + fragment pair.
#include "shaderc_test_util.h"

#include <shaders/variants.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

namespace v = penumbra::shaders::variants;

namespace {

bool sameSpirv(const rhi::ShaderDesc& a, const rhi::ShaderDesc& b) {
    return std::equal(a.spirv.begin(), a.spirv.end(), b.spirv.begin(), b.spirv.end());
}

// Criterion: the pragmas of both stages declare the variants, in order, with names derived from
// the defines; Default comes first.
TEST(ShadercVariants, DeclaredVariantsAndNames) {
    static_assert(v::kVariantCount == 4);
    EXPECT_EQ(static_cast<uint32_t>(v::Variant::Default), 0u);
    EXPECT_STREQ(v::kVariantNames[0], "Default");
    EXPECT_STREQ(v::kVariantNames[static_cast<uint32_t>(v::Variant::FlipY)], "FlipY");
    EXPECT_STREQ(v::kVariantNames[static_cast<uint32_t>(v::Variant::AlbedoOnly)], "AlbedoOnly");
    EXPECT_STREQ(v::kVariantNames[static_cast<uint32_t>(v::Variant::AlbedoOnlyFlipY)], "AlbedoOnlyFlipY");
    EXPECT_EQ(&v::vertex(), &v::vertex(v::Variant::Default));
    EXPECT_EQ(&v::fragment(), &v::fragment(v::Variant::Default));
    EXPECT_EQ(v::fragment(v::Variant::AlbedoOnly).debugName, "variants.frag[AlbedoOnly]");
    EXPECT_EQ(v::vertex().debugName, "variants.vert");
}

// Criterion: a define changes exactly the stages that use it (SPIR-V and OpenGL GLSL), and every
// variant is compiled for both stages.
TEST(ShadercVariants, DefinesChangeTheStagesThatUseThem) {
    // FLIP_Y is used by the vertex shader only.
    EXPECT_FALSE(sameSpirv(v::vertex(v::Variant::FlipY), v::vertex()));
    EXPECT_NE(v::vertex(v::Variant::FlipY).glsl, v::vertex().glsl);
    EXPECT_TRUE(sameSpirv(v::fragment(v::Variant::FlipY), v::fragment()));
    // Identical code is stored once.
    EXPECT_EQ(v::fragment(v::Variant::FlipY).spirv.data(), v::fragment().spirv.data());
    EXPECT_NE(&v::fragment(v::Variant::FlipY), &v::fragment());
    // ALBEDO_ONLY by the fragment shader only.
    EXPECT_FALSE(sameSpirv(v::fragment(v::Variant::AlbedoOnly), v::fragment()));
    EXPECT_NE(v::fragment(v::Variant::AlbedoOnly).glsl, v::fragment().glsl);
    EXPECT_TRUE(sameSpirv(v::vertex(v::Variant::AlbedoOnly), v::vertex()));
    // The combination has both.
    EXPECT_TRUE(sameSpirv(v::vertex(v::Variant::AlbedoOnlyFlipY), v::vertex(v::Variant::FlipY)));
    EXPECT_TRUE(sameSpirv(v::fragment(v::Variant::AlbedoOnlyFlipY), v::fragment(v::Variant::AlbedoOnly)));
    for (uint32_t i = 0; i < v::kVariantCount; ++i) {
        const auto variant = static_cast<v::Variant>(i);
        SCOPED_TRACE(v::kVariantNames[i]);
        EXPECT_EQ(shaderc_test::validateSpirv(v::vertex(variant)), "");
        EXPECT_EQ(shaderc_test::validateSpirv(v::fragment(variant)), "");
        EXPECT_EQ(shaderc_test::compileDesktopGlsl({&v::vertex(variant), &v::fragment(variant)}), "");
    }
}

// Criterion: a variant's reflection is its own: the albedo texture exists only where ALBEDO_ONLY
// is defined, while the program's named slot covers all variants.
TEST(ShadercVariants, ReflectionIsPerVariantAndSlotsCoverAll) {
    EXPECT_EQ(penumbra::shaders::findBinding(v::fragment(), v::slot::gbufferAlbedo), nullptr);
    const rhi::ShaderBinding* albedo =
        penumbra::shaders::findBinding(v::fragment(v::Variant::AlbedoOnly), v::slot::gbufferAlbedo);
    ASSERT_NE(albedo, nullptr);
    EXPECT_STREQ(albedo->name, "gbufferAlbedo");
    EXPECT_EQ(albedo->set, 1u);
    EXPECT_EQ(albedo->binding, 1u);
    EXPECT_EQ(v::fragment().bindings.size() + 1, v::fragment(v::Variant::AlbedoOnly).bindings.size());
    // The shared View block is at set 0, binding 0 in both stages of every variant.
    for (uint32_t i = 0; i < v::kVariantCount; ++i) {
        for (const rhi::ShaderDesc* d :
             {&v::vertex(static_cast<v::Variant>(i)), &v::fragment(static_cast<v::Variant>(i))}) {
            const rhi::ShaderBinding* view = penumbra::shaders::findBinding(*d, v::slot::View);
            ASSERT_NE(view, nullptr) << d->debugName;
            EXPECT_STREQ(view->name, "View");
        }
    }
    static_assert(std::is_same_v<v::View, penumbra::shaders::View>);
    EXPECT_EQ(sizeof(v::PushConstants), v::fragment().pushConstantSize);
}

// Criterion: an out-of-range variant (only reachable through a cast) selects Default.
TEST(ShadercVariants, OutOfRangeSelectsDefault) {
    EXPECT_EQ(&v::vertex(static_cast<v::Variant>(99)), &v::vertex());
}

}  // namespace
