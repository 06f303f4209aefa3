// The asset manager: stable ids, reference counts, the processed-mesh disk cache (.pmesh, layout in
// docs/FORMATS.md "Processed-mesh cache (.pmesh)"), baked SDF fields and their .psdf cache (bakeSdf),
// normal generation and mesh validation.
#include "engine/assets/asset_manager.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <unordered_map>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include "engine/assets/mesh_internal.h"
#include "engine/core/log.h"
#include "engine/core/progress.h"

namespace penumbra::assets {

struct AssetManager::Entry {
    AssetInfo info;
    std::shared_ptr<void> data;
};

namespace {

namespace fs = std::filesystem;

// ---- hashing ------------------------------------------------------------------------------------

uint64_t rotl(uint64_t v, int r) { return (v << r) | (v >> (64 - r)); }

// Final avalanche: every input bit affects every output bit.
uint64_t avalanche(uint64_t h, uint64_t k1, uint64_t k2) {
    h ^= h >> 31;
    h *= k1;
    h ^= h >> 29;
    h *= k2;
    h ^= h >> 32;
    return h;
}

uint64_t loadWord(const uint8_t* p) {
    uint64_t v = 0;
    for (int i = 7; i >= 0; --i) {
        v = (v << 8) | p[i];  // little-endian, independent of the host
    }
    return v;
}

// Two hashes over the same bytes with unrelated constants and different mixing steps, so that a
// collision in one says nothing about the other.
struct Hash128 {
    uint64_t a = 0;
    uint64_t b = 0;
};

Hash128 hashBytes(const void* data, size_t size) {
    const auto* p = static_cast<const uint8_t*>(data);
    uint64_t a = 0x6a09e667f3bcc909ull ^ (uint64_t(size) * 0x9e3779b97f4a7c15ull);
    uint64_t b = 0xbb67ae8584caa73bull + uint64_t(size);
    size_t i = 0;
    for (; i + 8 <= size; i += 8) {
        const uint64_t w = loadWord(p + i);
        a = rotl(a ^ (w * 0x87c37b91114253d5ull), 31) * 0x4cf5ad432745937full;
        b = (rotl(b, 27) + w) * 0xc2b2ae3d27d4eb4full + 0x165667b19e3779f9ull;
    }
    uint64_t tail = 0;
    for (size_t k = 0; i + k < size; ++k) {
        tail |= uint64_t(p[i + k]) << (8 * k);
    }
    a = rotl(a ^ (tail * 0x87c37b91114253d5ull), 31) * 0x4cf5ad432745937full;
    b = (rotl(b, 27) + tail) * 0xc2b2ae3d27d4eb4full + 0x165667b19e3779f9ull;
    return {avalanche(a, 0xff51afd7ed558ccdull, 0xc4ceb9fe1a85ec53ull),
            avalanche(b, 0xbf58476d1ce4e5b9ull, 0x94d049bb133111ebull)};
}

std::string hexHash(const Hash128& h) { return fmt::format("{:016x}{:016x}", h.a, h.b); }

// ---- .pmesh ----------------------------------------------------------------------------------

constexpr char kPmeshMagic[8] = {'P', 'N', 'B', 'R', 'M', 'S', 'H', '\n'};
constexpr uint32_t kPmeshVersion = 2;  // 2: normals shared by vertices at one position
constexpr size_t kPmeshHeaderBytes = 64;
constexpr uint32_t kFlagUvs = 1u;

void putU32(std::vector<uint8_t>& out, size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i) {
        out[at + size_t(i)] = uint8_t(v >> (8 * i));
    }
}
void putU64(std::vector<uint8_t>& out, size_t at, uint64_t v) {
    for (int i = 0; i < 8; ++i) {
        out[at + size_t(i)] = uint8_t(v >> (8 * i));
    }
}
uint32_t getU32(const uint8_t* p) {
    uint32_t v = 0;
    for (int i = 3; i >= 0; --i) {
        v = (v << 8) | p[i];
    }
    return v;
}

// The file hash as 16 raw bytes (from the 32 hex digits).
void hashDigits(const std::string& hex, uint8_t out[16]) {
    for (size_t i = 0; i < 16; ++i) {
        auto nibble = [](char c) { return c <= '9' ? c - '0' : c - 'a' + 10; };
        out[i] = uint8_t(nibble(hex[2 * i]) * 16 + nibble(hex[2 * i + 1]));
    }
}

std::vector<uint8_t> encodePmesh(const MeshData& mesh, const std::string& hash, uint64_t sourceBytes) {
    const uint64_t vc = mesh.positions.size();
    const uint64_t ic = mesh.indices.size();
    const bool uvs = !mesh.uvs.empty();
    const size_t payload = size_t(vc * 12 * 2 + (uvs ? vc * 8 : 0) + ic * 4);
    std::vector<uint8_t> out(kPmeshHeaderBytes + payload + 8, 0);
    std::memcpy(out.data(), kPmeshMagic, 8);
    putU32(out, 8, kPmeshVersion);
    putU32(out, 12, uvs ? kFlagUvs : 0u);
    putU64(out, 16, sourceBytes);
    hashDigits(hash, out.data() + 24);
    putU64(out, 40, vc);
    putU64(out, 48, ic);
    // bytes 56..63 reserved (zero)
    size_t at = kPmeshHeaderBytes;
    auto putFloats = [&](const float* f, size_t n) {
        for (size_t i = 0; i < n; ++i) {
            uint32_t bits;
            std::memcpy(&bits, &f[i], 4);
            putU32(out, at, bits);
            at += 4;
        }
    };
    putFloats(&mesh.positions.data()->x, size_t(vc) * 3);
    putFloats(&mesh.normals.data()->x, size_t(vc) * 3);
    if (uvs) {
        putFloats(&mesh.uvs.data()->x, size_t(vc) * 2);
    }
    for (uint32_t index : mesh.indices) {
        putU32(out, at, index);
        at += 4;
    }
    putU64(out, at, hashBytes(out.data(), at).a);
    return out;
}

// Parses a .pmesh image; false with the reason (for the warning) on anything unexpected.
bool decodePmesh(const uint8_t* p, size_t size, const std::string& hash, uint64_t sourceBytes,
                 const MeshLoadLimits& limits, MeshData& mesh, std::string& why) {
    if (size < kPmeshHeaderBytes + 8) {
        why = fmt::format("truncated ({} bytes, shorter than the header)", size);
        return false;
    }
    if (std::memcmp(p, kPmeshMagic, 8) != 0) {
        why = "bad magic";
        return false;
    }
    const uint32_t version = getU32(p + 8);
    if (version != kPmeshVersion) {
        why = fmt::format("version {} (expected {})", version, kPmeshVersion);
        return false;
    }
    const uint32_t flags = getU32(p + 12);
    if ((flags & ~kFlagUvs) != 0) {
        why = fmt::format("unknown flags 0x{:x}", flags);
        return false;
    }
    if (loadWord(p + 16) != sourceBytes) {
        why = fmt::format("stale: made from a {}-byte source, the file now has {} bytes", loadWord(p + 16),
                          sourceBytes);
        return false;
    }
    uint8_t digits[16];
    hashDigits(hash, digits);
    if (std::memcmp(p + 24, digits, 16) != 0) {
        why = "stale: the content hash in the header does not match the source file";
        return false;
    }
    const uint64_t vc = loadWord(p + 40);
    const uint64_t ic = loadWord(p + 48);
    if (loadWord(p + 56) != 0) {
        why = "reserved header bytes are not zero";
        return false;
    }
    if (vc == 0 || vc > limits.maxVertices || ic == 0 || ic % 3 != 0 || ic / 3 > limits.maxTriangles) {
        why = fmt::format("counts out of range ({} vertices, {} indices)", vc, ic);
        return false;
    }
    // Both counts are bounded by the limits (< 2^40), so these products cannot wrap.
    const bool uvs = (flags & kFlagUvs) != 0;
    const uint64_t expected = kPmeshHeaderBytes + vc * 24 + (uvs ? vc * 8 : 0) + ic * 4 + 8;
    if (expected != size) {
        why = fmt::format("size {} does not match the counts in the header (expected {} bytes)", size,
                          expected);
        return false;
    }
    const size_t checked = size - 8;
    if (hashBytes(p, checked).a != loadWord(p + checked)) {
        why = "checksum mismatch";
        return false;
    }
    mesh.positions.resize(size_t(vc));
    mesh.normals.resize(size_t(vc));
    mesh.uvs.resize(uvs ? size_t(vc) : 0);
    mesh.indices.resize(size_t(ic));
    size_t at = kPmeshHeaderBytes;
    auto getFloats = [&](float* f, size_t n) {
        for (size_t i = 0; i < n; ++i) {
            const uint32_t bits = getU32(p + at);
            std::memcpy(&f[i], &bits, 4);
            at += 4;
        }
    };
    getFloats(&mesh.positions.data()->x, size_t(vc) * 3);
    getFloats(&mesh.normals.data()->x, size_t(vc) * 3);
    if (uvs) {
        getFloats(&mesh.uvs.data()->x, size_t(vc) * 2);
    }
    for (uint32_t& index : mesh.indices) {
        index = getU32(p + at);
        at += 4;
    }
    std::string invalid;
    if (!validateMesh(mesh, "cached mesh", invalid)) {
        why = invalid;
        return false;
    }
    return true;
}

// Writes `bytes` to `path` through a temporary file in the same directory and a rename, so a
// reader never sees a partial file. False with the reason.
bool writeAtomically(const std::string& path, const std::vector<uint8_t>& bytes, std::string& why) {
    static std::atomic<uint64_t> counter{0};
    const std::string temp = fmt::format("{}.tmp.{}.{}", path, ::getpid(), counter.fetch_add(1));
    std::FILE* file = std::fopen(temp.c_str(), "wb");
    if (!file) {
        why = fmt::format("cannot create {}: {}", temp, std::strerror(errno));
        return false;
    }
    const bool written = std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
    const bool flushed = std::fflush(file) == 0;
    const bool closed = std::fclose(file) == 0;
    if (!written || !flushed || !closed) {
        why = fmt::format("cannot write {}", temp);
        std::remove(temp.c_str());
        return false;
    }
    if (std::rename(temp.c_str(), path.c_str()) != 0) {
        why = fmt::format("cannot rename {} to {}: {}", temp, path, std::strerror(errno));
        std::remove(temp.c_str());
        return false;
    }
    return true;
}

// The largest .pmesh the limits allow (saturating, for limits near 2^64).
uint64_t pmeshSizeCap(const MeshLoadLimits& limits) {
    constexpr uint64_t kMax = std::numeric_limits<uint64_t>::max();
    const uint64_t v = std::min(limits.maxVertices, kMax / 64);
    const uint64_t t = std::min(limits.maxTriangles, kMax / 64);
    return kPmeshHeaderBytes + 8 + v * 32 + t * 12;
}

uint64_t meshBytes(const MeshData& m) {
    return uint64_t(m.positions.size()) * sizeof(glm::vec3) + uint64_t(m.normals.size()) * sizeof(glm::vec3) +
           uint64_t(m.uvs.size()) * sizeof(glm::vec2) + uint64_t(m.indices.size()) * sizeof(uint32_t);
}

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

// ---- free functions ---------------------------------------------------------------------------

const char* assetKindName(AssetKind kind) {
    switch (kind) {
        case AssetKind::Mesh:
            return "mesh";
        case AssetKind::Material:
            return "material";
        case AssetKind::Texture:
            return "texture";
        case AssetKind::ShapeProgram:
            return "shapeProgram";
        case AssetKind::SdfField:
            return "sdfField";
        case AssetKind::Count:
            break;
    }
    return "unknown";
}

void generateNormals(MeshData& mesh) {
    if (!mesh.normals.empty()) {
        return;
    }
    // Files without normals often split vertices along uv or patch seams (the npm teapot has 263
    // such duplicates); normals computed per split vertex would show those seams as creases. So a
    // vertex also takes the faces of the other vertices at exactly its position, but only those
    // within kCreaseAngle of its own faces' normal, which keeps deliberate hard edges (a box
    // authored with 4 vertices per face) hard. A vertex's own faces always count, creased or not.
    constexpr double kCosCrease = 0.5;  // kCreaseAngle = 60 degrees
    const size_t n = mesh.positions.size();
    const size_t triangles = mesh.indices.size() / 3;

    // group[i]: the first vertex at vertex i's position (+0 and -0 are one position).
    std::vector<uint32_t> group(n);
    {
        struct Bits {
            uint32_t x, y, z;
            bool operator==(const Bits&) const = default;
        };
        struct BitsHash {
            size_t operator()(const Bits& b) const {
                uint64_t h = 1469598103934665603ull;
                for (uint32_t v : {b.x, b.y, b.z}) h = (h ^ v) * 1099511628211ull;
                return size_t(h);
            }
        };
        std::unordered_map<Bits, uint32_t, BitsHash> first;
        first.reserve(n);
        for (size_t i = 0; i < n; ++i) {
            const glm::vec3 p = mesh.positions[i] + glm::vec3(0.0f);
            Bits key{};
            std::memcpy(&key, &p, sizeof key);
            group[i] = first.emplace(key, uint32_t(i)).first->second;
        }
    }

    // Area-weighted face normals (the cross product's length is twice the area) and, per
    // position group, the list of faces touching it (compressed rows).
    std::vector<glm::dvec3> face(triangles, glm::dvec3(0.0));
    std::vector<glm::dvec3> own(n, glm::dvec3(0.0));
    std::vector<uint32_t> rowStart(n + 1, 0);
    for (size_t t = 0; t < triangles; ++t) {
        const uint32_t* tri = &mesh.indices[3 * t];
        if (tri[0] >= n || tri[1] >= n || tri[2] >= n) {
            continue;
        }
        const glm::dvec3 p0(mesh.positions[tri[0]]);
        face[t] =
            glm::cross(glm::dvec3(mesh.positions[tri[1]]) - p0, glm::dvec3(mesh.positions[tri[2]]) - p0);
        for (int c = 0; c < 3; ++c) {
            own[tri[c]] += face[t];
            ++rowStart[group[tri[c]] + 1];
        }
    }
    for (size_t i = 0; i < n; ++i) rowStart[i + 1] += rowStart[i];
    std::vector<uint32_t> faces(rowStart[n]);
    std::vector<uint32_t> fill(rowStart.begin(), rowStart.end() - 1);
    for (size_t t = 0; t < triangles; ++t) {
        const uint32_t* tri = &mesh.indices[3 * t];
        if (tri[0] >= n || tri[1] >= n || tri[2] >= n) {
            continue;
        }
        for (int c = 0; c < 3; ++c) faces[fill[group[tri[c]]]++] = uint32_t(t);
    }

    mesh.normals.resize(n);
    for (size_t i = 0; i < n; ++i) {
        glm::dvec3 sum = own[i];
        const double ownLen = glm::length(own[i]);
        if (ownLen > 0.0 && std::isfinite(ownLen)) {
            const glm::dvec3 ownDir = own[i] / ownLen;
            sum = glm::dvec3(0.0);
            const uint32_t g = group[i];
            for (uint32_t k = rowStart[g]; k < rowStart[g + 1]; ++k) {
                const uint32_t t = faces[k];
                const uint32_t* tri = &mesh.indices[3 * size_t(t)];
                const glm::dvec3& f = face[t];
                // A vertex's own faces always count; faces of its split copies only within the crease.
                const bool ownFace = tri[0] == i || tri[1] == i || tri[2] == i;
                if (ownFace || glm::dot(f, ownDir) >= kCosCrease * glm::length(f)) sum += f;
            }
        }
        const double len = glm::length(sum);
        mesh.normals[i] =
            len > 0.0 && std::isfinite(len) ? glm::vec3(sum / len) : glm::vec3(0.0f, 1.0f, 0.0f);
    }
}

bool validateMesh(const MeshData& mesh, std::string_view what, std::string& error) {
    auto fail = [&](const std::string& why) {
        error.assign(what).append(": ").append(why);
        return false;
    };
    if (mesh.positions.empty() || mesh.indices.empty()) {
        return fail(fmt::format("no triangles ({} vertices, {} indices)", mesh.positions.size(),
                                mesh.indices.size()));
    }
    if (mesh.positions.size() > std::numeric_limits<uint32_t>::max()) {
        return fail(fmt::format("too many vertices ({}) for 32-bit indices", mesh.positions.size()));
    }
    if (mesh.indices.size() % 3 != 0) {
        return fail(fmt::format("index count {} is not a multiple of 3", mesh.indices.size()));
    }
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) {
        return fail(fmt::format("{} normals for {} vertices", mesh.normals.size(), mesh.positions.size()));
    }
    if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size()) {
        return fail(
            fmt::format("{} texture coordinates for {} vertices", mesh.uvs.size(), mesh.positions.size()));
    }
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
        if (!finite(mesh.positions[i])) {
            return fail(fmt::format("vertex {} has a non-finite position (NaN or inf)", i));
        }
    }
    for (size_t i = 0; i < mesh.normals.size(); ++i) {
        if (!finite(mesh.normals[i])) {
            return fail(fmt::format("vertex {} has a non-finite normal (NaN or inf)", i));
        }
    }
    for (size_t i = 0; i < mesh.uvs.size(); ++i) {
        if (!std::isfinite(mesh.uvs[i].x) || !std::isfinite(mesh.uvs[i].y)) {
            return fail(fmt::format("vertex {} has a non-finite texture coordinate (NaN or inf)", i));
        }
    }
    const size_t n = mesh.positions.size();
    for (size_t i = 0; i < mesh.indices.size(); ++i) {
        if (mesh.indices[i] >= n) {
            return fail(fmt::format("triangle {} references vertex index {} out of range (vertex count {})",
                                    i / 3, mesh.indices[i], n));
        }
    }
    return true;
}

