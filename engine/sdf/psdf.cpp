#include "engine/sdf/psdf.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>

#include <fmt/format.h>
#include <glm/geometric.hpp>

namespace penumbra::sdf {

namespace {

// ---- CRC-32, slicing by 8 ----------------------------------------------------------------------

constexpr std::array<std::array<uint32_t, 256>, 8> makeCrcTables() {
    std::array<std::array<uint32_t, 256>, 8> t{};
    for (uint32_t i = 0; i < 256; ++i) {
        uint32_t c = i;
        for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
        t[0][i] = c;
    }
    for (uint32_t i = 0; i < 256; ++i)
        for (size_t s = 1; s < 8; ++s) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xffu];
    return t;
}
constexpr auto kCrcTables = makeCrcTables();

// ---- little-endian field access ------------------------------------------------------------------

void putU32(uint8_t* p, uint32_t v) {
    for (int i = 0; i < 4; ++i) p[i] = uint8_t(v >> (8 * i));
}
void putU64(uint8_t* p, uint64_t v) {
    for (int i = 0; i < 8; ++i) p[i] = uint8_t(v >> (8 * i));
}
void putF32(uint8_t* p, float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    putU32(p, bits);
}
void putF64(uint8_t* p, double v) {
    uint64_t bits;
    std::memcpy(&bits, &v, 8);
    putU64(p, bits);
}
uint32_t getU32(const uint8_t* p) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(p[i]) << (8 * i);
    return v;
}
uint64_t getU64(const uint8_t* p) {
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= uint64_t(p[i]) << (8 * i);
    return v;
}
float getF32(const uint8_t* p) {
    uint32_t bits = getU32(p);
    float v;
    std::memcpy(&v, &bits, 4);
    return v;
}
double getF64(const uint8_t* p) {
    uint64_t bits = getU64(p);
    double v;
    std::memcpy(&v, &bits, 8);
    return v;
}

// Header byte offsets (docs/FORMATS.md).
enum Offset : size_t {
    kOffMagic = 0,
    kOffVersion = 4,
    kOffDims = 8,
    kOffEncoding = 20,
    kOffOrigin = 24,
    kOffVoxelSize = 48,
    kOffFlags = 56,
    kOffReserved = 60,
    kOffBandWidth = 64,
    kOffBoundsMin = 72,
    kOffBoundsMax = 96,
    kOffMinDistance = 120,
    kOffMaxDistance = 124,
    kOffPayloadBytes = 128,
    kOffPayloadCrc = 136,
    kOffHeaderCrc = 140,
};
static_assert(kOffHeaderCrc + 4 == kPsdfHeaderBytes);

constexpr uint8_t kMagic[4] = {'P', 'S', 'D', 'F'};
constexpr float kHalfMax = 65504.0f;

bool finite3(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

uint8_t quantiseU8(float d, double bandWidth) {
    const double t = std::clamp(double(d) / bandWidth, -1.0, 1.0);
    const double q = std::nearbyint((t + 1.0) * 127.5);
    return uint8_t(std::clamp(q, 0.0, 255.0));
}
float dequantiseU8(uint8_t q, double bandWidth) { return float((double(q) / 255.0 * 2.0 - 1.0) * bandWidth); }

std::string fmtVec(const glm::dvec3& v) { return fmt::format("({}, {}, {})", v.x, v.y, v.z); }

// Euclidean length without overflow or underflow in the squares (glm::length squares: it gives
// inf from about 1.3e154 on); inf only when the length itself exceeds the largest double.
double length3(const glm::dvec3& v) { return std::hypot(v.x, v.y, v.z); }

double distanceToBox(const glm::dvec3& p, const glm::dvec3& lo, const glm::dvec3& hi) {
    return length3(glm::max(glm::max(lo - p, p - hi), glm::dvec3(0.0)));
}

// Why dims x voxelSize is outside the range of gridRangeRepresentable (sdf_grid.h), naming fields.
std::string rangeProblem(const glm::uvec3& dims, double voxelSize) {
    if (!(voxelSize >= kMinVoxelSize))
        return fmt::format("field 'voxelSize' is {}: below the smallest normal 32-bit float ({})", voxelSize,
                           kMinVoxelSize);
    return fmt::format(
        "fields 'voxelSize' {} and 'dims' {} x {} x {}: the grid's diagonal {} exceeds the largest 32-bit "
        "float "
        "({})",
        voxelSize, dims.x, dims.y, dims.z, gridDiagonal(dims, voxelSize), kMaxGridDiagonal);
}

}  // namespace

