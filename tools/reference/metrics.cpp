#include "reference/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace penumbra::reference {
namespace {

bool isHit(float depth) { return std::isfinite(depth) && depth > 0.0f; }

bool checkShapes(const FloatImage& a, const FloatImage& b, const std::vector<uint8_t>& mask,
                 std::string& error) {
    if (a.width != b.width || a.height != b.height || a.channels != b.channels) {
        error = fmt::format("images differ in size: {}x{}x{} against {}x{}x{}", a.width, a.height, a.channels,
                            b.width, b.height, b.channels);
        return false;
    }
    const size_t pixels = size_t(a.width) * a.height;
    if (a.data.size() != pixels * a.channels || b.data.size() != pixels * b.channels) {
        error = "image data does not match its size";
        return false;
    }
    if (!mask.empty() && mask.size() != pixels) {
        error = fmt::format("the mask has {} entries for {} pixels", mask.size(), pixels);
        return false;
    }
    return true;
}

}  // namespace

double ssim(const FloatImage& test, const FloatImage& reference, const std::vector<uint8_t>& mask,
            double peak) {
    std::string error;
    if (!checkShapes(test, reference, mask, error)) return std::numeric_limits<double>::quiet_NaN();
    constexpr int kRadius = 5;  // 11 x 11
    constexpr double kSigma = 1.5;
    double weights[2 * kRadius + 1];
    for (int i = -kRadius; i <= kRadius; ++i)
        weights[i + kRadius] = std::exp(-double(i * i) / (2.0 * kSigma * kSigma));
    const double c1 = (0.01 * peak) * (0.01 * peak), c2 = (0.03 * peak) * (0.03 * peak);
    const int w = int(test.width), h = int(test.height), ch = int(test.channels);
    double sum = 0.0;
    size_t count = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!mask.empty() && !mask[size_t(y) * w + x]) continue;
            for (int c = 0; c < ch; ++c) {
                double ws = 0, mx = 0, my = 0, xx = 0, yy = 0, xy = 0;
                for (int dy = -kRadius; dy <= kRadius; ++dy) {
                    const int yy0 = y + dy;
                    if (yy0 < 0 || yy0 >= h) continue;
                    for (int dx = -kRadius; dx <= kRadius; ++dx) {
                        const int xx0 = x + dx;
                        if (xx0 < 0 || xx0 >= w) continue;
                        const double wt = weights[dy + kRadius] * weights[dx + kRadius];
                        const size_t i = (size_t(yy0) * w + xx0) * ch + c;
                        const double a = test.data[i], b = reference.data[i];
                        ws += wt;
                        mx += wt * a;
                        my += wt * b;
                        xx += wt * a * a;
                        yy += wt * b * b;
                        xy += wt * a * b;
                    }
                }
                mx /= ws;
                my /= ws;
                const double vx = std::max(0.0, xx / ws - mx * mx), vy = std::max(0.0, yy / ws - my * my);
                const double cxy = xy / ws - mx * my;
                sum += ((2 * mx * my + c1) * (2 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
                ++count;
            }
        }
    return count ? sum / double(count) : std::numeric_limits<double>::quiet_NaN();
}

bool compareImages(const FloatImage& test, const FloatImage& reference, const MetricsDesc& desc,
                   ErrorStats& out, std::string& error) {
    if (!checkShapes(test, reference, desc.mask, error)) return false;
    if (!(desc.peak > 0.0)) {
        error = fmt::format("the peak value {} must be > 0", desc.peak);
        return false;
    }
    const size_t pixels = size_t(test.width) * test.height;
    std::vector<double> abs;
    abs.reserve(pixels * test.channels);
    double sq = 0.0;
    for (size_t p = 0; p < pixels; ++p) {
        if (!desc.mask.empty() && !desc.mask[p]) continue;
        for (uint32_t c = 0; c < test.channels; ++c) {
            const double a = test.data[p * test.channels + c], b = reference.data[p * test.channels + c];
            if (!std::isfinite(a) || !std::isfinite(b)) {
                error = fmt::format("pixel ({}, {}) channel {} is not finite ({} against {})", p % test.width,
                                    p / test.width, c, a, b);
                return false;
            }
            const double e = a - b;
            sq += e * e;
            abs.push_back(std::abs(e));
        }
    }
    if (abs.empty()) {
        error = "the mask selects no pixel";
        return false;
    }
    out = {};
    out.count = abs.size();
    const double mse = sq / double(abs.size());
    out.rmse = std::sqrt(mse);
    double sumAbs = 0.0;
    for (double v : abs) sumAbs += v;
    out.meanAbs = sumAbs / double(abs.size());
    const size_t rank = size_t(std::ceil(0.99 * double(abs.size())));  // 1-based nearest rank
    std::nth_element(abs.begin(), abs.begin() + (rank - 1), abs.end());
    out.p99Abs = abs[rank - 1];
    out.maxAbs = *std::max_element(abs.begin(), abs.end());
    out.psnr =
        mse > 0.0 ? 10.0 * std::log10(desc.peak * desc.peak / mse) : std::numeric_limits<double>::infinity();
    out.ssim = ssim(test, reference, desc.mask, desc.peak);
    return true;
}

bool compareImages(const ImageRGBA8& test, const ImageRGBA8& reference, const MetricsDesc& desc,
                   ErrorStats& out, std::string& error) {
    auto toFloat = [](const ImageRGBA8& img) {
        FloatImage f;
        f.width = img.width;
        f.height = img.height;
        f.channels = 3;
        const size_t pixels = size_t(img.width) * img.height;
        f.data.resize(pixels * 3);
        for (size_t p = 0; p < pixels && p * 4 + 3 < img.pixels.size(); ++p)
            for (int c = 0; c < 3; ++c) f.data[p * 3 + c] = float(img.pixels[p * 4 + c]) / 255.0f;
        return f;
    };
    if (test.pixels.size() != size_t(test.width) * test.height * 4 ||
        reference.pixels.size() != size_t(reference.width) * reference.height * 4) {
        error = "RGBA8 image data does not match its size";
        return false;
    }
    return compareImages(toFloat(test), toFloat(reference), desc, out, error);
}

bool silhouetteMismatch(const FloatImage& depthA, const FloatImage& depthB, SilhouetteStats& out,
                        std::string& error) {
    if (!checkShapes(depthA, depthB, {}, error)) return false;
    if (depthA.channels != 1) {
        error = "depth images have one channel";
        return false;
    }
    out = {};
    for (size_t i = 0; i < depthA.data.size(); ++i) {
        const bool a = isHit(depthA.data[i]), b = isHit(depthB.data[i]);
        out.hitA += a;
        out.hitB += b;
        out.hitBoth += a && b;
        out.hitEither += a || b;
    }
    out.mismatchRate = out.hitEither ? double(out.hitEither - out.hitBoth) / double(out.hitEither) : 0.0;
    return true;
}

std::vector<uint8_t> bothHitMask(const FloatImage& depthA, const FloatImage& depthB) {
    if (depthA.data.size() != depthB.data.size() || depthA.channels != 1 || depthB.channels != 1) return {};
    std::vector<uint8_t> mask(depthA.data.size());
    for (size_t i = 0; i < mask.size(); ++i) mask[i] = isHit(depthA.data[i]) && isHit(depthB.data[i]);
    return mask;
}

}  // namespace penumbra::reference