// ---- AssetManager -------------------------------------------------------------------------------

AssetManager::AssetManager(AssetManagerDesc desc) : m_desc(std::move(desc)) {}
AssetManager::~AssetManager() = default;

std::string AssetManager::contentHash(const void* data, size_t size) {
    return hexHash(hashBytes(data, size));
}

AssetId AssetManager::stableId(AssetKind kind, std::string_view key) {
    uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a 64 offset basis
    auto mix = [&](std::string_view s) {
        for (const char c : s) {
            h ^= uint8_t(c);
            h *= 0x100000001b3ull;  // FNV prime
        }
    };
    mix(assetKindName(kind));
    mix(":");
    mix(key);
    return h != 0 ? h : 1;
}

AssetManager::Entry* AssetManager::find(AssetId id) {
    const auto it = m_entries.find(id);
    return it == m_entries.end() ? nullptr : it->second.get();
}

const AssetManager::Entry* AssetManager::find(AssetId id) const {
    const auto it = m_entries.find(id);
    return it == m_entries.end() ? nullptr : it->second.get();
}

AssetId AssetManager::insert(AssetKind kind, std::string_view key, std::string sourcePath,
                             std::shared_ptr<void> data, uint64_t bytes) {
    const AssetId id = stableId(kind, key);
    if (Entry* existing = find(id)) {
        if (existing->info.kind != kind || existing->info.key != key) {
            log::error("asset id collision: {} '{}' and {} '{}' both hash to {:016x}; the second is refused",
                       assetKindName(existing->info.kind), existing->info.key, assetKindName(kind), key, id);
            return 0;
        }
        ++existing->info.refCount;
        return id;
    }
    auto entry = std::make_unique<Entry>();
    entry->info.id = id;
    entry->info.kind = kind;
    entry->info.key = std::string(key);
    entry->info.sourcePath = std::move(sourcePath);
    entry->info.refCount = 1;
    entry->info.bytes = bytes;
    entry->data = std::move(data);
    m_entries.emplace(id, std::move(entry));
    return id;
}

