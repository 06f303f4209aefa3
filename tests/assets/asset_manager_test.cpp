// The asset manager: stable ids, reference counts, mesh validation, normal generation and the
// processed-mesh (.pmesh) disk cache, including corrupt cache files.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>
#include <glm/glm.hpp>

#include "assets/assets_test_util.h"
#include "engine/assets/asset_manager.h"
#include "engine/core/log.h"
#include "engine/image/image.h"

namespace penumbra::assets {
namespace {

namespace fs = std::filesystem;

std::string readFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Reference FNV-1a 64 (offset basis 0xcbf29ce484222325, prime 0x100000001b3).
uint64_t fnv1a(const std::string& s) {
    uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : s) {
        h = (h ^ c) * 0x100000001b3ull;
    }
    return h;
}

// Two triangles (a unit square in z = 0) with texture coordinates, no normals.
MeshData square() {
    MeshData m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    m.indices = {0, 1, 2, 0, 2, 3};
    return m;
}

// A unit cube with 4 vertices per face (24), counter-clockwise seen from outside.
MeshData cube() {
    MeshData m;
    const glm::vec3 normals[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const glm::vec3& n : normals) {
        // Two axes spanning the face with u x v = n.
        const glm::vec3 u = std::abs(n.y) > 0.5f ? glm::vec3(0, 0, n.y) : glm::vec3(-n.z, 0, n.x);
        const glm::vec3 v = glm::cross(n, u);
        const uint32_t base = uint32_t(m.positions.size());
        m.positions.push_back(n * 0.5f - u * 0.5f - v * 0.5f);
        m.positions.push_back(n * 0.5f + u * 0.5f - v * 0.5f);
        m.positions.push_back(n * 0.5f + u * 0.5f + v * 0.5f);
        m.positions.push_back(n * 0.5f - u * 0.5f + v * 0.5f);
        m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
    return m;
}

std::string writeSquarePly(const test::TempDir& dir, const std::string& name) {
    const std::string path = dir.file(name);
    std::string error;
    EXPECT_TRUE(writePly(path, square(), error)) << error;
    return path;
}

// Captures warnings logged during a test.
class LogCapture {
public:
    LogCapture() {
        m_previous = log::setSink([this](log::Severity s, std::string_view m) {
            if (s >= log::Severity::Warning) {
                m_messages.emplace_back(m);
            }
        });
    }
    ~LogCapture() { log::setSink(m_previous); }
    const std::vector<std::string>& messages() const { return m_messages; }

private:
    log::Sink m_previous;
    std::vector<std::string> m_messages;
};

void expectSameMesh(const MeshData& a, const MeshData& b) {
    ASSERT_EQ(a.positions.size(), b.positions.size());
    ASSERT_EQ(a.normals.size(), b.normals.size());
    ASSERT_EQ(a.uvs.size(), b.uvs.size());
    EXPECT_EQ(a.indices, b.indices);
    for (size_t i = 0; i < a.positions.size(); ++i) {
        ASSERT_EQ(a.positions[i], b.positions[i]) << "vertex " << i;  // bit-exact: the cache stores floats
        ASSERT_EQ(a.normals[i], b.normals[i]) << "vertex " << i;
    }
    for (size_t i = 0; i < a.uvs.size(); ++i) {
        ASSERT_EQ(a.uvs[i], b.uvs[i]) << "vertex " << i;
    }
}

TEST(AssetManager, StableIdIsFnv1aOfKindAndKeyAndNeverZero) {
    EXPECT_EQ(AssetManager::stableId(AssetKind::Material, "red"), fnv1a("material:red"));
    EXPECT_EQ(AssetManager::stableId(AssetKind::Mesh, "file:abc"), fnv1a("mesh:file:abc"));
    EXPECT_EQ(AssetManager::stableId(AssetKind::Texture, "t"), fnv1a("texture:t"));
    EXPECT_NE(AssetManager::stableId(AssetKind::Mesh, "x"), AssetManager::stableId(AssetKind::Material, "x"));
    EXPECT_NE(AssetManager::stableId(AssetKind::Mesh, ""), 0u);
}

TEST(AssetManager, ContentHashIs32HexDigitsAndSensitiveToEveryByte) {
    const std::string a = "the quick brown fox jumps over the lazy dog";
    const std::string h = AssetManager::contentHash(a.data(), a.size());
    ASSERT_EQ(h.size(), 32u);
    EXPECT_EQ(h.find_first_not_of("0123456789abcdef"), std::string::npos) << h;
    EXPECT_EQ(h, AssetManager::contentHash(a.data(), a.size()));
    for (size_t i = 0; i < a.size(); ++i) {
        std::string b = a;
        b[i] ^= 1;
        const std::string hb = AssetManager::contentHash(b.data(), b.size());
        // Both 64-bit halves change when any single bit changes.
        EXPECT_NE(h.substr(0, 16), hb.substr(0, 16)) << "byte " << i;
        EXPECT_NE(h.substr(16), hb.substr(16)) << "byte " << i;
    }
    // Length matters even when the extra bytes are zero.
    const std::string z1(7, '\0'), z2(8, '\0');
    EXPECT_NE(AssetManager::contentHash(z1.data(), z1.size()),
              AssetManager::contentHash(z2.data(), z2.size()));
}

TEST(AssetManager, IdsAreStableAcrossManagers) {
    test::TempDir dir;
    const std::string path = writeSquarePly(dir, "square.ply");
    std::string error;
    AssetManager a;
    AssetManager b;
    const AssetId ma = a.loadMesh(path, error);
    ASSERT_NE(ma, 0u) << error;
    const AssetId mb = b.loadMesh(path, error);
    EXPECT_EQ(ma, mb);
    const std::string bytes = readFile(path);
    const std::string key = "file:" + AssetManager::contentHash(bytes.data(), bytes.size());
    EXPECT_EQ(ma, AssetManager::stableId(AssetKind::Mesh, key));
    ASSERT_NE(a.info(ma), nullptr);
    EXPECT_EQ(a.info(ma)->key, key);
    EXPECT_EQ(a.info(ma)->sourcePath, path);
    EXPECT_EQ(a.addMaterial("red", ecs::Material{}), b.addMaterial("red", ecs::Material{}));
}

TEST(AssetManager, SameContentUnderTwoPathsIsOneAsset) {
    test::TempDir dir;
    const std::string p1 = writeSquarePly(dir, "one.ply");
    const std::string p2 = dir.file("two.ply");
    fs::copy_file(p1, p2);
    AssetManager assets;
    std::string error;
    const AssetId a = assets.loadMesh(p1, error);
    const AssetId b = assets.loadMesh(p2, error);
    ASSERT_NE(a, 0u) << error;
    EXPECT_EQ(a, b);
    EXPECT_EQ(assets.count(), 1u);
    EXPECT_EQ(assets.refCount(a), 2u);
    // Different content, different id.
    MeshData other = square();
    other.positions[2].z = 0.5f;
    const std::string p3 = dir.file("three.ply");
    ASSERT_TRUE(writePly(p3, other, error)) << error;
    const AssetId c = assets.loadMesh(p3, error);
    ASSERT_NE(c, 0u) << error;
    EXPECT_NE(c, a);
    EXPECT_EQ(assets.count(AssetKind::Mesh), 2u);
}

TEST(AssetManager, ReferenceCountingFreesAtZero) {
    AssetManager assets;
    ecs::Material m;
    m.roughness = 0.25f;
    const AssetId id = assets.addMaterial("rough", m);
    ASSERT_NE(id, 0u);
    EXPECT_EQ(assets.refCount(id), 1u);
    EXPECT_TRUE(assets.retain(id));
    EXPECT_EQ(assets.refCount(id), 2u);
    // Adding the same key again is one more reference to the existing asset; the new data is dropped.
    ecs::Material other;
    other.roughness = 0.75f;
    EXPECT_EQ(assets.addMaterial("rough", other), id);
    EXPECT_EQ(assets.refCount(id), 3u);
    ASSERT_NE(assets.material(id), nullptr);
    EXPECT_EQ(assets.material(id)->roughness, 0.25f);
    EXPECT_TRUE(assets.release(id));
    EXPECT_TRUE(assets.release(id));
    EXPECT_TRUE(assets.contains(id));
    EXPECT_TRUE(assets.release(id));
    EXPECT_FALSE(assets.contains(id));
    EXPECT_EQ(assets.material(id), nullptr);
    EXPECT_EQ(assets.info(id), nullptr);
    EXPECT_EQ(assets.refCount(id), 0u);
    EXPECT_EQ(assets.count(), 0u);
    EXPECT_FALSE(assets.release(id));
    EXPECT_FALSE(assets.retain(id));
    EXPECT_FALSE(assets.retain(12345));
    // The freed id is a valid number: the same key gets it back.
    EXPECT_EQ(assets.addMaterial("rough", other), id);
    EXPECT_EQ(assets.material(id)->roughness, 0.75f);
}

TEST(AssetManager, AccessorsCheckTheKind) {
    AssetManager assets;
    std::string error;
    const AssetId mat = assets.addMaterial("m", ecs::Material{});
    const AssetId mesh = assets.addMesh("sq", square(), error);
    ASSERT_NE(mesh, 0u) << error;
    EXPECT_EQ(assets.mesh(mat), nullptr);
    EXPECT_EQ(assets.texture(mat), nullptr);
    EXPECT_NE(assets.material(mat), nullptr);
    EXPECT_EQ(assets.material(mesh), nullptr);
    EXPECT_NE(assets.mesh(mesh), nullptr);
    EXPECT_EQ(assets.mesh(0), nullptr);
}

struct BadMesh {
    const char* name;
    MeshData mesh;
    const char* keyword;
};

TEST(AssetManager, AddMeshValidates) {
    std::vector<BadMesh> cases;
    {
        MeshData m = square();
        m.indices[4] = 9;
        cases.push_back({"index", m, "vertex index 9 out of range"});
    }
    {
        MeshData m = square();
        m.indices.pop_back();
        cases.push_back({"count", m, "not a multiple of 3"});
    }
    {
        MeshData m = square();
        m.positions[1].y = NAN;
        cases.push_back({"nan", m, "non-finite position"});
    }
    {
        MeshData m = square();
        m.normals.assign(3, glm::vec3(0, 0, 1));
        cases.push_back({"normals", m, "3 normals for 4 vertices"});
    }
    {
        MeshData m = square();
        m.uvs.pop_back();
        cases.push_back({"uvs", m, "3 texture coordinates for 4 vertices"});
    }
    {
        MeshData m = square();
        m.uvs[0].x = INFINITY;
        cases.push_back({"uvinf", m, "non-finite texture coordinate"});
    }
    cases.push_back({"empty", MeshData{}, "no triangles"});
    AssetManager assets;
    for (BadMesh& c : cases) {
        std::string error;
        EXPECT_EQ(assets.addMesh(c.name, std::move(c.mesh), error), 0u) << c.name;
        EXPECT_NE(error.find(std::string("mesh '") + c.name + "'"), std::string::npos) << error;
        EXPECT_NE(error.find(c.keyword), std::string::npos) << c.name << ": " << error;
    }
    EXPECT_EQ(assets.count(), 0u);

    AssetManagerDesc desc;
    desc.meshLimits.maxTriangles = 1;
    AssetManager limited(desc);
    std::string error;
    EXPECT_EQ(limited.addMesh("two", square(), error), 0u);
    EXPECT_NE(error.find("limit"), std::string::npos) << error;
}

TEST(AssetManager, GeneratesUnitFaceNormalsForACube) {
    AssetManager assets;
    std::string error;
    const AssetId id = assets.addMesh("cube", cube(), error);
    ASSERT_NE(id, 0u) << error;
    const MeshData* m = assets.mesh(id);
    ASSERT_NE(m, nullptr);
    ASSERT_EQ(m->normals.size(), 24u);
    const glm::vec3 expected[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (size_t i = 0; i < 24; ++i) {
        // Each vertex touches only its own face: the normal is that face's outward normal.
        EXPECT_NEAR(glm::length(m->normals[i]), 1.0f, 1e-6f) << i;
        EXPECT_LT(glm::length(m->normals[i] - expected[i / 4]), 1e-6f) << "vertex " << i;
    }
}

TEST(AssetManager, GeneratedNormalsAreAreaWeightedAndUnit) {
    // Vertex 0 is shared by a large triangle in z = 0 (normal +Z, area 2) and a small one in
    // x = 0 (normal +X, area 0.125): the normal leans towards +Z by the area ratio 16:1.
    MeshData m;
    m.positions = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, -0.5f}, {0, 0.5f, 0}, {5, 5, 5}, {6, 6, 6}};
    m.indices = {0, 1, 2, 0, 3, 4, 5, 6, 5};  // the last triangle is degenerate
    generateNormals(m);
    ASSERT_EQ(m.normals.size(), 7u);
    const glm::vec3 n0 = glm::normalize(glm::vec3(0.25f, 0, 4));  // 2 * area: (0.25, 0, 4)
    EXPECT_LT(glm::length(m.normals[0] - n0), 1e-6f);
    for (const glm::vec3& n : m.normals) {
        EXPECT_NEAR(glm::length(n), 1.0f, 1e-6f);
    }
    // Vertices touched only by a degenerate triangle get +Y.
    EXPECT_EQ(m.normals[5], glm::vec3(0, 1, 0));
    EXPECT_EQ(m.normals[6], glm::vec3(0, 1, 0));
    // Existing normals are left alone.
    const std::vector<glm::vec3> before = m.normals;
    m.positions[0].x = 10;
    generateNormals(m);
    EXPECT_EQ(m.normals, before);
}

TEST(AssetManager, CacheMissThenHit) {
    test::TempDir dir;
    const std::string path = writeSquarePly(dir, "square.ply");
    const std::string cacheDir = dir.file("cache");
    AssetManagerDesc desc;
    desc.cacheDir = cacheDir;
    std::string error;
    MeshData first;
    std::string hash;
    {
        AssetManager assets(desc);
        const AssetId id = assets.loadMesh(path, error);
        ASSERT_NE(id, 0u) << error;
        EXPECT_EQ(assets.cacheStats().misses, 1u);
        EXPECT_EQ(assets.cacheStats().writes, 1u);
        EXPECT_EQ(assets.cacheStats().hits, 0u);
        first = *assets.mesh(id);
        const std::string bytes = readFile(path);
        hash = AssetManager::contentHash(bytes.data(), bytes.size());
        EXPECT_TRUE(fs::is_regular_file(cacheDir + "/meshes/" + hash + ".pmesh"));
        // A second load in the same manager is a reference, not a cache access.
        EXPECT_EQ(assets.loadMesh(path, error), id);
        EXPECT_EQ(assets.cacheStats().hits + assets.cacheStats().misses, 1u);
    }
    // No temporary files are left behind.
    size_t files = 0;
    for (const auto& e : fs::directory_iterator(cacheDir + "/meshes")) {
        EXPECT_EQ(e.path().extension(), ".pmesh") << e.path();
        ++files;
    }
    EXPECT_EQ(files, 1u);
    ASSERT_EQ(first.normals.size(), 4u);
    EXPECT_EQ(first.normals[0], glm::vec3(0, 0, 1));

    AssetManager again(desc);
    const AssetId id = again.loadMesh(path, error);
    ASSERT_NE(id, 0u) << error;
    EXPECT_EQ(again.cacheStats().hits, 1u);
    EXPECT_EQ(again.cacheStats().misses, 0u);
    EXPECT_EQ(again.cacheStats().writes, 0u);
    EXPECT_EQ(again.cacheStats().rejected, 0u);
    expectSameMesh(*again.mesh(id), first);
    EXPECT_EQ(again.mesh(id)->sourcePath, path);
}

TEST(AssetManager, CacheHitDoesNotParse) {
    // Proof that a hit reads the cache: the importer is not called again by a second manager.
    test::TempDir dir;
    const std::string path = dir.write("thing.tri", "one triangle");
    AssetManagerDesc desc;
    desc.cacheDir = dir.file("cache");
    int calls = 0;
    auto importer = [&](const std::string&, MeshData& out, std::string&) {
        ++calls;
        out.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
        out.uvs = {{0, 0}, {1, 0}, {0, 1}};
        out.indices = {0, 1, 2};
        return true;
    };
    std::string error;
    AssetManager first(desc);
    first.setMeshImporter("tri", importer);
    const AssetId id = first.loadMesh(path, error);
    ASSERT_NE(id, 0u) << error;
    EXPECT_EQ(calls, 1);
    AssetManager second(desc);
    second.setMeshImporter("tri", importer);
    ASSERT_EQ(second.loadMesh(path, error), id) << error;
    EXPECT_EQ(calls, 1);
    EXPECT_EQ(second.cacheStats().hits, 1u);
    expectSameMesh(*second.mesh(id), *first.mesh(id));
    EXPECT_EQ(second.mesh(id)->uvs.size(), 3u);
}

enum class Corruption {
    FlipPayloadByte,
    Truncate,
    AppendByte,
    BadMagic,
    HugeVertexCount,
    WrongVersion,
    Empty
};

const char* corruptionName(Corruption c) {
    switch (c) {
        case Corruption::FlipPayloadByte:
            return "flip";
        case Corruption::Truncate:
            return "truncate";
        case Corruption::AppendByte:
            return "append";
        case Corruption::BadMagic:
            return "magic";
        case Corruption::HugeVertexCount:
            return "count";
        case Corruption::WrongVersion:
            return "version";
        case Corruption::Empty:
            return "empty";
    }
    return "?";
}

class CorruptCache : public testing::TestWithParam<Corruption> {};

TEST_P(CorruptCache, IsRejectedDeletedAndRebuilt) {
    test::TempDir dir;
    const std::string path = writeSquarePly(dir, "square.ply");
    AssetManagerDesc desc;
    desc.cacheDir = dir.file("cache");
    std::string error;
    MeshData original;
    {
        AssetManager assets(desc);
        const AssetId id = assets.loadMesh(path, error);
        ASSERT_NE(id, 0u) << error;
        original = *assets.mesh(id);
    }
    const std::string bytes = readFile(path);
    const std::string pmesh =
        desc.cacheDir + "/meshes/" + AssetManager::contentHash(bytes.data(), bytes.size()) + ".pmesh";
    std::string cached = readFile(pmesh);
    ASSERT_GT(cached.size(), 100u);
    switch (GetParam()) {
        case Corruption::FlipPayloadByte:
            cached[80] ^= 0x10;
            break;
        case Corruption::Truncate:
            cached.resize(cached.size() / 2);
            break;
        case Corruption::AppendByte:
            cached.push_back('x');
            break;
        case Corruption::BadMagic:
            cached[0] = 'X';
            break;
        case Corruption::HugeVertexCount:
            cached[40 + 5] = 0x7f;  // vertex count ~ 2^46: must be refused before allocating
            break;
        case Corruption::WrongVersion:
            cached[8] = 99;
            break;
        case Corruption::Empty:
            cached.clear();
            break;
    }
    std::ofstream(pmesh, std::ios::binary | std::ios::trunc) << cached;

    LogCapture logs;
    AssetManager assets(desc);
    const AssetId id = assets.loadMesh(path, error);
    ASSERT_NE(id, 0u) << error;
    EXPECT_EQ(assets.cacheStats().rejected, 1u);
    EXPECT_EQ(assets.cacheStats().hits, 0u);
    EXPECT_EQ(assets.cacheStats().writes, 1u);
    expectSameMesh(*assets.mesh(id), original);
    ASSERT_EQ(logs.messages().size(), 1u);
    EXPECT_NE(logs.messages()[0].find(pmesh), std::string::npos) << logs.messages()[0];
    EXPECT_NE(logs.messages()[0].find("rejected"), std::string::npos) << logs.messages()[0];
    // The rebuilt file is good again.
    AssetManager after(desc);
    ASSERT_NE(after.loadMesh(path, error), 0u) << error;
    EXPECT_EQ(after.cacheStats().hits, 1u);
    EXPECT_EQ(after.cacheStats().rejected, 0u);
}

INSTANTIATE_TEST_SUITE_P(Kinds, CorruptCache,
                         testing::Values(Corruption::FlipPayloadByte, Corruption::Truncate,
                                         Corruption::AppendByte, Corruption::BadMagic,
                                         Corruption::HugeVertexCount, Corruption::WrongVersion,
                                         Corruption::Empty),
                         [](const testing::TestParamInfo<Corruption>& info) {
                             return std::string(corruptionName(info.param));
                         });

TEST(AssetManager, CacheFileOfOtherContentIsStale) {
    // A cache file renamed to another mesh's hash names the wrong source: stale, rebuilt.
    test::TempDir dir;
    const std::string a = writeSquarePly(dir, "a.ply");
    MeshData other = square();
    other.positions[3].x = -1;
    const std::string b = dir.file("b.ply");
    std::string error;
    ASSERT_TRUE(writePly(b, other, error)) << error;
    AssetManagerDesc desc;
    desc.cacheDir = dir.file("cache");
    {
        AssetManager assets(desc);
        ASSERT_NE(assets.loadMesh(a, error), 0u) << error;
        ASSERT_NE(assets.loadMesh(b, error), 0u) << error;
    }
    const std::string ba = readFile(a), bb = readFile(b);
    const std::string pa =
        desc.cacheDir + "/meshes/" + AssetManager::contentHash(ba.data(), ba.size()) + ".pmesh";
    const std::string pb =
        desc.cacheDir + "/meshes/" + AssetManager::contentHash(bb.data(), bb.size()) + ".pmesh";
    fs::copy_file(pa, pb, fs::copy_options::overwrite_existing);
    LogCapture logs;
    AssetManager assets(desc);
    const AssetId id = assets.loadMesh(b, error);
    ASSERT_NE(id, 0u) << error;
    EXPECT_EQ(assets.cacheStats().rejected, 1u);
    EXPECT_EQ(assets.mesh(id)->positions[3].x, -1.0f);
    ASSERT_EQ(logs.messages().size(), 1u);
    EXPECT_NE(logs.messages()[0].find("stale"), std::string::npos) << logs.messages()[0];
}

TEST(AssetManager, CountsMemoryAndList) {
    AssetManager assets;
    std::string error;
    const AssetId mesh = assets.addMesh("sq", square(), error);
    ASSERT_NE(mesh, 0u) << error;
    const AssetId m1 = assets.addMaterial("a", ecs::Material{});
    const AssetId m2 = assets.addMaterial("b", ecs::Material{});
    TextureData tex;
    tex.width = 2;
    tex.height = 3;
    tex.rgba8.assign(24, 7);
    tex.sourcePath = "made-in-test";
    const AssetId t = assets.addTexture("tex", tex, error);
    ASSERT_NE(t, 0u) << error;
    EXPECT_EQ(assets.count(), 4u);
    EXPECT_EQ(assets.count(AssetKind::Mesh), 1u);
    EXPECT_EQ(assets.count(AssetKind::Material), 2u);
    EXPECT_EQ(assets.count(AssetKind::Texture), 1u);
    // square(): 4 positions + 4 generated normals (12 bytes each), 4 uvs (8), 6 indices (4).
    EXPECT_EQ(assets.memoryBytes(AssetKind::Mesh), 4u * 12 + 4u * 12 + 4u * 8 + 6u * 4);
    EXPECT_EQ(assets.memoryBytes(AssetKind::Texture), 24u);
    EXPECT_EQ(assets.memoryBytes(AssetKind::Material), 2 * sizeof(ecs::Material));
    const std::vector<AssetInfo> list = assets.list();
    ASSERT_EQ(list.size(), 4u);
    for (size_t i = 1; i < list.size(); ++i) {
        EXPECT_LT(list[i - 1].id, list[i].id);
    }
    for (const AssetInfo& info : list) {
        EXPECT_EQ(info.refCount, 1u);
        if (info.id == t) {
            EXPECT_EQ(info.kind, AssetKind::Texture);
            EXPECT_EQ(info.key, "tex");
            EXPECT_EQ(info.sourcePath, "made-in-test");
        } else if (info.id == mesh) {
            EXPECT_EQ(info.kind, AssetKind::Mesh);
        } else {
            EXPECT_TRUE(info.id == m1 || info.id == m2);
            EXPECT_EQ(info.kind, AssetKind::Material);
        }
    }
    EXPECT_STREQ(assetKindName(AssetKind::Texture), "texture");
    assets.release(t);
    EXPECT_EQ(assets.memoryBytes(AssetKind::Texture), 0u);
}

TEST(AssetManager, AddTextureValidates) {
    AssetManager assets;
    std::string error;
    TextureData bad;
    bad.width = 2;
    bad.height = 2;
    bad.rgba8.assign(15, 0);
    EXPECT_EQ(assets.addTexture("short", bad, error), 0u);
    EXPECT_NE(error.find("texture 'short'"), std::string::npos) << error;
    EXPECT_NE(error.find("expected 16"), std::string::npos) << error;
    TextureData empty;
    EXPECT_EQ(assets.addTexture("empty", empty, error), 0u);
    EXPECT_NE(error.find("empty texture"), std::string::npos) << error;
    EXPECT_EQ(assets.count(), 0u);
}

TEST(AssetManager, LoadMeshErrors) {
    test::TempDir dir;
    AssetManager assets;
    std::string error;
    EXPECT_EQ(assets.loadMesh(dir.file("missing.ply"), error), 0u);
    EXPECT_NE(error.find("missing.ply"), std::string::npos) << error;
    EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
    const std::string unknown = dir.write("mesh.xyz", "1 2 3\n");
    EXPECT_EQ(assets.loadMesh(unknown, error), 0u);
    EXPECT_NE(error.find("unknown mesh format"), std::string::npos) << error;
    const std::string broken = dir.write("broken.ply", "ply\nformat ascii 1.0\nelement vertex 3\n");
    EXPECT_EQ(assets.loadMesh(broken, error), 0u);
    EXPECT_NE(error.find("broken.ply"), std::string::npos) << error;
    EXPECT_EQ(assets.count(), 0u);

    AssetManagerDesc desc;
    desc.meshLimits.maxFileBytes = 16;
    desc.cacheDir = dir.file("cache");
    AssetManager small(desc);
    const std::string big = writeSquarePly(dir, "big.ply");
    EXPECT_EQ(small.loadMesh(big, error), 0u);
    EXPECT_NE(error.find("file too large"), std::string::npos) << error;
    EXPECT_EQ(small.cacheStats().misses + small.cacheStats().hits, 0u);
    EXPECT_FALSE(fs::exists(desc.cacheDir));
}

TEST(AssetManager, RegisteredImporter) {
    test::TempDir dir;
    const std::string path = dir.write("thing.tri", "a triangle");
    AssetManager assets;
    int calls = 0;
    assets.setMeshImporter(".TRI", [&](const std::string& p, MeshData& out, std::string&) {
        ++calls;
        out.positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, -1}};
        out.indices = {0, 1, 2};
        out.sourcePath = p;
        return true;
    });
    std::string error;
    const AssetId id = assets.loadMesh(path, error);
    ASSERT_NE(id, 0u) << error;
    EXPECT_EQ(calls, 1);
    ASSERT_EQ(assets.mesh(id)->normals.size(), 3u);
    EXPECT_LT(glm::length(assets.mesh(id)->normals[0] - glm::vec3(0, 1, 0)), 1e-6f);
    // An importer producing a bad mesh is refused with its file named.
    const std::string bad = dir.write("bad.tri", "another");
    assets.setMeshImporter("tri", [](const std::string&, MeshData& out, std::string&) {
        out.positions = {{0, 0, 0}};
        out.indices = {0, 0, 5};
        return true;
    });
    EXPECT_EQ(assets.loadMesh(bad, error), 0u);
    EXPECT_NE(error.find("bad.tri"), std::string::npos) << error;
    EXPECT_NE(error.find("out of range"), std::string::npos) << error;
    EXPECT_EQ(assets.count(), 1u);
}

