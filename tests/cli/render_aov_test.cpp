// `penumbra render --aov` (tools/penumbra/aov_output.h, docs/FORMATS.md "AOV images"):
//   - the --aov list (names, duplicates, .pfm) and the conversion of read-back G-buffer texels into
//     AOV images, on the CPU (synthetic texels, gbuffer.aux included);
//   - the CLI on both backends: depth equals `penumbra reference`'s depth, normals are unit length
//     where something is hit and 0 elsewhere, the PFM rows run bottom to top, and ids / steps
//     come from gbuffer.aux.
// The error cases that must leave no file behind are CTest entries (cli.render.aov_*).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <glm/gtc/packing.hpp>

#include "aov_output.h"
#include "reference/pfm.h"
#include "renderer/core/gbuffer_encoding.h"
#include "renderer/renderer.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using cli::AovOutput;
using cli::RenderAov;
using cli::TargetTexels;

// ---- the --aov list ------------------------------------------------------------------------------

TEST(AovList, ParsesAnySubsetInOrder) {
    std::vector<AovOutput> aovs;
    std::string error;
    ASSERT_TRUE(cli::parseAovOutputs("steps=s.pfm,depth=out/d.PFM,normal=n.pfm,ids=i.pfm", aovs, error))
        << error;
    ASSERT_EQ(aovs.size(), 4u);
    EXPECT_EQ(aovs[0].kind, RenderAov::Steps);
    EXPECT_EQ(aovs[1].kind, RenderAov::Depth);
    EXPECT_EQ(aovs[1].path, "out/d.PFM");
    EXPECT_EQ(aovs[2].kind, RenderAov::Normal);
    EXPECT_EQ(aovs[3].kind, RenderAov::Ids);
    EXPECT_TRUE(cli::aovsNeedAux(aovs));

    ASSERT_TRUE(cli::parseAovOutputs("normal=a=b.pfm", aovs, error)) << error;  // the first '=' splits
    ASSERT_EQ(aovs.size(), 1u);
    EXPECT_EQ(aovs[0].path, "a=b.pfm");
    EXPECT_FALSE(cli::aovsNeedAux(aovs));

    ASSERT_TRUE(cli::parseAovOutputs("", aovs, error)) << error;
    EXPECT_TRUE(aovs.empty());
}

TEST(AovList, RefusesBadItems) {
    struct Case {
        const char* spec;
        const char* message;
    };
    const Case cases[] = {
        {"colour=c.pfm",
         "unknown AOV 'colour' (depth, normal, ids, steps, ao, shadow, shadowN, bentnormal, thickness)"},
        {"depth=a.pfm,depth=b.pfm", "AOV 'depth' is listed twice"},
        {"depth=d.png", "must end in .pfm"},
        {"depth=d", "must end in .pfm"},
        {"depth", "expected NAME=PATH.pfm"},
        {"depth=", "expected NAME=PATH.pfm"},
        {"=d.pfm", "expected NAME=PATH.pfm"},
        {"depth=d.pfm,,normal=n.pfm", "expected NAME=PATH.pfm"},
        {"depth=d.pfm,", "empty item after the last comma"},
    };
    for (const Case& c : cases) {
        std::vector<AovOutput> aovs;
        std::string error;
        EXPECT_FALSE(cli::parseAovOutputs(c.spec, aovs, error)) << c.spec;
        EXPECT_NE(error.find(c.message), std::string::npos) << c.spec << ": " << error;
    }
}

// ---- conversion of read-back texels (CPU) -------------------------------------------------------

template <class T>
TargetTexels texels(rhi::Format format, const std::vector<T>& values) {
    TargetTexels t;
    t.format = format;
    t.texels.resize(values.size() * sizeof(T));
    std::memcpy(t.texels.data(), values.data(), t.texels.size());
    return t;
}

