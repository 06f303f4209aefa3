// 8-bit RGBA images and PNG I/O (libpng reads untrusted files with limits; stb writes).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra {

struct ImageRGBA8 {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> pixels;  // width * height * 4, row 0 = top

    bool empty() const { return width == 0 || height == 0; }
    const uint8_t* at(uint32_t x, uint32_t y) const { return &pixels[(size_t(y) * width + x) * 4]; }
};

// Writes an 8-bit RGBA PNG; creates missing parent directories. Returns false and sets `error`.
bool writePng(const std::string& path, const ImageRGBA8& image, std::string* error = nullptr);

// Largest image readPng accepts (pixels), to refuse decompression bombs.
inline constexpr uint64_t kMaxPngPixels = 16384ull * 16384ull;

// Reads any PNG (palette, grey, 16-bit, alpha or not) as 8-bit RGBA. Returns false and sets
// `error` (naming the file and the reason) on a missing, truncated, corrupt or oversized file.
bool readPng(const std::string& path, ImageRGBA8& out, std::string* error = nullptr);

// The same from memory (e.g. an image embedded in a glTF file); `name` starts the error message.
// Data ending before the image does is reported as truncated.
bool readPngMemory(const uint8_t* data, size_t size, const std::string& name, ImageRGBA8& out,
                   std::string* error = nullptr);

}  // namespace penumbra
