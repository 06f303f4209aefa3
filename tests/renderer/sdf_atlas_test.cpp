// The field atlas (renderer/features/sdf_atlas.h, issue 10 item 2) on both backends under
// validation: one slot per asset id however many uses, no upload for an unchanged frame, freed space
// reused, replaced assets re-uploaded, growth keeping every resident field's texels (read back and
// compared bit for bit with the grid rounded toward -infinity), non-overlapping slots under churn,
// bytes and fill, and clear errors (never a crash) for fields the device cannot hold.
// The float -> half conversion is checked against every half.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/core/log.h"
#include "engine/sdf/psdf.h"
#include "renderer/features/sdf_atlas.h"
#include "support/test_device.h"

namespace {

namespace sdf = penumbra::sdf;
using penumbra::render::GpuSdfField;
using penumbra::render::SdfAtlas;
using penumbra::render::toFloatTowardNegative;
using penumbra::render::toHalfTowardNegative;
using FieldList = std::vector<std::pair<penumbra::assets::AssetId, const sdf::PsdfAsset*>>;

// A field of the given size whose values (mesh units) are neither half- nor voxel-aligned and span
// both signs and several binades.
std::unique_ptr<sdf::PsdfAsset> makeField(glm::uvec3 dims, double voxel, uint32_t seed) {
    auto a = std::make_unique<sdf::PsdfAsset>();
    a->grid.dims = dims;
    a->grid.voxelSize = voxel;
    a->grid.origin = glm::dvec3(-0.5 * dims.x * voxel, 0.25 * seed, 1.0);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    a->grid.distances.resize(size_t(dims.x) * dims.y * dims.z);
    for (size_t i = 0; i < a->grid.distances.size(); ++i)
        a->grid.distances[i] = float(u(rng) * std::ldexp(voxel, int(i % 13) - 4));
    a->header.dims = dims;
    a->header.voxelSize = voxel;
    a->header.origin = a->grid.origin;
    a->header.boundsMin = a->grid.origin + 2.0 * voxel;
    a->header.boundsMax = a->grid.origin + (glm::dvec3(dims) - 2.0) * voxel;
    return a;
}

double halfValue(uint16_t h) { return double(sdf::halfToFloat(h)); }

TEST(SdfAtlasHalf, RoundsTowardNegativeInfinityForEveryHalf) {
    // Every finite half converts to itself; every value strictly between two neighbouring halves
    // converts to the lower one.
    std::vector<double> halves;
    for (uint32_t h = 0; h < 0x10000; ++h) {
        const uint16_t bits = uint16_t(h);
        if ((bits & 0x7c00) == 0x7c00) continue;  // inf / NaN
        const double v = halfValue(bits);
        ASSERT_EQ(halfValue(toHalfTowardNegative(v)), v) << "half 0x" << std::hex << h;
        if (bits != 0x8000) halves.push_back(v);
    }
    std::sort(halves.begin(), halves.end());
    ASSERT_EQ(halves.size(), 2u * 0x7c00 - 1);
    for (size_t i = 0; i + 1 < halves.size(); ++i) {
        const double lo = halves[i], hi = halves[i + 1];
        for (double v :
             {std::nextafter(lo, hi), 0.5 * (lo + hi), std::nextafter(hi, lo), lo + 0.999 * (hi - lo)}) {
            if (!(v > lo && v < hi)) continue;
            ASSERT_EQ(halfValue(toHalfTowardNegative(v)), lo) << v << " between " << lo << " and " << hi;
        }
    }
    EXPECT_EQ(halfValue(toHalfTowardNegative(1e9)), 65504.0);
    EXPECT_EQ(halfValue(toHalfTowardNegative(65504.5)), 65504.0);
    EXPECT_EQ(halfValue(toHalfTowardNegative(-1e9)), -65504.0);  // clamped (documented)
    EXPECT_EQ(halfValue(toHalfTowardNegative(-1e-30)), -std::ldexp(1.0, -24));
    EXPECT_EQ(halfValue(toHalfTowardNegative(1e-30)), 0.0);
    EXPECT_EQ(toHalfTowardNegative(std::nan("")), 0);
}

TEST(SdfAtlasHalf, FloatRoundsTowardNegativeInfinity) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < 100000; ++i) {
        const double v = u(rng) * std::ldexp(1.0, int(rng() % 200) - 100);
        const float f = toFloatTowardNegative(v);
        ASSERT_LE(double(f), v);
        ASSERT_GT(double(std::nextafter(f, FLT_MAX)), v);
    }
    EXPECT_EQ(toFloatTowardNegative(1e300), FLT_MAX);
    EXPECT_EQ(toFloatTowardNegative(-1e300), -FLT_MAX);
}