AssetId AssetManager::loadMesh(const std::string& path, std::string& error) {
    const std::string ext = detail::lowerExtension(path);
    const auto importer = m_importers.find(ext);
    const bool builtin = ext == "ply" || ext == "obj" || ext == "gltf" || ext == "glb";
    if (importer == m_importers.end() && !builtin) {
        error = fmt::format("{}: unknown mesh format '.{}' (supported: .ply, .obj, .gltf, .glb{})", path, ext,
                            m_importers.empty() ? "" : " and registered importers");
        return 0;
    }
    // The bytes are read once here (under the file cap) for the content hash; the cache and the
    // id depend only on them.
    std::string hash;
    uint64_t sourceBytes = 0;
    {
        detail::FileBytes bytes;
        if (!detail::readWholeFile(path, m_desc.meshLimits.maxFileBytes, bytes, error)) {
            return 0;
        }
        hash = contentHash(bytes.data(), bytes.size());
        sourceBytes = bytes.size();
    }
    const std::string key = fmt::format("file:{}", hash);
    const AssetId id = stableId(AssetKind::Mesh, key);
    if (Entry* existing = find(id);
        existing && existing->info.kind == AssetKind::Mesh && existing->info.key == key) {
        ++existing->info.refCount;
        return id;
    }

    auto mesh = std::make_shared<MeshData>();
    bool fromCache = false;
    std::string cacheFile;
    if (!m_desc.cacheDir.empty()) {
        cacheFile = (fs::path(m_desc.cacheDir) / "meshes" / (hash + ".pmesh")).string();
        std::error_code ec;
        if (fs::exists(cacheFile, ec)) {
            std::string why;
            detail::FileBytes cached;
            const uint64_t cap = pmeshSizeCap(m_desc.meshLimits);
            if (detail::readWholeFile(cacheFile, cap, cached, why) &&
                decodePmesh(reinterpret_cast<const uint8_t*>(cached.data()), cached.size(), hash, sourceBytes,
                            m_desc.meshLimits, *mesh, why)) {
                fromCache = true;
                ++m_cacheStats.hits;
            } else {
                log::warn("mesh cache file {} rejected ({}); deleting it and rebuilding from {}", cacheFile,
                          why, path);
                fs::remove(cacheFile, ec);
                ++m_cacheStats.rejected;
                *mesh = MeshData{};
            }
        } else {
            ++m_cacheStats.misses;
        }
    }
    if (!fromCache) {
        const bool ok = importer != m_importers.end()
                            ? importer->second(path, *mesh, error)
                            : assets::loadMesh(path, *mesh, error, m_desc.meshLimits);
        if (!ok) {
            if (error.empty()) {
                error = fmt::format("{}: the importer for '.{}' failed without a message", path, ext);
            }
            return 0;
        }
        mesh->sourcePath = path;
        if (!validateMesh(*mesh, path, error)) {
            return 0;
        }
        if (mesh->positions.size() > m_desc.meshLimits.maxVertices ||
            mesh->indices.size() / 3 > m_desc.meshLimits.maxTriangles) {
            error = fmt::format("{}: mesh exceeds the limits ({} vertices, {} triangles)", path,
                                mesh->positions.size(), mesh->indices.size() / 3);
            return 0;
        }
        generateNormals(*mesh);
        if (!cacheFile.empty()) {
            std::error_code ec;
            fs::create_directories(fs::path(cacheFile).parent_path(), ec);
            std::string why;
            if (ec) {
                log::warn("cannot create the mesh cache directory for {}: {}", cacheFile, ec.message());
            } else if (!writeAtomically(cacheFile, encodePmesh(*mesh, hash, sourceBytes), why)) {
                log::warn("cannot write the mesh cache file: {}", why);
            } else {
                ++m_cacheStats.writes;
            }
        }
    }
    mesh->sourcePath = path;
    const uint64_t bytes = meshBytes(*mesh);
    const AssetId result = insert(AssetKind::Mesh, key, path, std::move(mesh), bytes);
    if (result == 0) {
        error = fmt::format("{}: asset id collision for key '{}'", path, key);
    }
    return result;
}

