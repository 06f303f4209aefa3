// Hard cases of baked fields (issue 11 item 4), each on both backends under validation:
//   2a a box mesh 0.3 voxel thick at the default (automatic, quality medium) bake resolution
//   3  open and non-manifold meshes (teapot, dragon_vrip_res4) baked and traced vs rasterized
//   6a two baked boxes with a gap of half a voxel
//   8  degenerate (zero-area) triangles added to a mesh
// Bakes use AssetManager::bakeSdf with default settings and a disk cache under the build folder
// (PENUMBRA_STABILITY_TMP/cache), so the second backend / process reads the .psdf instead of baking.
#include <filesystem>

#include "engine/assets/primitives.h"
#include "reference/reference.h"
#include "stability/stability_util.h"

namespace penumbra::test::stability {
namespace {

using render::FrameDesc;
using render::SceneRenderer;
using scene::TraceQuality;
using sdf::ShapeNode;
namespace cpuref = ::penumbra::reference;  // the CPU reference renderer (tools/reference)

class StabilityBaked : public GpuTest {
protected:
    rhi::Backend backend() const { return GetParam(); }
};

assets::AssetManagerDesc cachedAssets() {
    assets::AssetManagerDesc d;
    d.cacheDir = std::string(PENUMBRA_STABILITY_TMP) + "/cache";
    return d;
}

assets::MeshData boxMesh(glm::vec3 half) {
    assets::MeshData m;
    std::string error;
    EXPECT_TRUE(assets::makeBox(half, m, error)) << error;
    return m;
}

assets::AssetId bake(StabScene& s, assets::AssetId mesh, std::string& error) {
    sdf::BakeSettings settings;  // defaults: automatic resolution (quality medium), padding 2, sign auto
    return s.assets.bakeSdf(mesh, settings, error);
}

// ---- 2a. a baked wall 0.3 voxel thick ---------------------------------------------------------------------

// A box mesh 1 x 1 x t with t = 0.3 voxel: the thin axis is "flat" (< 1/64 of the longest), so the
// automatic resolution is 128 and the voxel 1 / 124; the field's samples never see a negative value.
// Viewed face-on and at 60 degrees, camera 1.5 away. Criterion: of the pixels whose exact ray hits the
// slab and whose 8 neighbours' rays do too (interior), >= 99 % are traced as hits of the wall (rays must
// not pass through), per preset medium and reference; and the traced point lies within 1 voxel +
// 4 * hitEpsilon footprints of the exact slab (perpendicular).
// Shadows (one more frame per angle at "medium", shadows at resolutionScale 1): a floor y = -0.45 in
// front of the wall (the wall reaches 0.05 below it), two suns behind the wall 45 degrees up (toward
// (0, 1, -1)), hard (angular radius 0) and soft (0.5 degrees), the camera raised to (0, 0.6, 0.3).
// Light leaking through the wall is the visibility on the floor's umbra pixels against the exact
// slab (stability_util.h wallShadow, 2 pixel footprints of margin). Criteria: hard sun: umbra mean
// visibility <= 0.01 and no umbra pixel over 0.5; soft sun: umbra mean <= 0.15 and max <= 0.5, the
// measured leak (a known limit of the cone estimate, stated at the assertion); both: lit floor pixels
// darker than 0.5 <= 1 %.
TEST_P(StabilityBaked, Case02a_BakedWallThinnerThanOneVoxel) {
    constexpr uint32_t w = 128, h = 96;
    const double voxel = 1.0 / 124.0, thickness = 0.3 * voxel;
    for (float angle : {0.0f, 60.0f}) {
        StabScene s({0, 0, 0}, {0, 0, -1}, 0.1f, 100.0f, cachedAssets());
        std::string error;
        const assets::AssetId mesh =
            s.assets.addMesh("stability:thin-box", boxMesh({0.5f, 0.5f, float(0.5 * thickness)}), error);
        ASSERT_NE(mesh, 0u) << error;
        const assets::AssetId field = bake(s, mesh, error);
        ASSERT_NE(field, 0u) << error;
        const sdf::PsdfHeader& hd = s.assets.sdfField(field)->header;
        const glm::quat rot = glm::angleAxis(glm::radians(angle), glm::vec3(0, 1, 0));
        const ecs::Entity e = s.field(field, {0, 0, -1.5f}, rot);
        ecs::updateTransforms(s.world);
        const RefCamera cam(s.world, s.camera, w, h);
        const glm::dmat4 model(s.world.get<ecs::Transform>(e)->worldMatrix);
        const glm::dmat4 inv = glm::inverse(model);
        const glm::dvec3 half(0.5, 0.5, double(float(0.5 * thickness)));
        auto exact = [&](const glm::dvec3& o, const glm::dvec3& d) {
            const glm::dvec3 lo(inv * glm::dvec4(o, 1.0)), ld(glm::dmat3(inv) * d);
            Hit hh = rayBox(lo, ld, glm::dvec3(0.0), half, cam.nearPlane);
            if (hh.s != kInf) hh.n = glm::normalize(glm::dmat3(model) * hh.n);
            return hh;
        };
        SceneRenderer r(dev());
        for (TraceQuality q : {TraceQuality::Medium, TraceQuality::Reference}) {
            GBuffer g;
            ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h, q), g));
            const double fp = cam.footprint(), eps = 4.0 * double(scene::tracePreset(q).hitEpsilon);
            size_t interior = 0, interiorHit = 0, over = 0;
            double maxPerpVoxels = 0;
            for (uint32_t y = 1; y + 1 < h; ++y)
                for (uint32_t x = 1; x + 1 < w; ++x) {
                    bool all = true;
                    for (int dy = -1; dy <= 1 && all; ++dy)
                        for (int dx = -1; dx <= 1 && all; ++dx)
                            all = exact(cam.eye, cam.dir(x + dx, y + dy)).s != kInf;
                    if (!all) continue;
                    ++interior;
                    const size_t i = g.at(x, y);
                    if (!g.hit(i) || g.id(i) != int(e.index)) continue;
                    ++interiorHit;
                    const glm::dvec3 d = cam.dir(x, y);
                    const Hit hh = exact(cam.eye, d);
                    const double len = glm::length(d), t = hh.s * len;
                    const double perp =
                        std::abs(double(g.depth[i]) - hh.s) * len * std::abs(glm::dot(hh.n, d / len));
                    maxPerpVoxels = std::max(maxPerpVoxels, perp / hd.voxelSize);
                    over += perp > hd.voxelSize + eps * fp * t + 1e-5 * t;
                }
            const double rate = interior ? double(interiorHit) / double(interior) : 0.0;
            summary("02a thin baked wall", backend(),
                    "%2.0f deg %-9s: voxel %.6f (grid %ux%ux%u), wall %.3f voxel thick; interior hit rate "
                    "%.3f %% of %zu px "
                    "(>= 99 %%), perp. error max %.3f voxel, %zu over 1 voxel + %.2f fp",
                    double(angle), scene::toString(q), hd.voxelSize, hd.dims[0], hd.dims[1], hd.dims[2],
                    2 * half.z / hd.voxelSize, 100 * rate, interior, maxPerpVoxels, over, eps);
            EXPECT_NEAR(hd.voxelSize, voxel, 1e-9)
                << "the automatic resolution changed: the wall is no longer 0.3 voxel";
            EXPECT_TRUE(checkSanity(g, 0.1f, 100.0f).ok());
            EXPECT_GT(interior, size_t(1000));
            EXPECT_GE(rate, 0.99) << scene::toString(q) << ": rays pass through the thin wall";
            EXPECT_EQ(over, 0u) << scene::toString(q);
        }