class SdfAtlasGpu : public penumbra::test::GpuTest {
protected:
    // The texels of every resident field equal the grid / voxelSize rounded toward -infinity, bit for
    // bit; slots lie inside the texture and do not overlap; bytes() and fill() are right.
    void checkAtlas(const SdfAtlas& atlas, const FieldList& fields) {
        ASSERT_TRUE(atlas.texture().isValid());
        const rhi::TextureDesc* desc = dev().describe(atlas.texture());
        ASSERT_NE(desc, nullptr);
        const glm::uvec3 size(desc->width, desc->height, desc->depthOrLayers);
        EXPECT_EQ(size, atlas.size());
        EXPECT_EQ(atlas.bytes(), rhi::textureBytes(*desc));
        for (int a = 0; a < 3; ++a) EXPECT_EQ(size[a] % 8, 0u) << "atlas sizes are multiples of 8 texels";
        std::vector<uint8_t> texels;
        ASSERT_TRUE(dev().readTexture(atlas.texture(), {0, 0}, rhi::Access::ShaderSampled, texels));
        const uint32_t texel = rhi::formatInfo(desc->format).bytesPerTexel;
        ASSERT_EQ(texels.size(), uint64_t(size.x) * size.y * size.z * texel);
        std::vector<uint8_t> owner(texels.size() / texel, 0);
        uint64_t voxels = 0, mismatches = 0;
        std::vector<bool> seenSlot(atlas.fields().size(), false);
        for (const auto& [id, asset] : fields) {
            const uint32_t slot = atlas.slotOf(id);
            ASSERT_LT(slot, atlas.fields().size()) << "asset " << id << " is not resident";
            if (seenSlot[slot]) continue;
            seenSlot[slot] = true;
            const GpuSdfField& f = atlas.fields()[slot];
            const sdf::SdfGrid& g = asset->grid;
            EXPECT_EQ(glm::uvec3(glm::vec3(f.dims)), g.dims);
            EXPECT_EQ(f.origin.w, float(g.voxelSize));
            EXPECT_EQ(glm::vec3(f.origin), glm::vec3(g.origin + 0.5 * g.voxelSize));
            EXPECT_EQ(glm::vec3(f.uvwScale), 1.0f / glm::vec3(size));
            const glm::uvec3 off(glm::vec3(f.uvwOffset));
            EXPECT_EQ(glm::vec3(off), glm::vec3(f.uvwOffset)) << "integer offsets";
            for (int a = 0; a < 3; ++a) {
                ASSERT_LE(off[a] + g.dims[a], size[a]) << "slot " << slot << " leaves the texture";
                EXPECT_LE(double(f.boundsMin[a]), asset->header.boundsMin[a]);
                EXPECT_GE(double(f.boundsMax[a]), asset->header.boundsMax[a]);
            }
            voxels += uint64_t(g.dims.x) * g.dims.y * g.dims.z;
            for (uint32_t k = 0; k < g.dims.z; ++k)
                for (uint32_t j = 0; j < g.dims.y; ++j)
                    for (uint32_t i = 0; i < g.dims.x; ++i) {
                        const size_t t = (size_t(off.z + k) * size.y + off.y + j) * size.x + off.x + i;
                        ASSERT_EQ(owner[t]++, 0) << "slots overlap at texel " << t;
                        const double v = double(g.distances[g.index(i, j, k)]) / g.voxelSize;
                        if (texel == 2) {
                            uint16_t h = 0;
                            std::memcpy(&h, &texels[t * 2], 2);
                            mismatches += h != toHalfTowardNegative(v);
                        } else {
                            float x = 0;
                            std::memcpy(&x, &texels[t * 4], 4);
                            mismatches += x != toFloatTowardNegative(v);
                        }
                    }
        }
        EXPECT_EQ(mismatches, 0u);
        EXPECT_EQ(atlas.residentCount(), uint32_t(std::count(seenSlot.begin(), seenSlot.end(), true)));
        EXPECT_DOUBLE_EQ(atlas.fill(), double(voxels) / (double(size.x) * size.y * size.z));
        EXPECT_GT(atlas.fill(), 0.0);
        EXPECT_LE(atlas.fill(), 1.0);
    }
};