AssetId AssetManager::loadTexture(const std::string& path, bool srgb, std::string& error) {
    detail::FileBytes bytes;
    if (!detail::readWholeFile(path, m_desc.textureLimits.maxFileBytes, bytes, error)) {
        return 0;
    }
    const std::string key =
        fmt::format("file:{}:{}", contentHash(bytes.data(), bytes.size()), srgb ? "srgb" : "linear");
    const AssetId id = stableId(AssetKind::Texture, key);
    if (Entry* existing = find(id);
        existing && existing->info.kind == AssetKind::Texture && existing->info.key == key) {
        ++existing->info.refCount;
        return id;
    }
    auto texture = std::make_shared<TextureData>();
    texture->srgb = srgb;
    if (!decodeTexture(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), path, *texture, error,
                       m_desc.textureLimits)) {
        return 0;
    }
    texture->srgb = srgb;
    texture->sourcePath = path;
    const uint64_t size = texture->rgba8.size();
    const AssetId result = insert(AssetKind::Texture, key, path, std::move(texture), size);
    if (result == 0) {
        error = fmt::format("{}: asset id collision for key '{}'", path, key);
    }
    return result;
}

AssetId AssetManager::addMesh(std::string_view key, MeshData mesh, std::string& error) {
    const AssetId id = stableId(AssetKind::Mesh, key);
    if (Entry* existing = find(id);
        existing && existing->info.kind == AssetKind::Mesh && existing->info.key == key) {
        ++existing->info.refCount;
        return id;
    }
    const std::string what = fmt::format("mesh '{}'", key);
    if (!validateMesh(mesh, what, error)) {
        return 0;
    }
    if (mesh.positions.size() > m_desc.meshLimits.maxVertices ||
        mesh.indices.size() / 3 > m_desc.meshLimits.maxTriangles) {
        error = fmt::format("{}: exceeds the limits ({} vertices, {} triangles; limits {} and {})", what,
                            mesh.positions.size(), mesh.indices.size() / 3, m_desc.meshLimits.maxVertices,
                            m_desc.meshLimits.maxTriangles);
        return 0;
    }
    generateNormals(mesh);
    std::string source = mesh.sourcePath;
    const uint64_t bytes = meshBytes(mesh);
    const AssetId result =
        insert(AssetKind::Mesh, key, std::move(source), std::make_shared<MeshData>(std::move(mesh)), bytes);
    if (result == 0) {
        error = fmt::format("{}: asset id collision", what);
    }
    return result;
}

