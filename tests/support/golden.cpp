#include "support/golden.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

namespace penumbra::test {

std::string ImageDiff::summary() const {
    if (sizeMismatch) return "image sizes differ";
    return fmt::format("max {}/255, mean {:.4f}/255, {} px ({:.4f} %) over tolerance", maxDelta, meanDelta,
                       pixelsOver, fractionOver * 100.0);
}

std::string ImageDiff::json() const {
    return fmt::format(
        "{{\"size_mismatch\": {}, \"identical\": {}, \"max_delta\": {}, \"mean_delta\": {:.6f}, "
        "\"pixels_over\": {}, \"fraction_over\": {:.8f}, \"pass\": {}}}\n",
        sizeMismatch, identical, maxDelta, meanDelta, pixelsOver, fractionOver, pass);
}

ImageDiff compareImages(const ImageRGBA8& a, const ImageRGBA8& b, const ImageRule& rule) {
    ImageDiff d;
    if (a.width != b.width || a.height != b.height || a.pixels.size() != b.pixels.size()) {
        d.sizeMismatch = true;
        return d;
    }
    d.identical = a.pixels == b.pixels;
    d.diffImage.width = a.width;
    d.diffImage.height = a.height;
    d.diffImage.pixels.assign(a.pixels.size(), 0);
    uint64_t sum = 0;
    const size_t n = size_t(a.width) * a.height;
    for (size_t p = 0; p < n; ++p) {
        int pixelMax = 0;
        for (int c = 0; c < 4; ++c) {
            int delta = std::abs(int(a.pixels[p * 4 + c]) - int(b.pixels[p * 4 + c]));
            sum += uint64_t(delta);
            pixelMax = std::max(pixelMax, delta);
            d.diffImage.pixels[p * 4 + c] = c == 3 ? 255 : uint8_t(std::min(255, delta * 8));
        }
        d.maxDelta = std::max(d.maxDelta, pixelMax);
        if (pixelMax > rule.perChannelTolerance) ++d.pixelsOver;
    }
    d.meanDelta = n ? double(sum) / double(n * 4) : 0.0;
    d.fractionOver = n ? double(d.pixelsOver) / double(n) : 0.0;
    d.pass = d.identical || (d.fractionOver <= rule.maxFractionOver && d.maxDelta <= rule.hardLimit);
    return d;
}

std::string goldenPath(const std::string& backend, const std::string& name) {
    return std::string(PENUMBRA_SOURCE_DIR) + "/tests/golden/" + backend + "/" + name + ".png";
}

std::string goldenOutDir(const std::string& backend) {
    return std::string(PENUMBRA_BINARY_DIR) + "/golden_out/" + backend;
}

ImageDiff compareBackends(const std::string& name, const ImageRGBA8& vulkan, const ImageRGBA8& gl,
                          const ImageRule& rule) {
    ImageDiff d = compareImages(vulkan, gl, rule);
    if (!d.pass) {
        const std::string dir = goldenOutDir("parity");
        std::filesystem::create_directories(dir);
        writePng(dir + "/" + name + ".vulkan.png", vulkan);
        writePng(dir + "/" + name + ".gl.png", gl);
        if (!d.sizeMismatch) writePng(dir + "/" + name + ".diff.png", d.diffImage);
    }
    return d;
}

std::string checkGolden(const std::string& backend, const std::string& name, const ImageRGBA8& actual,
                        const ImageRule& rule) {
    const std::string outDir = goldenOutDir(backend);
    std::filesystem::create_directories(outDir);
    const std::string actualPath = outDir + "/" + name + ".actual.png";
    // Remove stale outputs of an earlier failing run so accept_goldens only sees this run's.
    std::filesystem::remove(actualPath);
    std::filesystem::remove(outDir + "/" + name + ".diff.png");
    std::filesystem::remove(outDir + "/" + name + ".json");

    ImageRGBA8 golden;
    std::string err;
    if (!readPng(goldenPath(backend, name), golden, &err)) {
        writePng(actualPath, actual);
        return "no usable golden (" + err + "); actual written to " + actualPath +
               " — review it and run tools/accept_goldens.sh";
    }
    ImageDiff d = compareImages(actual, golden, rule);
    if (d.pass) return {};
    writePng(actualPath, actual);
    if (!d.sizeMismatch) writePng(outDir + "/" + name + ".diff.png", d.diffImage);
    std::ofstream(outDir + "/" + name + ".json") << d.json();
    return "golden mismatch for " + backend + "/" + name + ": " + d.summary() +
           "; actual, diff and json in " + outDir;
}

}  // namespace penumbra::test