TEST_P(SdfAtlasGpu, OneSlotPerAssetAndNothingUploadedForAnUnchangedFrame) {
    const auto a = makeField({20, 12, 9}, 0.05, 1);
    const auto b = makeField({7, 30, 11}, 0.125, 2);
    const auto c = makeField({16, 16, 16}, 1.5, 3);
    FieldList uses;
    for (int i = 0; i < 100; ++i) {  // 100 instances of three assets
        const int k = (i * 7) % 3;
        uses.push_back(k == 0   ? FieldList::value_type{11, a.get()}
                       : k == 1 ? FieldList::value_type{22, b.get()}
                                : FieldList::value_type{33, c.get()});
    }
    SdfAtlas atlas(dev());
    EXPECT_FALSE(atlas.texture().isValid());
    EXPECT_EQ(atlas.bytes(), 0u);
    EXPECT_EQ(atlas.fill(), 0.0);
    std::string error;
    ASSERT_TRUE(atlas.update(uses, error)) << error;
    EXPECT_EQ(atlas.residentCount(), 3u);
    EXPECT_EQ(atlas.uploads(), 3u);
    EXPECT_EQ(atlas.fields().size(), 3u);
    EXPECT_NE(atlas.slotOf(11), atlas.slotOf(22));
    EXPECT_NE(atlas.slotOf(22), atlas.slotOf(33));
    EXPECT_NE(atlas.slotOf(11), atlas.slotOf(33));
    EXPECT_EQ(atlas.slotOf(44), UINT32_MAX);
    if (any(dev().formatSupport(rhi::Format::R16_FLOAT) & rhi::FormatSupport::Filterable)) {
        EXPECT_EQ(atlas.format(), rhi::Format::R16_FLOAT);
    }
    checkAtlas(atlas, uses);
    const rhi::TextureHandle texture = atlas.texture();
    const std::vector<GpuSdfField> before = atlas.fields();
    ASSERT_TRUE(atlas.update(uses, error)) << error;
    EXPECT_EQ(atlas.uploads(), 3u) << "a second frame with the same fields uploads nothing";
    EXPECT_EQ(atlas.texture(), texture);
    EXPECT_EQ(std::memcmp(before.data(), atlas.fields().data(), before.size() * sizeof(GpuSdfField)), 0);
    // Order does not matter either.
    std::reverse(uses.begin(), uses.end());
    ASSERT_TRUE(atlas.update(uses, error)) << error;
    EXPECT_EQ(atlas.uploads(), 3u);
    checkAtlas(atlas, uses);
}

