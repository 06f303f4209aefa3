// glTF instance amplification (issue 8, item 13): a scene may not list a root twice, and the
// triangles and vertices of every node instance are totalled against MeshLoadLimits before any
// instance is read or merged, with a message that gives the totals and how to raise the limit.
// The fixtures are generated here: a mesh of K triangles (in an external .bin) used by N nodes.
#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "assets/assets_test_util.h"
#include "engine/assets/gltf_scene.h"
#include "engine/assets/mesh.h"
#include "engine/ecs/world.h"

namespace penumbra::assets {
namespace {

// Writes dir/inst.gltf + inst.bin: mesh 0 = K triangles (0, 1, 2) over 3 vertices, nodes 0..N-1
// each {"mesh": 0}, all listed as roots of scene 0 (or `roots` verbatim when given).
std::string writeInstanced(const test::TempDir& dir, uint32_t triangles, uint32_t nodes,
                           const std::string& roots = "") {
    std::string bin(36 + 6 * size_t(triangles), '\0');
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    std::memcpy(bin.data(), pos, sizeof pos);
    for (uint32_t t = 0; t < triangles; ++t) {
        const uint16_t idx[3] = {0, 1, 2};
        std::memcpy(bin.data() + 36 + 6 * size_t(t), idx, sizeof idx);
    }
    bin.resize((bin.size() + 3) / 4 * 4, '\0');
    dir.write("inst.bin", bin);
    std::string nodeList, rootList;
    for (uint32_t n = 0; n < nodes; ++n) {
        nodeList += std::string(n ? "," : "") + R"({"mesh":0})";
        rootList += std::string(n ? "," : "") + std::to_string(n);
    }
    return dir.write(
        "inst.gltf",
        R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":)" + std::to_string(bin.size()) +
            R"(,"uri":"inst.bin"}],"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},)" +
            R"({"buffer":0,"byteOffset":36,"byteLength":)" + std::to_string(6 * size_t(triangles)) +
            R"(}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",)" +
            R"("min":[0,0,0],"max":[1,1,0]},{"bufferView":1,"componentType":5123,"count":)" +
            std::to_string(3 * size_t(triangles)) +
            R"(,"type":"SCALAR"}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],)" +
            R"("nodes":[)" + nodeList + R"(],"scenes":[{"nodes":[)" + (roots.empty() ? rootList : roots) +
            R"(]}],"scene":0})");
}

// Metric: the issue's file (one root listed 20 000 times) is refused with "listed twice" by the
// mesh loader and by the scene loader; before the fix it loaded 20 000 copies.
TEST(GltfInstancing, DuplicateSceneRootsAreRefused) {
    test::TempDir dir;
    std::string roots;
    for (int i = 0; i < 20000; ++i) roots += std::string(i ? "," : "") + "0";
    const std::string path = writeInstanced(dir, 100, 1, roots);
    MeshData mesh;
    std::string error;
    EXPECT_FALSE(loadMesh(path, mesh, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("scene 0: node 0 is listed twice in 'nodes'"), std::string::npos) << error;
    EXPECT_TRUE(mesh.positions.empty());

    ecs::World world;
    AssetManager assets;
    std::vector<AssetId> acquired;
    error.clear();
    EXPECT_FALSE(loadGltfScene(path, world, assets, acquired, error));
    EXPECT_NE(error.find("listed twice"), std::string::npos) << error;
    EXPECT_EQ(world.aliveCount(), 0u);
    EXPECT_TRUE(acquired.empty());
}

// Metric: 20 000 nodes x 10 000 triangles = 200 000 000 instanced triangles (a 300 KB file) are
// refused by the default limit (16 Mi triangles) with the exact total, the implied memory and the
// flag to raise it. The total can only be in the message if it was counted before merging (the
// old loader merged up to the limit, 1 GB and seconds, and then reported "more than N").
TEST(GltfInstancing, InstancedTotalIsBoundedBeforeMerging) {
    test::TempDir dir;
    const std::string path = writeInstanced(dir, 10000, 20000);
    MeshData mesh;
    std::string error;
    EXPECT_FALSE(loadMesh(path, mesh, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("instances 20000 meshes with 200000000 triangles and 60000 vertices"),
              std::string::npos)
        << error;
    EXPECT_NE(error.find("exceeds the limit of 16777216 triangles"), std::string::npos) << error;
    EXPECT_NE(error.find("MiB merged"), std::string::npos) << error;
    EXPECT_NE(error.find("--max-triangles"), std::string::npos) << error;
    EXPECT_TRUE(mesh.indices.empty());
}

// Metric: 50 nodes x 100 triangles: refused at maxTriangles 4999, loaded with exactly 5000
// triangles and 150 vertices at 5000 (the limit is inclusive and can be raised); the vertex total
// is bounded the same way.
TEST(GltfInstancing, LimitIsInclusiveAndCanBeRaised) {
    test::TempDir dir;
    const std::string path = writeInstanced(dir, 100, 50);
    MeshLoadLimits limits;
    limits.maxTriangles = 4999;
    MeshData mesh;
    std::string error;
    EXPECT_FALSE(loadMesh(path, mesh, error, limits));
    EXPECT_NE(error.find("5000 triangles"), std::string::npos) << error;
    EXPECT_NE(error.find("limit of 4999 triangles"), std::string::npos) << error;
    limits.maxTriangles = 5000;
    ASSERT_TRUE(loadMesh(path, mesh, error, limits)) << error;
    EXPECT_EQ(mesh.triangleCount(), 5000u);
    EXPECT_EQ(mesh.positions.size(), 150u);
    limits.maxVertices = 149;
    EXPECT_FALSE(loadMesh(path, mesh, error, limits));
    EXPECT_NE(error.find("limit of 149 vertices"), std::string::npos) << error;
    EXPECT_NE(error.find("maxVertices"), std::string::npos) << error;
}

}  // namespace
}  // namespace penumbra::assets