TEST(AssetManager, LoadTextureKeysBySrgbAndContent) {
    test::TempDir dir;
    ImageRGBA8 img;
    img.width = 2;
    img.height = 1;
    img.pixels = {255, 0, 0, 255, 0, 0, 255, 128};
    const std::string path = dir.file("t.png");
    ASSERT_TRUE(writePng(path, img));
    AssetManager assets;
    std::string error;
    const AssetId srgb = assets.loadTexture(path, true, error);
    const AssetId linear = assets.loadTexture(path, false, error);
    ASSERT_NE(srgb, 0u) << error;
    ASSERT_NE(linear, 0u) << error;
    EXPECT_NE(srgb, linear);
    EXPECT_TRUE(assets.texture(srgb)->srgb);
    EXPECT_FALSE(assets.texture(linear)->srgb);
    EXPECT_EQ(assets.texture(linear)->rgba8, img.pixels);
    EXPECT_EQ(assets.loadTexture(path, true, error), srgb);
    EXPECT_EQ(assets.refCount(srgb), 2u);
    const std::string garbage = dir.write("g.png", "definitely not an image");
    EXPECT_EQ(assets.loadTexture(garbage, true, error), 0u);
    EXPECT_NE(error.find("g.png"), std::string::npos) << error;
    EXPECT_EQ(assets.count(), 2u);
}

