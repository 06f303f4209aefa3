// .psdf v1: round trips for every encoding, CRC and half-float conversions, writer errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>

#include <glm/geometric.hpp>

#include "engine/sdf/psdf.h"

namespace {

using namespace penumbra::sdf;

// A sphere of radius 0.6 centred at c, sampled exactly at the voxel centres.
SdfGrid sphereGrid(glm::uvec3 dims, glm::dvec3 origin, double voxel, glm::dvec3 c, double r) {
    SdfGrid g;
    g.dims = dims;
    g.origin = origin;
    g.voxelSize = voxel;
    g.distances.resize(size_t(dims.x) * dims.y * dims.z);
    for (uint32_t k = 0; k < dims.z; ++k)
        for (uint32_t j = 0; j < dims.y; ++j)
            for (uint32_t i = 0; i < dims.x; ++i)
                g.distances[g.index(i, j, k)] = float(glm::length(g.voxelCenter(i, j, k) - c) - r);
    return g;
}

std::string tempPath(const char* name) {
    return (std::filesystem::temp_directory_path() / (std::string("penumbra_psdf_") + name)).string();
}

TEST(PsdfFormat, Crc32MatchesTheStandardCheckValue) {
    const char* text = "123456789";
    EXPECT_EQ(crc32(text, 9), 0xCBF43926u);
    EXPECT_EQ(crc32(nullptr, 0), 0u);
    // Running checksum over pieces equals the one-shot value, across the 8-byte fast path.
    std::vector<uint8_t> data(1000);
    for (size_t i = 0; i < data.size(); ++i) data[i] = uint8_t(i * 131 + 7);
    const uint32_t whole = crc32(data.data(), data.size());
    uint32_t running = 0;
    for (size_t off = 0; off < data.size(); off += 37)
        running = crc32(data.data() + off, std::min<size_t>(37, data.size() - off), running);
    EXPECT_EQ(running, whole);
}

TEST(PsdfFormat, HalfConversionRoundTripsEveryHalfAndRoundsToNearestEven) {
    for (uint32_t h = 0; h < 65536; ++h) {
        const float f = halfToFloat(uint16_t(h));
        if (std::isnan(f)) continue;
        ASSERT_EQ(floatToHalf(f), uint16_t(h)) << "half 0x" << std::hex << h;
    }
    EXPECT_EQ(halfToFloat(floatToHalf(65504.0f)), 65504.0f);
    EXPECT_TRUE(std::isinf(halfToFloat(floatToHalf(65520.0f))));
    EXPECT_EQ(halfToFloat(floatToHalf(65519.0f)), 65504.0f);
    // 1 + 2^-11 lies halfway between 1 and 1 + 2^-10: ties to even gives 1.
    EXPECT_EQ(halfToFloat(floatToHalf(1.0f + std::ldexp(1.0f, -11))), 1.0f);
    EXPECT_EQ(halfToFloat(floatToHalf(1.0f + 3 * std::ldexp(1.0f, -11))), 1.0f + std::ldexp(1.0f, -9));
    EXPECT_EQ(halfToFloat(floatToHalf(std::ldexp(1.0f, -24))), std::ldexp(1.0f, -24));  // smallest subnormal
    EXPECT_EQ(halfToFloat(floatToHalf(std::ldexp(1.0f, -25))), 0.0f);                   // tie to even (0)
    EXPECT_EQ(halfToFloat(floatToHalf(std::ldexp(1.5f, -25))), std::ldexp(1.0f, -24));
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-60000.f, 60000.f);
    for (int i = 0; i < 100000; ++i) {
        const float f = u(rng) * (i % 3 == 0 ? 1e-4f : 1.0f);
        EXPECT_LE(std::fabs(double(halfToFloat(floatToHalf(f))) - f),
                  quantisationError(PsdfEncoding::F16, f, 0))
            << f;
    }
}