const char* toString(PsdfEncoding e) {
    switch (e) {
        case PsdfEncoding::F32:
            return "f32";
        case PsdfEncoding::F16:
            return "f16";
        case PsdfEncoding::U8:
            return "u8";
    }
    return "unknown";
}

bool parsePsdfEncoding(const std::string& text, PsdfEncoding& out) {
    if (text == "f32")
        out = PsdfEncoding::F32;
    else if (text == "f16")
        out = PsdfEncoding::F16;
    else if (text == "u8")
        out = PsdfEncoding::U8;
    else
        return false;
    return true;
}

uint32_t bytesPerVoxel(PsdfEncoding e) {
    switch (e) {
        case PsdfEncoding::F32:
            return 4;
        case PsdfEncoding::F16:
            return 2;
        case PsdfEncoding::U8:
            return 1;
    }
    return 0;
}

const char* toString(PsdfSign s) {
    switch (s) {
        case PsdfSign::Winding:
            return "winding";
        case PsdfSign::Pseudonormal:
            return "pseudonormal";
        case PsdfSign::Parity:
            return "parity";
        case PsdfSign::Unknown:
            return "unknown";
    }
    return "unknown";
}

uint32_t crc32(const void* data, size_t size, uint32_t crc) {
    const uint8_t* p = static_cast<const uint8_t*>(data);
    uint32_t c = ~crc;
    while (size >= 8) {
        const uint32_t lo =
            c ^ (uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24);
        c = kCrcTables[7][lo & 0xff] ^ kCrcTables[6][(lo >> 8) & 0xff] ^ kCrcTables[5][(lo >> 16) & 0xff] ^
            kCrcTables[4][lo >> 24] ^ kCrcTables[3][p[4]] ^ kCrcTables[2][p[5]] ^ kCrcTables[1][p[6]] ^
            kCrcTables[0][p[7]];
        p += 8;
        size -= 8;
    }
    while (size-- > 0) c = kCrcTables[0][(c ^ *p++) & 0xff] ^ (c >> 8);
    return ~c;
}

uint16_t floatToHalf(float f) {
    uint32_t x;
    std::memcpy(&x, &f, 4);
    const uint32_t sign = (x >> 16) & 0x8000u;
    const uint32_t absx = x & 0x7fffffffu;
    if (absx >= 0x7f800000u) return uint16_t(sign | (absx > 0x7f800000u ? 0x7e00u : 0x7c00u));
    if (absx >= 0x477ff000u) return uint16_t(sign | 0x7c00u);  // >= 65520 rounds to infinity
    if (absx <= 0x33000000u) return uint16_t(sign);            // <= 2^-25 rounds (to even) to zero
    const uint32_t exp = absx >> 23;
    if (exp < 113) {
        // Half subnormal: units of 2^-24. value = mant * 2^(exp - 150) -> mant >> (126 - exp).
        const uint32_t mant = (absx & 0x7fffffu) | 0x800000u;
        const uint32_t shift = 126 - exp;
        uint32_t h = mant >> shift;
        const uint32_t rem = mant & ((1u << shift) - 1u), halfway = 1u << (shift - 1);
        if (rem > halfway || (rem == halfway && (h & 1u))) ++h;
        return uint16_t(sign | h);
    }
    uint32_t h = ((exp - 112) << 10) + ((absx & 0x7fffffu) >> 13);
    const uint32_t rem = absx & 0x1fffu;
    if (rem > 0x1000u || (rem == 0x1000u && (h & 1u))) ++h;  // a carry moves into the exponent
    return uint16_t(sign | h);
}

