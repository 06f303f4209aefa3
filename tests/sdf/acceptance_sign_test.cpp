// Acceptance, sign: with --sign auto, the baked inside/outside agrees with a brute-force generalized
// winding number (WindingNumber::exact, inside if w > 0.5) at >= 99.9 % of the sampled voxel
// centres where |w - 0.5| > 0.2, on bunny (closed), teapot (open), dragon_vrip_res4 (non-manifold)
// and dragon_vrip (871k triangles; exact() is O(n) per point, so 300 voxel centres there). Half of
// the samples are uniform over the grid, half among voxels within 3 voxels of the surface, where
// the sign is hard. Pseudonormal and parity agreement on the open meshes is computed and reported
// (RecordProperty + stdout), not asserted. Needs data/meshes (tools/fetch_meshes.sh).
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "engine/sdf/bake.h"
#include "engine/sdf/winding.h"
#include "sdf/acceptance_support.h"

namespace {

using namespace penumbra;
using namespace penumbra::acceptance;

constexpr double kConfidence = 0.2;  // |w - 0.5| above this counts
constexpr double kRequired = 0.999;  // agreement required for auto

struct Samples {
    std::vector<glm::uvec3> voxels;
    std::vector<double> winding;
};

struct Agreement {
    size_t confident = 0, agree = 0;
    double fraction() const { return confident ? double(agree) / double(confident) : 0.0; }
};

Agreement agreement(const sdf::SdfGrid& g, const Samples& s) {
    Agreement a;
    for (size_t i = 0; i < s.voxels.size(); ++i) {
        if (!(std::fabs(s.winding[i] - 0.5) > kConfidence)) continue;
        ++a.confident;
        const bool insideRef = s.winding[i] > 0.5;
        const bool insideBake = g.distances[g.index(s.voxels[i].x, s.voxels[i].y, s.voxels[i].z)] < 0;
        if (insideRef == insideBake) ++a.agree;
    }
    return a;
}

void checkSign(const char* meshName, uint32_t resolution, size_t sampleCount, bool reportOthers) {
    assets::MeshData mesh;
    std::string error;
    ASSERT_TRUE(loadAcceptanceMesh(PENUMBRA_SOURCE_DIR, meshName, mesh, error)) << error;
    sdf::BakeSettings settings;
    settings.resolution = resolution;
    settings.sign = sdf::SignMethod::Auto;
    const sdf::BakeResult baked = sdf::bake(mesh, settings);
    ASSERT_TRUE(baked.ok) << meshName << ": " << baked.error;
    const sdf::SdfGrid& g = baked.grid;

    std::mt19937_64 rng(0xa11ce + resolution);
    std::vector<glm::uvec3> band;
    for (uint32_t k = 0; k < g.dims.z; ++k)
        for (uint32_t j = 0; j < g.dims.y; ++j)
            for (uint32_t i = 0; i < g.dims.x; ++i)
                if (std::fabs(g.distances[g.index(i, j, k)]) < 3 * g.voxelSize) band.push_back({i, j, k});
    ASSERT_GT(band.size(), 100u);
    Samples s;
    s.voxels.resize(sampleCount);
    for (size_t i = 0; i < sampleCount; ++i)
        s.voxels[i] = i % 2 ? band[rng() % band.size()]
                            : glm::uvec3(uint32_t(rng() % g.dims.x), uint32_t(rng() % g.dims.y),
                                         uint32_t(rng() % g.dims.z));

    // Reference on the mesh as loaded (no clean-up), in double.
    std::vector<glm::dvec3> positions(mesh.positions.begin(), mesh.positions.end());
    std::vector<glm::uvec3> triangles(mesh.triangleCount());
    for (size_t t = 0; t < triangles.size(); ++t)
        triangles[t] = {mesh.indices[3 * t], mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]};
    const sdf::WindingNumber reference(positions, triangles);
    s.winding.resize(sampleCount);
    parallelIndices(sampleCount, hardwareThreads(), [&](size_t i) {
        s.winding[i] = reference.exact(g.voxelCenter(s.voxels[i].x, s.voxels[i].y, s.voxels[i].z));
    });

    const Agreement autoAgree = agreement(g, s);
    const std::string prefix = std::string(meshName) + "_";
    testing::Test::RecordProperty(prefix + "triangles", std::to_string(triangles.size()));
    testing::Test::RecordProperty(prefix + "boundary_edges", std::to_string(baked.diagnostics.boundaryEdges));
    testing::Test::RecordProperty(prefix + "non_manifold_edges",
                                  std::to_string(baked.diagnostics.nonManifoldEdges));
    testing::Test::RecordProperty(prefix + "auto_method", sdf::toString(baked.signUsed));
    testing::Test::RecordProperty(prefix + "samples", std::to_string(sampleCount));
    testing::Test::RecordProperty(prefix + "confident_samples", std::to_string(autoAgree.confident));
    testing::Test::RecordProperty(prefix + "auto_agreement", std::to_string(autoAgree.fraction()));
    std::printf(
        "[ sign     ] %s: %zu triangles, %llu boundary / %llu non-manifold edges, %ux%ux%u; auto -> %s (%s); "
        "%zu voxel centres sampled, %zu with |w - 0.5| > %.1f; auto agrees at %zu (%.3f %%)\n",
        meshName, triangles.size(), (unsigned long long)baked.diagnostics.boundaryEdges,
        (unsigned long long)baked.diagnostics.nonManifoldEdges, g.dims.x, g.dims.y, g.dims.z,
        sdf::toString(baked.signUsed), baked.signReason.c_str(), sampleCount, autoAgree.confident,
        kConfidence, autoAgree.agree, 100.0 * autoAgree.fraction());
    EXPECT_GE(autoAgree.confident, sampleCount / 2) << meshName;
    EXPECT_GE(autoAgree.fraction(), kRequired)
        << meshName << ": auto (" << sdf::toString(baked.signUsed) << ") agrees with the winding number at "
        << autoAgree.agree << " of " << autoAgree.confident << " voxel centres";

    if (!reportOthers) return;
    for (sdf::SignMethod m : {sdf::SignMethod::Pseudonormal, sdf::SignMethod::Parity}) {
        settings.sign = m;
        const sdf::BakeResult other = sdf::bake(mesh, settings);
        ASSERT_TRUE(other.ok) << other.error;
        ASSERT_EQ(other.grid.dims, g.dims);
        const Agreement a = agreement(other.grid, s);
        testing::Test::RecordProperty(prefix + sdf::toString(m) + "_agreement", std::to_string(a.fraction()));
        std::printf("[ sign     ] %s: %s agrees at %zu of %zu (%.3f %%) (reported, not asserted)\n", meshName,
                    sdf::toString(m), a.agree, a.confident, 100.0 * a.fraction());
    }
}

TEST(AcceptanceSign, BunnyClosed) { checkSign("bunny.ply", 64, 2000, false); }
TEST(AcceptanceSign, TeapotOpen) { checkSign("teapot.ply", 64, 2000, true); }
TEST(AcceptanceSign, DragonVripRes4NonManifold) { checkSign("dragon_vrip_res4.ply", 64, 2000, true); }
TEST(AcceptanceSign, DragonVripFull) { checkSign("dragon_vrip.ply", 64, 300, true); }

}  // namespace
