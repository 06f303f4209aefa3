// glTF loading of the fixtures in tests/assets/fixtures (written by tests/assets/make_test_files.py).
#include <filesystem>
#include <map>

#include <gtest/gtest.h>
#include <glm/glm.hpp>

#include "assets/assets_test_util.h"
#include "engine/assets/mesh.h"

namespace penumbra::assets {
namespace {

std::string fixture(const std::string& name) { return test::sourcePath("tests/assets/fixtures/" + name); }

void expectNear(const glm::vec3& a, const glm::vec3& b, float eps = 1e-5f) {
    EXPECT_NEAR(a.x, b.x, eps);
    EXPECT_NEAR(a.y, b.y, eps);
    EXPECT_NEAR(a.z, b.z, eps);
}

glm::vec3 faceNormal(const MeshData& m, size_t t) {
    const glm::vec3 a = m.positions[m.indices[3 * t]];
    const glm::vec3 b = m.positions[m.indices[3 * t + 1]];
    const glm::vec3 c = m.positions[m.indices[3 * t + 2]];
    return glm::normalize(glm::cross(b - a, c - a));
}

TEST(Gltf, NodeHierarchyTransformsAreApplied) {
    MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadMesh(fixture("hierarchy.gltf"), mesh, error)) << error;
    // Default scene 0: root (T(10,0,0) S(2)) with children "rotated" (90 deg about z) and "matrix"
    // (T(0,0,5)), whose child "mirrored" has scale (-1,1,1). Node 4 is only in scene 1.
    ASSERT_EQ(mesh.positions.size(), 9u);
    ASSERT_EQ(mesh.triangleCount(), 3u);
    // rotated
    expectNear(mesh.positions[0], {10, 0, 0});
    expectNear(mesh.positions[1], {10, 2, 0});
    expectNear(mesh.positions[2], {8, 0, 0});
    // matrix
    expectNear(mesh.positions[3], {10, 0, 10});
    expectNear(mesh.positions[4], {12, 0, 10});
    expectNear(mesh.positions[5], {10, 2, 10});
    // mirrored: x flipped before the parent transforms; winding reversed to keep the facing.
    expectNear(mesh.positions[6], {10, 0, 10});
    expectNear(mesh.positions[7], {8, 0, 10});
    expectNear(mesh.positions[8], {10, 2, 10});
    for (size_t t = 0; t < 3; ++t) {
        expectNear(faceNormal(mesh, t), {0, 0, 1});
    }
    for (const glm::vec3& p : mesh.positions) {
        EXPECT_LT(p.x, 50.0f) << "node outside the default scene was instanced";
    }
}

TEST(Gltf, GlbCubeIsClosedAndOutwardFacing) {
    MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadMesh(fixture("cube.glb"), mesh, error)) << error;
    ASSERT_EQ(mesh.positions.size(), 8u);
    ASSERT_EQ(mesh.triangleCount(), 12u);
    std::map<std::pair<uint32_t, uint32_t>, int> directedEdges;
    double volume = 0.0;
    for (size_t t = 0; t < 12; ++t) {
        const uint32_t* tri = &mesh.indices[3 * t];
        for (int k = 0; k < 3; ++k) {
            ++directedEdges[{tri[k], tri[(k + 1) % 3]}];
        }
        const glm::dvec3 a = mesh.positions[tri[0]], b = mesh.positions[tri[1]], c = mesh.positions[tri[2]];
        volume += glm::dot(a, glm::cross(b, c)) / 6.0;
    }
    for (const auto& [edge, count] : directedEdges) {
        EXPECT_EQ(count, 1);
        EXPECT_EQ(directedEdges.count({edge.second, edge.first}), 1u) << "boundary edge";
    }
    EXPECT_NEAR(volume, 1.0, 1e-9);
}

TEST(Gltf, ExternalBufferInterleavedStrideAndRootNodesWithoutScene) {
    MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadMesh(fixture("external.gltf"), mesh, error)) << error;
    ASSERT_EQ(mesh.positions.size(), 4u);
    ASSERT_EQ(mesh.triangleCount(), 2u);
    expectNear(mesh.positions[2], {2, 3, 1});
    ASSERT_EQ(mesh.normals.size(), 4u);
    for (const glm::vec3& n : mesh.normals) {
        expectNear(n, {0, 0, 1});
    }
    const std::vector<uint32_t> expected = {0, 1, 2, 0, 2, 3};
    EXPECT_EQ(mesh.indices, expected);
}

TEST(Gltf, ExternalBufferWorksFromAnotherWorkingDirectory) {
    const auto previous = std::filesystem::current_path();
    std::filesystem::current_path(std::filesystem::temp_directory_path());
    MeshData mesh;
    std::string error;
    const bool ok = loadMesh(fixture("external.gltf"), mesh, error);
    std::filesystem::current_path(previous);
    EXPECT_TRUE(ok) << error;
}

TEST(Gltf, RelativeAssetPathWithExternalBuffer) {
    const auto previous = std::filesystem::current_path();
    std::filesystem::current_path(test::sourcePath("tests/assets"));
    MeshData mesh;
    std::string error;
    const bool ok = loadMesh("fixtures/external.gltf", mesh, error);
    std::filesystem::current_path(previous);
    EXPECT_TRUE(ok) << error;
    EXPECT_EQ(mesh.triangleCount(), 2u);
}

TEST(Gltf, SparseAccessorAndTriangleStrip) {
    MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadMesh(fixture("sparse_strip.gltf"), mesh, error)) << error;
    ASSERT_EQ(mesh.positions.size(), 7u);
    ASSERT_EQ(mesh.triangleCount(), 3u);
    expectNear(mesh.positions[2], {0, 5, 0});  // sparse override of vertex 2
    const std::vector<uint32_t> expected = {0, 1, 2, 3, 4, 5, 4, 6, 5};
    EXPECT_EQ(mesh.indices, expected);
    for (size_t t = 1; t < 3; ++t) {
        expectNear(faceNormal(mesh, t), {0, 0, 1});
    }
}

TEST(Gltf, FixturesRoundTripThroughPly) {
    MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadMesh(fixture("cube.glb"), mesh, error)) << error;
    test::TempDir dir;
    ASSERT_TRUE(writePly(dir.file("cube.ply"), mesh, error)) << error;
    MeshData back;
    ASSERT_TRUE(loadMesh(dir.file("cube.ply"), back, error)) << error;
    EXPECT_EQ(back.indices, mesh.indices);
    EXPECT_EQ(back.positions, mesh.positions);
}

}  // namespace
}  // namespace penumbra::assets
