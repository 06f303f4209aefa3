// Textures as RGBA8 texel arrays, decoded from PNG (libpng, engine/image) or JPEG (stb_image),
// with the malformed-asset limits of shared/design.md: whole-file cap, pixel cap checked from the
// header before any allocation, one clear message naming the file and the reason.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::assets {

struct TextureData {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> rgba8;  // width * height * 4, row 0 = top (image order)
    bool srgb = true;            // colour data (base colour, emissive) vs linear data
    std::string sourcePath;
};

struct TextureLoadLimits {
    uint64_t maxFileBytes = 256ull << 20;
    uint32_t maxDimension = 16384;
};

// By content (magic bytes), not extension: PNG or JPEG. False with `error` on anything else.
bool loadTexture(const std::string& path, TextureData& out, std::string& error,
                 const TextureLoadLimits& limits = {});
// The same from memory (glTF data: URIs and GLB buffer views); `name` is used in messages.
bool decodeTexture(const uint8_t* data, size_t size, const std::string& name, TextureData& out,
                   std::string& error, const TextureLoadLimits& limits = {});

}  // namespace penumbra::assets