TEST_P(SdfAtlasGpu, FreedSpaceAndSlotsAreReusedAndReplacedAssetsUploadedAgain) {
    std::vector<std::unique_ptr<sdf::PsdfAsset>> assets;
    for (uint32_t i = 0; i < 40; ++i) assets.push_back(makeField({12, 10, 9}, 0.1, 10 + i));
    SdfAtlas atlas(dev());
    std::string error;
    // Four fields of one size at a time, one replaced by a new asset id every frame: each newcomer
    // fits the space its predecessor freed, so the atlas never grows.
    FieldList frame;
    for (uint32_t i = 0; i < 4; ++i) frame.push_back({1000 + i, assets[i].get()});
    ASSERT_TRUE(atlas.update(frame, error)) << error;
    const glm::uvec3 size = atlas.size();
    for (uint32_t i = 4; i < 40; ++i) {
        const uint32_t victim = i % 4;
        const uint32_t freedSlot = atlas.slotOf(frame[victim].first);
        frame[victim] = {1000 + i, assets[i].get()};
        const uint64_t uploads = atlas.uploads();
        ASSERT_TRUE(atlas.update(frame, error)) << error;
        EXPECT_EQ(atlas.slotOf(1000 + i), freedSlot) << "the freed slot index is reused";
        EXPECT_EQ(atlas.uploads(), uploads + 1);
        EXPECT_EQ(atlas.residentCount(), 4u);
        EXPECT_EQ(atlas.fields().size(), 4u);
        EXPECT_EQ(atlas.slotOf(1000 + i - 4), UINT32_MAX);
    }
    EXPECT_EQ(atlas.size(), size) << "freed space is reused: the atlas did not grow";
    EXPECT_EQ(atlas.growths(), 0u);
    checkAtlas(atlas, frame);

    // Same id, different PsdfAsset object: uploaded again, same slot.
    const uint32_t slot = atlas.slotOf(frame[2].first);
    const auto replacement = makeField(frame[2].second->grid.dims, 0.1, 999);
    frame[2].second = replacement.get();
    const uint64_t uploads = atlas.uploads();
    ASSERT_TRUE(atlas.update(frame, error)) << error;
    EXPECT_EQ(atlas.uploads(), uploads + 1);
    EXPECT_EQ(atlas.slotOf(frame[2].first), slot);
    checkAtlas(atlas, frame);

    // An empty frame frees everything (the texture stays for the next frame).
    ASSERT_TRUE(atlas.update({}, error)) << error;
    EXPECT_EQ(atlas.residentCount(), 0u);
    EXPECT_EQ(atlas.fill(), 0.0);
    ASSERT_TRUE(atlas.update(frame, error)) << error;
    EXPECT_EQ(atlas.size(), size);
    checkAtlas(atlas, frame);
}

TEST_P(SdfAtlasGpu, GrowthKeepsEveryResidentField) {
    std::mutex mutex;
    std::vector<std::string> infos;
    auto previous = penumbra::log::setSink([&](penumbra::log::Severity s, std::string_view m) {
        std::lock_guard lock(mutex);
        if (s == penumbra::log::Severity::Info) infos.emplace_back(m);
    });
    std::vector<std::unique_ptr<sdf::PsdfAsset>> assets;
    SdfAtlas atlas(dev());
    std::string error;
    FieldList frame;
    uint32_t growths = 0;
    glm::uvec3 lastSize(0);
    for (uint32_t i = 0; i < 14; ++i) {
        assets.push_back(
            makeField({9 + 3 * i, 17 + (5 * i) % 11, 13 + (7 * i) % 19}, 0.02 * (i + 1), 100 + i));
        frame.push_back({500 + i, assets.back().get()});
        ASSERT_TRUE(atlas.update(frame, error)) << error;
        if (atlas.size() != lastSize && i > 0) {
            ++growths;
            checkAtlas(atlas, frame);  // every resident field survived the growth
        }
        lastSize = atlas.size();
    }
    penumbra::log::setSink(previous);
    EXPECT_GE(growths, 2u);
    EXPECT_EQ(atlas.growths(), growths);
    checkAtlas(atlas, frame);
    size_t grewMessages = 0;
    for (const std::string& m : infos) grewMessages += m.find("sdf atlas: grew") != std::string::npos;
    EXPECT_EQ(grewMessages, growths) << "growth is reported at info level";
}

