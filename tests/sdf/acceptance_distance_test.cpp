// Acceptance, distance: at 2000 random voxel centres (1000 uniform over the grid, 1000 uniform
// among the voxels within 3 voxels of the surface) of bakes of the real meshes (bunny, teapot,
// dragon_vrip_res3; written to and read back from a .psdf image, f32), the stored |d| equals an
// independent brute-force exact distance (every triangle, region tests, double) within 1e-4
// voxel. Needs data/meshes (tools/fetch_meshes.sh); fails, not skips, when it is missing.
#include <gtest/gtest.h>

#include <random>

#include "engine/sdf/bake.h"
#include "engine/sdf/psdf.h"
#include "sdf/acceptance_support.h"

namespace {

using namespace penumbra;
using namespace penumbra::acceptance;

constexpr size_t kSamples = 2000;
constexpr double kToleranceVoxels = 1e-4;

void checkDistances(const char* meshName, uint32_t resolution) {
    assets::MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadAcceptanceMesh(PENUMBRA_SOURCE_DIR, meshName, mesh, error)) << error;
    sdf::BakeSettings settings;
    settings.resolution = resolution;
    const sdf::BakeResult baked = sdf::bake(mesh, settings);
    ASSERT_TRUE(baked.ok) << meshName << ": " << baked.error;

    // Through the file format, as an asset would be used.
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(sdf::encodePsdf(baked.grid, {}, bytes, error)) << error;
    sdf::PsdfAsset asset;
    ASSERT_TRUE(sdf::decodePsdf(bytes.data(), bytes.size(), meshName, asset, error)) << error;
    const sdf::SdfGrid& g = asset.grid;

    std::mt19937_64 rng(0x5eed + resolution);
    std::vector<glm::uvec3> band;
    for (uint32_t k = 0; k < g.dims.z; ++k)
        for (uint32_t j = 0; j < g.dims.y; ++j)
            for (uint32_t i = 0; i < g.dims.x; ++i)
                if (std::fabs(g.distances[g.index(i, j, k)]) < 3 * g.voxelSize) band.push_back({i, j, k});
    ASSERT_GT(band.size(), 100u) << meshName;
    std::vector<glm::uvec3> voxels(kSamples);
    for (size_t i = 0; i < kSamples; ++i)
        voxels[i] = i % 2 ? band[rng() % band.size()]
                          : glm::uvec3(uint32_t(rng() % g.dims.x), uint32_t(rng() % g.dims.y),
                                       uint32_t(rng() % g.dims.z));
    const std::vector<Triangle> tris = toTriangles(mesh);
    std::vector<double> exact(kSamples);
    parallelIndices(kSamples, hardwareThreads(), [&](size_t i) {
        exact[i] = bruteForceDistance(tris, g.voxelCenter(voxels[i].x, voxels[i].y, voxels[i].z));
    });

    double worst = 0, sum = 0;
    size_t worstIndex = 0, nearSurface = 0;
    for (size_t i = 0; i < kSamples; ++i) {
        const double stored = g.distances[g.index(voxels[i].x, voxels[i].y, voxels[i].z)];
        const double e = std::fabs(std::fabs(stored) - exact[i]) / g.voxelSize;
        sum += e;
        if (exact[i] < 3 * g.voxelSize) ++nearSurface;
        if (e > worst) {
            worst = e;
            worstIndex = i;
        }
    }
    const glm::uvec3 w = voxels[worstIndex];
    EXPECT_LE(worst, kToleranceVoxels)
        << meshName << ": voxel (" << w.x << ", " << w.y << ", " << w.z << ") stores "
        << g.distances[g.index(w.x, w.y, w.z)] << ", brute force " << exact[worstIndex] << " (voxel size "
        << g.voxelSize << ")";
    testing::Test::RecordProperty(std::string(meshName) + "_triangles", std::to_string(tris.size()));
    testing::Test::RecordProperty(
        std::string(meshName) + "_dims",
        std::to_string(g.dims.x) + "x" + std::to_string(g.dims.y) + "x" + std::to_string(g.dims.z));
    testing::Test::RecordProperty(std::string(meshName) + "_max_error_voxels", std::to_string(worst));
    testing::Test::RecordProperty(std::string(meshName) + "_mean_error_voxels",
                                  std::to_string(sum / kSamples));
    testing::Test::RecordProperty(std::string(meshName) + "_samples_within_3_voxels",
                                  std::to_string(nearSurface));
    std::printf(
        "[ distance ] %s: %zu triangles, %ux%ux%u, %zu voxel centres (%zu within 3 voxels of the "
        "surface): max | |stored| - exact | = %.3g voxel, mean %.3g voxel\n",
        meshName, tris.size(), g.dims.x, g.dims.y, g.dims.z, kSamples, nearSurface, worst, sum / kSamples);
}

TEST(AcceptanceDistance, Bunny) { checkDistances("bunny.ply", 64); }
TEST(AcceptanceDistance, Teapot) { checkDistances("teapot.ply", 64); }
TEST(AcceptanceDistance, DragonVripRes3) { checkDistances("dragon_vrip_res3.ply", 64); }

}  // namespace
