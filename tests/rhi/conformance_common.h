// Shared helpers of the cross-backend RHI conformance tests (tests/rhi/conformance_*_test.cpp):
// a fixture that tracks and destroys what a test creates, deterministic random numbers, half-float
// and sRGB conversions, CPU texture-filtering references and raster helpers. Everything here is
// written against the public RHI API only.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rhi/device.h"
#include "support/test_device.h"

namespace penumbra::conformance {

// ---------------------------------------------------------------------------------------------
// Deterministic pseudo-random numbers (xorshift32): identical sequences on every platform.
// ---------------------------------------------------------------------------------------------
class Rng {
public:
    explicit Rng(uint32_t seed) : m_state(seed != 0 ? seed : 0x9e3779b9u) {}
    uint32_t next() {
        m_state ^= m_state << 13;
        m_state ^= m_state >> 17;
        m_state ^= m_state << 5;
        return m_state;
    }
    // Uniform in [0, 1) with 24 bits of resolution (exactly representable as float).
    float unit() { return float(next() >> 8) * (1.0f / 16777216.0f); }
    // Uniform in [lo, hi).
    float range(float lo, float hi) { return lo + (hi - lo) * unit(); }

private:
    uint32_t m_state;
};

// ---------------------------------------------------------------------------------------------
// IEEE 754 binary16 conversions (round to nearest even), for RGBA16F / R16F data.
// ---------------------------------------------------------------------------------------------
inline uint16_t floatToHalf(float f) {
    uint32_t x;
    std::memcpy(&x, &f, 4);
    const uint32_t sign = (x >> 16) & 0x8000u;
    const uint32_t mag = x & 0x7fffffffu;
    if (mag >= 0x7f800000u) return uint16_t(sign | 0x7c00u | (mag > 0x7f800000u ? 0x200u : 0u));
    if (mag >= 0x477ff000u) return uint16_t(sign | 0x7c00u);  // rounds to >= 65520: infinity
    if (mag < 0x38800000u) {                                  // half subnormal or zero
        if (mag < 0x33000000u) return uint16_t(sign);         // below half of the smallest subnormal
        const uint32_t e = mag >> 23;
        const uint32_t m = (mag & 0x7fffffu) | 0x800000u;
        const uint32_t shift = 126u - e;
        uint32_t q = m >> shift;
        const uint32_t rem = m & ((1u << shift) - 1u);
        const uint32_t halfway = 1u << (shift - 1u);
        if (rem > halfway || (rem == halfway && (q & 1u))) ++q;
        return uint16_t(sign | q);
    }
    uint32_t h = (mag + 0xfffu + ((mag >> 13) & 1u)) >> 13;
    h -= 112u << 10;
    return uint16_t(sign | h);
}

inline float halfToFloat(uint16_t h) {
    const uint32_t sign = uint32_t(h & 0x8000u) << 16;
    const uint32_t e = (h >> 10) & 0x1fu;
    const uint32_t m = h & 0x3ffu;
    if (e == 0) {
        const float v = std::ldexp(float(m), -24);
        return sign ? -v : v;
    }
    const uint32_t bits =
        e == 31 ? (sign | 0x7f800000u | (m << 13)) : (sign | ((e + 112u) << 23) | (m << 13));
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
}

// Linear -> sRGB transfer function (IEC 61966-2-1), in [0, 1].
inline double srgbEncode(double linear) {
    if (linear <= 0.0031308) return 12.92 * linear;
    return 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

// Float in [0,1] -> UNORM8 as the graphics APIs define it (round to nearest).
inline int toUnorm8(double v) { return int(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); }

// ---------------------------------------------------------------------------------------------
// CPU sampling references (Vulkan/GL conventions: texel centres at (i + 0.5) / N).
// ---------------------------------------------------------------------------------------------
inline int wrapIndex(int i, int n, rhi::AddressMode mode) {
    switch (mode) {
        case rhi::AddressMode::ClampToEdge:
            return std::clamp(i, 0, n - 1);
        case rhi::AddressMode::Repeat:
            return ((i % n) + n) % n;
        case rhi::AddressMode::MirroredRepeat: {
            const int t = ((i % (2 * n)) + 2 * n) % (2 * n);
            return t < n ? t : 2 * n - 1 - t;
        }
    }
    return 0;
}

// Texels stored as floats, `channels` per texel, x fastest, then y, then z.
struct CpuVolume {
    int width = 1, height = 1, depth = 1, channels = 1;
    std::vector<float> texels;
    float at(int x, int y, int z, int c) const {
        return texels[((size_t(z) * height + y) * width + x) * channels + c];
    }
};

// Linear filtering along every axis that has more than one texel (depth == 1: bilinear).
inline double sampleLinear(const CpuVolume& v, double u, double t, double w, int c, rhi::AddressMode mode) {
    auto axis = [mode](double coord, int n, int& i0, int& i1, double& f) {
        const double x = coord * n - 0.5;
        const double fl = std::floor(x);
        f = x - fl;
        i0 = wrapIndex(int(fl), n, mode);
        i1 = wrapIndex(int(fl) + 1, n, mode);
    };
    int x0, x1, y0, y1, z0 = 0, z1 = 0;
    double fx, fy, fz = 0.0;
    axis(u, v.width, x0, x1, fx);
    axis(t, v.height, y0, y1, fy);
    if (v.depth > 1) axis(w, v.depth, z0, z1, fz);
    auto lerp = [](double a, double b, double f) { return a + (b - a) * f; };
    auto plane = [&](int z) {
        return lerp(lerp(v.at(x0, y0, z, c), v.at(x1, y0, z, c), fx),
                    lerp(v.at(x0, y1, z, c), v.at(x1, y1, z, c), fx), fy);
    };
    return lerp(plane(z0), plane(z1), fz);
}

inline double sampleNearest2D(const CpuVolume& v, double u, double t, int c, rhi::AddressMode mode) {
    const int x = wrapIndex(int(std::floor(u * v.width)), v.width, mode);
    const int y = wrapIndex(int(std::floor(t * v.height)), v.height, mode);
    return v.at(x, y, 0, c);
}

// ---------------------------------------------------------------------------------------------
// Raster helpers. Pixel (x, y) of a W x H target has its centre at NDC
// ((x + 0.5) * 2 / W - 1, (y + 0.5) * 2 / H - 1); image row 0 is NDC y = -1 on both backends.
// ---------------------------------------------------------------------------------------------
inline float ndcX(uint32_t px, uint32_t width) { return 2.0f * float(px) / float(width) - 1.0f; }
inline float ndcY(uint32_t py, uint32_t height) { return 2.0f * float(py) / float(height) - 1.0f; }

// Push constants of the conf_rect* programs (conf_rect_vs.glsl / conf_rect_push.glsl).
struct RectPush {
    float rect[4] = {-1, -1, 1, 1};    // x0, y0, x1, y1 in NDC
    float color[4] = {0, 0, 0, 0};     // fragment colour
    float depth[4] = {0.5f, 0, 0, 0};  // x: clip z, y: fragment depth offset, z: extra value
};
static_assert(sizeof(RectPush) == 48);

inline std::array<uint8_t, 4> pixelRgba8(const std::vector<uint8_t>& image, uint32_t width, uint32_t x,
                                         uint32_t y) {
    const size_t i = (size_t(y) * width + x) * 4;
    return {image[i], image[i + 1], image[i + 2], image[i + 3]};
}

inline float pixelFloat(const std::vector<uint8_t>& image, uint32_t width, uint32_t x, uint32_t y) {
    float f;
    std::memcpy(&f, image.data() + (size_t(y) * width + x) * 4, 4);
    return f;
}

// Coverage of a pixel centre by a triangle given in NDC: 1 inside, 0 outside, -1 when the centre is
// within `marginPx` pixels of an edge (rasterisation rules may go either way there).
inline int triangleCoverage(const float (&tri)[3][2], uint32_t px, uint32_t py, uint32_t width,
                            uint32_t height, double marginPx = 0.75) {
    double p[3][2];
    for (int i = 0; i < 3; ++i) {
        p[i][0] = (tri[i][0] + 1.0) * 0.5 * width;
        p[i][1] = (tri[i][1] + 1.0) * 0.5 * height;
    }
    const double cx = px + 0.5, cy = py + 0.5;
    const double area = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
    const double orient = area > 0 ? 1.0 : -1.0;
    bool inside = true;
    for (int i = 0; i < 3; ++i) {
        const double* a = p[i];
        const double* b = p[(i + 1) % 3];
        const double ex = b[0] - a[0], ey = b[1] - a[1];
        const double dist = orient * (ex * (cy - a[1]) - ey * (cx - a[0])) / std::sqrt(ex * ex + ey * ey);
        if (dist < -marginPx) return 0;
        if (dist <= marginPx) inside = false;
    }
    return inside ? 1 : -1;
}

// ---------------------------------------------------------------------------------------------
// Fixture: a validated device (from GpuTest) plus creation helpers whose objects are destroyed
// at the end of the test, before GpuTest checks for validation errors.
// ---------------------------------------------------------------------------------------------
class ConformanceTest : public test::GpuTest {
protected:
    void TearDown() override {
        if (m_device) {
            for (auto it = m_cleanup.rbegin(); it != m_cleanup.rend(); ++it) (*it)();
        }
        m_cleanup.clear();
        GpuTest::TearDown();
    }

    template <typename H>
    H track(H h) {
        if (h.isValid()) {
            m_cleanup.push_back([this, h] {
                if (m_device->isAlive(h)) m_device->destroy(h);
            });
        }
        return h;
    }

    rhi::BufferHandle makeBuffer(uint64_t size, rhi::BufferUsage usage,
                                 rhi::MemoryType memory = rhi::MemoryType::GpuOnly,
                                 const void* initialData = nullptr, std::string name = "conf buffer") {
        rhi::BufferDesc desc;
        desc.size = size;
        desc.usage = usage;
        desc.memory = memory;
        desc.debugName = std::move(name);
        return track(dev().createBuffer(desc, initialData));
    }
    template <typename T>
    rhi::BufferHandle makeBufferFrom(const std::vector<T>& data, rhi::BufferUsage usage,
                                     rhi::MemoryType memory = rhi::MemoryType::GpuOnly) {
        return makeBuffer(data.size() * sizeof(T), usage, memory, data.data());
    }

    rhi::TextureHandle makeTexture(const rhi::TextureDesc& desc) { return track(dev().createTexture(desc)); }
    rhi::TextureHandle makeTexture2D(rhi::Format format, uint32_t width, uint32_t height,
                                     rhi::TextureUsage usage, uint32_t mipLevels = 1) {
        rhi::TextureDesc desc;
        desc.dimension = rhi::TextureDimension::Tex2D;
        desc.format = format;
        desc.width = width;
        desc.height = height;
        desc.mipLevels = mipLevels;
        desc.usage = usage;
        desc.debugName = "conf texture";
        return makeTexture(desc);
    }
    rhi::TextureHandle makeColorTarget(uint32_t width, uint32_t height,
                                       rhi::Format format = rhi::Format::RGBA8_UNORM) {
        return makeTexture2D(format, width, height,
                             rhi::TextureUsage::ColorTarget | rhi::TextureUsage::CopySrc);
    }
    rhi::TextureHandle makeDepthTarget(uint32_t width, uint32_t height) {
        return makeTexture2D(rhi::Format::D32_FLOAT, width, height,
                             rhi::TextureUsage::DepthTarget | rhi::TextureUsage::CopySrc);
    }

    rhi::SamplerHandle makeSampler(rhi::Filter filter, rhi::AddressMode address) {
        rhi::SamplerDesc desc;
        desc.minFilter = filter;
        desc.magFilter = filter;
        desc.mipFilter = rhi::Filter::Nearest;
        desc.addressU = desc.addressV = desc.addressW = address;
        desc.debugName = "conf sampler";
        return track(dev().createSampler(desc));
    }

    rhi::ShaderHandle makeShader(const rhi::ShaderDesc& desc) { return track(dev().createShader(desc)); }

    rhi::PipelineHandle makeComputePipeline(const rhi::ShaderDesc& cs) {
        rhi::ComputePipelineDesc desc;
        desc.shader = makeShader(cs);
        desc.debugName = std::string(cs.debugName);
        EXPECT_TRUE(desc.shader.isValid()) << "compute shader creation failed";
        return track(dev().createComputePipeline(desc));
    }

    rhi::PipelineHandle makeGraphicsPipeline(rhi::GraphicsPipelineDesc desc, const rhi::ShaderDesc& vs,
                                             const rhi::ShaderDesc& fs) {
        desc.vertexShader = makeShader(vs);
        desc.fragmentShader = makeShader(fs);
        EXPECT_TRUE(desc.vertexShader.isValid()) << "vertex shader creation failed";
        EXPECT_TRUE(desc.fragmentShader.isValid()) << "fragment shader creation failed";
        if (desc.debugName.empty()) desc.debugName = std::string(vs.debugName);
        return track(dev().createGraphicsPipeline(desc));
    }

    rhi::BindGroupHandle makeBindGroup(rhi::PipelineHandle pipeline, uint32_t set,
                                       std::vector<rhi::BindGroupEntry> entries) {
        rhi::BindGroupDesc desc;
        desc.pipeline = pipeline;
        desc.set = set;
        desc.entries = std::move(entries);
        desc.debugName = "conf bind group";
        return track(dev().createBindGroup(desc));
    }

    rhi::QueryPoolHandle makeQueryPool(uint32_t count) {
        rhi::QueryPoolDesc desc;
        desc.count = count;
        desc.debugName = "conf timestamps";
        return track(dev().createQueryPool(desc));
    }

    template <typename T>
    std::vector<T> readBuffer(rhi::BufferHandle buffer, size_t count, uint64_t offsetBytes = 0) {
        std::vector<T> out(count);
        EXPECT_TRUE(dev().readBuffer(buffer, offsetBytes, count * sizeof(T), out.data()))
            << "readBuffer failed";
        return out;
    }

    std::vector<uint8_t> readTexture(rhi::TextureHandle texture, rhi::TextureSubresource sub,
                                     rhi::Access currentAccess) {
        std::vector<uint8_t> out;
        EXPECT_TRUE(dev().readTexture(texture, sub, currentAccess, out)) << "readTexture failed";
        return out;
    }
    template <typename T>
    std::vector<T> readTextureAs(rhi::TextureHandle texture, rhi::TextureSubresource sub,
                                 rhi::Access currentAccess) {
        const std::vector<uint8_t> bytes = readTexture(texture, sub, currentAccess);
        std::vector<T> out(bytes.size() / sizeof(T));
        if (!out.empty()) std::memcpy(out.data(), bytes.data(), out.size() * sizeof(T));
        return out;
    }

    void submitAndWait(rhi::CommandList& cmd) {
        const uint64_t serial = dev().submit(cmd);
        dev().waitForSubmission(serial);
    }

    // Viewport and scissor covering the whole target (both are dynamic state: set in every pass).
    static void setFullViewport(rhi::CommandList& cmd, uint32_t width, uint32_t height) {
        rhi::Viewport vp;
        vp.width = float(width);
        vp.height = float(height);
        cmd.setViewport(vp);
        rhi::Rect scissor;
        scissor.width = width;
        scissor.height = height;
        cmd.setScissor(scissor);
    }

    static void pushRect(rhi::CommandList& cmd, const RectPush& push) {
        cmd.pushConstants(&push, sizeof(push));
    }

private:
    std::vector<std::function<void()>> m_cleanup;
};

}  // namespace penumbra::conformance