        // Shadows: light behind the wall, receivers on the floor in front of it.
        const ecs::Entity floor = s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, -0.45f, 0});
        const glm::dvec3 toSun = glm::normalize(glm::dvec3(0.0, 1.0, -1.0));
        const float softRadius = glm::radians(0.5f);
        const ecs::Entity suns[2] = {directionalLight(s, toSun, 0.0f),
                                     directionalLight(s, toSun, softRadius)};
        s.placeCamera({0, 0.6f, 0.3f}, {0, -0.45f, -1.0f});
        FrameDesc fd = s.frame(w, h);
        fd.settings.shadows.resolutionScale = 1.0f;
        GBuffer sg;
        ASSERT_TRUE(renderAndRead(s, r, fd, sg));
        ShadowStrip strip;
        ASSERT_TRUE(readShadow(r, w, h, 2, strip));
        const RefCamera scam(s.world, s.camera, w, h);
        for (uint32_t k = 0; k < 2; ++k) {
            const WallShadowStats ws = wallShadow(sg, scam, int(floor.index), model, half, strip, k,
                                                  towardLight(s, suns[k]), k ? double(softRadius) : 0.0);
            summary("02a thin baked wall", backend(),
                    "%2.0f deg shadow, %s sun: umbra %zu px: visibility mean %.4f max %.3f, %zu over 0.5; "
                    "lit %zu px: mean %.4f, %zu under 0.5",
                    double(angle), k ? "soft 0.5 deg" : "hard", ws.umbra, ws.umbraMean, ws.umbraMax,
                    ws.umbraOver, ws.lit, ws.litMean, ws.litDark);
            EXPECT_GT(ws.umbra, size_t(300));
            EXPECT_GT(ws.lit, size_t(100));
            EXPECT_LE(double(ws.litDark), 0.01 * double(ws.lit)) << "lit floor shadowed";
            if (k == 0) {  // measured 2026-12-02: umbra mean 0, max 0 at both angles
                EXPECT_LE(ws.umbraMean, 0.01) << "hard light leaking through the wall";
                EXPECT_EQ(ws.umbraOver, 0u) << "hard light leaking through the wall";
            } else {
                // Measured 2026-12-02 (both backends): umbra mean 0.100 at 0 deg, 0.056 at 60 deg, max
                // 0.349 / 0.235. A known limit of the cone estimate: the field of a 0.3-voxel wall
                // never goes negative (its samples lie off the slab), so the cone sees distances >= 0
                // and passes light in proportion to how much of its cross-section the interpolated
                // field's thin minimum covers (sdf_cone.glsl: an occluder thinner than the cone's
                // cross-section lets light through). Criterion: the measured values, rounded up.
                EXPECT_LE(ws.umbraMean, 0.15) << "soft light leaking through the wall";
                EXPECT_LE(ws.umbraMax, 0.5) << "soft light leaking through the wall";
            }
        }
    }
}

