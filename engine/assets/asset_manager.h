// The asset manager: owns every mesh, material and texture a scene uses, hands out stable ids,
// counts references and keeps a content-hash cache of processed meshes on disk.
//
// Stable ids: an id is a 64-bit hash of (kind, key) and never 0. File assets are keyed by the hash
// of their bytes, so the same file content gets the same id in every run, on every machine and
// under any path; in-memory assets (glTF primitives, procedural meshes, materials) are keyed by a
// caller-chosen string that names what they are (e.g. "gltf:<content hash>#mesh3/prim0",
// "primitive:sphere:r=0.5:s=32"). Adding a key that already exists returns the existing asset
// (its reference count goes up; the new data is dropped).
//
// Reference counting: every load/add returns one reference owned by the caller; retain() adds
// one, release() drops one and frees the asset when the count reaches zero. Ids of freed assets
// stay valid numbers: loading the same content again returns the same id.
//
// Cache: with a cache directory, loadMesh() stores the processed mesh (parsed, validated, normals
// generated when the file has none) as <cacheDir>/meshes/<content hash>.pmesh and later loads of
// the same bytes read that file instead of parsing. A cache file is never trusted: its header,
// sizes and checksum are verified and anything wrong is reported (warning), deleted and rebuilt.
//
// Baked fields: bakeSdf() turns a mesh asset into an SdfField asset keyed by
// "bake:<mesh key>:<bakeSettingsKey()>", so one mesh baked with the same settings is one asset per
// process. With a cache directory the field is also stored as <cacheDir>/sdf/<hash>.psdf (F32) and
// read back in later processes instead of baking; <hash> is contentHash() of the key and of the
// mesh's positions and indices (an in-memory mesh key reused for other geometry never reads a
// stale field). Cached .psdf files are verified like loadPsdf() (header, sizes, CRCs); a bad one
// is reported (warning), deleted and baked again.
// Not thread-safe.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "engine/assets/mesh.h"
#include "engine/assets/texture.h"
#include "engine/ecs/components.h"
#include "engine/sdf/bake.h"
#include "engine/sdf/psdf.h"
#include "engine/sdf/shape_program.h"

namespace penumbra::assets {

using AssetId = ecs::AssetId;

// ShapeProgram: compiled analytic shapes (engine/sdf/shape_program.h); SdfField: a .psdf grid.
enum class AssetKind : uint8_t { Mesh, Material, Texture, ShapeProgram, SdfField, Count };
const char* assetKindName(AssetKind kind);

struct AssetManagerDesc {
    std::string cacheDir;  // empty: no disk cache
    MeshLoadLimits meshLimits;
    TextureLoadLimits textureLimits;
};

struct AssetInfo {
    AssetId id = 0;
    AssetKind kind = AssetKind::Mesh;
    std::string key;
    std::string sourcePath;  // file it came from, if any
    uint32_t refCount = 0;
    uint64_t bytes = 0;  // CPU memory held
};

struct AssetCacheStats {
    uint64_t hits = 0;      // processed meshes read from the cache
    uint64_t misses = 0;    // parsed because no cache file existed
    uint64_t writes = 0;    // cache files written
    uint64_t rejected = 0;  // cache files found corrupt or stale, deleted and rebuilt
    // bakeSdf(): baked fields (<cacheDir>/sdf/*.psdf). Hits, misses, writes and rejections count
    // only with a cache directory; bakes counts every bake this manager ran (cache or not).
    uint64_t sdfHits = 0;      // fields read from the cache instead of baking
    uint64_t sdfMisses = 0;    // no cache file existed: baked
    uint64_t sdfWrites = 0;    // cache files written
    uint64_t sdfRejected = 0;  // cache files found corrupt or stale, deleted and baked again
    uint64_t sdfBakes = 0;     // sdf::bake() runs (a field already in memory or cached is not baked)
};

// Importer for extra mesh file types (e.g. from a plugin): same contract as loadMesh().
using MeshFileImporter = std::function<bool(const std::string& path, MeshData& out, std::string& error)>;

class AssetManager {
public:
    explicit AssetManager(AssetManagerDesc desc = {});
    ~AssetManager();
    AssetManager(const AssetManager&) = delete;
    AssetManager& operator=(const AssetManager&) = delete;