float halfToFloat(uint16_t h) {
    const uint32_t sign = uint32_t(h & 0x8000u) << 16;
    const uint32_t exp = (h >> 10) & 0x1fu;
    const uint32_t mant = h & 0x3ffu;
    uint32_t bits;
    if (exp == 0) {
        const float v = std::ldexp(float(mant), -24);
        return sign ? -v : v;
    }
    if (exp == 31)
        bits = sign | 0x7f800000u | (mant << 13);
    else
        bits = sign | ((exp + 112) << 23) | (mant << 13);
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
}

double quantisationError(PsdfEncoding e, double distance, double bandWidth) {
    const double a = std::fabs(distance);
    switch (e) {
        case PsdfEncoding::F32:
            return 0.0;
        case PsdfEncoding::F16:
            if (a > kHalfMax) return a - kHalfMax;
            return a * std::ldexp(1.0, -11) + std::ldexp(1.0, -25);
        case PsdfEncoding::U8:
            if (a > bandWidth) return a - bandWidth;
            return bandWidth / 255.0;
    }
    return 0.0;
}

// ---- writer ------------------------------------------------------------------------------------

bool encodePsdf(const SdfGrid& grid, const PsdfWriteOptions& options, std::vector<uint8_t>& out,
                std::string& error) {
    const PsdfLimits limits;
    if (grid.dims.x > limits.maxDim || grid.dims.y > limits.maxDim || grid.dims.z > limits.maxDim ||
        uint64_t(grid.dims.x) * grid.dims.y * grid.dims.z > limits.maxVoxels) {
        error = fmt::format(
            "cannot write an SDF with dims {} x {} x {}: readers accept at most {} per axis and {} voxels",
            grid.dims.x, grid.dims.y, grid.dims.z, limits.maxDim, limits.maxVoxels);
        return false;
    }
    const uint64_t voxels = uint64_t(grid.dims.x) * grid.dims.y * grid.dims.z;
    if (grid.dims.x == 0 || grid.dims.y == 0 || grid.dims.z == 0) {
        error =
            fmt::format("cannot write an SDF with dims {} x {} x {}", grid.dims.x, grid.dims.y, grid.dims.z);
        return false;
    }
    if (grid.distances.size() != voxels) {
        error = fmt::format("SDF grid has {} values for dims {} x {} x {} ({} voxels)", grid.distances.size(),
                            grid.dims.x, grid.dims.y, grid.dims.z, voxels);
        return false;
    }
    if (!finite3(grid.origin) || !std::isfinite(grid.voxelSize) || !(grid.voxelSize > 0)) {
        error = fmt::format("SDF grid origin {} / voxel size {} must be finite and the voxel size > 0",
                            fmtVec(grid.origin), grid.voxelSize);
        return false;
    }
    if (!gridRangeRepresentable(grid.dims, grid.voxelSize)) {
        error = fmt::format("cannot write an SDF grid whose distances cannot be represented: {}",
                            rangeProblem(grid.dims, grid.voxelSize));
        return false;
    }
    const PsdfEncoding enc = options.encoding;
    const uint32_t bpv = bytesPerVoxel(enc);
    if (bpv == 0) {
        error = fmt::format("unknown .psdf encoding {}", uint32_t(enc));
        return false;
    }
    double band = 0;
    if (enc == PsdfEncoding::U8) {
        band = options.bandWidth == 0 ? 4.0 * grid.voxelSize : options.bandWidth;
        if (!std::isfinite(band) || !(band > 0) || !(band <= kMaxGridDiagonal)) {
            error = fmt::format("u8 band width {} must be finite, > 0 and at most the largest 32-bit float",
                                band);
            return false;
        }
    }
    glm::dvec3 bmin = options.boundsMin, bmax = options.boundsMax;
    if (bmin.x > bmax.x || bmin.y > bmax.y || bmin.z > bmax.z) {
        bmin = grid.origin + 0.5 * grid.voxelSize;
        bmax = grid.origin + (glm::dvec3(grid.dims) - 0.5) * grid.voxelSize;
    }
    if (!finite3(bmin) || !finite3(bmax)) {
        error = "source mesh bounds must be finite";
        return false;
    }

    const uint64_t payloadBytes = voxels * bpv;
    out.assign(kPsdfHeaderBytes + payloadBytes, 0);
    uint8_t* payload = out.data() + kPsdfHeaderBytes;
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (uint64_t i = 0; i < voxels; ++i) {
        const float d = grid.distances[i];
        if (!std::isfinite(d)) {
            error = fmt::format("SDF value {} at voxel index {} is not finite", d, i);
            out.clear();
            return false;
        }
        float stored = d;
        switch (enc) {
            case PsdfEncoding::F32:
                putF32(payload + 4 * i, d);
                break;
            case PsdfEncoding::F16: {
                const uint16_t h = floatToHalf(std::clamp(d, -kHalfMax, kHalfMax));
                payload[2 * i] = uint8_t(h);
                payload[2 * i + 1] = uint8_t(h >> 8);
                stored = halfToFloat(h);
                break;
            }
            case PsdfEncoding::U8: {
                const uint8_t q = quantiseU8(d, band);
                payload[i] = q;
                stored = dequantiseU8(q, band);
                break;
            }
        }
        lo = std::min(lo, stored);
        hi = std::max(hi, stored);
    }

    uint8_t* h = out.data();
    std::memcpy(h + kOffMagic, kMagic, 4);
    putU32(h + kOffVersion, kPsdfVersion);
    putU32(h + kOffDims, grid.dims.x);
    putU32(h + kOffDims + 4, grid.dims.y);
    putU32(h + kOffDims + 8, grid.dims.z);
    putU32(h + kOffEncoding, uint32_t(enc));
    for (int a = 0; a < 3; ++a) putF64(h + kOffOrigin + 8 * a, grid.origin[a]);
    putF64(h + kOffVoxelSize, grid.voxelSize);
    uint32_t flags = uint32_t(options.sign) & kPsdfFlagSignMask;
    if (options.closedManifold) flags |= kPsdfFlagClosedManifold;
    if (options.boundaryEdges) flags |= kPsdfFlagBoundaryEdges;
    if (options.nonManifold) flags |= kPsdfFlagNonManifold;
    putU32(h + kOffFlags, flags);
    putU32(h + kOffReserved, 0);
    putF64(h + kOffBandWidth, band);
    for (int a = 0; a < 3; ++a) {
        putF64(h + kOffBoundsMin + 8 * a, bmin[a]);
        putF64(h + kOffBoundsMax + 8 * a, bmax[a]);
    }
    putF32(h + kOffMinDistance, lo);
    putF32(h + kOffMaxDistance, hi);
    putU64(h + kOffPayloadBytes, payloadBytes);
    putU32(h + kOffPayloadCrc, crc32(payload, payloadBytes));
    putU32(h + kOffHeaderCrc, crc32(h, kOffHeaderCrc));
    return true;
}

