// GPU tests of the world SDF cache (renderer/features/sdf_world_cache.h, world_cache_clipmap.h,
// renderer/shaders/sdf_world_cache_update.comp) on both backends under validation. The cache is
// read back whole (SceneRenderer::readWorldCache) and looked up on the CPU exactly as
// sdf_world_cache.glsl does (finest level whose window holds floor(p / h), toroidal texel):
//   1. conservativeness: at 100 000 random points inside the windows the cached distance never
//      exceeds the exact scene distance (spheres and boxes, rotated and uniformly scaled, a box
//      under non-uniform scale, a plane) by more than eps = 1e-5 max(1, |p|) (float evaluation),
//      after the first fill, in the frame right after several objects moved with a small budget
//      (bricks still queued: the splats keep it conservative), and after a camera scroll;
//   2. ids: wherever a cell names an object, that object is the exact nearest at the point;
//   3. after the queue drains the cache equals a from-scratch fill of the same frame;
//   4. a camera move across one level-0 voxel boundary recomputes exactly R^2 voxels (stats);
//   5. memory follows the scene: one object seen from 6 units needs two levels, 80 objects spread
//      over 28 x 22 units four.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/assets/primitives.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"
#include "engine/sdf/shape_program.h"
#include "renderer/features/world_cache_clipmap.h"
#include "renderer/scene_renderer.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using render::SceneRenderer;
using render::WorldCacheReadback;
using sdf::ShapeNode;

// Exact world distance of one test object (double precision).
struct RefObject {
    uint32_t entity = 0;
    const sdf::ShapeProgram* program = nullptr;  // rigid + uniform scale: exact
    glm::dmat4 inv{1.0};
    double scale = 1.0;
    bool axisBox = false;   // a box under non-uniform axis-aligned scale: exact box distance
    bool localBox = false;  // a field baked from a box mesh of these local half extents
    glm::dvec3 centre{0.0}, half{0.0};
    double distance(const glm::dvec3& p) const {
        if (localBox) {
            const glm::dvec3 q = glm::abs(glm::dvec3(inv * glm::dvec4(p, 1.0))) - half;
            return scale * (glm::length(glm::max(q, 0.0)) + std::min(std::max({q.x, q.y, q.z}), 0.0));
        }
        if (axisBox) {
            const glm::dvec3 q = glm::abs(p - centre) - half;
            return glm::length(glm::max(q, 0.0)) + std::min(std::max({q.x, q.y, q.z}), 0.0);
        }
        return scale * sdf::evaluateShapeProgram(*program, glm::dvec3(inv * glm::dvec4(p, 1.0)));
    }
};

struct CacheScene {
    ecs::World world;
    assets::AssetManager assets;
    ecs::Entity camera;
    std::vector<ecs::Entity> objects;