TEST(PsdfFormat, F32RoundTripIsExactAndKeepsEveryHeaderField) {
    const SdfGrid g = sphereGrid({9, 7, 5}, {1e5 - 1.0, -0.5, 2.25}, 0.25, {1e5, 0.4, 2.8}, 0.6);
    PsdfWriteOptions opt;
    opt.sign = PsdfSign::Pseudonormal;
    opt.closedManifold = true;
    opt.boundsMin = {1e5 - 0.6, -0.2, 2.2 + 0.1};
    opt.boundsMax = {1e5 + 0.6, 1.0, 3.3};
    const std::string path = tempPath("roundtrip_f32.psdf");
    std::string err;
    ASSERT_TRUE(writePsdf(path, g, opt, err)) << err;
    PsdfAsset a;
    ASSERT_TRUE(readPsdf(path, a, err)) << err;
    EXPECT_EQ(std::filesystem::file_size(path), kPsdfHeaderBytes + 4 * g.distances.size());
    EXPECT_EQ(a.grid.dims, g.dims);
    EXPECT_EQ(a.grid.origin, g.origin);
    EXPECT_EQ(a.grid.voxelSize, g.voxelSize);
    EXPECT_EQ(a.grid.distances, g.distances);  // bit exact
    EXPECT_EQ(a.header.encoding, PsdfEncoding::F32);
    EXPECT_EQ(a.header.sign(), PsdfSign::Pseudonormal);
    EXPECT_EQ(a.header.flags, uint32_t(PsdfSign::Pseudonormal) | kPsdfFlagClosedManifold);
    EXPECT_EQ(a.header.boundsMin, opt.boundsMin);
    EXPECT_EQ(a.header.boundsMax, opt.boundsMax);
    EXPECT_EQ(a.header.bandWidth, 0.0);
    EXPECT_EQ(a.header.minDistance, *std::min_element(g.distances.begin(), g.distances.end()));
    EXPECT_EQ(a.header.maxDistance, *std::max_element(g.distances.begin(), g.distances.end()));
    std::remove(path.c_str());
}

TEST(PsdfFormat, F16RoundTripStaysWithinHalfPrecision) {
    const SdfGrid g = sphereGrid({16, 12, 10}, {-2, -1.5, -1.25}, 0.25, {0.1, 0.2, 0.0}, 0.9);
    PsdfWriteOptions opt;
    opt.encoding = PsdfEncoding::F16;
    opt.sign = PsdfSign::Winding;
    opt.boundaryEdges = true;
    std::vector<uint8_t> bytes;
    std::string err;
    ASSERT_TRUE(encodePsdf(g, opt, bytes, err)) << err;
    EXPECT_EQ(bytes.size(), kPsdfHeaderBytes + 2 * g.distances.size());
    PsdfAsset a;
    ASSERT_TRUE(decodePsdf(bytes.data(), bytes.size(), "mem", a, err)) << err;
    ASSERT_EQ(a.grid.distances.size(), g.distances.size());
    double worst = 0;
    for (size_t i = 0; i < g.distances.size(); ++i) {
        const double e = std::fabs(double(a.grid.distances[i]) - g.distances[i]);
        ASSERT_LE(e, quantisationError(PsdfEncoding::F16, g.distances[i], 0)) << i;
        worst = std::max(worst, e / g.voxelSize);
    }
    EXPECT_GT(worst, 0.0);    // it really is quantised
    EXPECT_LT(worst, 0.005);  // distances up to ~8 voxels: 8 * 2^-11 voxel
    EXPECT_EQ(a.header.sign(), PsdfSign::Winding);
    EXPECT_TRUE(a.header.flags & kPsdfFlagBoundaryEdges);
}

TEST(PsdfFormat, F16ClampsDistancesBeyondTheHalfRange) {
    SdfGrid g;
    g.dims = {2, 1, 1};
    g.voxelSize = 1.0;
    g.distances = {1e6f, -1e6f};
    PsdfWriteOptions opt;
    opt.encoding = PsdfEncoding::F16;
    std::vector<uint8_t> bytes;
    std::string err;
    ASSERT_TRUE(encodePsdf(g, opt, bytes, err)) << err;
    PsdfAsset a;
    ASSERT_TRUE(decodePsdf(bytes.data(), bytes.size(), "mem", a, err)) << err;
    EXPECT_EQ(a.grid.distances[0], 65504.0f);  // clamped magnitude: never larger than the truth
    EXPECT_EQ(a.grid.distances[1], -65504.0f);
}

