// The effect AOVs of `penumbra render --aov` (issue 12 item 7; tools/penumbra/aov_output.h) on the
// CPU: the names (ao, shadow, shadowN, bentnormal, thickness) and the conversion of read-back effect
// targets (effects.shadow R8 layers, effects.ao RGBA8 with the bent normal, effects.thickness R16F)
// into PFM images: values, background 0, layer selection and the errors.
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/packing.hpp>

#include "aov_output.h"

namespace penumbra::test {
namespace {

using cli::AovOutput;
using cli::RenderAov;
using cli::TargetTexels;

template <typename T>
TargetTexels texels(rhi::Format f, const std::vector<T>& v) {
    TargetTexels t;
    t.format = f;
    t.texels.resize(v.size() * sizeof(T));
    std::memcpy(t.texels.data(), v.data(), t.texels.size());
    return t;
}

TEST(EffectAovs, ParsesNamesAndLightIndices) {
    std::vector<AovOutput> aovs;
    std::string error;
    ASSERT_TRUE(cli::parseAovOutputs(
        "ao=a.pfm,shadow=s.pfm,shadow2=s2.pfm,bentnormal=b.pfm,thickness=t.pfm,depth=d.pfm", aovs, error))
        << error;
    ASSERT_EQ(aovs.size(), 6u);
    EXPECT_EQ(aovs[0].kind, RenderAov::Ao);
    EXPECT_EQ(aovs[1].kind, RenderAov::Shadow);
    EXPECT_EQ(aovs[1].light, 0u);
    EXPECT_EQ(aovs[2].kind, RenderAov::Shadow);
    EXPECT_EQ(aovs[2].light, 2u);
    EXPECT_EQ(cli::aovLabel(aovs[2]), "shadow2");
    EXPECT_EQ(aovs[3].kind, RenderAov::BentNormal);
    EXPECT_EQ(aovs[4].kind, RenderAov::Thickness);
    EXPECT_FALSE(cli::aovsNeedAux(aovs));  // effect AOVs need no gbuffer.aux
    // shadow0 is shadow: listed twice
    EXPECT_FALSE(cli::parseAovOutputs("shadow=a.pfm,shadow0=b.pfm", aovs, error));
    EXPECT_NE(error.find("listed twice"), std::string::npos) << error;
    for (const char* bad : {"shadowx=a.pfm", "shadow-1=a.pfm", "shadow1x=a.pfm", "bent=a.pfm"}) {
        EXPECT_FALSE(cli::parseAovOutputs(bad, aovs, error)) << bad;
        EXPECT_NE(error.find("unknown AOV"), std::string::npos) << error;
    }
}

// 3x2 pixels, pixel 1 and 3 background (depth 0).
struct Fixture {
    static constexpr uint32_t kW = 3, kH = 2;
    TargetTexels depth =
        texels(rhi::Format::R32_FLOAT, std::vector<float>{1.5f, 0.0f, 2.0f, 0.0f, 7.0f, 9.0f});
};

TEST(EffectAovs, ShadowLayers) {
    Fixture f;
    // two layers: row 0 = layer 0 (x 0..2) then layer 1 (x 3..5); row 1 likewise
    const TargetTexels shadow = texels(
        rhi::Format::R8_UNORM, std::vector<uint8_t>{255, 200, 0, 10, 20, 30, 51, 255, 102, 40, 50, 60});
    reference::FloatImage img;
    std::string error;
    AovOutput a{RenderAov::Shadow, "s.pfm", 0};
    ASSERT_TRUE(cli::convertEffectAov(a, f.kW, f.kH, f.depth, shadow, img, error)) << error;
    ASSERT_EQ(img.channels, 1u);
    const std::vector<float> layer0 = {1.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.4f};  // background 0
    for (size_t i = 0; i < 6; ++i) EXPECT_FLOAT_EQ(img.data[i], layer0[i]) << i;
    a.light = 1;
    ASSERT_TRUE(cli::convertEffectAov(a, f.kW, f.kH, f.depth, shadow, img, error)) << error;
    const std::vector<float> layer1 = {10 / 255.0f, 0.0f, 30 / 255.0f, 0.0f, 50 / 255.0f, 60 / 255.0f};
    for (size_t i = 0; i < 6; ++i) EXPECT_FLOAT_EQ(img.data[i], layer1[i]) << i;
    a.light = 2;  // no third shadowed light: an error naming the count
    EXPECT_FALSE(cli::convertEffectAov(a, f.kW, f.kH, f.depth, shadow, img, error));
    EXPECT_NE(error.find("has 2 shadowed light"), std::string::npos) << error;
}

TEST(EffectAovs, AoBentNormalAndThickness) {
    Fixture f;
    std::vector<uint8_t> ao;
    const glm::vec3 bent = glm::normalize(glm::vec3(1, 2, -2));
    for (int i = 0; i < 6; ++i) {
        const glm::vec3 e = glm::round((bent * 0.5f + 0.5f) * 255.0f);
        ao.insert(ao.end(), {uint8_t(i * 40), uint8_t(e.x), uint8_t(e.y), uint8_t(e.z)});
    }
    const TargetTexels aoTexels = texels(rhi::Format::RGBA8_UNORM, ao);
    reference::FloatImage img;
    std::string error;
    ASSERT_TRUE(
        cli::convertEffectAov({RenderAov::Ao, "a.pfm", 0}, f.kW, f.kH, f.depth, aoTexels, img, error));
    EXPECT_FLOAT_EQ(img.data[2], 80 / 255.0f);
    EXPECT_EQ(img.data[1], 0.0f);  // background
    ASSERT_TRUE(cli::convertEffectAov({RenderAov::BentNormal, "b.pfm", 0}, f.kW, f.kH, f.depth, aoTexels, img,
                                      error));
    ASSERT_EQ(img.channels, 3u);
    for (size_t i : {0u, 2u, 4u, 5u}) {
        const glm::vec3 n(img.data[i * 3], img.data[i * 3 + 1], img.data[i * 3 + 2]);
        EXPECT_NEAR(glm::length(n), 1.0f, 1e-5f);       // unit
        EXPECT_GT(glm::dot(n, bent), std::cos(0.02f));  // within 8-bit encoding (~1 degree)
    }
    EXPECT_EQ(img.data[3], 0.0f);  // background 0, 0, 0
    std::vector<uint16_t> half;
    for (float t : {0.25f, 3.0f, 0.0f, 1.0f, 12.5f, 0.0f}) half.push_back(glm::packHalf1x16(t));
    const TargetTexels thick = texels(rhi::Format::R16_FLOAT, half);
    ASSERT_TRUE(
        cli::convertEffectAov({RenderAov::Thickness, "t.pfm", 0}, f.kW, f.kH, f.depth, thick, img, error));
    const std::vector<float> want = {0.25f, 0.0f, 0.0f, 0.0f, 12.5f, 0.0f};  // background 0
    for (size_t i = 0; i < 6; ++i) EXPECT_FLOAT_EQ(img.data[i], want[i]) << i;
    // a wrong format is an error
    EXPECT_FALSE(
        cli::convertEffectAov({RenderAov::Thickness, "t.pfm", 0}, f.kW, f.kH, f.depth, aoTexels, img, error));
}

}  // namespace
}  // namespace penumbra::test