    CacheScene() {
        camera = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(camera);
        t->position = {0.1f, 1.0f, 6.0f};
        ecs::Camera c;
        c.fovY = 1.0f;
        c.nearPlane = 0.1f;
        c.farPlane = 100.0f;
        world.add<ecs::Camera>(camera, c);
    }
    assets::AssetId program(const ShapeNode& root) {
        sdf::ShapeProgram p;
        std::string error;
        EXPECT_TRUE(sdf::compileShapeProgram(root, p, error)) << error;
        const std::string key = assets::AssetManager::shapeProgramKey(p);
        const assets::AssetId id = assets.addShapeProgram(key, std::move(p), error);
        EXPECT_NE(id, 0u) << error;
        return id;
    }
    ecs::Entity add(const ShapeNode& root, glm::vec3 pos, glm::quat rot = {1, 0, 0, 0},
                    glm::vec3 scale = glm::vec3(1)) {
        ecs::Entity e = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = pos;
        t->rotation = rot;
        t->scale = scale;
        ecs::SdfRenderer sr;
        sr.sdf = program(root);
        sr.source = ecs::SdfSource::Shapes;
        world.add<ecs::SdfRenderer>(e, sr);
        objects.push_back(e);
        return e;
    }
    // A field baked from a box mesh of half extents `half` (its distance is the exact box distance).
    ecs::Entity addBakedBox(float half, glm::vec3 pos, glm::quat rot, float scale) {
        assets::MeshData mesh;
        std::string error;
        EXPECT_TRUE(assets::makeBox(glm::vec3(half), mesh, error)) << error;
        const assets::AssetId meshId = assets.addMesh("cache-test-box", mesh, error);
        EXPECT_NE(meshId, 0u) << error;
        const assets::AssetId fieldId = assets.bakeSdf(meshId, sdf::BakeSettings{}, error);
        EXPECT_NE(fieldId, 0u) << error;
        ecs::Entity e = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = pos;
        t->rotation = rot;
        t->scale = glm::vec3(scale);
        ecs::SdfRenderer sr;
        sr.sdf = fieldId;
        sr.source = ecs::SdfSource::Field;
        world.add<ecs::SdfRenderer>(e, sr);
        objects.push_back(e);
        boxHalf[e.index] = half;
        return e;
    }
    std::map<uint32_t, double> boxHalf;  // entity -> half extent of its baked box
    void move(ecs::Entity e, glm::vec3 pos) { world.get<ecs::Transform>(e)->position = pos; }
    render::FrameDesc frame(const scene::AccelerationSettings& accel) const {
        render::FrameDesc d;
        d.width = 64;
        d.height = 48;
        d.camera = camera;
        d.settings.acceleration = accel;
        return d;
    }
    void render(SceneRenderer& r, const scene::AccelerationSettings& accel) {
        ecs::updateTransforms(world);
        std::string error;
        ASSERT_TRUE(r.render(world, assets, frame(accel), error)) << error;
    }
    std::vector<RefObject> refs() {
        ecs::updateTransforms(world);
        std::vector<RefObject> out;
        for (auto [e, sr, t] : world.view<ecs::SdfRenderer, ecs::Transform>()) {
            RefObject o;
            o.entity = e.index;
            o.program = assets.shapeProgram(sr.sdf);
            const glm::dmat4 m(t.worldMatrix);
            o.inv = glm::inverse(m);
            const glm::dvec3 s(glm::length(glm::dvec3(m[0])), glm::length(glm::dvec3(m[1])),
                               glm::length(glm::dvec3(m[2])));
            o.scale = s.x;
            if (sr.source == ecs::SdfSource::Field) {
                o.localBox = true;
                o.half = glm::dvec3(boxHalf.at(e.index));
                out.push_back(o);
                continue;
            }
            if (std::abs(s.x - s.y) > 1e-6 * s.x || std::abs(s.x - s.z) > 1e-6 * s.x) {
                // Only axis-aligned boxes are scaled non-uniformly here (half extents 0.5 locally).
                o.axisBox = true;
                o.centre = glm::dvec3(m[3]);
                o.half = 0.5 * s;
            }
            out.push_back(o);
        }
        return out;
    }
};

// Five shapes around the origin and a ground plane; cache voxel 0.125, R = 32, 3 levels.
void buildScene(CacheScene& s) {
    s.add(ShapeNode::sphere(0.5), {0.0f, 0.5f, 0.0f});
    s.add(ShapeNode::box({0.4, 0.3, 0.5}), {1.3f, 0.4f, -0.6f},
          glm::quat(glm::radians(glm::vec3(20, 35, 10))));
    s.add(ShapeNode::sphere(0.4), {-1.4f, 0.8f, 0.3f}, glm::quat(glm::radians(glm::vec3(0, 50, 30))),
          glm::vec3(1.5f));
    s.add(ShapeNode::box({0.5, 0.5, 0.5}), {0.2f, 0.6f, 1.5f}, {1, 0, 0, 0}, {2.0f, 1.0f, 0.5f});
    s.add(ShapeNode::torus(0.5, 0.15), {-0.5f, 1.8f, -1.2f}, glm::quat(glm::radians(glm::vec3(70, 0, 0))),
          glm::vec3(0.8f));
    s.add(ShapeNode::plane({0, 1, 0}, 0.0), {0.0f, 0.0f, 0.0f});
}