// ---- 3. open and non-manifold meshes ---------------------------------------------------------------------

// teapot (open: boundary edges) and dragon_vrip_res4 (non-manifold edges), baked with the default
// settings, placed rotated at world radius ~1 and drawn once rasterized (MeshRenderer) and once traced
// (SdfRenderer of the field), 160 x 120. Criteria: (a) silhouette mismatch (pixels hit in one only /
// hit in either) <= 2 % - the issue-10 acceptance value - at the default trace "medium" and at
// "reference"; (b) every one-sided pixel touches a pixel hit in both (no blob or hole away from the
// silhouette: the signature of sign errors of open / non-manifold bakes).
// Shadows (one more frame per mesh, 128 x 96 at "medium", shadows at resolutionScale 1): the traced
// field over a floor 0.25 below the mesh's lowest point, a hard sun (angular radius 0) toward
// (-1, 0.7, 0) (35 degrees up: the shadow falls to the right of the mesh), the camera raised to
// (0, 2.5, 1.5) with a 28-degree field of view on the mesh and its shadow. The floor's shadow visibility
// against the CPU reference renderer's exact visibility of the original mesh (cpuref::lightVisibility, a hard
// light: binary) at the exact floor point of each pixel; pixels within 2 pixels of an exact shadow
// edge (any pixel of the 5 x 5 block around them sees the sun otherwise) are not counted.
// Criterion: disagreeing floor pixels <= 1 % of those counted.
TEST_P(StabilityBaked, Case03_OpenAndNonManifoldMeshes) {
    constexpr uint32_t w = 160, h = 120;
    for (const char* name : {"teapot", "dragon_vrip_res4"}) {
        StabScene s({0, 0, 0}, {0, 0, -1}, 0.05f, 20.0f, cachedAssets());
        const std::string path = std::string(PENUMBRA_SOURCE_DIR) + "/data/meshes/" + name + ".ply";
        ASSERT_TRUE(std::filesystem::exists(path)) << path << " is missing: run tools/fetch_meshes.sh";
        std::string error;
        const assets::AssetId mesh = s.assets.loadMesh(path, error);
        ASSERT_NE(mesh, 0u) << error;
        const assets::AssetId field = bake(s, mesh, error);
        ASSERT_NE(field, 0u) << error;
        const assets::MeshData* md = s.assets.mesh(mesh);
        glm::dvec3 lo(1e300), hi(-1e300);
        for (const glm::vec3& p : md->positions) {
            lo = glm::min(lo, glm::dvec3(p));
            hi = glm::max(hi, glm::dvec3(p));
        }
        const glm::dvec3 centre = 0.5 * (lo + hi);
        double radius = 0;
        for (const glm::vec3& p : md->positions)
            radius = std::max(radius, glm::length(glm::dvec3(p) - centre));
        const float scale = float(1.0 / radius);
        const glm::quat rot = glm::quat(glm::radians(glm::vec3(-23.0f, 37.0f, 11.0f)));
        const glm::vec3 target(0.0f, 0.0f, -2.2f);
        const glm::vec3 position = target - rot * (scale * glm::vec3(centre));
        const ecs::Entity me = s.mesh(mesh, position, rot, glm::vec3(scale));
        const ecs::Entity se = s.field(field, position, rot, glm::vec3(scale));
        const sdf::PsdfHeader& hd = s.assets.sdfField(field)->header;
        SceneRenderer r(dev());
        s.world.get<ecs::SdfRenderer>(se)->visible = false;
        GBuffer raster;
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), raster));
        s.world.get<ecs::SdfRenderer>(se)->visible = true;
        s.world.get<ecs::MeshRenderer>(me)->visible = false;
        for (TraceQuality q : {TraceQuality::Medium, TraceQuality::Reference}) {
            GBuffer g;
            ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h, q), g));
            size_t both = 0, onlyMesh = 0, onlySdf = 0, detached = 0;
            for (uint32_t y = 0; y < h; ++y)
                for (uint32_t x = 0; x < w; ++x) {
                    const size_t i = g.at(x, y);
                    const bool a = raster.hit(i), b = g.hit(i);
                    both += a && b;
                    onlyMesh += a && !b;
                    onlySdf += b && !a;
                    if (a == b) continue;
                    bool touches = false;
                    for (int dy = -1; dy <= 1; ++dy)
                        for (int dx = -1; dx <= 1; ++dx) {
                            const int xx = int(x) + dx, yy = int(y) + dy;
                            if (xx < 0 || yy < 0 || xx >= int(w) || yy >= int(h)) continue;
                            const size_t j = g.at(uint32_t(xx), uint32_t(yy));
                            touches = touches || (raster.hit(j) && g.hit(j));
                        }
                    detached += !touches;
                }
            const size_t either = both + onlyMesh + onlySdf;
            const double mismatch = either ? double(onlyMesh + onlySdf) / double(either) : 1.0;
            summary("03 open/non-manifold", backend(),
                    "%-16s %-9s: grid %ux%ux%u, %zu px in both, silhouette mismatch %.3f %% (<= 2 %%: %zu "
                    "mesh only, %zu sdf "
                    "only), one-sided px away from the silhouette %zu (<= 0.1 %% of both)",
                    name, scene::toString(q), hd.dims[0], hd.dims[1], hd.dims[2], both, 100 * mismatch,
                    onlyMesh, onlySdf, detached);
            EXPECT_TRUE(checkSanity(g, 0.05f, 20.0f).ok());
            EXPECT_GT(both, size_t(w) * h / 10) << name;
            // Measured 2026-12-01: teapot 0.98 % / 0.63 %, dragon_vrip_res4 1.26 % / 1.23 % (medium /
            // reference). One-sided pixels away from the silhouette: teapot 0, dragon_vrip_res4 1 at
            // both presets (not investigated further: an isolated pixel, likely a part of the coarse
            // non-manifold dragon thinner than the 128-voxel field resolves); criterion: at most 0.1 % of the
            // pixels hit in both.
            EXPECT_LE(mismatch, 0.02) << name << " " << scene::toString(q) << ": silhouette mismatch";
            EXPECT_LE(double(detached), 0.001 * double(both))
                << name << " " << scene::toString(q) << ": one-sided pixels away from the silhouette";
        }

        // Shadows of the traced field on a floor, against the original mesh's exact visibility.
        constexpr uint32_t sw = 128, sh = 96;
        ecs::updateTransforms(s.world);
        const glm::dmat4 meshModel(s.world.get<ecs::Transform>(me)->worldMatrix);
        double lowest = 1e300;
        for (const glm::vec3& p : md->positions)
            lowest = std::min(lowest, (meshModel * glm::dvec4(glm::dvec3(p), 1.0)).y);
        const float floorY = float(lowest - 0.25);
        const ecs::Entity floor = s.shape(ShapeNode::plane({0, 1, 0}, 0.0), {0, floorY, 0});
        const ecs::Entity sun = directionalLight(s, glm::normalize(glm::dvec3(-1.0, 0.7, 0.0)), 0.0f);
        s.placeCamera({0.0f, 2.5f, 1.5f}, {0.6f, floorY + 0.3f, -2.2f});
        s.world.get<ecs::Camera>(s.camera)->fovY = glm::radians(28.0f);
        FrameDesc fd = s.frame(sw, sh);
        fd.settings.shadows.resolutionScale = 1.0f;
        GBuffer sg;
        ASSERT_TRUE(renderAndRead(s, r, fd, sg));
        ShadowStrip strip;
        ASSERT_TRUE(readShadow(r, sw, sh, 1, strip));
        const RefCamera cam(s.world, s.camera, sw, sh);
        auto refScene = cpuref::ReferenceScene::create(error);
        ASSERT_TRUE(refScene) << error;
        ASSERT_TRUE(refScene->addMesh(*md, meshModel, 1, cpuref::kMaskCamera | cpuref::kMaskShadow, error))
            << error;
        ASSERT_TRUE(refScene->commit(error)) << error;
        cpuref::ReferenceLight light;
        light.type = ecs::LightType::Directional;
        light.direction = -towardLight(s, sun);
        // Exact visibility at each pixel's exact floor point (-1: the pixel's ray misses the floor).
        std::vector<int> exactVis(size_t(sw) * sh, -1);
        for (uint32_t y = 0; y < sh; ++y)
            for (uint32_t x = 0; x < sw; ++x) {
                const Hit fh = rayPlane(cam.eye, cam.dir(x, y), {0, 1, 0}, double(floorY), cam.nearPlane);
                if (fh.s == kInf || fh.s > cam.farPlane) continue;
                const glm::dvec3 p = cam.eye + cam.dir(x, y) * fh.s;
                exactVis[size_t(y) * sw + x] =
                    cpuref::lightVisibility(*refScene, light, p, {0, 1, 0}, 1, 1).value > 0.5 ? 1 : 0;
            }
        size_t compared = 0, shadowed = 0, leaks = 0, dark = 0, band = 0;
        for (uint32_t y = 0; y < sh; ++y)
            for (uint32_t x = 0; x < sw; ++x) {
                const size_t i = sg.at(x, y);
                const int ev = exactVis[i];
                if (!sg.hit(i) || sg.id(i) != int(floor.index) || ev < 0) continue;
                bool edge = false;
                for (int dy = -2; dy <= 2 && !edge; ++dy)
                    for (int dx = -2; dx <= 2 && !edge; ++dx) {
                        const int xx = int(x) + dx, yy = int(y) + dy;
                        if (xx < 0 || yy < 0 || xx >= int(sw) || yy >= int(sh)) continue;
                        const int nv = exactVis[size_t(yy) * sw + size_t(xx)];
                        edge = nv >= 0 && nv != ev;
                    }
                if (edge) {
                    ++band;
                    continue;
                }
                const bool gpuLit = strip.at(0, x, y) > 0.5;
                ++compared;
                shadowed += ev == 0;
                leaks += gpuLit && ev == 0;
                dark += !gpuLit && ev == 1;
            }
        const double disagree = compared ? double(leaks + dark) / double(compared) : 1.0;
        summary("03 open/non-manifold", backend(),
                "%-16s shadow, hard sun: %zu floor px compared (%zu shadowed, %zu in the 2 px edge band), "
                "disagree %.3f %% (<= 1 %%: %zu lit by the field only, %zu shadowed by the field only)",
                name, compared, shadowed, band, 100 * disagree, leaks, dark);
        EXPECT_GT(compared, size_t(sw) * sh / 4) << name;
        EXPECT_GT(shadowed, size_t(200)) << name;
        // Measured 2026-12-02 (both backends): teapot 2 of 9311 pixels (0.021 %), dragon_vrip_res4 5
        // of 8505 (0.059 %), all shadowed by the field only (a hard ray stops within half a pixel
        // footprint of the field, which lies up to a voxel off the mesh); 1466 / 927 shadowed.
        EXPECT_LE(disagree, 0.01) << name << ": shadow of the traced field vs the mesh's exact shadow";
    }
}