TEST(PsdfFormat, U8RoundTripStaysWithinHalfAStepInsideTheBandAndClampsOutside) {
    const SdfGrid g = sphereGrid({20, 20, 20}, {-1, -1, -1}, 0.1, {0, 0, 0}, 0.6);
    for (double band : {0.0, 0.25}) {
        PsdfWriteOptions opt;
        opt.encoding = PsdfEncoding::U8;
        opt.bandWidth = band;
        std::vector<uint8_t> bytes;
        std::string err;
        ASSERT_TRUE(encodePsdf(g, opt, bytes, err)) << err;
        EXPECT_EQ(bytes.size(), kPsdfHeaderBytes + g.distances.size());
        PsdfAsset a;
        ASSERT_TRUE(decodePsdf(bytes.data(), bytes.size(), "mem", a, err)) << err;
        const double bw = band == 0 ? 4 * g.voxelSize : band;  // default: 4 voxels
        EXPECT_DOUBLE_EQ(a.header.bandWidth, bw);
        size_t inBand = 0;
        for (size_t i = 0; i < g.distances.size(); ++i) {
            const double d = g.distances[i], s = a.grid.distances[i];
            if (std::fabs(d) <= bw) {
                ++inBand;
                ASSERT_LE(std::fabs(s - d), bw / 255.0 + 1e-6) << i;
            } else {
                ASSERT_FLOAT_EQ(float(s), float(d > 0 ? bw : -bw)) << i;
            }
            ASSERT_LE(std::fabs(s), std::fabs(d) + bw / 255.0 + 1e-6);  // never much larger in magnitude
            ASSERT_LE(std::fabs(s - d), quantisationError(PsdfEncoding::U8, d, bw) + 1e-6);
        }
        EXPECT_GT(inBand, 100u);
    }
}

TEST(PsdfFormat, WriterRejectsBadGridsWithAClearMessage) {
    PsdfWriteOptions opt;
    std::vector<uint8_t> bytes;
    std::string err;
    SdfGrid g;
    EXPECT_FALSE(encodePsdf(g, opt, bytes, err));
    EXPECT_NE(err.find("dims"), std::string::npos) << err;

    g.dims = {2, 2, 2};
    g.voxelSize = 1;
    g.distances.assign(7, 0.f);
    EXPECT_FALSE(encodePsdf(g, opt, bytes, err));
    EXPECT_NE(err.find("values"), std::string::npos) << err;

    g.distances.assign(8, 0.f);
    g.distances[3] = std::nanf("");
    EXPECT_FALSE(encodePsdf(g, opt, bytes, err));
    EXPECT_NE(err.find("not finite"), std::string::npos) << err;

    g.distances[3] = 0;
    g.voxelSize = -1;
    EXPECT_FALSE(encodePsdf(g, opt, bytes, err));
    EXPECT_NE(err.find("voxel size"), std::string::npos) << err;

    g.voxelSize = 1;
    opt.encoding = PsdfEncoding::U8;
    opt.bandWidth = -2;
    EXPECT_FALSE(encodePsdf(g, opt, bytes, err));
    EXPECT_NE(err.find("band width"), std::string::npos) << err;

    SdfGrid wide;
    wide.dims = {20000, 1, 1};
    wide.voxelSize = 1;
    wide.distances.assign(20000, 1.f);
    EXPECT_FALSE(encodePsdf(wide, {}, bytes, err));
    EXPECT_NE(err.find("at most 16384 per axis"), std::string::npos) << err;

    opt = {};
    EXPECT_FALSE(writePsdf("/proc/penumbra/none/x.psdf", g, opt, err));
    EXPECT_NE(err.find("cannot open"), std::string::npos) << err;
    EXPECT_NE(err.find("/proc/penumbra/none/x.psdf"), std::string::npos) << err;
}

TEST(PsdfFormat, EncodingNamesParse) {
    PsdfEncoding e;
    ASSERT_TRUE(parsePsdfEncoding("f16", e));
    EXPECT_EQ(e, PsdfEncoding::F16);
    ASSERT_TRUE(parsePsdfEncoding("u8", e));
    EXPECT_EQ(e, PsdfEncoding::U8);
    ASSERT_TRUE(parsePsdfEncoding("f32", e));
    EXPECT_EQ(e, PsdfEncoding::F32);
    EXPECT_FALSE(parsePsdfEncoding("f64", e));
    EXPECT_STREQ(toString(PsdfEncoding::U8), "u8");
    EXPECT_STREQ(toString(PsdfSign::Parity), "parity");
}

}  // namespace