TEST(AssetManager, LoadsTheNpmBunny) {
    const std::string path = test::npmMesh("bunny.ply");
    ASSERT_FALSE(path.empty());
    test::TempDir dir;
    AssetManagerDesc desc;
    desc.cacheDir = dir.file("cache");
    AssetManager assets(desc);
    std::string error;
    const AssetId id = assets.loadMesh(path, error);
    ASSERT_NE(id, 0u) << error;
    const MeshData* m = assets.mesh(id);
    ASSERT_NE(m, nullptr);
    EXPECT_EQ(m->positions.size(), 1839u);  // `element vertex 1839` in the file's header
    EXPECT_EQ(m->triangleCount(), 3674u);   // `element face 3674`
    ASSERT_EQ(m->normals.size(), m->positions.size());
    size_t unit = 0;
    for (const glm::vec3& n : m->normals) {
        unit += std::abs(glm::length(n) - 1.0f) < 1e-5f ? 1 : 0;
    }
    EXPECT_EQ(unit, m->normals.size());  // every normal unit length within 1e-5
    // Normals point outwards on average: the dot product with (vertex - centroid) is positive
    // for most vertices of this closed-ish, roughly convex mesh (threshold 80 %).
    glm::vec3 centroid(0.0f);
    for (const glm::vec3& p : m->positions) {
        centroid += p / float(m->positions.size());
    }
    size_t outward = 0;
    for (size_t i = 0; i < m->positions.size(); ++i) {
        outward += glm::dot(m->normals[i], m->positions[i] - centroid) > 0.0f ? 1 : 0;
    }
    EXPECT_GT(double(outward) / double(m->positions.size()), 0.8);
    EXPECT_EQ(assets.memoryBytes(AssetKind::Mesh), 1839u * 24 + 3674u * 12);
    // And from the cache, identical.
    AssetManager cached(desc);
    const AssetId again = cached.loadMesh(path, error);
    ASSERT_EQ(again, id) << error;
    EXPECT_EQ(cached.cacheStats().hits, 1u);
    expectSameMesh(*cached.mesh(again), *m);
}

}  // namespace
}  // namespace penumbra::assets

