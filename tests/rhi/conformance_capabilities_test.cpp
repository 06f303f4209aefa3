// RHI conformance: capability queries. Device::formatSupport answers what the API guarantees (and
// what it claims, creation honours), and the limits report subgroups, 3D textures and workgroups.
#include <algorithm>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "conformance_common.h"

namespace {

using namespace rhi;
using penumbra::conformance::ConformanceTest;

class ConformanceCapabilities : public ConformanceTest {};

bool has(FormatSupport s, FormatSupport bits) { return (s & bits) == bits; }

// Formats whose support Vulkan 1.3 and GL 4.5 both require, and integer formats that never filter.
TEST_P(ConformanceCapabilities, FormatSupportReportsRequiredCapabilities) {
    // Metric: required capability flags are reported. Threshold: every listed flag set / clear.
    EXPECT_TRUE(has(dev().formatSupport(Format::RGBA8_UNORM),
                    FormatSupport::Sampled | FormatSupport::Filterable | FormatSupport::Storage |
                        FormatSupport::ColorTarget | FormatSupport::Blendable));
    EXPECT_TRUE(has(dev().formatSupport(Format::RGBA32_FLOAT),
                    FormatSupport::Sampled | FormatSupport::Storage | FormatSupport::ColorTarget));
    EXPECT_TRUE(has(dev().formatSupport(Format::R32_UINT), FormatSupport::Sampled | FormatSupport::Storage |
                                                               FormatSupport::StorageAtomic |
                                                               FormatSupport::ColorTarget));
    EXPECT_FALSE(
        any(dev().formatSupport(Format::R32_UINT) & (FormatSupport::Filterable | FormatSupport::Blendable)));
    EXPECT_TRUE(
        has(dev().formatSupport(Format::D32_FLOAT), FormatSupport::Sampled | FormatSupport::DepthTarget));
    EXPECT_FALSE(
        any(dev().formatSupport(Format::D32_FLOAT) & (FormatSupport::Storage | FormatSupport::ColorTarget)));
    EXPECT_TRUE(has(dev().formatSupport(Format::RGB32_FLOAT), FormatSupport::VertexAttribute));
    EXPECT_EQ(dev().formatSupport(Format::Undefined), FormatSupport::None);
}

// Every claim holds: a texture with every usage a format claims is created without errors.
TEST_P(ConformanceCapabilities, ClaimedUsagesCanBeCreated) {
    for (uint32_t f = 1; f < uint32_t(Format::Count); ++f) {
        const Format format = Format(f);
        const FormatSupport s = dev().formatSupport(format);
        TextureUsage usage = TextureUsage::CopySrc | TextureUsage::CopyDst;
        if (any(s & FormatSupport::Sampled)) usage |= TextureUsage::Sampled;
        if (any(s & FormatSupport::Storage)) usage |= TextureUsage::Storage;
        if (any(s & FormatSupport::ColorTarget)) usage |= TextureUsage::ColorTarget;
        if (any(s & FormatSupport::DepthTarget)) usage |= TextureUsage::DepthTarget;
        if (usage == (TextureUsage::CopySrc | TextureUsage::CopyDst)) continue;  // vertex-only format
        // Metric: creation succeeds. Threshold: valid handle (and no validation error, checked by the
        // fixture).
        EXPECT_TRUE(makeTexture2D(format, 8, 8, usage).isValid())
            << formatInfo(format).name << " claims " << toString(s);
    }
}

TEST_P(ConformanceCapabilities, LimitsReportSubgroupsVolumesAndWorkgroups) {
    const DeviceInfo& info = dev().info();
    const DeviceLimits& l = info.limits;
    // Metric: limits at least the minimums both APIs guarantee (Vulkan 1.3 minimums). Threshold: >=.
    EXPECT_GE(l.maxTextureSize3D, 256u);
    EXPECT_GE(l.maxComputeWorkgroupSize[0], 128u);
    EXPECT_GE(l.maxComputeWorkgroupSize[2], 64u);
    EXPECT_GE(l.maxComputeWorkgroupCount[0], 65535u);
    EXPECT_GE(l.maxComputeWorkgroupInvocations, 128u);
    if (GetParam() == Backend::Vulkan) {
        // Vulkan 1.1+: subgroups exist in compute with at least the basic operations.
        EXPECT_GE(l.subgroupSize, 1u);
        EXPECT_TRUE(any(l.subgroupOps & SubgroupOps::Basic));
        EXPECT_TRUE(any(l.subgroupStages & ShaderStageFlags::Compute));
        EXPECT_FALSE(info.enabledFeatures.empty())
            << "lavapipe supports optional features, e.g. independentBlend";
    } else if (l.subgroupSize == 0) {
        // GL without GL_KHR_shader_subgroup reports no subgroup operations.
        EXPECT_EQ(l.subgroupOps, SubgroupOps::None);
    } else {
        EXPECT_TRUE(any(l.subgroupOps & SubgroupOps::Basic));
    }
    // Metric: each enabled feature is named once. Threshold: no duplicates, no empty names.
    const std::set<std::string> unique(info.enabledFeatures.begin(), info.enabledFeatures.end());
    EXPECT_EQ(unique.size(), info.enabledFeatures.size());
    EXPECT_EQ(unique.count(""), 0u);
    std::printf("[ %s ] subgroup size %u ops %s; %zu enabled features\n", toString(GetParam()),
                l.subgroupSize, toString(l.subgroupOps).c_str(), info.enabledFeatures.size());
}

INSTANTIATE_TEST_SUITE_P(Backends, ConformanceCapabilities, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