bool writePsdf(const std::string& path, const SdfGrid& grid, const PsdfWriteOptions& options,
               std::string& error) {
    std::vector<uint8_t> bytes;
    if (!encodePsdf(grid, options, bytes, error)) {
        error = fmt::format("{}: {}", path, error);
        return false;
    }
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) {
        error = fmt::format("{}: cannot open for writing: {}", path, std::strerror(errno));
        return false;
    }
    const size_t written = std::fwrite(bytes.data(), 1, bytes.size(), f);
    const bool closed = std::fclose(f) == 0;
    if (written != bytes.size() || !closed) {
        error = fmt::format("{}: write failed after {} of {} bytes", path, written, bytes.size());
        std::remove(path.c_str());
        return false;
    }
    return true;
}

// ---- reader ------------------------------------------------------------------------------------

namespace {

// Validates the header (the first min(size, 144) bytes of `data`) against the total file size.
bool parseHeader(const uint8_t* data, size_t size, uint64_t fileSize, const std::string& name, PsdfHeader& hd,
                 std::string& error, const PsdfLimits& limits) {
    auto fail = [&](const std::string& msg) {
        error = fmt::format("{}: {}", name, msg);
        return false;
    };
    if (fileSize == 0) return fail("file is empty (0 bytes); not a .psdf file");
    if (size < 4 || std::memcmp(data, kMagic, 4) != 0) {
        std::string got;
        for (size_t i = 0; i < std::min<size_t>(size, 4); ++i)
            got += (data[i] >= 0x20 && data[i] < 0x7f) ? char(data[i]) : '?';
        return fail(fmt::format("bad magic '{}' (expected 'PSDF'); not a .psdf file", got));
    }
    if (size >= 8 && getU32(data + kOffVersion) != kPsdfVersion)
        return fail(fmt::format("unsupported version {} (this reader supports version {})",
                                getU32(data + kOffVersion), kPsdfVersion));
    if (size < kPsdfHeaderBytes)
        return fail(fmt::format("truncated header: file has {} bytes, the v{} header needs {}", fileSize,
                                kPsdfVersion, kPsdfHeaderBytes));
    hd.version = getU32(data + kOffVersion);
    hd.headerCrc = getU32(data + kOffHeaderCrc);
    const uint32_t headerCrc = crc32(data, kOffHeaderCrc);
    if (headerCrc != hd.headerCrc)
        return fail(
            fmt::format("header CRC mismatch (stored 0x{:08x}, computed 0x{:08x}): the header is corrupt",
                        hd.headerCrc, headerCrc));

    hd.dims = {getU32(data + kOffDims), getU32(data + kOffDims + 4), getU32(data + kOffDims + 8)};
    hd.encoding = PsdfEncoding(getU32(data + kOffEncoding));
    for (int a = 0; a < 3; ++a) {
        hd.origin[a] = getF64(data + kOffOrigin + 8 * a);
        hd.boundsMin[a] = getF64(data + kOffBoundsMin + 8 * a);
        hd.boundsMax[a] = getF64(data + kOffBoundsMax + 8 * a);
    }
    hd.voxelSize = getF64(data + kOffVoxelSize);
    hd.flags = getU32(data + kOffFlags);
    const uint32_t reserved = getU32(data + kOffReserved);
    hd.bandWidth = getF64(data + kOffBandWidth);
    hd.minDistance = getF32(data + kOffMinDistance);
    hd.maxDistance = getF32(data + kOffMaxDistance);
    hd.payloadBytes = getU64(data + kOffPayloadBytes);
    hd.payloadCrc = getU32(data + kOffPayloadCrc);

    const std::string dimsText = fmt::format("{} x {} x {}", hd.dims.x, hd.dims.y, hd.dims.z);
    if (hd.dims.x == 0 || hd.dims.y == 0 || hd.dims.z == 0)
        return fail(fmt::format("field 'dims' is {}: every dimension must be at least 1", dimsText));
    if (hd.dims.x > limits.maxDim || hd.dims.y > limits.maxDim || hd.dims.z > limits.maxDim)
        return fail(
            fmt::format("field 'dims' is {}: a dimension exceeds the limit of {}", dimsText, limits.maxDim));
    // Overflow-safe voxel count: each step checks against the cap by division.
    uint64_t voxels = hd.dims.x;
    for (uint32_t d : {hd.dims.y, hd.dims.z}) {
        if (voxels > limits.maxVoxels / d)
            return fail(fmt::format("field 'dims' is {}: the voxel count exceeds the limit of {} voxels",
                                    dimsText, limits.maxVoxels));
        voxels *= d;
    }
    if (!finite3(hd.origin)) return fail(fmt::format("field 'origin' {} is not finite", fmtVec(hd.origin)));
    if (!std::isfinite(hd.voxelSize) || !(hd.voxelSize > 0))
        return fail(fmt::format("field 'voxelSize' is {}: it must be finite and > 0", hd.voxelSize));
    if (!finite3(hd.origin + glm::dvec3(hd.dims) * hd.voxelSize))
        return fail(fmt::format("fields 'origin' {} and 'voxelSize' {}: the grid's far corner is not finite",
                                fmtVec(hd.origin), hd.voxelSize));
    if (!gridRangeRepresentable(hd.dims, hd.voxelSize))
        return fail(fmt::format("{}: the grid's distances cannot be represented",
                                rangeProblem(hd.dims, hd.voxelSize)));
    const uint32_t bpv = bytesPerVoxel(hd.encoding);
    if (bpv == 0)
        return fail(
            fmt::format("field 'encoding' is {}: unknown (0 = f32, 1 = f16, 2 = u8)", uint32_t(hd.encoding)));
    if (hd.flags & ~kPsdfKnownFlags)
        return fail(fmt::format("field 'flags' is 0x{:08x}: unknown bits 0x{:08x} set", hd.flags,
                                hd.flags & ~kPsdfKnownFlags));
    if ((hd.flags & kPsdfFlagClosedManifold) && (hd.flags & (kPsdfFlagBoundaryEdges | kPsdfFlagNonManifold)))
        return fail(
            fmt::format("field 'flags' is 0x{:08x}: 'closed manifold' contradicts the edge flags", hd.flags));
    if (reserved != 0) return fail(fmt::format("field 'reserved' is {}: it must be 0", reserved));
    if (hd.encoding == PsdfEncoding::U8) {
        if (!std::isfinite(hd.bandWidth) || !(hd.bandWidth > 0))
            return fail(fmt::format("field 'bandWidth' is {}: the u8 encoding needs a finite band width > 0",
                                    hd.bandWidth));
        if (!(hd.bandWidth <= kMaxGridDiagonal))
            return fail(fmt::format(
                "field 'bandWidth' is {}: it exceeds the largest 32-bit float ({}), so the band's distances "
                "cannot be represented",
                hd.bandWidth, kMaxGridDiagonal));
    } else if (hd.bandWidth != 0) {
        return fail(fmt::format("field 'bandWidth' is {}: it must be 0 for encoding {}", hd.bandWidth,
                                toString(hd.encoding)));
    }
    if (!finite3(hd.boundsMin) || !finite3(hd.boundsMax) || hd.boundsMin.x > hd.boundsMax.x ||
        hd.boundsMin.y > hd.boundsMax.y || hd.boundsMin.z > hd.boundsMax.z)
        return fail(
            fmt::format("fields 'boundsMin' {} / 'boundsMax' {}: bounds must be finite with min <= max",
                        fmtVec(hd.boundsMin), fmtVec(hd.boundsMax)));
    if (!std::isfinite(hd.minDistance) || !std::isfinite(hd.maxDistance) || hd.minDistance > hd.maxDistance)
        return fail(fmt::format("fields 'minDistance' {} / 'maxDistance' {}: must be finite with min <= max",
                                hd.minDistance, hd.maxDistance));
    const uint64_t expectedPayload = voxels * bpv;  // voxels <= maxVoxels: no overflow
    if (hd.payloadBytes != expectedPayload)
        return fail(fmt::format("field 'payloadBytes' is {}, but dims {} with encoding {} need {} bytes",
                                hd.payloadBytes, dimsText, toString(hd.encoding), expectedPayload));
    const uint64_t available = fileSize - kPsdfHeaderBytes;
    if (available < expectedPayload)
        return fail(
            fmt::format("truncated payload: {} of {} payload bytes present", available, expectedPayload));
    if (available > expectedPayload)
        return fail(fmt::format("file size {} bytes: {} unexpected bytes after the {}-byte payload", fileSize,
                                available - expectedPayload, expectedPayload));
    return true;
}

// Checks the CRC and decodes a payload of exactly hd.payloadBytes bytes.
bool decodePayload(const uint8_t* payload, const PsdfHeader& hd, const std::string& name, PsdfAsset& out,
                   std::string& error) {
    auto fail = [&](const std::string& msg) {
        error = fmt::format("{}: {}", name, msg);
        return false;
    };
    const uint32_t payloadCrc = crc32(payload, hd.payloadBytes);
    if (payloadCrc != hd.payloadCrc)
        return fail(
            fmt::format("payload CRC mismatch (stored 0x{:08x}, computed 0x{:08x}): the data is corrupt",
                        hd.payloadCrc, payloadCrc));
    const uint64_t voxels = hd.voxelCount();
    SdfGrid grid;
    grid.dims = hd.dims;
    grid.origin = hd.origin;
    grid.voxelSize = hd.voxelSize;
    grid.distances.resize(voxels);
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (uint64_t i = 0; i < voxels; ++i) {
        float d = 0;
        switch (hd.encoding) {
            case PsdfEncoding::F32:
                d = getF32(payload + 4 * i);
                break;
            case PsdfEncoding::F16:
                d = halfToFloat(uint16_t(payload[2 * i] | (payload[2 * i + 1] << 8)));
                break;
            case PsdfEncoding::U8:
                d = dequantiseU8(payload[i], hd.bandWidth);
                break;
        }
        if (!std::isfinite(d)) {
            const uint64_t x = i % hd.dims.x, y = (i / hd.dims.x) % hd.dims.y;
            const uint64_t z = i / (uint64_t(hd.dims.x) * hd.dims.y);
            return fail(fmt::format("payload value at voxel ({}, {}, {}) is not finite", x, y, z));
        }
        grid.distances[i] = d;
        lo = std::min(lo, d);
        hi = std::max(hi, d);
    }
    if (lo != hd.minDistance || hi != hd.maxDistance)
        return fail(
            fmt::format("fields 'minDistance' {} / 'maxDistance' {} disagree with the payload ({} / {})",
                        hd.minDistance, hd.maxDistance, lo, hi));
    out.header = hd;
    out.grid = std::move(grid);
    return true;
}

}  // namespace

