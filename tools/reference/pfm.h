// PFM (Netpbm "portable float map") images: "PF" (3 channels) or "Pf" (1 channel), then width and
// height, then the scale, whose sign gives the byte order (negative: little-endian), then 32-bit
// floats row by row from the BOTTOM row to the top, as the format defines. In memory, row 0 is the
// top row (like every image of the project); writePfm and readPfm flip.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::reference {

struct FloatImage {
    uint32_t width = 0, height = 0, channels = 1;  // channels: 1 or 3
    std::vector<float> data;                       // width * height * channels, row 0 = top
};

// Writes little-endian PFM (scale -1). False with `error` (naming the file) on failure.
bool writePfm(const std::string& path, uint32_t width, uint32_t height, uint32_t channels, const float* data,
              std::string& error);
inline bool writePfm(const std::string& path, const FloatImage& image, std::string& error) {
    return writePfm(path, image.width, image.height, image.channels, image.data.data(), error);
}
// Reads PF / Pf of either byte order; checks the header and the file size. Sizes above
// 16384 x 16384 are refused.
bool readPfm(const std::string& path, FloatImage& out, std::string& error);

}  // namespace penumbra::reference
