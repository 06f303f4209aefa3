// Texture decoding: the format comes from the magic bytes; the dimensions are read from the header
// (PNG IHDR, JPEG SOF through stb_image's info call) and checked against the limits before any
// texel memory is allocated. PNG goes through libpng (engine/image), JPEG through stb_image
// (third_party/stb/stb_impl.c, JPEG only).
#include "engine/assets/texture.h"

#include <climits>
#include <cstring>
#include <memory>

#include <fmt/format.h>

#include "engine/assets/mesh_internal.h"
#include "engine/image/image.h"

extern "C" {
int penumbra_jpeg_info(const unsigned char* data, int size, int* width, int* height, int* components);
unsigned char* penumbra_jpeg_load_rgba8(const unsigned char* data, int size, int* width, int* height);
void penumbra_jpeg_free(unsigned char* pixels);
const char* penumbra_jpeg_failure_reason(void);
}

namespace penumbra::assets {
namespace {

constexpr uint8_t kPngMagic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
constexpr size_t kPngHeaderBytes = 8 + 8 + 13 + 4;  // signature, IHDR chunk header, data, CRC

uint32_t readBigEndian32(const uint8_t* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

bool fail(std::string& error, const std::string& name, std::string_view why) {
    error = name;
    error.append(": ").append(why);
    return false;
}

bool checkDimensions(const std::string& name, const char* format, uint64_t width, uint64_t height,
                     const TextureLoadLimits& limits, std::string& error) {
    if (width == 0 || height == 0) {
        return fail(error, name, fmt::format("invalid {} dimensions {} x {}", format, width, height));
    }
    if (width > limits.maxDimension || height > limits.maxDimension) {
        return fail(error, name,
                    fmt::format("{} image dimensions {} x {} exceed the limit of {} pixels per side "
                                "(refused before decoding)",
                                format, width, height, limits.maxDimension));
    }
    return true;
}

const char* jpegReason() {
    const char* reason = penumbra_jpeg_failure_reason();
    return reason ? reason : "unknown error";
}

bool decodePng(const uint8_t* data, size_t size, const std::string& name, TextureData& out,
               std::string& error, const TextureLoadLimits& limits) {
    if (size < kPngHeaderBytes) {
        return fail(
            error, name,
            fmt::format("truncated PNG ({} bytes, shorter than the {}-byte header)", size, kPngHeaderBytes));
    }
    if (readBigEndian32(data + 8) != 13 || std::memcmp(data + 12, "IHDR", 4) != 0) {
        return fail(error, name, "corrupt PNG: the first chunk is not a 13-byte IHDR");
    }
    const uint32_t width = readBigEndian32(data + 16);
    const uint32_t height = readBigEndian32(data + 20);
    if (!checkDimensions(name, "PNG", width, height, limits, error)) {
        return false;
    }
    ImageRGBA8 image;
    std::string message;
    if (!readPngMemory(data, size, name, image, &message)) {
        error = message;
        return false;
    }
    out.width = image.width;
    out.height = image.height;
    out.rgba8 = std::move(image.pixels);
    return true;
}

bool hasJpegEnd(const uint8_t* data, size_t size) {
    // Entropy-coded data stuffs every 0xFF with 0x00, so FF D9 only occurs as a marker.
    for (size_t i = size - 1; i >= 3; --i) {
        if (data[i] == 0xD9 && data[i - 1] == 0xFF) {
            return true;
        }
    }
    return false;
}

// Walks the JPEG marker segments up to the frame header (SOFn) and reads the image size from it.
// False with the reason when the segments are malformed or end before a frame header.
bool jpegFrameSize(const uint8_t* data, size_t size, uint32_t& width, uint32_t& height, std::string& why) {
    size_t at = 2;  // after SOI (FF D8)
    while (true) {
        if (at >= size || data[at] != 0xFF) {
            why = at >= size ? "the data ends before the frame header" : "expected a marker";
            return false;
        }
        while (at < size && data[at] == 0xFF) {
            ++at;  // fill bytes
        }
        if (at >= size) {
            why = "the data ends before the frame header";
            return false;
        }
        const uint8_t marker = data[at++];
        if (marker == 0xD9 || marker == 0xDA) {
            why = "no frame header before the image data";
            return false;
        }
        if ((marker >= 0xD0 && marker <= 0xD7) || marker == 0x01) {
            continue;  // standalone markers carry no length
        }
        if (size - at < 2) {
            why = "the data ends inside a segment header";
            return false;
        }
        const size_t length = (size_t(data[at]) << 8) | data[at + 1];
        if (length < 2 || length > size - at) {
            why = fmt::format("segment length {} runs past the end of the data", length);
            return false;
        }
        const bool frame =
            marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
        if (frame) {
            if (length < 8) {
                why = "frame header too short";
                return false;
            }
            height = (uint32_t(data[at + 3]) << 8) | data[at + 4];
            width = (uint32_t(data[at + 5]) << 8) | data[at + 6];
            return true;
        }
        at += length;
    }
}

bool decodeJpeg(const uint8_t* data, size_t size, const std::string& name, TextureData& out,
                std::string& error, const TextureLoadLimits& limits) {
    if (size > size_t(INT_MAX)) {
        return fail(error, name, fmt::format("JPEG too large for the decoder ({} bytes)", size));
    }
    uint32_t frameWidth = 0;
    uint32_t frameHeight = 0;
    std::string why;
    if (!jpegFrameSize(data, size, frameWidth, frameHeight, why)) {
        return fail(error, name, fmt::format("corrupt or truncated JPEG header ({})", why));
    }
    if (!checkDimensions(name, "JPEG", frameWidth, frameHeight, limits, error)) {
        return false;
    }
    int width = 0;
    int height = 0;
    int components = 0;
    if (!penumbra_jpeg_info(data, int(size), &width, &height, &components) || uint32_t(width) != frameWidth ||
        uint32_t(height) != frameHeight) {
        return fail(error, name, fmt::format("corrupt JPEG header ({})", jpegReason()));
    }
    if (!hasJpegEnd(data, size)) {
        return fail(error, name, "truncated JPEG (no end-of-image marker)");
    }
    int w = 0;
    int h = 0;
    std::unique_ptr<unsigned char, void (*)(unsigned char*)> pixels(
        penumbra_jpeg_load_rgba8(data, int(size), &w, &h), &penumbra_jpeg_free);
    if (!pixels) {
        return fail(error, name, fmt::format("corrupt JPEG ({})", jpegReason()));
    }
    if (w != width || h != height) {
        return fail(error, name, "corrupt JPEG (decoded size differs from the header)");
    }
    out.width = uint32_t(w);
    out.height = uint32_t(h);
    out.rgba8.assign(pixels.get(), pixels.get() + size_t(w) * size_t(h) * 4);
    return true;
}

}  // namespace

bool decodeTexture(const uint8_t* data, size_t size, const std::string& name, TextureData& out,
                   std::string& error, const TextureLoadLimits& limits) {
    const bool srgb = out.srgb;
    out = TextureData{};
    out.srgb = srgb;
    if (!data || size == 0) {
        return fail(error, name, "empty image data (0 bytes)");
    }
    if (size > limits.maxFileBytes) {
        return fail(
            error, name,
            fmt::format("image data too large ({} bytes, limit {} bytes)", size, limits.maxFileBytes));
    }
    bool ok = false;
    if (size >= 8 && std::memcmp(data, kPngMagic, 8) == 0) {
        ok = decodePng(data, size, name, out, error, limits);
    } else if (size >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF) {
        ok = decodeJpeg(data, size, name, out, error, limits);
    } else {
        return fail(error, name, "unrecognised image format (by its magic bytes it is neither PNG nor JPEG)");
    }
    if (!ok) {
        out = TextureData{};
        out.srgb = srgb;
        return false;
    }
    out.sourcePath = name;
    return true;
}

bool loadTexture(const std::string& path, TextureData& out, std::string& error,
                 const TextureLoadLimits& limits) {
    detail::FileBytes bytes;
    if (!detail::readWholeFile(path, limits.maxFileBytes, bytes, error)) {
        const bool srgb = out.srgb;
        out = TextureData{};
        out.srgb = srgb;
        return false;
    }
    return decodeTexture(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), path, out, error,
                         limits);
}

}  // namespace penumbra::assets