namespace penumbra::assets {
namespace {

// Split vertices at one position share their normal when their faces are nearly coplanar (a seam),
// but not across a crease sharper than 60 degrees.
TEST(AssetManager, GeneratedNormalsSmoothSplitSeamsButKeepCreases) {
    // Two triangles meeting at the edge x = 0 with their own copies of the edge vertices; the right
    // one is tilted by 20 degrees about z (a seam), a third copy continues at 90 degrees (a crease).
    const float c = std::cos(0.349066f), s = std::sin(0.349066f);
    MeshData m;
    m.positions = {{-1, 0, 0}, {0, 0, -1}, {0, 0, 1},    // left, in y = 0, normal +Y
                   {0, 0, -1}, {0, 0, 1},  {c, s, 0},    // right copy, tilted up by 20 degrees
                   {0, 0, -1}, {0, 0, 1},  {0, -1, 0}};  // wall going down from the edge: crease
    m.indices = {0, 2, 1, 3, 4, 5, 6, 8, 7};
    generateNormals(m);
    ASSERT_EQ(m.normals.size(), 9u);
    // The left and right copies of the edge vertex agree (smoothed across the 20-degree seam) ...
    EXPECT_LT(glm::length(m.normals[1] - m.normals[3]), 1e-6f);
    EXPECT_LT(glm::length(m.normals[2] - m.normals[4]), 1e-6f);
    // ... and lie between the two face normals, not equal to the left one.
    EXPECT_GT(glm::length(m.normals[1] - glm::vec3(0, 1, 0)), 0.05f);
    // The wall's copies keep the wall's own normal (90 degrees away: not blended).
    const glm::vec3 wall =
        glm::normalize(glm::cross(m.positions[8] - m.positions[6], m.positions[7] - m.positions[6]));
    EXPECT_LT(glm::length(m.normals[6] - wall), 1e-6f);
    EXPECT_LT(glm::length(m.normals[7] - wall), 1e-6f);
}

}  // namespace
}  // namespace penumbra::assets