scene::AccelerationSettings accel(uint32_t budget = 1u << 20) {
    scene::AccelerationSettings a;
    a.worldCache = true;
    a.idField = true;
    a.cacheLevels = 3;
    a.cacheResolution = 32;
    a.cacheVoxel = 0.125f;
    a.cacheBudgetVoxels = budget;
    return a;
}

// The lookup of sdf_world_cache.glsl on the read-back textures (same float arithmetic).
bool lookup(const WorldCacheReadback& c, glm::vec3 p, float& d, uint32_t& id) {
    const int r = int(c.resolution);
    for (uint32_t l = 0; l < c.levels; ++l) {
        const render::CacheLevelGpu& lv = c.levelInfo[l];
        const glm::vec3 rel = glm::floor(p / lv.params.x) - glm::vec3(glm::ivec3(lv.origin));
        if (glm::any(glm::lessThan(rel, glm::vec3(0.0f))) ||
            glm::any(glm::greaterThanEqual(rel, glm::vec3(float(r)))))
            continue;
        glm::ivec3 t = glm::ivec3(rel) + glm::ivec3(lv.wrap);
        for (int a = 0; a < 3; ++a)
            if (t[a] >= r) t[a] -= r;
        t.z += lv.origin.w;
        const size_t i = (size_t(t.z) * r + size_t(t.y)) * r + size_t(t.x);
        d = c.distance[i];
        id = c.ids[i];
        return true;
    }
    return false;
}

struct CheckResult {
    size_t points = 0, violations = 0, idChecked = 0, idViolations = 0, none = 0, uncertain = 0;
    double worstExcess = -1e30;
};

// 100 000 random points inside the windows (level chosen at random, uniform in its window).
CheckResult checkConservative(const WorldCacheReadback& c, const std::vector<RefObject>& refs,
                              uint32_t seed) {
    CheckResult res;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int k = 0; k < 100000; ++k) {
        const render::CacheLevelGpu& lv = c.levelInfo[size_t(rng() % c.levels)];
        const float span = lv.params.x * float(c.resolution);
        const glm::vec3 p =
            glm::vec3(glm::ivec3(lv.origin)) * lv.params.x + glm::vec3(u(rng), u(rng), u(rng)) * span;
        float d = 0.0f;
        uint32_t id = 0;
        if (!lookup(c, p, d, id)) continue;
        ++res.points;
        double exact = std::numeric_limits<double>::infinity();
        std::vector<double> per(refs.size());
        for (size_t i = 0; i < refs.size(); ++i)
            exact = std::min(exact, per[i] = refs[i].distance(glm::dvec3(p)));
        const double eps = 1e-5 * std::max(1.0, double(glm::length(p)));
        res.worstExcess = std::max(res.worstExcess, double(d) - exact);
        if (double(d) > exact + eps) ++res.violations;
        if (id == render::kCacheNone)
            ++res.none;
        else if (id == render::kCacheUncertain)
            ++res.uncertain;
        else {
            ++res.idChecked;
            const uint32_t entity = id < c.objectKeys.size() ? c.objectKeys[id] : ~0u;
            double named = std::numeric_limits<double>::infinity();
            for (size_t i = 0; i < refs.size(); ++i)
                if (refs[i].entity == entity) named = per[i];
            if (named > exact + eps) ++res.idViolations;
        }
    }
    return res;
}

void expectConservative(const WorldCacheReadback& c, const std::vector<RefObject>& refs, const char* what,
                        size_t minNamed = 1000) {
    const CheckResult r = checkConservative(c, refs, 11);
    std::printf(
        "  [%s] %zu points: %zu over exact + eps (worst cached - exact %.3g); ids: %zu named, %zu wrong, "
        "%zu uncertain, %zu none\n",
        what, r.points, r.violations, r.worstExcess, r.idChecked, r.idViolations, r.uncertain, r.none);
    EXPECT_GT(r.points, 90000u);       // the points lie in the windows
    EXPECT_EQ(r.violations, 0u);       // cached(p) <= exact(p) + 1e-5 max(1, |p|) everywhere
    EXPECT_EQ(r.idViolations, 0u);     // a named object is the exact nearest (within eps)
    EXPECT_GT(r.idChecked, minNamed);  // and the id field does name objects
}