AssetId AssetManager::addMaterial(std::string_view key, const ecs::Material& material) {
    return insert(AssetKind::Material, key, {}, std::make_shared<ecs::Material>(material),
                  sizeof(ecs::Material));
}

AssetId AssetManager::addTexture(std::string_view key, TextureData texture, std::string& error) {
    const AssetId id = stableId(AssetKind::Texture, key);
    if (Entry* existing = find(id);
        existing && existing->info.kind == AssetKind::Texture && existing->info.key == key) {
        ++existing->info.refCount;
        return id;
    }
    const std::string what = fmt::format("texture '{}'", key);
    if (texture.width == 0 || texture.height == 0) {
        error = fmt::format("{}: empty texture ({} x {})", what, texture.width, texture.height);
        return 0;
    }
    if (texture.width > m_desc.textureLimits.maxDimension ||
        texture.height > m_desc.textureLimits.maxDimension) {
        error = fmt::format("{}: dimensions {} x {} exceed the limit of {} per side", what, texture.width,
                            texture.height, m_desc.textureLimits.maxDimension);
        return 0;
    }
    if (texture.rgba8.size() != uint64_t(texture.width) * texture.height * 4) {
        error =
            fmt::format("{}: {} bytes of texels for {} x {} RGBA8 (expected {})", what, texture.rgba8.size(),
                        texture.width, texture.height, uint64_t(texture.width) * texture.height * 4);
        return 0;
    }
    std::string source = texture.sourcePath;
    const uint64_t bytes = texture.rgba8.size();
    const AssetId result = insert(AssetKind::Texture, key, std::move(source),
                                  std::make_shared<TextureData>(std::move(texture)), bytes);
    if (result == 0) {
        error = fmt::format("{}: asset id collision", what);
    }
    return result;
}