TEST(AovConvert, DepthNormalIdsSteps) {
    constexpr uint32_t kW = 3, kH = 2;
    const std::vector<float> depthValues = {1.5f, 0.0f, 2.0f, 0.0f, 7.25f, 100.0f};
    const std::vector<glm::vec3> normals = {{0, 0, 1},  {0, 1, 0},  glm::normalize(glm::vec3(1, -2, -3)),
                                            {0, 0, -1}, {-1, 0, 0}, {0.6f, 0.8f, 0}};
    std::vector<uint16_t> half;
    for (const glm::vec3& n : normals) {
        const glm::vec2 e = render::octEncode(n);
        half.push_back(glm::packHalf1x16(e.x));
        half.push_back(glm::packHalf1x16(e.y));
    }
    const std::vector<float> auxValues = {3, 0, -1, 0, 12, 41, -1, 0, 0, 7, 5, 0};  // (id, steps) pairs
    const TargetTexels depth = texels(rhi::Format::R32_FLOAT, depthValues);
    const TargetTexels normal = texels(rhi::Format::RG16_FLOAT, half);
    const TargetTexels aux = texels(rhi::Format::RG32_FLOAT, auxValues);

    reference::FloatImage img;
    std::string error;
    ASSERT_TRUE(cli::convertAov(RenderAov::Depth, kW, kH, &depth, nullptr, nullptr, img, error)) << error;
    EXPECT_EQ(img.channels, 1u);
    EXPECT_EQ(img.data, depthValues);

    ASSERT_TRUE(cli::convertAov(RenderAov::Normal, kW, kH, &depth, &normal, nullptr, img, error)) << error;
    ASSERT_EQ(img.channels, 3u);
    ASSERT_EQ(img.data.size(), size_t(kW) * kH * 3);
    for (size_t i = 0; i < depthValues.size(); ++i) {
        const glm::vec3 n(img.data[i * 3], img.data[i * 3 + 1], img.data[i * 3 + 2]);
        if (depthValues[i] == 0.0f) {
            EXPECT_EQ(n, glm::vec3(0.0f)) << "pixel " << i << ": nothing hit";
        } else {
            EXPECT_NEAR(glm::length(n), 1.0f, 1e-6f) << "pixel " << i;
            EXPECT_GT(glm::dot(n, normals[i]), std::cos(0.002f)) << "pixel " << i;  // RG16F: < 0.1 degree
        }
    }

    ASSERT_TRUE(cli::convertAov(RenderAov::Ids, kW, kH, nullptr, nullptr, &aux, img, error)) << error;
    EXPECT_EQ(img.channels, 1u);
    EXPECT_EQ(img.data, (std::vector<float>{3, -1, 12, -1, 0, 5}));
    ASSERT_TRUE(cli::convertAov(RenderAov::Steps, kW, kH, nullptr, nullptr, &aux, img, error)) << error;
    EXPECT_EQ(img.data, (std::vector<float>{0, 0, 41, 0, 7, 0}));
}

TEST(AovConvert, RefusesWrongFormatOrSize) {
    const TargetTexels depth = texels(rhi::Format::R32_FLOAT, std::vector<float>(6, 1.0f));
    reference::FloatImage img;
    std::string error;
    EXPECT_FALSE(cli::convertAov(RenderAov::Depth, 4, 2, &depth, nullptr, nullptr, img, error));
    EXPECT_NE(error.find("expected 32 for 4x2"), std::string::npos) << error;
    const TargetTexels wrong = texels(rhi::Format::RG16_FLOAT, std::vector<uint16_t>(12, 0));
    EXPECT_FALSE(cli::convertAov(RenderAov::Ids, 3, 2, nullptr, nullptr, &wrong, img, error));
    EXPECT_NE(error.find("gbuffer.aux has format"), std::string::npos) << error;
    EXPECT_FALSE(cli::convertAov(RenderAov::Steps, 3, 2, nullptr, nullptr, nullptr, img, error));
}

// ---- the CLI on both backends ---------------------------------------------------------------------

const std::string kSourceDir = PENUMBRA_SOURCE_DIR;

struct CliRun {
    int status = -1;
    std::string output;
};

CliRun runCli(const std::string& args, const std::string& logPath) {
    const std::string cmd = fmt::format("'{}' {} > '{}' 2>&1", PENUMBRA_CLI_PATH, args, logPath);
    CliRun r;
    const int raw = std::system(cmd.c_str());
    r.status = raw == -1 ? -1 : WEXITSTATUS(raw);
    std::ifstream in(logPath);
    r.output.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    return r;
}

reference::FloatImage readImage(const std::string& path, uint32_t channels) {
    reference::FloatImage img;
    std::string error;
    EXPECT_TRUE(reference::readPfm(path, img, error)) << error;
    EXPECT_EQ(img.channels, channels) << path;
    return img;
}

