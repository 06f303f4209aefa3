// Error metrics between a test image and a reference image (docs/ACCURACY.md, "Metrics"): used by
// the tests and by the accuracy benchmarks. Float AOV images (reference/pfm.h FloatImage) and RGBA8
// images (engine/image/image.h; RGB channels as value / 255, alpha ignored).
//
//   count    values compared: pixels in the mask times channels
//   rmse     sqrt(mean(e^2)), e = test - reference per channel value
//   meanAbs  mean(|e|)
//   p99Abs   99th percentile of |e|, nearest rank: the ceil(0.99 n)-th smallest of the n values
//   maxAbs   max(|e|)
//   psnr     10 log10(peak^2 / mean(e^2)) in dB; +infinity when the images are equal
//   ssim     mean SSIM (Wang et al. 2004): 11 x 11 Gaussian window, sigma 1.5, K1 = 0.01, K2 = 0.03,
//            L = peak; per channel, over every pixel centre in the mask; at the image borders the
//            window is cut to the image and its weights renormalised; averaged over channels
//
// Silhouette mismatch (depth images): a pixel is hit where its depth is finite and > 0; the rate
// is (pixels hit in one image only) / (pixels hit in either), 0 when neither has a hit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/image/image.h"
#include "reference/pfm.h"

namespace penumbra::reference {

struct ErrorStats {
    size_t count = 0;
    double rmse = 0.0;
    double meanAbs = 0.0;
    double p99Abs = 0.0;
    double maxAbs = 0.0;
    double psnr = 0.0;
    double ssim = 1.0;
};

struct MetricsDesc {
    // One byte per pixel, non-zero = compare it; empty = every pixel.
    std::vector<uint8_t> mask;
    // The dynamic range L of PSNR and SSIM (1 for images in [0, 1]; RGBA8 images use 1 after / 255).
    double peak = 1.0;
};

// False with `error` when the sizes or channel counts differ, the mask has the wrong size, a
// compared value is not finite, or the mask selects no pixel.
bool compareImages(const FloatImage& test, const FloatImage& reference, const MetricsDesc& desc,
                   ErrorStats& out, std::string& error);
bool compareImages(const ImageRGBA8& test, const ImageRGBA8& reference, const MetricsDesc& desc,
                   ErrorStats& out, std::string& error);

// SSIM alone (the definition above); NaN when the sizes differ or the mask selects nothing.
double ssim(const FloatImage& test, const FloatImage& reference, const std::vector<uint8_t>& mask,
            double peak);

struct SilhouetteStats {
    size_t hitA = 0, hitB = 0, hitBoth = 0, hitEither = 0;
    double mismatchRate = 0.0;  // (hitEither - hitBoth) / hitEither
};
// Depth images of the same size (1 channel); false with `error` otherwise.
bool silhouetteMismatch(const FloatImage& depthA, const FloatImage& depthB, SilhouetteStats& out,
                        std::string& error);
// The mask of pixels hit in both depth images (empty when the sizes differ).
std::vector<uint8_t> bothHitMask(const FloatImage& depthA, const FloatImage& depthB);

}  // namespace penumbra::reference