bool AssetManager::retain(AssetId id) {
    Entry* entry = find(id);
    if (!entry) {
        return false;
    }
    ++entry->info.refCount;
    return true;
}

bool AssetManager::release(AssetId id) {
    Entry* entry = find(id);
    if (!entry) {
        return false;
    }
    if (--entry->info.refCount == 0) {
        m_entries.erase(id);
    }
    return true;
}

uint32_t AssetManager::refCount(AssetId id) const {
    const Entry* entry = find(id);
    return entry ? entry->info.refCount : 0;
}

const MeshData* AssetManager::mesh(AssetId id) const {
    const Entry* entry = find(id);
    return entry && entry->info.kind == AssetKind::Mesh ? static_cast<const MeshData*>(entry->data.get())
                                                        : nullptr;
}

const ecs::Material* AssetManager::material(AssetId id) const {
    const Entry* entry = find(id);
    return entry && entry->info.kind == AssetKind::Material
               ? static_cast<const ecs::Material*>(entry->data.get())
               : nullptr;
}

const TextureData* AssetManager::texture(AssetId id) const {
    const Entry* entry = find(id);
    return entry && entry->info.kind == AssetKind::Texture
               ? static_cast<const TextureData*>(entry->data.get())
               : nullptr;
}

const sdf::ShapeProgram* AssetManager::shapeProgram(AssetId id) const {
    const Entry* entry = find(id);
    return entry && entry->info.kind == AssetKind::ShapeProgram
               ? static_cast<const sdf::ShapeProgram*>(entry->data.get())
               : nullptr;
}

const sdf::PsdfAsset* AssetManager::sdfField(AssetId id) const {
    const Entry* entry = find(id);
    return entry && entry->info.kind == AssetKind::SdfField
               ? static_cast<const sdf::PsdfAsset*>(entry->data.get())
               : nullptr;
}

AssetId AssetManager::copySdfField(AssetId fieldId, std::string_view tag, std::string& error) {
    const Entry* entry = find(fieldId);
    if (!entry || entry->info.kind != AssetKind::SdfField) {
        error = fmt::format("copySdfField: asset {:016x} is not a field", fieldId);
        return 0;
    }
    const std::string key = fmt::format("copy:{}:{}", tag, entry->info.key);
    const AssetId id = insert(AssetKind::SdfField, key, entry->info.sourcePath, entry->data, 0);
    if (id == 0) error = fmt::format("copySdfField: the key '{}' collides with another asset", key);
    return id;
}