TEST_P(SdfAtlasGpu, RandomChurnKeepsSlotsApartAndValuesIntact) {
    std::vector<std::unique_ptr<sdf::PsdfAsset>> assets;
    std::mt19937 rng(42);
    for (uint32_t i = 0; i < 30; ++i)
        assets.push_back(
            makeField({4 + rng() % 29, 4 + rng() % 29, 4 + rng() % 29}, 0.01 + 0.01 * (rng() % 7), i));
    SdfAtlas atlas(dev());
    std::string error;
    for (int frameIndex = 0; frameIndex < 25; ++frameIndex) {
        FieldList frame;
        for (uint32_t i = 0; i < assets.size(); ++i)
            if (rng() % 3 == 0) frame.push_back({i + 1, assets[i].get()});
        ASSERT_TRUE(atlas.update(frame, error)) << error;
        if (frame.empty()) continue;
        const uint64_t uploads = atlas.uploads();
        ASSERT_TRUE(atlas.update(frame, error)) << error;
        EXPECT_EQ(atlas.uploads(), uploads) << "an unchanged frame uploads nothing";
        if (frameIndex % 6 == 5) checkAtlas(atlas, frame);
    }
}

TEST_P(SdfAtlasGpu, FieldsTheDeviceCannotHoldFailWithAnError) {
    const uint32_t max3D = dev().info().limits.maxTextureSize3D;
    ASSERT_GT(max3D, 0u);
    SdfAtlas atlas(dev());
    std::string error;
    const auto small = makeField({8, 8, 8}, 0.1, 5);
    ASSERT_TRUE(atlas.update({{1, small.get()}}, error)) << error;
    const uint64_t uploads = atlas.uploads();
    const rhi::TextureHandle texture = atlas.texture();

    sdf::PsdfAsset huge;
    huge.grid.dims = {max3D + 1, 1, 2};
    huge.grid.voxelSize = 0.5;
    huge.grid.distances.assign(size_t(max3D + 1) * 2, 1.0f);
    EXPECT_FALSE(atlas.update({{1, small.get()}, {2, &huge}}, error));
    EXPECT_NE(error.find("maximum 3D texture size " + std::to_string(max3D)), std::string::npos) << error;
    // Nothing changed: the previous frame's field is still resident where it was.
    EXPECT_EQ(atlas.slotOf(1), 0u);
    EXPECT_EQ(atlas.slotOf(2), UINT32_MAX);
    EXPECT_EQ(atlas.texture(), texture);
    EXPECT_EQ(atlas.uploads(), uploads);

    error.clear();
    EXPECT_FALSE(atlas.update({{3, nullptr}}, error));
    EXPECT_NE(error.find("field asset 3"), std::string::npos) << error;
    sdf::PsdfAsset inconsistent = *small;
    inconsistent.grid.distances.pop_back();
    error.clear();
    EXPECT_FALSE(atlas.update({{4, &inconsistent}}, error));
    EXPECT_NE(error.find("distances"), std::string::npos) << error;
    inconsistent = *small;
    inconsistent.grid.voxelSize = 0;
    error.clear();
    EXPECT_FALSE(atlas.update({{4, &inconsistent}}, error));
    EXPECT_NE(error.find("voxel size"), std::string::npos) << error;
    const auto other = makeField({8, 8, 8}, 0.1, 6);
    error.clear();
    EXPECT_FALSE(atlas.update({{5, small.get()}, {5, other.get()}}, error));
    EXPECT_NE(error.find("two different fields"), std::string::npos) << error;
    EXPECT_EQ(atlas.residentCount(), 1u);
    checkAtlas(atlas, {{1, small.get()}});
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfAtlasGpu, testing::ValuesIn(penumbra::test::gpuBackends()),
                         penumbra::test::backendName);

}  // namespace