class SdfWorldCacheTest : public GpuTest {};

TEST_P(SdfWorldCacheTest, ConservativeAfterFillMovesAndScroll) {
    CacheScene s;
    buildScene(s);
    SceneRenderer r(dev());
    s.render(r, accel());
    const render::FrameStats& st0 = r.lastFrameStats();
    ASSERT_TRUE(st0.worldCache.active);
    EXPECT_EQ(st0.worldCache.levels, 3u);
    WorldCacheReadback c;
    std::string error;
    ASSERT_TRUE(r.readWorldCache(c, error)) << error;
    expectConservative(c, s.refs(), "first fill");

    // Three objects move far (0.3 - 0.6 units, several voxels) under a small budget: bricks stay queued.
    const uint32_t budget = 4096;
    s.move(s.objects[0], {0.4f, 0.5f, 0.3f});
    s.move(s.objects[1], {0.9f, 0.6f, -0.6f});
    s.move(s.objects[4], {-0.2f, 1.6f, -1.0f});
    s.render(r, accel(budget));
    const render::WorldCacheReport& st1 = r.lastFrameStats().worldCache;
    std::printf("  after the move: %llu splat, %llu dirty, %llu still queued voxels\n",
                (unsigned long long)st1.voxels.splatVoxels, (unsigned long long)st1.voxels.dirtyVoxels,
                (unsigned long long)st1.voxels.queuedVoxels);
    EXPECT_EQ(st1.voxels.changedObjects, 3u);
    EXPECT_GT(st1.voxels.queuedVoxels, 0u);           // the budget left bricks queued
    EXPECT_LE(st1.voxels.dirtyVoxels, budget + 512);  // within the budget (+ at most one brick)
    ASSERT_TRUE(r.readWorldCache(c, error)) << error;
    expectConservative(c, s.refs(), "moved, queue not drained");

    // Drain (large budget), then compare with a fresh renderer's from-scratch fill of the same frame.
    s.render(r, accel());
    EXPECT_EQ(r.lastFrameStats().worldCache.voxels.queuedVoxels, 0u);
    ASSERT_TRUE(r.readWorldCache(c, error)) << error;
    expectConservative(c, s.refs(), "drained");
    SceneRenderer fresh(dev());
    s.render(fresh, accel());
    WorldCacheReadback f;
    ASSERT_TRUE(fresh.readWorldCache(f, error)) << error;
    ASSERT_EQ(f.distance.size(), c.distance.size());
    size_t distDiff = 0, idDiff = 0;
    for (size_t i = 0; i < f.distance.size(); ++i) {
        if (std::abs(f.distance[i] - c.distance[i]) > 1e-6f * std::max(1.0f, std::abs(f.distance[i])))
            ++distDiff;
        if (f.ids[i] != c.ids[i]) ++idDiff;
    }
    std::printf("  drained vs from scratch: %zu distances, %zu ids differ of %zu texels\n", distDiff, idDiff,
                f.distance.size());
    EXPECT_EQ(distDiff, 0u);  // |drained - scratch| <= 1e-6 max(1, |d|) at every texel
    EXPECT_EQ(idDiff, 0u);    // identical ids

    // Camera scroll across one level-0 voxel boundary (x 0.1 -> 0.2 crosses 0.125; levels 1 and 2
    // have boundaries at multiples of 0.25 and 0.5): exactly the R x R slab of level 0.
    ecs::Transform* cam = s.world.get<ecs::Transform>(s.camera);
    cam->position.x = 0.2f;
    s.render(r, accel());
    const render::WorldCacheReport& st2 = r.lastFrameStats().worldCache;
    std::printf("  scroll: %llu voxels recomputed (R^2 = %u)\n", (unsigned long long)st2.voxels.scrollVoxels,
                32u * 32u);
    EXPECT_EQ(st2.voxels.scrollVoxels, 32u * 32u);  // the exposed slab exactly
    EXPECT_EQ(st2.voxels.fullVoxels + st2.voxels.dirtyVoxels + st2.voxels.splatVoxels, 0u);
    ASSERT_TRUE(r.readWorldCache(c, error)) << error;
    expectConservative(c, s.refs(), "scrolled");
}

