// The real test meshes from npm (tools/fetch_meshes.sh): exact counts from their PLY headers.
#include <chrono>
#include <cmath>

#include <gtest/gtest.h>
#include <glm/glm.hpp>

#include "assets/assets_test_util.h"
#include "engine/assets/mesh.h"

namespace penumbra::assets {
namespace {

struct NpmMesh {
    const char* file;
    size_t vertices;
    size_t triangles;
    glm::vec3 boundsMin;  // bounding box, measured once
    glm::vec3 boundsMax;
};

void PrintTo(const NpmMesh& m, std::ostream* os) { *os << m.file; }

class NpmMeshTest : public testing::TestWithParam<NpmMesh> {};

TEST_P(NpmMeshTest, LoadsWithExactCounts) {
    const NpmMesh& expected = GetParam();
    const std::string path = test::npmMesh(expected.file);
    ASSERT_FALSE(path.empty());
    MeshData mesh;
    std::string error;
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_TRUE(loadMesh(path, mesh, error)) << error;
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    RecordProperty("load_ms", std::to_string(ms));
    EXPECT_EQ(mesh.positions.size(), expected.vertices);
    EXPECT_EQ(mesh.triangleCount(), expected.triangles);
    EXPECT_EQ(mesh.sourcePath, path);
    EXPECT_TRUE(mesh.normals.empty());
    EXPECT_TRUE(mesh.uvs.empty());
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (const glm::vec3& p : mesh.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(lo[a], expected.boundsMin[a], 2e-6f) << "axis " << a;
        EXPECT_NEAR(hi[a], expected.boundsMax[a], 2e-6f) << "axis " << a;
    }
    for (uint32_t i : mesh.indices) {
        ASSERT_LT(i, mesh.positions.size());
    }
}

// Counts are the `element vertex` / `element face` lines of the files (every face is a triangle);
// bounds were measured once and pin down that coordinates are parsed, not just counted.
INSTANTIATE_TEST_SUITE_P(
    Npm, NpmMeshTest,
    testing::Values(
        NpmMesh{
            "bunny.ply", 1839, 3674, {-4.958475f, -0.003149f, -3.729833f}, {4.948850f, 9.654748f, 3.810639f}},
        NpmMesh{"teapot.ply", 792, 992, {-16.0703125f, -7.875f, -10.0f}, {16.0703125f, 7.875f, 10.0f}},
        NpmMesh{"dragon_vrip.ply",
                437645,
                871414,
                {-0.108324f, 0.0527295f, -0.0504143f},
                {0.0965662f, 0.197173f, 0.0412075f}},
        NpmMesh{"dragon_vrip_res2.ply",
                100250,
                202520,
                {-0.108188f, 0.0527392f, -0.0503454f},
                {0.0964062f, 0.197139f, 0.0411367f}},
        NpmMesh{"dragon_vrip_res3.ply",
                22998,
                47794,
                {-0.107673f, 0.0527743f, -0.050051f},
                {0.0959825f, 0.196644f, 0.0408262f}},
        NpmMesh{"dragon_vrip_res4.ply",
                5205,
                11102,
                {-0.107585f, 0.0528441f, -0.0498360f},
                {0.0952357f, 0.196343f, 0.0408262f}}),
    [](const testing::TestParamInfo<NpmMesh>& info) {
        std::string name = info.param.file;
        return name.substr(0, name.find('.'));
    });

TEST(NpmMeshes, LimitsAreEnforcedOnRealData) {
    const std::string path = test::npmMesh("bunny.ply");
    ASSERT_FALSE(path.empty());
    MeshData mesh;
    std::string error;
    MeshLoadLimits limits;
    limits.maxTriangles = 1000;
    EXPECT_FALSE(loadMesh(path, mesh, error, limits));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("limit"), std::string::npos) << error;
    EXPECT_TRUE(mesh.positions.empty());

    limits = {};
    limits.maxVertices = 100;
    EXPECT_FALSE(loadMesh(path, mesh, error, limits));
    EXPECT_NE(error.find("vertex limit"), std::string::npos) << error;

    limits = {};
    limits.maxFileBytes = 1000;
    EXPECT_FALSE(loadMesh(path, mesh, error, limits));
    EXPECT_NE(error.find("too large"), std::string::npos) << error;
}

}  // namespace
}  // namespace penumbra::assets