bool decodePsdf(const uint8_t* data, size_t size, const std::string& name, PsdfAsset& out, std::string& error,
                const PsdfLimits& limits) {
    PsdfHeader hd;
    if (!parseHeader(data, std::min(size, kPsdfHeaderBytes), size, name, hd, error, limits)) return false;
    return decodePayload(data + kPsdfHeaderBytes, hd, name, out, error);
}

bool readPsdf(const std::string& path, PsdfAsset& out, std::string& error, const PsdfLimits& limits) {
    std::error_code ec;
    if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec)) {
        error = fmt::format("{}: not a regular file", path);
        return false;
    }
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) {
        error = fmt::format("{}: cannot open: {}", path, std::strerror(errno));
        return false;
    }
    struct Closer {
        std::FILE* f;
        ~Closer() { std::fclose(f); }
    } closer{f};
    long end = -1;
    if (std::fseek(f, 0, SEEK_END) != 0 || (end = std::ftell(f)) < 0 || std::fseek(f, 0, SEEK_SET) != 0) {
        error = fmt::format("{}: cannot determine the file size (not a regular file?)", path);
        return false;
    }
    const uint64_t fileSize = uint64_t(end);
    // The header is validated against the file size first, so a huge declared payload in a tiny
    // file is rejected before anything is allocated for it.
    uint8_t header[kPsdfHeaderBytes];
    const size_t headerRead = std::fread(header, 1, kPsdfHeaderBytes, f);
    PsdfHeader hd;
    if (!parseHeader(header, headerRead, fileSize, path, hd, error, limits)) return false;
    std::vector<uint8_t> payload(size_t(hd.payloadBytes));
    if (std::fread(payload.data(), 1, payload.size(), f) != payload.size()) {
        error = fmt::format("{}: read error in the payload", path);
        return false;
    }
    return decodePayload(payload.data(), hd, path, out, error);
}

