// The .psdf signed-distance asset (format v1, byte layout in docs/FORMATS.md): a fixed 144-byte
// little-endian header with its own CRC32, then the payload (f32, f16 or 8-bit narrow band) with a
// CRC32 of its own. Readers validate every field and the file size before allocating anything and
// reject a bad file with one message naming the file and the field.
//
// Sampling (SdfSampler): trilinear between voxel centres inside the grid; outside it a conservative
// rule that never overestimates the distance given exact samples (derivation in docs/FORMATS.md):
//   q = clamp(p, box of voxel centres), a = |p - q|, s = trilinear(q)
//   mesh bounds inside that box:  d = max(sqrt(a^2 + s^2), distance(p, mesh bounds))
//   otherwise:                    d = max(distance(p, mesh bounds), s - a)   (or s + a if s < -a)
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "engine/sdf/sdf_grid.h"

namespace penumbra::sdf {

inline constexpr uint32_t kPsdfVersion = 1;
inline constexpr size_t kPsdfHeaderBytes = 144;

enum class PsdfEncoding : uint32_t {
    F32 = 0,  // IEEE binary32
    F16 = 1,  // IEEE binary16, round to nearest even, magnitudes clamped to 65504
    U8 = 2,   // narrow band: value = (q / 255 * 2 - 1) * bandWidth, clamped to +-bandWidth
};
const char* toString(PsdfEncoding e);
bool parsePsdfEncoding(const std::string& text, PsdfEncoding& out);
uint32_t bytesPerVoxel(PsdfEncoding e);

// Sign method recorded in flags bits 0..1.
enum class PsdfSign : uint32_t { Winding = 0, Pseudonormal = 1, Parity = 2, Unknown = 3 };
const char* toString(PsdfSign s);

inline constexpr uint32_t kPsdfFlagSignMask = 0x3u;
inline constexpr uint32_t kPsdfFlagClosedManifold = 1u << 2;  // no boundary, no non-manifold edges
inline constexpr uint32_t kPsdfFlagBoundaryEdges = 1u << 3;   // the mesh had boundary edges
inline constexpr uint32_t kPsdfFlagNonManifold = 1u << 4;     // the mesh had non-manifold edges
inline constexpr uint32_t kPsdfKnownFlags = 0x1fu;

struct PsdfHeader {
    uint32_t version = kPsdfVersion;
    glm::uvec3 dims{0, 0, 0};
    glm::dvec3 origin{0, 0, 0};  // minimum corner of voxel (0,0,0), see SdfGrid
    double voxelSize = 0;
    PsdfEncoding encoding = PsdfEncoding::F32;
    uint32_t flags = 0;
    double bandWidth = 0;  // U8 only (> 0, mesh units); 0 for the other encodings
    glm::dvec3 boundsMin{0, 0, 0}, boundsMax{0, 0, 0};  // source mesh bounds (after clean-up)
    float minDistance = 0, maxDistance = 0;             // over the stored (decoded) values
    uint64_t payloadBytes = 0;
    uint32_t payloadCrc = 0;
    uint32_t headerCrc = 0;

    PsdfSign sign() const { return PsdfSign(flags & kPsdfFlagSignMask); }
    uint64_t voxelCount() const { return uint64_t(dims.x) * dims.y * dims.z; }
};

struct PsdfAsset {
    PsdfHeader header;
    SdfGrid grid;  // decoded to float
};

struct PsdfLimits {
    uint64_t maxVoxels = 1ull << 30;  // 1024^3, the baker's own limit (4 GiB decoded)
    uint32_t maxDim = 16384;          // per axis, the baker's own limit
};

struct PsdfWriteOptions {
    PsdfEncoding encoding = PsdfEncoding::F32;
    double bandWidth = 0;  // U8: half-width of the band in mesh units; 0 = 4 voxels
    PsdfSign sign = PsdfSign::Unknown;
    bool closedManifold = false, boundaryEdges = false, nonManifold = false;
    // Source mesh bounds; when min > max (the default) the box of voxel centres is recorded.
    glm::dvec3 boundsMin{1, 1, 1}, boundsMax{0, 0, 0};
};

// Encodes a grid into a complete file image. Fails on an empty/inconsistent grid, non-finite
// distances, origin or voxel size, or an invalid band width.
bool encodePsdf(const SdfGrid& grid, const PsdfWriteOptions& options, std::vector<uint8_t>& out,
                std::string& error);
bool writePsdf(const std::string& path, const SdfGrid& grid, const PsdfWriteOptions& options,
               std::string& error);

// Decodes and validates a file image; `name` is used in messages.
bool decodePsdf(const uint8_t* data, size_t size, const std::string& name, PsdfAsset& out, std::string& error,
                const PsdfLimits& limits = {});
bool readPsdf(const std::string& path, PsdfAsset& out, std::string& error, const PsdfLimits& limits = {});

// Largest difference between a finite distance d and its stored value (see FORMATS.md): 0 for
// F32, |d| * 2^-11 (+ 2^-25 for subnormals) for F16 below 65504, bandWidth / 255 inside the band
// for U8 (outside the band the stored value is +-bandWidth).
double quantisationError(PsdfEncoding e, double distance, double bandWidth);

// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, init and final xor 0xFFFFFFFF), the same
// value as zlib's crc32(). Pass the previous result as `crc` to continue a running checksum.
uint32_t crc32(const void* data, size_t size, uint32_t crc = 0);

uint16_t floatToHalf(float f);
float halfToFloat(uint16_t h);

// Distance queries on a grid in the mesh's own coordinates. Keeps a reference to the grid.
class SdfSampler {
public:
    SdfSampler(const SdfGrid& grid, const glm::dvec3& meshBoundsMin, const glm::dvec3& meshBoundsMax);
    explicit SdfSampler(const PsdfAsset& asset);

    // Trilinear interpolation between voxel centres at p clamped to the box of voxel centres.
    double trilinear(const glm::dvec3& p) const;
    // Trilinear inside the box of voxel centres, the conservative outside rule beyond it.
    double sample(const glm::dvec3& p) const;

    glm::dvec3 sampleBoxMin() const { return m_boxMin; }
    glm::dvec3 sampleBoxMax() const { return m_boxMax; }
    // True when the mesh bounds lie inside the box of voxel centres (the Pythagorean rule applies).
    bool meshInsideSampleBox() const { return m_meshInside; }

private:
    const SdfGrid& m_grid;
    glm::dvec3 m_boxMin, m_boxMax;
    glm::dvec3 m_meshMin, m_meshMax;
    bool m_meshInside = false;
};

}  // namespace penumbra::sdf