    // ---- loading (each returns one reference; 0 and `error` on failure, nothing kept) ---------
    // A render-ready mesh from .ply/.obj/.gltf/.glb (or a registered importer's extension):
    // validated by the loaders, smooth area-weighted normals generated when the file has none.
    AssetId loadMesh(const std::string& path, std::string& error);
    // A PNG or JPEG texture as RGBA8 (see texture.h); `srgb` marks colour data.
    AssetId loadTexture(const std::string& path, bool srgb, std::string& error);
    // A .psdf signed-distance field, fully validated (sdf::readPsdf), keyed by its content hash.
    AssetId loadPsdf(const std::string& path, std::string& error);
    // The signed distance field of a mesh asset as an SdfField asset (sdf::bake with `settings`;
    // the header is the one a written F32 .psdf of the bake has: dims, origin, voxel size, sign
    // method and topology flags, mesh bounds after clean-up, min/max distance). Same mesh key and
    // same bakeSettingsKey() -> the same asset (one more reference; no bake). With a cache
    // directory the result is read from / written to <cacheDir>/sdf/ (see the header comment).
    // settings.progress, when set, receives the bake's progress; otherwise a progress bar is drawn
    // on stderr when it is a terminal and the bake takes longer than a second. Bakes of a second
    // or more are logged (info). 0 and `error` when `mesh` is not a mesh asset or the bake fails
    // (e.g. "mesh has no non-degenerate triangles").
    AssetId bakeSdf(AssetId mesh, const sdf::BakeSettings& settings, std::string& error);
    // A second SdfField asset with the same field as `field` under the key
    // "copy:<tag>:<field's key>" (one more reference when that copy exists): a distinct id, so the
    // renderer gives it its own atlas slot (a non-instanced object: scene sdf "shared": false),
    // while the CPU grid is shared (the copy counts 0 bytes). 0 and `error` when `field` is not a
    // field asset.
    AssetId copySdfField(AssetId field, std::string_view tag, std::string& error);

    // ---- in-memory assets ------------------------------------------------------------------
    // Meshes are validated (indices in range, multiple of 3, finite positions, attribute counts);
    // 0 with `error` if invalid. Normals are generated when empty.
    AssetId addMesh(std::string_view key, MeshData mesh, std::string& error);
    AssetId addMaterial(std::string_view key, const ecs::Material& material);
    AssetId addTexture(std::string_view key, TextureData texture, std::string& error);
    // Checked with sdf::validateShapeProgram; 0 with `error` if invalid. shapeProgramKey() gives
    // the content key, so identical programs share one asset (instancing).
    AssetId addShapeProgram(std::string_view key, sdf::ShapeProgram program, std::string& error);

    // ---- references ----------------------------------------------------------------------
    bool retain(AssetId id);              // false for an unknown id
    bool release(AssetId id);             // false for an unknown id; frees the asset at zero
    uint32_t refCount(AssetId id) const;  // 0 for unknown / freed ids

    // ---- access (null when unknown, freed, or of another kind) --------------------------------
    const MeshData* mesh(AssetId id) const;
    const ecs::Material* material(AssetId id) const;
    const TextureData* texture(AssetId id) const;
    const sdf::ShapeProgram* shapeProgram(AssetId id) const;
    const sdf::PsdfAsset* sdfField(AssetId id) const;
    bool contains(AssetId id) const;
    const AssetInfo* info(AssetId id) const;

    size_t count() const;
    size_t count(AssetKind kind) const;
    uint64_t memoryBytes(AssetKind kind) const;
    std::vector<AssetInfo> list() const;  // sorted by id

    void setMeshImporter(std::string_view extension, MeshFileImporter importer);

    const AssetCacheStats& cacheStats() const { return m_cacheStats; }
    const std::string& cacheDir() const { return m_desc.cacheDir; }

    // 128-bit content hash of a byte range as 32 lower-case hex digits (two independent 64-bit
    // hashes; used for cache file names and file-asset keys).
    static std::string contentHash(const void* data, size_t size);
    // The id for (kind, key): FNV-1a 64 of "<kind>:<key>", never 0.
    static AssetId stableId(AssetKind kind, std::string_view key);
    // "shapes:<content hash of the records>".
    static std::string shapeProgramKey(const sdf::ShapeProgram& program);
    // Canonical text of everything in `settings` that changes a bake's result (resolution, voxel
    // size, padding, sign method, quality, flipInsideOut, and the bake cache version), e.g.
    // "v1:res=128:vs=0:pad=2:sign=auto:q=medium:flip=1". Threads and progress do not change it
    // (the baker's grids are bitwise identical for any thread count).
    static std::string bakeSettingsKey(const sdf::BakeSettings& settings);

private:
    struct Entry;
    AssetId insert(AssetKind kind, std::string_view key, std::string sourcePath, std::shared_ptr<void> data,
                   uint64_t bytes);
    Entry* find(AssetId id);
    const Entry* find(AssetId id) const;

    AssetManagerDesc m_desc;
    std::unordered_map<AssetId, std::unique_ptr<Entry>> m_entries;
    std::unordered_map<std::string, MeshFileImporter> m_importers;
    AssetCacheStats m_cacheStats;
};

// Fills `mesh.normals` with smooth, area-weighted vertex normals when it is empty (unit length;
// vertices touched only by degenerate triangles get +Y).
void generateNormals(MeshData& mesh);

// Checks a mesh as addMesh() does; false with a message naming `what` and the reason.
bool validateMesh(const MeshData& mesh, std::string_view what, std::string& error);

}  // namespace penumbra::assets