// ---- 6a. two baked boxes half a voxel apart
// ----------------------------------------------------------------

// Two instances of one baked unit box (voxel 1/124) side by side with a gap of 0.5 voxel, a back wall
// (analytic plane) behind them; the camera 0.2 in front of their front faces so that the gap spans ~2
// pixels. Criteria: (a) outside the gap, no pixel whose exact ray hits box A is traced with box B's
// id or vice versa (wrong-side ids: 0); (b) every gap pixel (its ray crosses the front-face plane
// inside the gap and then meets a side face) is a hit on one of the two boxes — no hole, no back
// wall seen through a gap the field cannot resolve — with its hit point between the front face and
// the exact side-face hit (1 voxel of slack, and in front 4 hit epsilons more for the step-limit
// rule): the interpolated fields of both boxes
// overlap in a sub-voxel gap and close it somewhere inside, so either box may own the pixel (how
// many the other one owns is printed), but a hit is never in front of the boxes nor behind the
// true surface. Printed: how many are at the exact depth (1e-3 relative), closed within 1 voxel of the
// front face, or in between.
TEST_P(StabilityBaked, Case06a_TwoBakedBoxesHalfAVoxelApart) {
    constexpr uint32_t w = 160, h = 120;
    const double voxel = 1.0 / 124.0, gap = 0.5 * voxel;
    StabScene s({0, 0, 0.7f}, {0, 0, -1}, 0.01f, 100.0f, cachedAssets());
    std::string error;
    const assets::AssetId mesh = s.assets.addMesh("stability:unit-box", boxMesh(glm::vec3(0.5f)), error);
    ASSERT_NE(mesh, 0u) << error;
    const assets::AssetId field = bake(s, mesh, error);
    ASSERT_NE(field, 0u) << error;
    const sdf::PsdfHeader& hd = s.assets.sdfField(field)->header;
    const float cx = float(0.5 + 0.5 * gap);
    const ecs::Entity a = s.field(field, {-cx, 0, 0});
    const ecs::Entity b = s.field(field, {cx, 0, 0});
    s.shape(ShapeNode::plane({0, 0, 1}, 0.0), {0, 0, -2});  // the back wall
    ecs::updateTransforms(s.world);
    const RefCamera cam(s.world, s.camera, w, h);
    const glm::dvec3 ca(s.world.get<ecs::Transform>(a)->worldMatrix[3]),
        cb(s.world.get<ecs::Transform>(b)->worldMatrix[3]);
    SceneRenderer r(dev());
    GBuffer g;
    ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), g));
    size_t wrongSide = 0, gapPx = 0, exactDepth = 0, closedFront = 0, inGap = 0, other = 0;
    size_t otherBack = 0, otherMiss = 0, otherDeep = 0;  // the kinds of `other`
    size_t gapOtherBox = 0;                              // gap pixels owned by the other box
    // At the gap's entrance a ray can run out of steps; the step-limit rule then keeps its best point,
    // up to 4 hit epsilons (medium: 0.5 footprints) from a surface: 1 voxel + 2 footprints at the
    // front faces' distance (0.2) is the slack in front.
    const double frontSlack = hd.voxelSize + 2.0 * cam.footprint() * 0.2;
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const size_t i = g.at(x, y);
            const glm::dvec3 d = cam.dir(x, y);
            const Hit ha = rayBox(cam.eye, d, ca, glm::dvec3(0.5), cam.nearPlane);
            const Hit hb = rayBox(cam.eye, d, cb, glm::dvec3(0.5), cam.nearPlane);
            if (ha.s == kInf && hb.s == kInf) continue;
            const Hit& hx = ha.s <= hb.s ? ha : hb;
            const int expect = ha.s <= hb.s ? int(a.index) : int(b.index);
            const int otherBox = expect == int(a.index) ? int(b.index) : int(a.index);
            // A gap pixel: its ray crosses the front-face plane z = 0.5 between the two boxes (it then
            // meets a side face inside the gap).
            const double xFront = (cam.eye + d * ((0.5 - cam.eye.z) / d.z)).x;
            if (std::abs(xFront) >= 0.5 * (cb.x - ca.x - 1.0)) {
                wrongSide += g.id(i) == otherBox;
                continue;
            }
            ++gapPx;
            // Inside a gap narrower than a voxel both boxes' interpolated fields overlap, so either
            // box may own the pixel; it must be one of the two.
            const bool aBox = g.id(i) == int(a.index) || g.id(i) == int(b.index);
            gapOtherBox += g.id(i) == otherBox;
            const double zHit = (cam.eye + d * double(g.depth[i])).z, zExact = (cam.eye + d * hx.s).z;
            if (g.id(i) == expect && relErr(g.depth[i], hx.s) <= 1e-3) {
                ++exactDepth;
            } else if (aBox && std::abs(zHit - 0.5) <= frontSlack) {
                ++closedFront;
            } else if (aBox && zHit <= 0.5 + frontSlack && zHit >= zExact - hd.voxelSize) {
                ++inGap;
            } else {
                ++other;
                otherBack += g.id(i) != int(a.index) && g.id(i) != int(b.index) && g.hit(i);
                otherMiss += !g.hit(i);
                otherDeep += aBox && zHit < zExact - hd.voxelSize;
                if (other <= 4)
                    std::printf(
                        "    06a other px %u,%u: id %d (expect %d), z %.6f (front 0.5, exact %.6f), "
                        "%.0f steps\n",
                        x, y, g.id(i), expect, zHit, zExact, g.aux[i].y);
            }
        }
    summary("06a baked boxes 0.5 voxel", backend(),
            "voxel %.6f, gap %.6f (%.2f px); wrong-side box ids %zu (0); %zu gap px: %zu at the exact "
            "side-face depth, "
            "%zu closed within 1 voxel of the front face (%.1f %%), %zu between (%zu gap px by the other "
            "box), %zu other (0: %zu back wall, %zu miss, %zu behind the side face)",
            hd.voxelSize, cb.x - ca.x - 1.0, (cb.x - ca.x - 1.0) / (cam.footprint() * (0.7 - 0.5)), wrongSide,
            gapPx, exactDepth, closedFront, gapPx ? 100.0 * double(closedFront) / double(gapPx) : 0.0, inGap,
            gapOtherBox, other, otherBack, otherMiss, otherDeep);
    EXPECT_NEAR(hd.voxelSize, voxel, 1e-9);
    EXPECT_TRUE(checkSanity(g, 0.01f, 100.0f).ok());
    EXPECT_GT(gapPx, size_t(h));  // the gap is visible: at least one pixel per row
    EXPECT_EQ(wrongSide, 0u);
    // Measured 2026-12-02 (both backends), since a field's hit decision walks the interpolant's
    // cells for its exact root: 240 gap pixels, 204 at the exact side-face depth, 8 closed at the
    // front face, 28 in between (10 owned by the other box),
    // 0 other; 0 wrong-side ids outside the gap. Before (secant steps on the filtered value): 0 exact,
    // 40 closed at the front face, 200 in between.
    EXPECT_EQ(other, 0u);
}