class RenderAovCli : public testing::TestWithParam<rhi::Backend> {
protected:
    void SetUp() override {
        std::string name = testing::UnitTest::GetInstance()->current_test_info()->name();
        for (char& c : name)
            if (c == '/') c = '_';  // "Test/0" of the parameterised suite
        m_dir = fmt::format("{}/tests/cli_out/render_aov/{}", PENUMBRA_BINARY_DIR, name);
        std::filesystem::remove_all(m_dir);
        std::filesystem::create_directories(m_dir);
    }
    std::string backend() const { return GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl"; }
    // `penumbra render` of `scene` at kW x kH with --aov `aovs` (NAME=FILE relative to the test folder).
    CliRun render(const std::string& scene, uint32_t w, uint32_t h, const std::string& aovs) {
        std::string spec;
        for (size_t start = 0; start < aovs.size();) {
            size_t end = aovs.find(',', start);
            if (end == std::string::npos) end = aovs.size();
            const std::string item = aovs.substr(start, end - start);
            const size_t eq = item.find('=');
            spec += (spec.empty() ? "" : ",") + item.substr(0, eq + 1) + m_dir + "/" + item.substr(eq + 1);
            start = end + 1;
        }
        return runCli(
            fmt::format("render '{}' --backend {} --validation --no-cache --width {} --height {} -o "
                        "'{}/image.png' --aov '{}'",
                        scene, backend(), w, h, m_dir, spec),
            m_dir + "/render.log");
    }
    std::string m_dir;
};

// Criterion (issue 10 item 7): the depth AOV equals the CPU reference's depth within 1e-3 relative on
// >= 99 % of the pixels hit in both; normals are unit length (to 1e-3) wherever depth > 0 and exactly
// 0 elsewhere.
TEST_P(RenderAovCli, PrimitivesDepthMatchesReferenceAndNormalsAreUnit) {
    constexpr uint32_t kW = 160, kH = 90;
    const std::string scene = kSourceDir + "/scenes/primitives.json";
    const CliRun r = render(scene, kW, kH, "depth=depth.pfm,normal=normal.pfm");
    ASSERT_EQ(r.status, 0) << r.output;
    const CliRun ref =
        runCli(fmt::format("reference '{}' --width {} --height {} --aov depth,normal --samples 1 -q "
                           "-o '{}/ref'",
                           scene, kW, kH, m_dir),
               m_dir + "/reference.log");
    ASSERT_EQ(ref.status, 0) << ref.output;

    const reference::FloatImage depth = readImage(m_dir + "/depth.pfm", 1);
    const reference::FloatImage normal = readImage(m_dir + "/normal.pfm", 3);
    const reference::FloatImage refDepth = readImage(m_dir + "/ref/depth.pfm", 1);
    const reference::FloatImage refNormal = readImage(m_dir + "/ref/normal.pfm", 3);
    ASSERT_EQ(depth.width, kW);
    ASSERT_EQ(depth.height, kH);
    ASSERT_EQ(normal.width, kW);
    ASSERT_EQ(normal.height, kH);
    ASSERT_EQ(refDepth.data.size(), depth.data.size());

    size_t both = 0, close = 0, hit = 0, unit = 0, zeroWhereMissed = 0, missed = 0, normalClose = 0;
    for (size_t i = 0; i < depth.data.size(); ++i) {
        const float a = depth.data[i], b = refDepth.data[i];
        const glm::vec3 n(normal.data[i * 3], normal.data[i * 3 + 1], normal.data[i * 3 + 2]);
        if (a > 0.0f) {
            ++hit;
            unit += std::abs(glm::length(n) - 1.0f) <= 1e-3f;
        } else {
            ++missed;
            zeroWhereMissed += a == 0.0f && n == glm::vec3(0.0f);
        }
        if (!(a > 0.0f) || !(b > 0.0f)) continue;
        ++both;
        close += std::abs(a - b) <= 1e-3f * b;
        const glm::vec3 m(refNormal.data[i * 3], refNormal.data[i * 3 + 1], refNormal.data[i * 3 + 2]);
        normalClose += glm::dot(n, m) >= std::cos(glm::radians(2.0f));
    }
    const double fraction = both ? double(close) / double(both) : 0.0;
    std::printf(
        "[%s] %zu pixels hit in both, %.3f %% depth within 1e-3 relative, %.3f %% normals within 2 deg "
        "of the reference; %zu hit, %zu missed\n",
        backend().c_str(), both, 100.0 * fraction, both ? 100.0 * double(normalClose) / double(both) : 0.0,
        hit, missed);
    EXPECT_GT(both, size_t(kW) * kH / 2);
    EXPECT_GE(fraction, 0.99);
    EXPECT_EQ(unit, hit) << "normals not of unit length where something is hit";
    EXPECT_EQ(zeroWhereMissed, missed) << "depth / normal not 0 where nothing is hit";
    // The interpolated vertex normals of the tessellated primitives against the same in the reference
    // (both use the mesh's vertex normals): >= 99 % within 2 degrees.
    EXPECT_GE(both ? double(normalClose) / double(both) : 0.0, 0.99);
}

// The PFM rows run from the bottom of the image to the top: a box only in the top half of the image
// gives non-zero depth in the LAST rows of the file and zeros in the first ones.
TEST_P(RenderAovCli, PfmRowsRunBottomToTop) {
    constexpr uint32_t kW = 64, kH = 48;
    const CliRun r = render(kSourceDir + "/tests/cli/aov_top_half.json", kW, kH, "depth=d.pfm,normal=n.pfm");
    ASSERT_EQ(r.status, 0) << r.output;

    std::ifstream in(m_dir + "/d.pfm", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string header = "Pf\n64 48\n-1.0\n";
    ASSERT_EQ(bytes.substr(0, header.size()), header);
    ASSERT_EQ(bytes.size(), header.size() + size_t(kW) * kH * 4);
    auto rowHits = [&](uint32_t fileRow) {
        uint32_t n = 0;
        for (uint32_t x = 0; x < kW; ++x) {
            float v;  // little-endian (scale -1), as is this machine
            std::memcpy(&v, bytes.data() + header.size() + (size_t(fileRow) * kW + x) * 4, 4);
            n += v > 0.0f;
        }
        return n;
    };
    for (uint32_t row = 0; row < kH / 2; ++row) EXPECT_EQ(rowHits(row), 0u) << "file row " << row;
    uint32_t topHits = 0;
    for (uint32_t row = kH / 2; row < kH; ++row) topHits += rowHits(row);
    EXPECT_GT(topHits, 100u);
    EXPECT_EQ(rowHits(kH - 1), 0u) << "the box does not reach the top edge";
    EXPECT_GT(rowHits(kH - 10), 0u) << "the box is seen a few rows below the top edge";

    // Through readPfm (which flips): row 0 in memory is the top row, as in every image of the project.
    const reference::FloatImage depth = readImage(m_dir + "/d.pfm", 1);
    float topHalf = 0, bottomHalf = 0;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) (y < kH / 2 ? topHalf : bottomHalf) += depth.data[y * kW + x];
    EXPECT_GT(topHalf, 0.0f);
    EXPECT_EQ(bottomHalf, 0.0f);

    std::ifstream nin(m_dir + "/n.pfm", std::ios::binary);
    const std::string normalBytes((std::istreambuf_iterator<char>(nin)), std::istreambuf_iterator<char>());
    const std::string normalHeader = "PF\n64 48\n-1.0\n";
    EXPECT_EQ(normalBytes.substr(0, normalHeader.size()), normalHeader) << "three-channel header";
    EXPECT_EQ(normalBytes.size(), normalHeader.size() + size_t(kW) * kH * 3 * 4);
}

// ids / steps from gbuffer.aux: ids equal the reference's entity index on >= 99 % of the pixels hit in
// both and are -1 where nothing is hit; a mesh scene is rasterized, so steps are 0 everywhere.
TEST_P(RenderAovCli, IdsAndStepsOfAMeshScene) {
    constexpr uint32_t kW = 160, kH = 90;
    const std::string scene = kSourceDir + "/scenes/primitives.json";
    const CliRun r = render(scene, kW, kH, "depth=depth.pfm,ids=ids.pfm,steps=steps.pfm");
    ASSERT_EQ(r.status, 0) << r.output;
    const CliRun ref =
        runCli(fmt::format("reference '{}' --width {} --height {} --aov depth,ids --samples 1 -q "
                           "-o '{}/ref'",
                           scene, kW, kH, m_dir),
               m_dir + "/reference.log");
    ASSERT_EQ(ref.status, 0) << ref.output;
    const reference::FloatImage depth = readImage(m_dir + "/depth.pfm", 1);
    const reference::FloatImage ids = readImage(m_dir + "/ids.pfm", 1);
    const reference::FloatImage steps = readImage(m_dir + "/steps.pfm", 1);
    const reference::FloatImage refDepth = readImage(m_dir + "/ref/depth.pfm", 1);
    const reference::FloatImage refIds = readImage(m_dir + "/ref/ids.pfm", 1);
    size_t both = 0, same = 0, badBackground = 0, nonZeroSteps = 0;
    for (size_t i = 0; i < depth.data.size(); ++i) {
        nonZeroSteps += steps.data[i] != 0.0f;
        if (depth.data[i] == 0.0f) badBackground += ids.data[i] != -1.0f;
        if (!(depth.data[i] > 0.0f) || !(refDepth.data[i] > 0.0f)) continue;
        ++both;
        same += ids.data[i] == refIds.data[i];
    }
    std::printf("[%s] ids: %zu of %zu pixels hit in both agree with the reference\n", backend().c_str(), same,
                both);
    EXPECT_GT(both, size_t(kW) * kH / 2);
    EXPECT_GE(both ? double(same) / double(both) : 0.0, 0.99);
    EXPECT_EQ(badBackground, 0u) << "ids not -1 where nothing is hit";
    EXPECT_EQ(nonZeroSteps, 0u) << "a rasterized pixel has trace steps";
}

// `penumbra demo --aov` (the built-in scene, rasterized meshes): the AOVs are written at the image's
// size, ids are -1 exactly where depth is 0 and name an entity elsewhere, and steps are 0 (no pixel
// is traced). A bad list is a usage error (exit 2) that writes nothing, not even the PNG.
TEST_P(RenderAovCli, DemoWritesAovs) {
    constexpr uint32_t kW = 96, kH = 54;
    const CliRun r =
        runCli(fmt::format("demo --backend {} --validation --width {} --height {} -o '{}/demo.png' "
                           "--aov 'depth={}/d.pfm,ids={}/i.pfm,steps={}/s.pfm'",
                           backend(), kW, kH, m_dir, m_dir, m_dir, m_dir),
               m_dir + "/demo.log");
    ASSERT_EQ(r.status, 0) << r.output;
    const reference::FloatImage depth = readImage(m_dir + "/d.pfm", 1);
    const reference::FloatImage ids = readImage(m_dir + "/i.pfm", 1);
    const reference::FloatImage steps = readImage(m_dir + "/s.pfm", 1);
    ASSERT_EQ(depth.width, kW);
    ASSERT_EQ(depth.height, kH);
    ASSERT_EQ(ids.data.size(), depth.data.size());
    ASSERT_EQ(steps.data.size(), depth.data.size());
    size_t hit = 0, idMismatch = 0, traced = 0;
    for (size_t i = 0; i < depth.data.size(); ++i) {
        const bool h = depth.data[i] > 0.0f;
        hit += h;
        idMismatch += h ? !(ids.data[i] >= 0.0f) : ids.data[i] != -1.0f;
        traced += steps.data[i] != 0.0f;
    }
    EXPECT_GT(hit, size_t(kW) * kH / 2) << "the demo's floor and objects cover most of the image";
    EXPECT_LT(hit, size_t(kW) * kH) << "and the background the rest";
    EXPECT_EQ(idMismatch, 0u);
    EXPECT_EQ(traced, 0u) << "the demo scene is rasterized";

    const CliRun bad = runCli(fmt::format("demo --backend {} --width {} --height {} -o '{}/bad.png' --aov "
                                          "'depth={}/bad_d.pfm,bogus={}/bad_x.pfm'",
                                          backend(), kW, kH, m_dir, m_dir, m_dir),
                              m_dir + "/bad.log");
    EXPECT_EQ(bad.status, 2) << bad.output;
    EXPECT_NE(bad.output.find("unknown AOV 'bogus'"), std::string::npos) << bad.output;
    EXPECT_FALSE(std::filesystem::exists(m_dir + "/bad.png"));
    EXPECT_FALSE(std::filesystem::exists(m_dir + "/bad_d.pfm"));
}

INSTANTIATE_TEST_SUITE_P(Backends, RenderAovCli, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test