AssetId AssetManager::addShapeProgram(std::string_view key, sdf::ShapeProgram program, std::string& error) {
    const AssetId id = stableId(AssetKind::ShapeProgram, key);
    if (const Entry* existing = find(id);
        existing && existing->info.kind == AssetKind::ShapeProgram && existing->info.key == key) {
        ++find(id)->info.refCount;
        return id;
    }
    if (!sdf::validateShapeProgram(program.records, error)) {
        error = fmt::format("shape program '{}': {}", key, error);
        return 0;
    }
    const uint64_t bytes = program.records.size() * sizeof(sdf::ShapeInstruction);
    const AssetId result = insert(AssetKind::ShapeProgram, key, {},
                                  std::make_shared<sdf::ShapeProgram>(std::move(program)), bytes);
    if (result == 0) error = fmt::format("shape program '{}': asset id collision", key);
    return result;
}

std::string AssetManager::shapeProgramKey(const sdf::ShapeProgram& program) {
    return "shapes:" +
           contentHash(program.records.data(), program.records.size() * sizeof(sdf::ShapeInstruction));
}

AssetId AssetManager::loadPsdf(const std::string& path, std::string& error) {
    detail::FileBytes bytes;
    if (!detail::readWholeFile(path, uint64_t(1) << 33, bytes, error))
        return 0;  // .psdf limit: 2^30 voxels of 4 bytes
    const std::string key = fmt::format("file:{}", contentHash(bytes.data(), bytes.size()));
    const AssetId id = stableId(AssetKind::SdfField, key);
    if (Entry* existing = find(id);
        existing && existing->info.kind == AssetKind::SdfField && existing->info.key == key) {
        ++existing->info.refCount;
        return id;
    }
    auto field = std::make_shared<sdf::PsdfAsset>();
    if (!sdf::decodePsdf(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), path, *field, error)) {
        return 0;
    }
    const uint64_t size = field->grid.distances.size() * sizeof(float);
    const AssetId result = insert(AssetKind::SdfField, key, path, std::move(field), size);
    if (result == 0) error = fmt::format("{}: asset id collision", path);
    return result;
}

namespace {

// Bumped whenever the baker's output for the same mesh and settings changes, so older cache files
// are never read (their names no longer match).
constexpr int kSdfBakeCacheVersion = 1;

// The largest .psdf the reader accepts (2^30 voxels of 4 bytes, plus the header).
constexpr uint64_t kMaxPsdfFileBytes = uint64_t(1) << 33;

}  // namespace

std::string AssetManager::bakeSettingsKey(const sdf::BakeSettings& settings) {
    return fmt::format("v{}:res={}:vs={:.17g}:pad={}:sign={}:q={}:flip={}", kSdfBakeCacheVersion,
                       settings.resolution, settings.resolution ? 0.0 : settings.voxelSize, settings.padding,
                       sdf::toString(settings.sign), sdf::toString(settings.quality),
                       settings.flipInsideOut ? 1 : 0);
}

