#include "reference/pfm.h"

#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace penumbra::reference {
namespace {

uint32_t byteSwap(uint32_t v) {
    return (v >> 24) | ((v >> 8) & 0xFF00u) | ((v << 8) & 0xFF0000u) | (v << 24);
}

}  // namespace

bool writePfm(const std::string& path, uint32_t width, uint32_t height, uint32_t channels, const float* data,
              std::string& error) {
    if (width == 0 || height == 0 || (channels != 1 && channels != 3)) {
        error = fmt::format("{}: cannot write a {}x{} PFM with {} channel(s)", path, width, height, channels);
        return false;
    }
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) {
        error = fmt::format("cannot write {}: {}", path, std::strerror(errno));
        return false;
    }
    const std::string header = fmt::format("{}\n{} {}\n-1.0\n", channels == 3 ? "PF" : "Pf", width, height);
    bool ok = std::fwrite(header.data(), 1, header.size(), f) == header.size();
    const size_t rowFloats = size_t(width) * channels;
    std::vector<uint32_t> row(rowFloats);
    for (uint32_t y = height; ok && y-- > 0;) {  // bottom row first
        std::memcpy(row.data(), data + size_t(y) * rowFloats, rowFloats * 4);
        if constexpr (std::endian::native == std::endian::big)
            for (uint32_t& v : row) v = byteSwap(v);
        ok = std::fwrite(row.data(), 4, rowFloats, f) == rowFloats;
    }
    ok = std::fclose(f) == 0 && ok;
    if (!ok) error = fmt::format("cannot write {}: {}", path, std::strerror(errno));
    return ok;
}

bool readPfm(const std::string& path, FloatImage& out, std::string& error) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        error = fmt::format("cannot read {}: {}", path, std::strerror(errno));
        return false;
    }
    std::string magic;
    long long w = 0, h = 0;
    double scale = 0.0;
    in >> magic >> w >> h >> scale;
    if (!in || (magic != "PF" && magic != "Pf") || w <= 0 || h <= 0 || w > 16384 || h > 16384 ||
        scale == 0.0 || !std::isfinite(scale)) {
        error = fmt::format("{}: not a PFM file (expected 'PF' or 'Pf', width, height and a non-zero scale)",
                            path);
        return false;
    }
    in.get();  // the single whitespace character after the scale
    const uint32_t channels = magic == "PF" ? 3 : 1;
    const size_t count = size_t(w) * size_t(h) * channels;
    std::vector<uint32_t> raw(count);
    in.read(reinterpret_cast<char*>(raw.data()), std::streamsize(count * 4));
    if (size_t(in.gcount()) != count * 4) {
        error = fmt::format("{}: truncated: {} of {} bytes of pixel data", path, in.gcount(), count * 4);
        return false;
    }
    const bool fileLittle = scale < 0.0;
    if (fileLittle != (std::endian::native == std::endian::little))
        for (uint32_t& v : raw) v = byteSwap(v);
    out.width = uint32_t(w);
    out.height = uint32_t(h);
    out.channels = channels;
    out.data.resize(count);
    const size_t rowFloats = size_t(w) * channels;
    for (size_t y = 0; y < size_t(h); ++y)  // file row 0 is the bottom
        std::memcpy(out.data.data() + (size_t(h) - 1 - y) * rowFloats, raw.data() + y * rowFloats,
                    rowFloats * 4);
    return true;
}

}  // namespace penumbra::reference