// ---- sampling ----------------------------------------------------------------------------------

SdfSampler::SdfSampler(const SdfGrid& grid, const glm::dvec3& meshBoundsMin, const glm::dvec3& meshBoundsMax)
    : m_grid(grid), m_meshMin(meshBoundsMin), m_meshMax(meshBoundsMax) {
    m_boxMin = grid.origin + 0.5 * grid.voxelSize;
    m_boxMax = grid.origin + (glm::dvec3(grid.dims) - 0.5) * grid.voxelSize;
    m_meshInside = glm::all(glm::greaterThanEqual(m_meshMin, m_boxMin)) &&
                   glm::all(glm::lessThanEqual(m_meshMax, m_boxMax));
}

SdfSampler::SdfSampler(const PsdfAsset& asset)
    : SdfSampler(asset.grid, asset.header.boundsMin, asset.header.boundsMax) {}

double SdfSampler::trilinear(const glm::dvec3& p) const {
    const SdfGrid& g = m_grid;
    if (g.empty()) return 0.0;
    uint32_t i0[3], i1[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
        const double n = double(g.dims[a]);
        double x = (p[a] - g.origin[a]) / g.voxelSize - 0.5;
        if (!(x > 0)) x = 0;  // also catches NaN
        if (x > n - 1) x = n - 1;
        double base = std::floor(x);
        if (base > n - 2) base = std::max(n - 2, 0.0);
        i0[a] = uint32_t(base);
        i1[a] = std::min<uint32_t>(i0[a] + 1, g.dims[a] - 1);
        t[a] = x - base;
    }
    auto at = [&](uint32_t i, uint32_t j, uint32_t k) { return double(g.distances[g.index(i, j, k)]); };
    const double c00 = at(i0[0], i0[1], i0[2]) * (1 - t[0]) + at(i1[0], i0[1], i0[2]) * t[0];
    const double c10 = at(i0[0], i1[1], i0[2]) * (1 - t[0]) + at(i1[0], i1[1], i0[2]) * t[0];
    const double c01 = at(i0[0], i0[1], i1[2]) * (1 - t[0]) + at(i1[0], i0[1], i1[2]) * t[0];
    const double c11 = at(i0[0], i1[1], i1[2]) * (1 - t[0]) + at(i1[0], i1[1], i1[2]) * t[0];
    const double c0 = c00 * (1 - t[1]) + c10 * t[1];
    const double c1 = c01 * (1 - t[1]) + c11 * t[1];
    return c0 * (1 - t[2]) + c1 * t[2];
}

double SdfSampler::sample(const glm::dvec3& p) const {
    const glm::dvec3 q = glm::clamp(p, m_boxMin, m_boxMax);
    const double a = length3(p - q);
    const double s = trilinear(q);
    if (!(a > 0)) return s;
    const double toMesh = distanceToBox(p, m_meshMin, m_meshMax);
    if (m_meshInside) return std::max(std::hypot(a, s), toMesh);
    if (toMesh > 0) return std::max(toMesh, s - a);
    if (s >= a) return s - a;
    if (s <= -a) return s + a;
    return 0.0;
}

}  // namespace penumbra::sdf