// ---- 8. degenerate triangles
// --------------------------------------------------------------------------------

// The teapot with zero-area triangles added: (i) repeated indices (a, a, b) for every 7th triangle,
// (ii) collinear triangles (a, b, m) with m a new vertex at the midpoint of edge ab, (iii) a point
// triangle (v, v, v) at a new vertex far outside the mesh. Criterion: the bake of each degenerate
// variant equals the clean mesh's bit for bit (dims, origin, voxel size, every value), and the traced
// depth of the degenerate variant equals the clean one's on every pixel.
TEST_P(StabilityBaked, Case08_DegenerateTrianglesBakeLikeTheCleanMesh) {
    constexpr uint32_t w = 128, h = 96;
    StabScene s({0, 0, 0}, {0, 0, -1}, 0.05f, 20.0f, cachedAssets());
    const std::string path = std::string(PENUMBRA_SOURCE_DIR) + "/data/meshes/teapot.ply";
    ASSERT_TRUE(std::filesystem::exists(path)) << path << " is missing: run tools/fetch_meshes.sh";
    std::string error;
    const assets::AssetId cleanMesh = s.assets.loadMesh(path, error);
    ASSERT_NE(cleanMesh, 0u) << error;
    const assets::MeshData clean = *s.assets.mesh(cleanMesh);
    const assets::AssetId cleanField = bake(s, cleanMesh, error);
    ASSERT_NE(cleanField, 0u) << error;
    glm::vec3 lo(1e30f), hi(-1e30f);
    for (const glm::vec3& p : clean.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    auto addVertex = [](assets::MeshData& m, glm::vec3 p) {
        m.positions.push_back(p);
        if (!m.normals.empty()) m.normals.push_back({0, 1, 0});
        if (!m.uvs.empty()) m.uvs.push_back({0, 0});
        return uint32_t(m.positions.size() - 1);
    };
    const size_t triangles = clean.indices.size() / 3;
    for (int variant = 0; variant < 3; ++variant) {
        assets::MeshData m = clean;
        size_t added = 0;
        if (variant == 0) {
            for (size_t t = 0; t < triangles; t += 7) {
                m.indices.insert(m.indices.end(),
                                 {clean.indices[3 * t], clean.indices[3 * t], clean.indices[3 * t + 1]});
                ++added;
            }
        } else if (variant == 1) {
            for (size_t t = 0; t < triangles; t += 5) {
                const uint32_t ia = clean.indices[3 * t], ib = clean.indices[3 * t + 1];
                const uint32_t mid = addVertex(m, 0.5f * (clean.positions[ia] + clean.positions[ib]));
                m.indices.insert(m.indices.end(), {ia, ib, mid});
                ++added;
            }
        } else {
            const uint32_t v = addVertex(m, hi + 3.0f * (hi - lo));
            m.indices.insert(m.indices.end(), {v, v, v});
            ++added;
        }
        const char* what = variant == 0   ? "repeated indices"
                           : variant == 1 ? "collinear (edge midpoint)"
                                          : "point far outside";
        const assets::AssetId dm =
            s.assets.addMesh(std::string("stability:teapot-degenerate-") + std::to_string(variant), m, error);
        ASSERT_NE(dm, 0u) << what << ": " << error;
        const assets::AssetId df = bake(s, dm, error);
        ASSERT_NE(df, 0u) << what << ": " << error;
        const sdf::PsdfAsset& A = *s.assets.sdfField(cleanField);
        const sdf::PsdfAsset& B = *s.assets.sdfField(df);
        const bool sameGrid =
            A.header.dims[0] == B.header.dims[0] && A.header.dims[1] == B.header.dims[1] &&
            A.header.dims[2] == B.header.dims[2] && A.header.voxelSize == B.header.voxelSize &&
            A.header.origin[0] == B.header.origin[0] && A.header.origin[1] == B.header.origin[1] &&
            A.header.origin[2] == B.header.origin[2];
        const std::vector<float>& va = A.grid.distances;
        const std::vector<float>& vb = B.grid.distances;
        size_t differing = va.size() == vb.size() ? 0 : std::max(va.size(), vb.size());
        double maxDelta = 0;  // voxels
        if (va.size() == vb.size())
            for (size_t i = 0; i < va.size(); ++i) {
                differing += std::memcmp(&va[i], &vb[i], 4) != 0;
                maxDelta = std::max(maxDelta, std::abs(double(va[i]) - double(vb[i])) / A.header.voxelSize);
            }
        // Trace both at the same placement.
        const glm::quat rot = glm::quat(glm::radians(glm::vec3(-20.0f, 30.0f, 0.0f)));
        const float scale = 1.0f / glm::length(hi - lo) * 2.0f;
        const glm::vec3 position = glm::vec3(0, 0, -2) - rot * (scale * 0.5f * (lo + hi));
        const ecs::Entity ec = s.field(cleanField, position, rot, glm::vec3(scale));
        const ecs::Entity ed = s.field(df, position, rot, glm::vec3(scale));
        SceneRenderer r(dev());
        s.world.get<ecs::SdfRenderer>(ed)->visible = false;
        GBuffer gc, gd;
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), gc));
        s.world.get<ecs::SdfRenderer>(ed)->visible = true;
        s.world.get<ecs::SdfRenderer>(ec)->visible = false;
        ASSERT_TRUE(renderAndRead(s, r, s.frame(w, h), gd));
        s.world.destroy(ec);
        s.world.destroy(ed);
        size_t depthDiff = 0, hits = 0;
        for (size_t i = 0; i < gc.size(); ++i) {
            hits += gc.hit(i);
            depthDiff += std::memcmp(&gc.depth[i], &gd.depth[i], 4) != 0;
        }
        summary("08 degenerate triangles", backend(),
                "%-25s: %zu added; grid %ux%ux%u vs clean %ux%ux%u, same placement %s, %zu of %zu values "
                "differ ("
                "max |delta| %.3g voxel (<= 1e-5), sign %s vs %s); traced depth differs on %zu of %zu px (0; "
                "%zu hit)",
                what, added, B.header.dims[0], B.header.dims[1], B.header.dims[2], A.header.dims[0],
                A.header.dims[1], A.header.dims[2], sameGrid ? "yes" : "NO", differing, va.size(), maxDelta,
                sdf::toString(B.header.sign()), sdf::toString(A.header.sign()), depthDiff, gc.size(), hits);
        EXPECT_TRUE(sameGrid) << what;
        // The field equals the clean mesh's to float rounding: a degenerate triangle's distance is
        // computed through its own (collinear) edges, which can round differently from the clean
        // mesh's edge it lies on. Measured: repeated indices 0 values differ; collinear 5266 of
        // 682240 differ by at most 3.7e-6 voxel. Criterion: max |delta| <= 1e-5 voxel, traced depth
        // bit-identical on every pixel.
        EXPECT_LE(maxDelta, 1e-5) << what;
        EXPECT_EQ(depthDiff, 0u) << what;
        EXPECT_GT(hits, size_t(w) * h / 20);
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, StabilityBaked, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test::stability