TEST_P(SdfWorldCacheTest, MemoryFollowsTheScene) {
    scene::AccelerationSettings a;  // defaults: 4 levels of 64^3, voxel from the scene
    a.worldCache = true;
    CacheScene one;
    one.add(ShapeNode::sphere(0.5), {0.0f, 0.5f, 0.0f});
    SceneRenderer r1(dev());
    one.render(r1, a);
    const render::FrameStats s1 = r1.lastFrameStats();
    CacheScene many;
    for (int i = 0; i < 80; ++i)
        many.add(ShapeNode::sphere(0.5), {float(i % 10) * 3.0f - 13.5f, 0.5f, float(i / 10) * 3.0f - 12.0f});
    SceneRenderer r80(dev());
    many.render(r80, a);
    const render::FrameStats s80 = r80.lastFrameStats();
    std::printf("  1 object: %u levels, voxel %.4g, %llu bytes; 80 objects: %u levels, %llu bytes\n",
                s1.worldCache.levels, s1.worldCache.voxel, (unsigned long long)s1.memory.worldCache,
                s80.worldCache.levels, (unsigned long long)s80.memory.worldCache);
    // Level count = levels needed for the coarsest camera-centred window to hold every object: the
    // camera stands 6 units from the sphere, level 0 spans 64 x 0.125 = 8 units around it, level 1 16.
    EXPECT_EQ(s1.worldCache.levels, 2u);
    EXPECT_EQ(s80.worldCache.levels, 4u);  // 28 x 22 units need level 3 (64 units; capped at 4)
    EXPECT_EQ(s1.worldCache.distanceBytes, 2ull * 64 * 64 * 64 * 4);  // R^3 R32F texels per level
    EXPECT_EQ(s80.worldCache.distanceBytes, 2 * s1.worldCache.distanceBytes);
    EXPECT_LT(s1.memory.worldCache, s80.memory.worldCache * 51 / 100);  // half, + the levels table
    // With the cache off there is none.
    a.worldCache = a.idField = false;
    one.render(r1, a);
    EXPECT_FALSE(r1.lastFrameStats().worldCache.active);
    EXPECT_EQ(r1.lastFrameStats().memory.worldCache, 0u);
}

