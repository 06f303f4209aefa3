#include "renderer/features/sdf_atlas.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <functional>
#include <tuple>

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/vector_relational.hpp>

#include "engine/core/log.h"

namespace penumbra::render {

namespace {

constexpr uint32_t kMinAtlasSize = 16;              // texels per axis of the smallest atlas
constexpr uint64_t kClearChunkBytes = 16ull << 20;  // zero-fill uploads of at most this size

// Atlas sizes are multiples of kAtlasGranule texels per axis (tight for one field: a 128 x 66 x 84
// field takes 128 x 72 x 88 texels, where powers of two would take 128 x 128 x 128).
constexpr uint32_t kAtlasGranule = 8;
uint32_t roundUpGranule(uint32_t v) { return (v + kAtlasGranule - 1) / kAtlasGranule * kAtlasGranule; }

uint64_t volume(const glm::uvec3& s) { return uint64_t(s.x) * s.y * s.z; }

// Why the asset cannot be placed in an atlas (empty when it can).
std::string checkAsset(assets::AssetId id, const sdf::PsdfAsset* asset) {
    if (!asset) return fmt::format("field asset {}: no data (null PsdfAsset)", id);
    const sdf::SdfGrid& g = asset->grid;
    if (g.dims.x == 0 || g.dims.y == 0 || g.dims.z == 0)
        return fmt::format("field asset {}: empty grid ({}x{}x{} voxels)", id, g.dims.x, g.dims.y, g.dims.z);
    if (g.distances.size() != volume(g.dims))
        return fmt::format("field asset {}: {} distances for {}x{}x{} voxels", id, g.distances.size(),
                           g.dims.x, g.dims.y, g.dims.z);
    if (!(g.voxelSize > 0) || !std::isfinite(g.voxelSize))
        return fmt::format("field asset {}: voxel size {} is not positive and finite", id, g.voxelSize);
    return {};
}

}  // namespace

uint16_t toHalfTowardNegative(double v) {
    if (std::isnan(v) || v == 0.0) return 0;
    if (v >= 65504.0) return 0x7bff;
    if (v <= -65504.0) return 0xfbff;
    const bool negative = v < 0;
    const double m = std::fabs(v);
    int e = 0;
    std::frexp(m, &e);  // m = f * 2^e, f in [0.5, 1): m in [2^(e-1), 2^e)
    const int exponent = e - 1;
    // Step between halves at this magnitude: 2^-24 for subnormals, else 2^(exponent - 10).
    const int stepExp = exponent < -14 ? -24 : exponent - 10;
    const double q = std::ldexp(m, -stepExp);  // exact (a power-of-two scaling)
    // Toward -infinity: down in magnitude for positive values, up in magnitude for negative ones.
    const uint32_t n = uint32_t(negative ? std::ceil(q) : std::floor(q));
    uint32_t bits = 0;
    if (exponent < -14) {
        bits = n;  // subnormal; n == 1024 is the encoding of the smallest normal 2^-14 as well
    } else {
        // n in [1024, 2048]; 2048 carries into the next exponent by itself.
        bits = (uint32_t(exponent + 15) << 10) + (n - 1024);
    }
    return uint16_t((negative ? 0x8000u : 0u) | bits);
}

float toFloatTowardNegative(double v) {
    if (std::isnan(v)) return 0.0f;
    if (v >= double(FLT_MAX)) return FLT_MAX;
    if (v <= -double(FLT_MAX)) return -FLT_MAX;
    float f = float(v);
    if (double(f) > v) f = std::nextafter(f, -FLT_MAX);
    return f;
}

SdfAtlas::SdfAtlas(rhi::Device& device) : m_device(device) {}

SdfAtlas::~SdfAtlas() {
    if (m_texture.isValid()) m_device.destroy(m_texture);
}

uint32_t SdfAtlas::slotOf(assets::AssetId id) const {
    const auto it = m_resident.find(id);
    return it == m_resident.end() ? UINT32_MAX : it->second.slot;
}

uint64_t SdfAtlas::bytes() const {
    if (!m_texture.isValid()) return 0;
    rhi::TextureDesc d;
    d.dimension = rhi::TextureDimension::Tex3D;
    d.format = m_format;
    d.width = m_size.x;
    d.height = m_size.y;
    d.depthOrLayers = m_size.z;
    return rhi::textureBytes(d);
}

double SdfAtlas::fill() const {
    const uint64_t texels = volume(m_size);
    return texels == 0 ? 0.0 : double(m_residentVoxels) / double(texels);
}

bool SdfAtlas::chooseFormat(std::string& error) {
    if (m_format != rhi::Format::Undefined) return true;
    const rhi::FormatSupport need = rhi::FormatSupport::Sampled | rhi::FormatSupport::Filterable;
    for (rhi::Format f : {rhi::Format::R16_FLOAT, rhi::Format::R32_FLOAT}) {
        if ((m_device.formatSupport(f) & need) == need) {
            m_format = f;
            if (f != rhi::Format::R16_FLOAT)
                log::info("sdf atlas: R16_FLOAT is not filterable on this device; using R32_FLOAT");
            return true;
        }
    }
    error = "sdf atlas: the device can sample and filter neither R16_FLOAT nor R32_FLOAT textures";
    return false;
}

// Best fit by volume (ties: lowest z, y, x), then a guillotine split of the rest into three boxes.
bool SdfAtlas::allocate(std::vector<Box>& freeBoxes, const glm::uvec3& size, Box& out) {
    size_t best = SIZE_MAX;
    for (size_t i = 0; i < freeBoxes.size(); ++i) {
        const Box& f = freeBoxes[i];
        if (f.size.x < size.x || f.size.y < size.y || f.size.z < size.z) continue;
        if (best == SIZE_MAX) {
            best = i;
            continue;
        }
        const Box& b = freeBoxes[best];
        const uint64_t vf = volume(f.size), vb = volume(b.size);
        if (vf < vb ||
            (vf == vb && std::tie(f.pos.z, f.pos.y, f.pos.x) < std::tie(b.pos.z, b.pos.y, b.pos.x)))
            best = i;
    }
    if (best == SIZE_MAX) return false;
    const Box f = freeBoxes[best];
    freeBoxes.erase(freeBoxes.begin() + std::ptrdiff_t(best));
    out.pos = f.pos;
    out.size = size;
    const Box parts[3] = {
        {{f.pos.x + size.x, f.pos.y, f.pos.z}, {f.size.x - size.x, size.y, size.z}},
        {{f.pos.x, f.pos.y + size.y, f.pos.z}, {f.size.x, f.size.y - size.y, size.z}},
        {{f.pos.x, f.pos.y, f.pos.z + size.z}, {f.size.x, f.size.y, f.size.z - size.z}},
    };
    for (const Box& p : parts)
        if (volume(p.size) > 0) freeBoxes.push_back(p);
    return true;
}

// Returns the box to the free list and merges free boxes that share a whole face, until none do.
void SdfAtlas::release(std::vector<Box>& freeBoxes, const Box& box) {
    freeBoxes.push_back(box);
    bool merged = true;
    while (merged) {
        merged = false;
        for (size_t i = 0; i < freeBoxes.size() && !merged; ++i) {
            for (size_t j = 0; j < freeBoxes.size() && !merged; ++j) {
                if (i == j) continue;
                const Box& a = freeBoxes[i];
                const Box& b = freeBoxes[j];
                for (int axis = 0; axis < 3; ++axis) {
                    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
                    if (a.pos[u] != b.pos[u] || a.size[u] != b.size[u] || a.pos[v] != b.pos[v] ||
                        a.size[v] != b.size[v] || a.pos[axis] + a.size[axis] != b.pos[axis])
                        continue;
                    Box m = a;
                    m.size[axis] += b.size[axis];
                    freeBoxes[i] = m;
                    freeBoxes.erase(freeBoxes.begin() + std::ptrdiff_t(j));
                    merged = true;
                    break;
                }
            }
        }
    }
}

GpuSdfField SdfAtlas::describe(const Box& box, const sdf::PsdfAsset& asset) const {
    const sdf::SdfGrid& g = asset.grid;
    GpuSdfField f;
    const glm::dvec3 centre0 = g.origin + 0.5 * g.voxelSize;
    f.origin = glm::vec4(glm::vec3(centre0), float(g.voxelSize));
    f.uvwScale = glm::vec4(1.0f / float(m_size.x), 1.0f / float(m_size.y), 1.0f / float(m_size.z), 0.0f);
    f.uvwOffset = glm::vec4(float(box.pos.x), float(box.pos.y), float(box.pos.z), 0.0f);
    f.dims = glm::vec4(float(g.dims.x), float(g.dims.y), float(g.dims.z), 0.0f);
    // Mesh bounds rounded outward, so the distance to them is never overestimated.
    for (int a = 0; a < 3; ++a) {
        f.boundsMin[a] = toFloatTowardNegative(asset.header.boundsMin[a]);
        f.boundsMax[a] = -toFloatTowardNegative(-asset.header.boundsMax[a]);
    }
    const glm::dvec3 boxMin = centre0, boxMax = g.origin + (glm::dvec3(g.dims) - 0.5) * g.voxelSize;
    const bool meshInside = glm::all(glm::greaterThanEqual(asset.header.boundsMin, boxMin)) &&
                            glm::all(glm::lessThanEqual(asset.header.boundsMax, boxMax));
    f.boundsMin.w = meshInside ? 1.0f : 0.0f;
    return f;
}

bool SdfAtlas::upload(const Resident& r, const sdf::PsdfAsset& asset, std::string& error) {
    const sdf::SdfGrid& g = asset.grid;
    const uint64_t count = volume(g.dims);
    const uint64_t texel = rhi::formatInfo(m_format).bytesPerTexel;
    std::vector<uint8_t> data(count * texel);
    const double toVoxels = 1.0 / g.voxelSize;
    // Division in double: d / voxel is exact to 2^-53, far inside the storage rounding, which is
    // directed toward -infinity (so the stored value never exceeds d / voxel rounded in double).
    if (m_format == rhi::Format::R16_FLOAT) {
        uint16_t* out = reinterpret_cast<uint16_t*>(data.data());
        for (uint64_t i = 0; i < count; ++i) out[i] = toHalfTowardNegative(double(g.distances[i]) * toVoxels);
    } else {
        float* out = reinterpret_cast<float*>(data.data());
        for (uint64_t i = 0; i < count; ++i)
            out[i] = toFloatTowardNegative(double(g.distances[i]) * toVoxels);
    }
    if (!m_device.isAlive(m_texture)) {
        error = "sdf atlas: the atlas texture is gone";
        return false;
    }
    rhi::TextureRegion region;
    region.x = r.box.pos.x;
    region.y = r.box.pos.y;
    region.z = r.box.pos.z;
    region.width = g.dims.x;
    region.height = g.dims.y;
    region.depth = g.dims.z;
    m_device.writeTextureRegion(m_texture, region, data.data(), data.size());
    ++m_uploads;
    return true;
}

// Larger fields first (volume, then longest axis): the packing order.
bool SdfAtlas::largerField(const Pending& a, const Pending& b) {
    const glm::uvec3 da = a.asset->grid.dims, db = b.asset->grid.dims;
    const uint64_t va = volume(da), vb = volume(db);
    if (va != vb) return va > vb;
    return std::max({da.x, da.y, da.z}) > std::max({db.x, db.y, db.z});
}

bool SdfAtlas::collectWanted(const std::vector<std::pair<assets::AssetId, const sdf::PsdfAsset*>>& fields,
                             std::vector<Pending>& wanted,
                             std::unordered_map<assets::AssetId, const sdf::PsdfAsset*>& seen,
                             std::string& error) const {
    const uint32_t max3D = m_device.info().limits.maxTextureSize3D;
    for (const auto& [id, asset] : fields) {
        const auto it = seen.find(id);
        if (it != seen.end()) {
            if (it->second != asset) {
                error = fmt::format("sdf atlas: asset id {} is listed with two different fields", id);
                return false;
            }
            continue;
        }
        std::string why = checkAsset(id, asset);
        if (!why.empty()) {
            error = "sdf atlas: " + why;
            return false;
        }
        const glm::uvec3 d = asset->grid.dims;
        if (d.x > max3D || d.y > max3D || d.z > max3D) {
            error = fmt::format(
                "sdf atlas: field asset {} has {}x{}x{} voxels, more than the device's maximum 3D texture "
                "size "
                "{} along an axis",
                id, d.x, d.y, d.z, max3D);
            return false;
        }
        seen.emplace(id, asset);
        wanted.push_back({id, asset});
    }
    return true;
}

// Every wanted field packed again, largest first, into the current size or a larger one (sizes in
// multiples of kAtlasGranule, the smallest axis grown by half at a time up to the device's maximum).
bool SdfAtlas::packAll(const std::vector<Pending>& wanted, uint32_t max3D, glm::uvec3& size,
                       std::vector<Box>& freeBoxes, std::unordered_map<assets::AssetId, Box>& placed,
                       std::string& error) const {
    std::vector<Pending> all = wanted;
    std::stable_sort(all.begin(), all.end(), largerField);
    const uint32_t cap = std::max(max3D / kAtlasGranule * kAtlasGranule, kAtlasGranule);
    uint64_t totalVoxels = 0;
    glm::uvec3 largest(0);
    for (const Pending& p : all) {
        totalVoxels += volume(p.asset->grid.dims);
        largest = glm::max(largest, p.asset->grid.dims);
    }
    if (!m_texture.isValid()) size = glm::uvec3(kMinAtlasSize);
    for (int a = 0; a < 3; ++a) size[a] = std::max(size[a], std::min(cap, roundUpGranule(largest[a])));
    auto grow = [&] {  // grows the smallest axis that can still grow by half; false when none can
        int pick = -1;
        for (int a = 2; a >= 0; --a)
            if (size[a] < cap && (pick < 0 || size[a] < size[pick])) pick = a;
        if (pick < 0) return false;
        size[pick] = std::min(cap, roundUpGranule(size[pick] + size[pick] / 2));
        return true;
    };
    bool ok = true;
    while (volume(size) < totalVoxels && (ok = grow())) {
    }
    while (ok) {
        freeBoxes.assign(1, Box{glm::uvec3(0), size});
        placed.clear();
        bool fits = true;
        for (const Pending& p : all) {
            Box b;
            if (!allocate(freeBoxes, p.asset->grid.dims, b)) {
                fits = false;
                break;
            }
            placed[p.id] = b;
        }
        if (fits) break;
        ok = grow();
    }
    if (!ok) {
        error = fmt::format(
            "sdf atlas: {} fields of {} voxels in all do not fit a 3D texture of the device's maximum "
            "size "
            "{}^3",
            all.size(), totalVoxels, cap);
        return false;
    }
    return true;
}

// A zero-filled texture of `size` replaces the current one (created before anything else changes:
// a failure leaves the atlas as it was).
bool SdfAtlas::replaceTexture(const glm::uvec3& size, size_t fieldCount, std::string& error) {
    rhi::TextureDesc desc;
    desc.dimension = rhi::TextureDimension::Tex3D;
    desc.format = m_format;
    desc.width = size.x;
    desc.height = size.y;
    desc.depthOrLayers = size.z;
    desc.usage = rhi::TextureUsage::Sampled | rhi::TextureUsage::CopyDst | rhi::TextureUsage::CopySrc;
    desc.debugName = "sdf atlas";
    const rhi::TextureHandle texture = m_device.createTexture(desc);
    if (!texture.isValid()) {
        error = fmt::format("sdf atlas: could not create a {}x{}x{} {} texture ({} bytes)", size.x, size.y,
                            size.z, rhi::formatInfo(m_format).name, rhi::textureBytes(desc));
        return false;
    }
    // Zeros everywhere, in slabs of whole z-slices.
    const uint64_t slice = uint64_t(size.x) * size.y * rhi::formatInfo(m_format).bytesPerTexel;
    const uint32_t slabDepth = uint32_t(std::clamp<uint64_t>(kClearChunkBytes / slice, 1, size.z));
    const std::vector<uint8_t> zeros(slice * slabDepth, 0);
    for (uint32_t z = 0; z < size.z; z += slabDepth) {
        rhi::TextureRegion region;
        region.z = z;
        region.width = size.x;
        region.height = size.y;
        region.depth = std::min(slabDepth, size.z - z);
        m_device.writeTextureRegion(texture, region, zeros.data(), slice * region.depth);
    }
    if (m_texture.isValid()) {
        ++m_growths;
        log::info("sdf atlas: grew from {}x{}x{} to {}x{}x{} texels ({} fields, {:.1f} MiB); re-uploading",
                  m_size.x, m_size.y, m_size.z, size.x, size.y, size.z, fieldCount,
                  double(rhi::textureBytes(desc)) / (1 << 20));
        m_device.destroy(m_texture);
    }
    m_texture = texture;
    m_size = size;
    return true;
}

bool SdfAtlas::update(const std::vector<std::pair<assets::AssetId, const sdf::PsdfAsset*>>& fields,
                      std::string& error) {
    // The wanted set, in first-listed order, validated before anything changes.
    std::vector<Pending> wanted;
    std::unordered_map<assets::AssetId, const sdf::PsdfAsset*> seen;
    if (!collectWanted(fields, wanted, seen, error)) return false;
    const uint32_t max3D = m_device.info().limits.maxTextureSize3D;
    if (!wanted.empty() && !chooseFormat(error)) return false;

    // Plan on copies: keep unchanged residents, free the others, place the newcomers.
    std::vector<Box> freeBoxes = m_free;
    std::vector<Pending> newcomers;
    for (const auto& [id, r] : m_resident) {
        const auto it = seen.find(id);
        if (it == seen.end() || it->second != r.source) release(freeBoxes, r.box);  // gone or replaced
    }
    for (const Pending& p : wanted) {
        const auto it = m_resident.find(p.id);
        if (it == m_resident.end() || it->second.source != p.asset) newcomers.push_back(p);
    }
    std::stable_sort(newcomers.begin(), newcomers.end(), largerField);

    std::unordered_map<assets::AssetId, Box> placed;  // new boxes of the fields to upload
    bool repack = !m_texture.isValid() && !wanted.empty();
    if (!repack) {
        for (const Pending& p : newcomers) {
            Box b;
            if (!allocate(freeBoxes, p.asset->grid.dims, b)) {
                repack = true;
                break;
            }
            placed[p.id] = b;
        }
    }
    glm::uvec3 size = m_size;
    if (repack && !packAll(wanted, max3D, size, freeBoxes, placed, error)) return false;

    // A new texture when the size changes (created before anything else changes: a failure leaves
    // the atlas as it was).
    if (repack && (size != m_size || !m_texture.isValid()) && !replaceTexture(size, wanted.size(), error))
        return false;

    // Apply: free the slots of assets no longer listed, give newcomers a slot, record the boxes.
    for (auto it = m_resident.begin(); it != m_resident.end();) {
        if (!seen.count(it->first)) {
            m_gpuFields[it->second.slot] = GpuSdfField{};
            m_freeSlots.push_back(it->second.slot);
            m_residentVoxels -= volume(it->second.box.size);
            it = m_resident.erase(it);
        } else {
            ++it;
        }
    }
    std::sort(m_freeSlots.begin(), m_freeSlots.end(), std::greater<>());  // lowest index taken first
    for (const Pending& p : wanted) {
        auto it = m_resident.find(p.id);
        if (it == m_resident.end()) {
            Resident r;
            if (!m_freeSlots.empty()) {
                r.slot = m_freeSlots.back();
                m_freeSlots.pop_back();
            } else {
                r.slot = uint32_t(m_gpuFields.size());
                m_gpuFields.emplace_back();
            }
            it = m_resident.emplace(p.id, r).first;
        } else {
            m_residentVoxels -= volume(it->second.box.size);
        }
        Resident& r = it->second;
        const auto pl = placed.find(p.id);
        const bool moved = pl != placed.end();
        if (moved) r.box = pl->second;
        m_residentVoxels += volume(r.box.size);
        if (moved || r.source != p.asset) {
            r.source = p.asset;
            m_gpuFields[r.slot] = describe(r.box, *p.asset);
            if (!upload(r, *p.asset, error)) return false;
        }
    }
    m_free = std::move(freeBoxes);
    if (wanted.empty() && m_texture.isValid()) {
        // Nothing resident: keep the texture (the next frame probably needs it again) but the whole
        // of it is free.
        m_free.assign(1, Box{glm::uvec3(0), m_size});
    }
    return true;
}

}  // namespace penumbra::render