AssetId AssetManager::bakeSdf(AssetId meshId, const sdf::BakeSettings& settings, std::string& error) {
    const Entry* meshEntry = find(meshId);
    if (!meshEntry || meshEntry->info.kind != AssetKind::Mesh) {
        error = meshEntry ? fmt::format("bakeSdf: asset {:016x} is a {}, not a mesh", meshId,
                                        assetKindName(meshEntry->info.kind))
                          : fmt::format("bakeSdf: unknown mesh asset {:016x}", meshId);
        return 0;
    }
    const MeshData& mesh = *static_cast<const MeshData*>(meshEntry->data.get());
    const std::string what = meshEntry->info.sourcePath.empty()
                                 ? fmt::format("mesh '{}'", meshEntry->info.key)
                                 : meshEntry->info.sourcePath;
    const std::string key = fmt::format("bake:{}:{}", meshEntry->info.key, bakeSettingsKey(settings));
    const AssetId id = stableId(AssetKind::SdfField, key);
    if (Entry* existing = find(id);
        existing && existing->info.kind == AssetKind::SdfField && existing->info.key == key) {
        ++existing->info.refCount;
        return id;
    }
    const std::string sourcePath = meshEntry->info.sourcePath;

    auto field = std::make_shared<sdf::PsdfAsset>();
    bool fromCache = false;
    std::string cacheFile;
    if (!m_desc.cacheDir.empty()) {
        // The name covers the geometry too: in-memory mesh keys are chosen by callers.
        const std::string geometry =
            contentHash(mesh.positions.data(), mesh.positions.size() * sizeof(glm::vec3)) +
            contentHash(mesh.indices.data(), mesh.indices.size() * sizeof(uint32_t));
        const std::string nameKey = key + "\n" + geometry;
        cacheFile =
            (fs::path(m_desc.cacheDir) / "sdf" / (contentHash(nameKey.data(), nameKey.size()) + ".psdf"))
                .string();
        std::error_code ec;
        if (fs::exists(cacheFile, ec)) {
            std::string why;
            detail::FileBytes cached;
            bool ok = detail::readWholeFile(cacheFile, kMaxPsdfFileBytes, cached, why) &&
                      sdf::decodePsdf(reinterpret_cast<const uint8_t*>(cached.data()), cached.size(),
                                      cacheFile, *field, why);
            if (ok && field->header.encoding != sdf::PsdfEncoding::F32) {
                why = fmt::format("encoding {} (the bake cache writes f32)",
                                  sdf::toString(field->header.encoding));
                ok = false;
            }
            if (ok) {
                fromCache = true;
                ++m_cacheStats.sdfHits;
            } else {
                log::warn("sdf bake cache file {} rejected ({}); deleting it and baking {} again", cacheFile,
                          why, what);
                fs::remove(cacheFile, ec);
                ++m_cacheStats.sdfRejected;
                *field = sdf::PsdfAsset{};
            }
        } else {
            ++m_cacheStats.sdfMisses;
        }
    }
    if (!fromCache) {
        sdf::BakeSettings run = settings;
        StderrProgressOutput progressOut;
        ProgressBar bar(progressOut);
        if (!run.progress)
            run.progress = [&bar](double fraction, const char* phase) { bar.update(fraction, phase); };
        const auto t0 = std::chrono::steady_clock::now();
        sdf::BakeResult result = sdf::bake(mesh, run);
        bar.finish();
        ++m_cacheStats.sdfBakes;
        if (!result.ok) {
            error = fmt::format("cannot bake the SDF of {}: {}", what, result.error);
            return 0;
        }
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (seconds >= 1.0) {
            log::info("baked the SDF of {}: {} x {} x {} voxels in {:.1f} s", what, result.grid.dims.x,
                      result.grid.dims.y, result.grid.dims.z, seconds);
        }
        // The asset is the decoded image of the F32 file, so a cached load gives the same asset.
        const sdf::MeshDiagnostics& diag = result.diagnostics;
        sdf::PsdfWriteOptions wo;
        wo.encoding = sdf::PsdfEncoding::F32;
        wo.sign = sdf::psdfSign(result.signUsed);
        wo.closedManifold = diag.closedManifold;
        wo.boundaryEdges = diag.boundaryEdges > 0;
        wo.nonManifold = diag.nonManifoldEdges > 0;
        wo.boundsMin = diag.boundsMin;
        wo.boundsMax = diag.boundsMax;
        std::vector<uint8_t> image;
        std::string why;
        if (!sdf::encodePsdf(result.grid, wo, image, why) ||
            !sdf::decodePsdf(image.data(), image.size(), what, *field, why)) {
            error =
                fmt::format("cannot bake the SDF of {}: the baked grid is not a valid .psdf: {}", what, why);
            return 0;
        }
        result.grid = sdf::SdfGrid{};  // free the baker's copy before the cache write
        if (!cacheFile.empty()) {
            std::error_code ec;
            fs::create_directories(fs::path(cacheFile).parent_path(), ec);
            if (ec) {
                log::warn("cannot create the sdf bake cache directory for {}: {}", cacheFile, ec.message());
            } else if (!writeAtomically(cacheFile, image, why)) {
                log::warn("cannot write the sdf bake cache file: {}", why);
            } else {
                ++m_cacheStats.sdfWrites;
            }
        }
    }
    const uint64_t size = field->grid.distances.size() * sizeof(float);
    const AssetId result = insert(AssetKind::SdfField, key, sourcePath, std::move(field), size);
    if (result == 0) error = fmt::format("{}: asset id collision for key '{}'", what, key);
    return result;
}

bool AssetManager::contains(AssetId id) const { return find(id) != nullptr; }

const AssetInfo* AssetManager::info(AssetId id) const {
    const Entry* entry = find(id);
    return entry ? &entry->info : nullptr;
}

size_t AssetManager::count() const { return m_entries.size(); }

size_t AssetManager::count(AssetKind kind) const {
    size_t n = 0;
    for (const auto& [id, entry] : m_entries) {
        n += entry->info.kind == kind ? 1 : 0;
    }
    return n;
}

uint64_t AssetManager::memoryBytes(AssetKind kind) const {
    uint64_t total = 0;
    for (const auto& [id, entry] : m_entries) {
        total += entry->info.kind == kind ? entry->info.bytes : 0;
    }
    return total;
}

std::vector<AssetInfo> AssetManager::list() const {
    std::vector<AssetInfo> out;
    out.reserve(m_entries.size());
    for (const auto& [id, entry] : m_entries) {
        out.push_back(entry->info);
    }
    std::sort(out.begin(), out.end(), [](const AssetInfo& a, const AssetInfo& b) { return a.id < b.id; });
    return out;
}

void AssetManager::setMeshImporter(std::string_view extension, MeshFileImporter importer) {
    std::string ext(extension);
    if (!ext.empty() && ext[0] == '.') {
        ext.erase(0, 1);
    }
    for (char& c : ext) {
        if (c >= 'A' && c <= 'Z') {
            c = char(c - 'A' + 'a');
        }
    }
    if (importer) {
        m_importers[ext] = std::move(importer);
    } else {
        m_importers.erase(ext);
    }
}

}  // namespace penumbra::assets
