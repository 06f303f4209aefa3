// Golden-image comparison (rule from shared/design.md "Golden images and parity"):
// exact match first; otherwise pass if per-channel |delta| <= 5/255 for all but <= 0.1 % of pixels
// and no channel of any pixel differs by more than 64/255. Tests may pass a stricter rule.
#pragma once

#include <string>

#include "engine/image/image.h"

namespace penumbra::test {

struct ImageRule {
    int perChannelTolerance = 5;     // /255
    double maxFractionOver = 0.001;  // fraction of pixels allowed above perChannelTolerance
    int hardLimit = 64;              // /255, no pixel may exceed this
};

struct ImageDiff {
    bool sizeMismatch = false;
    bool identical = false;
    int maxDelta = 0;         // largest per-channel |delta| (0..255)
    double meanDelta = 0;     // mean per-channel |delta| (0..255)
    uint64_t pixelsOver = 0;  // pixels with any channel above the tolerance
    double fractionOver = 0;
    bool pass = false;
    ImageRGBA8 diffImage;         // |delta| amplified x8, alpha 255
    std::string summary() const;  // "max 3/255, mean 0.21/255, 0.000% over 5/255"
    std::string json() const;
};

ImageDiff compareImages(const ImageRGBA8& actual, const ImageRGBA8& expected, const ImageRule& rule = {});

// Compares `actual` with tests/golden/<backend>/<name>.png. On failure (or a missing golden) writes
// <build>/golden_out/<backend>/<name>.actual.png, .diff.png and .json, and returns a failure
// message naming them; tools/accept_goldens.sh copies the actuals over the goldens after review.
// Returns an empty string on success.
std::string checkGolden(const std::string& backend, const std::string& name, const ImageRGBA8& actual,
                        const ImageRule& rule = {});

// Vulkan against OpenGL (parity) by `rule`; when they differ beyond it, writes
// <build>/golden_out/parity/<name>.vulkan.png, .gl.png and .diff.png for review.
ImageDiff compareBackends(const std::string& name, const ImageRGBA8& vulkan, const ImageRGBA8& gl,
                          const ImageRule& rule = {});

std::string goldenPath(const std::string& backend, const std::string& name);
std::string goldenOutDir(const std::string& backend);

}  // namespace penumbra::test