// Ids for fields and inexact programs: a field (baked from a box mesh: its reference is the exact
// box distance) is named where its upper bound (interpolant + interpolation bound, in its box of
// voxel centres) clears every other object's lower bound, which for a field is also a bound of
// its interpolated surface (the one the trace hits, up to about a voxel nearer than its mesh):
// two fields side by side, each named somewhere and never where another object is nearer; a
// smooth union (its value is only a lower bound) is never named, an exact sphere is; distances
// stay conservative. The smooth union's reference distance is its program value, a lower bound:
// the checks against it are stricter than against its true distance. Checked with the tests'
// cache and with level-0 voxels of 1/256 to 1/64.
TEST_P(SdfWorldCacheTest, FieldsAreNamedWhereCertainInexactProgramsNever) {
    CacheScene s;
    s.world.get<ecs::Transform>(s.camera)->position = {0.0f, 0.8f, 1.0f};  // level 0 (4 units) holds them
    const ecs::Entity boxA =
        s.addBakedBox(0.5f, {0.8f, 0.6f, 0.0f}, glm::quat(glm::radians(glm::vec3(10, 30, 0))), 1.2f);
    const ecs::Entity boxB = s.addBakedBox(0.5f, {0.9f, 0.5f, 1.45f}, glm::quat(glm::vec3(0.0f)), 0.8f);
    const ecs::Entity blob =
        s.add(ShapeNode::csg(sdf::CsgOp::Union, {ShapeNode::sphere(0.4), ShapeNode::sphere(0.35)}, 0.3),
              {-0.9f, 0.5f, 0.2f});
    s.add(ShapeNode::sphere(0.3), {0.0f, 1.6f, -0.5f});
    SceneRenderer r(dev());
    s.render(r, accel());
    WorldCacheReadback c;
    std::string error;
    ASSERT_TRUE(r.readWorldCache(c, error)) << error;
    expectConservative(c, s.refs(), "fields + smooth union", 100);  // no named object farther than another
    // The same with finer caches, where the certainty margin sqrt(3) h + 2 s shrinks to 0.009
    // units at h = 1/256 (every level's points sampled).
    for (float h0 : {1.0f / 256.0f, 1.0f / 128.0f, 1.0f / 64.0f}) {
        SceneRenderer rf(dev());
        scene::AccelerationSettings a = accel();
        a.cacheVoxel = h0;
        a.cacheLevels = 6;
        a.cacheResolution = 64;
        s.render(rf, a);
        WorldCacheReadback cf;
        ASSERT_TRUE(rf.readWorldCache(cf, error)) << error;
        expectConservative(cf, s.refs(), "fields, fine cache", 100);
    }
    size_t fieldA = 0, fieldB = 0, smooth = 0, sphere = 0;
    for (uint32_t id : c.ids) {
        if (id >= c.objectKeys.size()) continue;
        if (c.objectKeys[id] == blob.index)
            ++smooth;
        else if (c.objectKeys[id] == boxA.index)
            ++fieldA;
        else if (c.objectKeys[id] == boxB.index)
            ++fieldB;
        else
            ++sphere;
    }
    std::printf("  texels naming field A: %zu, field B: %zu, the smooth union: %zu, the sphere: %zu\n",
                fieldA, fieldB, smooth, sphere);
    EXPECT_GT(fieldA, 100u);  // fields are named where certain
    EXPECT_GT(fieldB, 100u);
    EXPECT_EQ(smooth, 0u);    // a program with smooth CSG has no upper bound: never named
    EXPECT_GT(sphere, 100u);  // an exact program is
}

// An object moving back and forth every frame (splats, queued bricks and job counts that vary
// from frame to frame) creates no pipelines or bind groups once the loop is warm: the per-frame
// buffers come from the graph's pool at power-of-two sizes.
TEST_P(SdfWorldCacheTest, MovingObjectsCreateNothingAfterWarmUp) {
    CacheScene s;
    buildScene(s);
    SceneRenderer r(dev());
    rhi::DeviceStats warm{};
    uint64_t splats = 0;
    for (int frame = 0; frame < 14; ++frame) {
        s.move(s.objects[0], frame % 2 ? glm::vec3(0.4f, 0.5f, 0.0f) : glm::vec3(0.0f, 0.5f, 0.0f));
        s.render(r, accel(4096));
        if (frame >= 6) splats += r.lastFrameStats().worldCache.voxels.splatVoxels;
        if (frame == 5) warm = dev().stats();
    }
    const rhi::DeviceStats end = dev().stats();
    std::printf("  frames 7-14: %llu splat voxels; pipelines %llu -> %llu, bind groups %llu -> %llu\n",
                (unsigned long long)splats, (unsigned long long)warm.pipelinesCreated,
                (unsigned long long)end.pipelinesCreated, (unsigned long long)warm.bindGroupsCreated,
                (unsigned long long)end.bindGroupsCreated);
    EXPECT_GT(splats, 0u);                                     // the cache did work every frame
    EXPECT_EQ(end.pipelinesCreated, warm.pipelinesCreated);    // none created after frame 6
    EXPECT_EQ(end.bindGroupsCreated, warm.bindGroupsCreated);  // none created after frame 6
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfWorldCacheTest, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test
