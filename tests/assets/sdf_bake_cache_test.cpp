// AssetManager::bakeSdf: baked fields as SdfField assets (header as a written .psdf), one asset
// per mesh and settings, the .psdf bake cache across asset managers (hits, misses, writes,
// corrupt files rebaked with a warning), the settings key, and clear errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "assets/assets_test_util.h"
#include "engine/assets/asset_manager.h"
#include "engine/assets/primitives.h"
#include "engine/core/log.h"
#include "engine/sdf/bake.h"
#include "engine/sdf/psdf.h"

namespace penumbra::assets {
namespace {

namespace fs = std::filesystem;

MeshData box(float half = 0.5f) {
    MeshData mesh;
    std::string error;
    EXPECT_TRUE(makeBox(glm::vec3(half), mesh, error)) << error;
    return mesh;
}

AssetManagerDesc withCache(const std::string& dir) {
    AssetManagerDesc desc;
    desc.cacheDir = dir;
    return desc;
}

sdf::BakeSettings at(uint32_t resolution) {
    sdf::BakeSettings s;
    s.resolution = resolution;
    s.threads = 2;
    return s;
}

// The .psdf files in <cacheDir>/sdf.
std::vector<std::string> cacheFiles(const std::string& cacheDir) {
    std::vector<std::string> out;
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(fs::path(cacheDir) / "sdf", ec)) {
        out.push_back(entry.path().string());
    }
    return out;
}

class WarningCapture {
public:
    WarningCapture() {
        m_previous = log::setSink([this](log::Severity s, std::string_view m) {
            if (s >= log::Severity::Warning) m_messages.emplace_back(m);
        });
    }
    ~WarningCapture() { log::setSink(m_previous); }
    const std::vector<std::string>& messages() const { return m_messages; }

private:
    log::Sink m_previous;
    std::vector<std::string> m_messages;
};

void expectSameField(const sdf::PsdfAsset& a, const sdf::PsdfAsset& b) {
    EXPECT_EQ(a.header.dims, b.header.dims);
    EXPECT_EQ(a.header.origin, b.header.origin);
    EXPECT_EQ(a.header.voxelSize, b.header.voxelSize);
    EXPECT_EQ(a.header.flags, b.header.flags);
    EXPECT_EQ(a.header.boundsMin, b.header.boundsMin);
    EXPECT_EQ(a.header.boundsMax, b.header.boundsMax);
    EXPECT_EQ(a.header.payloadCrc, b.header.payloadCrc);
    EXPECT_EQ(a.grid.distances, b.grid.distances);  // bit-exact: f32
}

// Criterion: a bake is an SdfField asset whose header is the one the written .psdf would have
// (closed cube: pseudonormal sign, closed-manifold flag, bounds, min/max distance), whose field is
// the cube's distance, and baking the same mesh with the same settings again returns the same
// asset (one more reference, no second bake).
TEST(SdfBakeCache, BakeIsAFieldAssetSharedPerMeshAndSettings) {
    AssetManager assets;
    std::string error;
    const AssetId mesh = assets.addMesh("test:box", box(), error);
    ASSERT_NE(mesh, 0u) << error;
    const AssetId a = assets.bakeSdf(mesh, at(24), error);
    ASSERT_NE(a, 0u) << error;
    const AssetId b = assets.bakeSdf(mesh, at(24), error);
    EXPECT_EQ(a, b);
    EXPECT_EQ(assets.refCount(a), 2u);
    EXPECT_EQ(assets.cacheStats().sdfBakes, 1u);
    EXPECT_EQ(assets.cacheStats().sdfMisses, 0u);  // no cache directory: nothing counted
    ASSERT_NE(assets.info(a), nullptr);
    EXPECT_EQ(assets.info(a)->kind, AssetKind::SdfField);
    EXPECT_EQ(assets.info(a)->key, "bake:test:box:" + AssetManager::bakeSettingsKey(at(24)));

    const sdf::PsdfAsset* field = assets.sdfField(a);
    ASSERT_NE(field, nullptr);
    const sdf::PsdfHeader& h = field->header;
    EXPECT_EQ(h.dims, glm::uvec3(24, 24, 24));
    EXPECT_EQ(h.encoding, sdf::PsdfEncoding::F32);
    EXPECT_EQ(h.sign(), sdf::PsdfSign::Pseudonormal);
    EXPECT_NE(h.flags & sdf::kPsdfFlagClosedManifold, 0u);
    EXPECT_EQ(h.flags & (sdf::kPsdfFlagBoundaryEdges | sdf::kPsdfFlagNonManifold), 0u);
    EXPECT_EQ(h.boundsMin, glm::dvec3(-0.5));
    EXPECT_EQ(h.boundsMax, glm::dvec3(0.5));
    EXPECT_NEAR(h.voxelSize, 1.0 / 20.0, 1e-12);  // 24 voxels, 2 of padding on each side
    EXPECT_LT(h.minDistance, -0.4f);
    EXPECT_GT(h.maxDistance, 0.0f);
    EXPECT_EQ(h.voxelCount(), field->grid.distances.size());
    EXPECT_EQ(assets.info(a)->bytes, field->grid.distances.size() * sizeof(float));

    // The encoded header round-trips: re-encoding the asset gives an identical file header.
    std::vector<uint8_t> image;
    sdf::PsdfWriteOptions wo;
    wo.sign = h.sign();
    wo.closedManifold = true;
    wo.boundsMin = h.boundsMin;
    wo.boundsMax = h.boundsMax;
    ASSERT_TRUE(sdf::encodePsdf(field->grid, wo, image, error)) << error;
    sdf::PsdfAsset decoded;
    ASSERT_TRUE(sdf::decodePsdf(image.data(), image.size(), "re-encoded", decoded, error)) << error;
    EXPECT_EQ(decoded.header.headerCrc, h.headerCrc);

    const sdf::SdfSampler sampler(*field);
    EXPECT_NEAR(sampler.sample({0, 0, 0}), -0.5, 0.026);  // half a voxel: trilinear inside a box
    EXPECT_NEAR(sampler.sample({0.75, 0, 0}), 0.25, 0.01);

    // The mesh may go; the field stays until its last reference.
    EXPECT_TRUE(assets.release(mesh));
    EXPECT_TRUE(assets.release(a));
    EXPECT_NE(assets.sdfField(a), nullptr);
    EXPECT_TRUE(assets.release(a));
    EXPECT_EQ(assets.count(), 0u);
}

// Criterion: the key changes with everything that changes the result (resolution, voxel size,
// padding, sign method, quality when automatic, flipInsideOut) and not with threads or progress.
TEST(SdfBakeCache, KeyCoversEverySettingThatChangesTheResult) {
    const sdf::BakeSettings base = at(32);
    const std::string key = AssetManager::bakeSettingsKey(base);
    auto differs = [&](auto change) {
        sdf::BakeSettings s = base;
        change(s);
        return AssetManager::bakeSettingsKey(s) != key;
    };
    EXPECT_TRUE(differs([](sdf::BakeSettings& s) { s.resolution = 33; }));
    EXPECT_TRUE(differs([](sdf::BakeSettings& s) { s.padding = 3; }));
    EXPECT_TRUE(differs([](sdf::BakeSettings& s) { s.sign = sdf::SignMethod::Winding; }));
    EXPECT_TRUE(differs([](sdf::BakeSettings& s) { s.quality = sdf::BakeQuality::High; }));
    EXPECT_TRUE(differs([](sdf::BakeSettings& s) { s.flipInsideOut = false; }));
    EXPECT_TRUE(differs([](sdf::BakeSettings& s) {
        s.resolution = 0;
        s.voxelSize = 0.125;
    }));
    EXPECT_FALSE(differs([](sdf::BakeSettings& s) { s.threads = 7; }));
    EXPECT_FALSE(differs([](sdf::BakeSettings& s) { s.progress = [](double, const char*) {}; }));
    EXPECT_FALSE(differs([](sdf::BakeSettings& s) { s.voxelSize = 0.5; }));  // ignored with a resolution

    AssetManager assets;
    std::string error;
    const AssetId mesh = assets.addMesh("test:box", box(), error);
    const AssetId a = assets.bakeSdf(mesh, at(16), error);
    const AssetId b = assets.bakeSdf(mesh, at(20), error);
    ASSERT_NE(a, 0u) << error;
    ASSERT_NE(b, 0u) << error;
    EXPECT_NE(a, b);
    EXPECT_EQ(assets.sdfField(a)->header.dims.x, 16u);
    EXPECT_EQ(assets.sdfField(b)->header.dims.x, 20u);
    EXPECT_EQ(assets.cacheStats().sdfBakes, 2u);
}

// Criterion: with a cache directory the first manager bakes and writes <cacheDir>/sdf/<hash>.psdf;
// a second manager with the same directory (a later process) reads it instead of baking (hit, no
// bake) and gets an identical field under the same id. Meshes loaded from files work the same.
TEST(SdfBakeCache, SecondManagerReadsTheCache) {
    test::TempDir dir;
    const std::string cacheDir = dir.file("cache");
    std::string error;
    const std::string ply = dir.file("box.ply");
    ASSERT_TRUE(writePly(ply, box(), error)) << error;

    AssetId firstId = 0;
    sdf::PsdfAsset first;
    {
        AssetManager assets(withCache(cacheDir));
        const AssetId mesh = assets.loadMesh(ply, error);
        ASSERT_NE(mesh, 0u) << error;
        firstId = assets.bakeSdf(mesh, at(20), error);
        ASSERT_NE(firstId, 0u) << error;
        EXPECT_EQ(assets.info(firstId)->sourcePath, ply);
        first = *assets.sdfField(firstId);
        const AssetCacheStats& st = assets.cacheStats();
        EXPECT_EQ(st.sdfMisses, 1u);
        EXPECT_EQ(st.sdfHits, 0u);
        EXPECT_EQ(st.sdfWrites, 1u);
        EXPECT_EQ(st.sdfBakes, 1u);
    }
    const std::vector<std::string> files = cacheFiles(cacheDir);
    ASSERT_EQ(files.size(), 1u);
    EXPECT_EQ(fs::path(files[0]).extension(), ".psdf");
    EXPECT_EQ(fs::path(files[0]).stem().string().size(), 32u);  // contentHash()
    sdf::PsdfAsset onDisk;
    ASSERT_TRUE(sdf::readPsdf(files[0], onDisk, error)) << error;
    expectSameField(onDisk, first);

    AssetManager again(withCache(cacheDir));
    const AssetId mesh = again.loadMesh(ply, error);
    ASSERT_NE(mesh, 0u) << error;
    const AssetId id = again.bakeSdf(mesh, at(20), error);
    ASSERT_NE(id, 0u) << error;
    EXPECT_EQ(id, firstId);
    expectSameField(*again.sdfField(id), first);
    const AssetCacheStats& st = again.cacheStats();
    EXPECT_EQ(st.sdfHits, 1u);
    EXPECT_EQ(st.sdfMisses, 0u);
    EXPECT_EQ(st.sdfWrites, 0u);
    EXPECT_EQ(st.sdfBakes, 0u);

    // Another resolution is another cache file.
    ASSERT_NE(again.bakeSdf(mesh, at(16), error), 0u) << error;
    EXPECT_EQ(again.cacheStats().sdfMisses, 1u);
    EXPECT_EQ(cacheFiles(cacheDir).size(), 2u);
}

// Criterion: an in-memory mesh key reused for other geometry in a later process does not read the
// first process's field (the cache file name covers the geometry).
TEST(SdfBakeCache, ReusedInMemoryKeyDoesNotReadAStaleField) {
    test::TempDir dir;
    const std::string cacheDir = dir.file("cache");
    std::string error;
    {
        AssetManager assets(withCache(cacheDir));
        const AssetId mesh = assets.addMesh("test:thing", box(0.5f), error);
        ASSERT_NE(assets.bakeSdf(mesh, at(16), error), 0u) << error;
    }
    AssetManager assets(withCache(cacheDir));
    const AssetId mesh = assets.addMesh("test:thing", box(1.0f), error);
    const AssetId field = assets.bakeSdf(mesh, at(16), error);
    ASSERT_NE(field, 0u) << error;
    EXPECT_EQ(assets.cacheStats().sdfHits, 0u);
    EXPECT_EQ(assets.cacheStats().sdfBakes, 1u);
    EXPECT_EQ(assets.sdfField(field)->header.boundsMax, glm::dvec3(1.0));
}

// Criterion: a corrupt cache file (flipped payload byte, then a truncated file) is reported as a
// warning naming the file, deleted, baked again and rewritten; the result equals a fresh bake.
TEST(SdfBakeCache, CorruptCacheFileIsRebakedWithAWarning) {
    test::TempDir dir;
    const std::string cacheDir = dir.file("cache");
    std::string error;
    sdf::PsdfAsset reference;
    {
        AssetManager assets(withCache(cacheDir));
        const AssetId mesh = assets.addMesh("test:box", box(), error);
        const AssetId field = assets.bakeSdf(mesh, at(16), error);
        ASSERT_NE(field, 0u) << error;
        reference = *assets.sdfField(field);
    }
    const std::vector<std::string> files = cacheFiles(cacheDir);
    ASSERT_EQ(files.size(), 1u);
    const std::string file = files[0];

    auto corruptAndReload = [&](auto corrupt, const char* expectedReason) {
        corrupt();
        WarningCapture warnings;
        AssetManager assets(withCache(cacheDir));
        const AssetId mesh = assets.addMesh("test:box", box(), error);
        const AssetId field = assets.bakeSdf(mesh, at(16), error);
        ASSERT_NE(field, 0u) << error;
        expectSameField(*assets.sdfField(field), reference);
        const AssetCacheStats& st = assets.cacheStats();
        EXPECT_EQ(st.sdfRejected, 1u);
        EXPECT_EQ(st.sdfHits, 0u);
        EXPECT_EQ(st.sdfBakes, 1u);
        EXPECT_EQ(st.sdfWrites, 1u);
        ASSERT_EQ(warnings.messages().size(), 1u);
        const std::string& w = warnings.messages()[0];
        EXPECT_NE(w.find(file), std::string::npos) << w;
        EXPECT_NE(w.find("rejected"), std::string::npos) << w;
        EXPECT_NE(w.find(expectedReason), std::string::npos) << w;
        sdf::PsdfAsset rewritten;
        EXPECT_TRUE(sdf::readPsdf(file, rewritten, error)) << error;
    };
    corruptAndReload(
        [&] {
            std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
            f.seekp(std::streamoff(sdf::kPsdfHeaderBytes + 100));
            f.put('\x7f');
        },
        "CRC");
    corruptAndReload([&] { fs::resize_file(file, sdf::kPsdfHeaderBytes + 10); }, "truncated");
}

// Criterion: a mesh that cannot be baked (zero-area triangles only) fails with a message naming
// the mesh and the reason, keeps nothing and writes no cache file; a non-mesh id is refused.
TEST(SdfBakeCache, UnbakeableMeshIsAClearError) {
    test::TempDir dir;
    AssetManager assets(withCache(dir.file("cache")));
    MeshData flat;
    flat.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 0, 1}};
    flat.indices = {0, 1, 2, 0, 0, 3};
    std::string error;
    const AssetId mesh = assets.addMesh("test:degenerate", flat, error);
    ASSERT_NE(mesh, 0u) << error;
    EXPECT_EQ(assets.bakeSdf(mesh, at(16), error), 0u);
    EXPECT_NE(error.find("mesh 'test:degenerate'"), std::string::npos) << error;
    EXPECT_NE(error.find("no non-degenerate triangles"), std::string::npos) << error;
    EXPECT_EQ(assets.count(AssetKind::SdfField), 0u);
    EXPECT_EQ(assets.cacheStats().sdfWrites, 0u);
    EXPECT_TRUE(cacheFiles(dir.file("cache")).empty());

    const AssetId material = assets.addMaterial("test:m", ecs::Material{});
    error.clear();
    EXPECT_EQ(assets.bakeSdf(material, at(16), error), 0u);
    EXPECT_NE(error.find("not a mesh"), std::string::npos) << error;
    error.clear();
    EXPECT_EQ(assets.bakeSdf(12345, at(16), error), 0u);
    EXPECT_NE(error.find("unknown mesh asset"), std::string::npos) << error;
}

// Criterion: a caller's progress callback receives the bake's progress, ending at 1.
TEST(SdfBakeCache, ProgressReachesTheCaller) {
    AssetManager assets;
    std::string error;
    const AssetId mesh = assets.addMesh("test:box", box(), error);
    sdf::BakeSettings s = at(16);
    double last = -1;
    size_t calls = 0;
    s.progress = [&](double fraction, const char*) {
        last = fraction;
        ++calls;
    };
    ASSERT_NE(assets.bakeSdf(mesh, s, error), 0u) << error;
    EXPECT_GT(calls, 0u);
    EXPECT_DOUBLE_EQ(last, 1.0);
}

}  // namespace
}  // namespace penumbra::assets
