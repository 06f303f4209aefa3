// Malformed and truncated .psdf files (tests/malformed/psdf/, written by generate.py there): each
// is rejected with one message naming the file and the offending field; nothing crashes (this
// suite also runs under ASan). Plus exhaustive truncation and single-bit corruption of a valid file.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

#include "engine/sdf/psdf.h"

namespace {

using namespace penumbra::sdf;
namespace fs = std::filesystem;

const fs::path kDir = fs::path(PENUMBRA_SOURCE_DIR) / "tests/malformed/psdf";

std::vector<uint8_t> readBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// file -> a word its error message must contain.
const std::map<std::string, std::string> kCases = {
    {"empty.psdf", "empty"},
    {"bad_magic.psdf", "magic"},
    {"truncated_magic.psdf", "magic"},
    {"truncated_header.psdf", "truncated header"},
    {"future_version.psdf", "version"},
    {"header_crc_wrong.psdf", "header CRC"},
    {"zero_dims.psdf", "'dims'"},
    {"dims_over_axis_limit.psdf", "'dims'"},
    {"dims_product_overflow.psdf", "voxel count exceeds"},
    {"huge_dims_tiny_file.psdf", "truncated payload"},
    {"payload_size_mismatch.psdf", "'payloadBytes'"},
    {"truncated_payload.psdf", "truncated payload"},
    {"trailing_bytes.psdf", "unexpected bytes"},
    {"bad_payload_crc.psdf", "payload CRC"},
    {"nan_origin.psdf", "'origin'"},
    {"inf_origin.psdf", "'origin'"},
    {"negative_voxel_size.psdf", "'voxelSize'"},
    {"zero_voxel_size.psdf", "'voxelSize'"},
    {"inf_voxel_size.psdf", "'voxelSize'"},
    {"far_corner_overflow.psdf", "far corner"},
    {"voxel_size_1e300.psdf", "cannot be represented"},
    {"voxel_size_subnormal_float.psdf", "smallest normal 32-bit float"},
    {"u8_band_width_huge.psdf", "'bandWidth'"},
    {"unknown_encoding.psdf", "'encoding'"},
    {"u8_band_width_zero.psdf", "'bandWidth'"},
    {"u8_band_width_nan.psdf", "'bandWidth'"},
    {"f32_band_width_nonzero.psdf", "'bandWidth'"},
    {"unknown_flags.psdf", "'flags'"},
    {"contradictory_flags.psdf", "'flags'"},
    {"reserved_nonzero.psdf", "'reserved'"},
    {"nan_bounds.psdf", "'boundsMin'"},
    {"inverted_bounds.psdf", "'boundsMin'"},
    {"nan_payload_value.psdf", "not finite"},
    {"f16_inf_payload_value.psdf", "not finite"},
    {"nan_min_distance.psdf", "'minDistance'"},
    {"min_max_mismatch.psdf", "'maxDistance'"},
};

TEST(PsdfMalformed, CorpusIsCompleteAndLargeEnough) {
    ASSERT_TRUE(fs::is_directory(kDir)) << kDir << " is missing";
    std::set<std::string> onDisk;
    for (const auto& e : fs::directory_iterator(kDir))
        if (e.path().extension() == ".psdf" && e.path().filename().string().rfind("valid_", 0) != 0)
            onDisk.insert(e.path().filename().string());
    for (const auto& [name, keyword] : kCases)
        EXPECT_TRUE(onDisk.count(name)) << name << " missing: run generate.py";
    for (const auto& name : onDisk)
        EXPECT_TRUE(kCases.count(name)) << name << " has no expected keyword here";
    EXPECT_GE(kCases.size(), 15u);
}

TEST(PsdfMalformed, ValidFilesFromTheIndependentWriterAreAccepted) {
    // generate.py computes its CRCs with zlib and its halves with Python's struct: an independent
    // check of this reader's CRC-32, half decoding and u8 dequantisation.
    for (const char* name : {"valid_f32.psdf", "valid_f16.psdf", "valid_u8.psdf"}) {
        PsdfAsset a;
        std::string err;
        ASSERT_TRUE(readPsdf((kDir / name).string(), a, err)) << err;
        EXPECT_EQ(a.grid.dims, glm::uvec3(4, 3, 2));
        EXPECT_EQ(a.grid.distances.size(), 24u);
        EXPECT_NEAR(a.grid.distances[0], -1.0, 0.01) << name;
        EXPECT_NEAR(a.grid.distances[10], 0.0, 0.01) << name;
    }
}

TEST(PsdfMalformed, EveryCaseIsRejectedWithAClearMessage) {
    for (const auto& [name, keyword] : kCases) {
        SCOPED_TRACE(name);
        const fs::path path = kDir / name;
        PsdfAsset a;
        std::string err;
        EXPECT_FALSE(readPsdf(path.string(), a, err));
        EXPECT_NE(err.find(keyword), std::string::npos) << "error '" << err << "' lacks '" << keyword << "'";
        EXPECT_NE(err.find(name), std::string::npos) << "error '" << err << "' does not name the file";
        EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 0) << err;
        EXPECT_TRUE(a.grid.empty());
        // The in-memory decoder gives the same verdict.
        const std::vector<uint8_t> bytes = readBytes(path);
        std::string memErr;
        EXPECT_FALSE(decodePsdf(bytes.data(), bytes.size(), name, a, memErr));
        EXPECT_NE(memErr.find(keyword), std::string::npos) << memErr;
    }
}

TEST(PsdfMalformed, MissingFileAndDirectoryAreRejected) {
    PsdfAsset a;
    std::string err;
    EXPECT_FALSE(readPsdf((kDir / "does_not_exist.psdf").string(), a, err));
    EXPECT_NE(err.find("cannot open"), std::string::npos) << err;
    EXPECT_FALSE(readPsdf(kDir.string(), a, err));
    EXPECT_NE(err.find("not a regular file"), std::string::npos) << err;
}

TEST(PsdfMalformed, EveryTruncationAndEverySingleBitFlipOfAValidFileIsRejected) {
    for (const char* name : {"valid_f32.psdf", "valid_u8.psdf"}) {
        const std::vector<uint8_t> good = readBytes(kDir / name);
        ASSERT_GT(good.size(), kPsdfHeaderBytes);
        PsdfAsset a;
        std::string err;
        for (size_t n = 0; n < good.size(); ++n) {
            // A fresh allocation of exactly n bytes so ASan sees any read past the end.
            std::vector<uint8_t> cut(good.begin(), good.begin() + n);
            ASSERT_FALSE(decodePsdf(cut.data(), cut.size(), name, a, err)) << "truncated to " << n;
        }
        for (size_t byte = 0; byte < good.size(); ++byte) {
            for (int bit = 0; bit < 8; ++bit) {
                std::vector<uint8_t> bad = good;
                bad[byte] ^= uint8_t(1u << bit);
                ASSERT_FALSE(decodePsdf(bad.data(), bad.size(), name, a, err))
                    << "byte " << byte << " bit " << bit;
            }
        }
    }
}

}  // namespace
