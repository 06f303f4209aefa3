// Texture decoding: PNG (libpng) and JPEG (stb_image), detected by magic bytes; hostile input
// (truncated, garbage, oversized dimensions in the header) refused with a clear message.
#include <cstdlib>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "assets/assets_test_util.h"
#include "engine/assets/texture.h"
#include "engine/image/image.h"

namespace penumbra::assets {
namespace {

std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

const uint8_t* bytesOf(const std::string& s) { return reinterpret_cast<const uint8_t*>(s.data()); }

// A 3 x 2 image with distinct texels (alpha varies too).
ImageRGBA8 smallImage() {
    ImageRGBA8 img;
    img.width = 3;
    img.height = 2;
    for (uint32_t i = 0; i < 6; ++i) {
        img.pixels.insert(img.pixels.end(),
                          {uint8_t(40 * i), uint8_t(255 - 30 * i), uint8_t(7 * i), uint8_t(100 + i)});
    }
    return img;
}

std::string pngBytes(const test::TempDir& dir, const ImageRGBA8& img) {
    const std::string path = dir.file("tmp.png");
    EXPECT_TRUE(writePng(path, img));
    return readFile(path);
}

// The four flat colours of the 8 x 8 quadrants of the 16 x 16 JPEG fixture quadrants.jpg
// (written by tests/assets/make_scene_fixtures.py, an encoder independent of the decoder under test).
const uint8_t kQuadrants[4][3] = {{200, 30, 30}, {30, 200, 30}, {30, 30, 200}, {240, 240, 240}};

std::string jpegPath() { return test::sourcePath("tests/assets/fixtures/scenes/quadrants.jpg"); }
std::string jpegBytes() { return readFile(jpegPath()); }

// Offset of the SOF0/SOF2 segment marker, or npos.
size_t findSof(const std::string& jpeg) {
    for (size_t i = 2; i + 9 < jpeg.size(); ++i) {
        if (uint8_t(jpeg[i]) == 0xFF && (uint8_t(jpeg[i + 1]) == 0xC0 || uint8_t(jpeg[i + 1]) == 0xC2)) {
            return i;
        }
    }
    return std::string::npos;
}

TEST(Texture, DecodesPngFromFileAndMemory) {
    test::TempDir dir;
    const ImageRGBA8 img = smallImage();
    const std::string path = dir.file("small.png");
    ASSERT_TRUE(writePng(path, img));
    TextureData tex;
    std::string error;
    ASSERT_TRUE(loadTexture(path, tex, error)) << error;
    EXPECT_EQ(tex.width, 3u);
    EXPECT_EQ(tex.height, 2u);
    EXPECT_EQ(tex.rgba8, img.pixels);  // lossless: exact
    EXPECT_EQ(tex.sourcePath, path);
    EXPECT_TRUE(tex.srgb);

    const std::string bytes = readFile(path);
    TextureData mem;
    ASSERT_TRUE(decodeTexture(bytesOf(bytes), bytes.size(), "embedded", mem, error)) << error;
    EXPECT_EQ(mem.rgba8, img.pixels);
    EXPECT_EQ(mem.sourcePath, "embedded");
}

TEST(Texture, DecodesJpegByContentNotExtension) {
    test::TempDir dir;
    const std::string jpeg = jpegBytes();
    ASSERT_GT(jpeg.size(), 100u);
    ASSERT_EQ(uint8_t(jpeg[0]), 0xFF);
    const std::string path = dir.write("actually_a_jpeg.png", jpeg);
    TextureData tex;
    std::string error;
    ASSERT_TRUE(loadTexture(path, tex, error)) << error;
    ASSERT_EQ(tex.width, 16u);
    ASSERT_EQ(tex.height, 16u);
    ASSERT_EQ(tex.rgba8.size(), 16u * 16u * 4u);
    // Metric: largest absolute channel difference from the source colours; threshold 6 levels
    // (quantisation 1, flat 8 x 8 blocks: only DC coefficients, colour-conversion rounding only).
    int worst = 0;
    for (int y = 0; y < 16; ++y) {
        for (int x = 0; x < 16; ++x) {
            const uint8_t* c = kQuadrants[(y / 8) * 2 + x / 8];
            const uint8_t* t = &tex.rgba8[size_t(y * 16 + x) * 4];
            for (int k = 0; k < 3; ++k) {
                worst = std::max(worst, std::abs(int(t[k]) - int(c[k])));
            }
            ASSERT_EQ(t[3], 255) << "alpha at " << x << "," << y;
        }
    }
    EXPECT_LE(worst, 6);
}

TEST(Texture, RejectsGarbageAndEmptyAndMissing) {
    test::TempDir dir;
    TextureData tex;
    std::string error;
    const std::string garbage = dir.write("garbage.png", "GIF89a this is not what it claims");
    EXPECT_FALSE(loadTexture(garbage, tex, error));
    EXPECT_NE(error.find(garbage), std::string::npos) << error;
    EXPECT_NE(error.find("neither PNG nor JPEG"), std::string::npos) << error;
    EXPECT_TRUE(tex.rgba8.empty());

    const std::string empty = dir.write("empty.jpg", "");
    EXPECT_FALSE(loadTexture(empty, tex, error));
    EXPECT_NE(error.find("empty"), std::string::npos) << error;

    EXPECT_FALSE(loadTexture(dir.file("missing.png"), tex, error));
    EXPECT_NE(error.find("missing.png"), std::string::npos) << error;
    EXPECT_NE(error.find("cannot open"), std::string::npos) << error;

    EXPECT_FALSE(decodeTexture(nullptr, 0, "nothing", tex, error));
    EXPECT_NE(error.find("nothing: empty image data"), std::string::npos) << error;
}

TEST(Texture, RejectsTruncatedPng) {
    test::TempDir dir;
    const std::string png = pngBytes(dir, smallImage());
    ASSERT_GT(png.size(), 60u);
    TextureData tex;
    std::string error;
    // Cut inside the IHDR chunk.
    EXPECT_FALSE(decodeTexture(bytesOf(png), 20, "cut20.png", tex, error));
    EXPECT_NE(error.find("cut20.png: truncated PNG"), std::string::npos) << error;
    // Cut after the IHDR (inside the image data), and just before the end.
    for (size_t cut : {size_t(40), png.size() - 13}) {
        const std::string name = "cut" + std::to_string(cut) + ".png";
        const std::string path = dir.write(name, png.substr(0, cut));
        EXPECT_FALSE(loadTexture(path, tex, error)) << cut;
        EXPECT_NE(error.find(path), std::string::npos) << error;
        EXPECT_NE(error.find("corrupt PNG"), std::string::npos) << error;
        EXPECT_TRUE(tex.rgba8.empty());
    }
    // Garbage after a valid signature.
    std::string noIhdr = png.substr(0, 8) + std::string(40, 'x');
    EXPECT_FALSE(decodeTexture(bytesOf(noIhdr), noIhdr.size(), "noihdr", tex, error));
    EXPECT_NE(error.find("not a 13-byte IHDR"), std::string::npos) << error;
}

void setBigEndian32(std::string& s, size_t at, uint32_t v) {
    s[at] = char(v >> 24);
    s[at + 1] = char(v >> 16);
    s[at + 2] = char(v >> 8);
    s[at + 3] = char(v);
}

TEST(Texture, RejectsOversizedPngFromTheHeader) {
    test::TempDir dir;
    const std::string png = pngBytes(dir, smallImage());
    TextureData tex;
    std::string error;
    std::string huge = png;
    setBigEndian32(huge, 16, 100000);  // width
    setBigEndian32(huge, 20, 100000);  // height: 10^10 pixels, 40 GB of RGBA
    const std::string path = dir.write("huge.png", huge);
    EXPECT_FALSE(loadTexture(path, tex, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("100000 x 100000 exceed the limit of 16384"), std::string::npos) << error;

    std::string zero = png;
    setBigEndian32(zero, 16, 0);
    EXPECT_FALSE(decodeTexture(bytesOf(zero), zero.size(), "zero.png", tex, error));
    EXPECT_NE(error.find("invalid PNG dimensions 0 x 2"), std::string::npos) << error;

    // The caller's limit applies, not just the decoder's.
    TextureLoadLimits limits;
    limits.maxDimension = 2;
    EXPECT_FALSE(decodeTexture(bytesOf(png), png.size(), "small.png", tex, error, limits));
    EXPECT_NE(error.find("3 x 2 exceed the limit of 2"), std::string::npos) << error;
    limits = {};
    limits.maxFileBytes = 10;
    EXPECT_FALSE(decodeTexture(bytesOf(png), png.size(), "small.png", tex, error, limits));
    EXPECT_NE(error.find("too large"), std::string::npos) << error;
}

TEST(Texture, RejectsBadJpegs) {
    test::TempDir dir;
    const std::string jpeg = jpegBytes();
    TextureData tex;
    std::string error;
    // Header cut short: no frame header at all.
    EXPECT_FALSE(decodeTexture(bytesOf(jpeg), 24, "head.jpg", tex, error));
    EXPECT_NE(error.find("head.jpg: corrupt or truncated JPEG header"), std::string::npos) << error;
    // Cut in the middle of the entropy-coded data.
    const size_t sof = findSof(jpeg);
    ASSERT_NE(sof, std::string::npos);
    const std::string half = jpeg.substr(0, jpeg.size() - 20);
    const std::string path = dir.write("half.jpg", half);
    EXPECT_FALSE(loadTexture(path, tex, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("truncated JPEG"), std::string::npos) << error;
    EXPECT_TRUE(tex.rgba8.empty());
    // Frame header claiming 60000 x 60000.
    std::string huge = jpeg;
    huge[sof + 5] = char(0xEA);  // height 0xEA60 = 60000
    huge[sof + 6] = char(0x60);
    huge[sof + 7] = char(0xEA);  // width
    huge[sof + 8] = char(0x60);
    EXPECT_FALSE(decodeTexture(bytesOf(huge), huge.size(), "huge.jpg", tex, error));
    EXPECT_NE(error.find("JPEG image dimensions 60000 x 60000 exceed the limit"), std::string::npos) << error;
    // Just the magic bytes.
    const std::string magic = "\xFF\xD8\xFF";
    EXPECT_FALSE(decodeTexture(bytesOf(magic), magic.size(), "magic.jpg", tex, error));
    EXPECT_NE(error.find("magic.jpg: corrupt or truncated JPEG header"), std::string::npos) << error;
}

}  // namespace
}  // namespace penumbra::assets
