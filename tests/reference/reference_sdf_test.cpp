// The reference renderer's SDF objects (tools/reference/reference.h, docs/ACCURACY.md "SDF objects"):
// shape programs intersected in double precision against closed-form ray intersections (sphere,
// box, plane, a non-uniformly scaled box), first roots of shapes without a simple closed form
// (torus, capsule, CSG subtraction, repetition, smooth CSG) by their program distance, fields by
// their trilinear interpolant, MeshBake entities as their original mesh, every object of
// scenes/shapes.json hit, and depth agreement with the GPU trace (`penumbra render --quality
// reference`) on both backends. Each assertion states its metric and threshold.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <set>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "engine/engine.h"
#include "engine/scene/scene.h"
#include "reference/pfm.h"
#include "reference/reference.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using namespace penumbra::reference;
constexpr double kInfD = std::numeric_limits<double>::infinity();
const std::string kSourceDir = PENUMBRA_SOURCE_DIR;

sdf::ShapeProgram compile(const sdf::ShapeNode& root) {
    sdf::ShapeProgram p;
    std::string error;
    EXPECT_TRUE(sdf::compileShapeProgram(root, p, error)) << error;
    return p;
}

glm::dmat4 placement(const glm::dvec3& position, double angle, const glm::dvec3& axis,
                     const glm::dvec3& scale) {
    glm::dmat4 m = glm::translate(glm::dmat4(1.0), position);
    m = glm::rotate(m, angle, glm::normalize(axis));
    return glm::scale(m, scale);
}

// One shape program in a scene of its own, seen by a kW x kH camera.
struct ProgramScene {
    std::unique_ptr<ReferenceScene> scene;
    ReferenceCamera camera;
    sdf::ShapeProgram program;
    glm::dmat4 model{1.0};
};

constexpr uint32_t kW = 96, kH = 72;

ProgramScene makeProgramScene(const sdf::ShapeNode& root, const glm::dmat4& model, const glm::dvec3& eye,
                              const glm::dvec3& target) {
    ProgramScene s;
    std::string error;
    s.scene = ReferenceScene::create(error);
    EXPECT_TRUE(s.scene) << error;
    s.program = compile(root);
    s.model = model;
    EXPECT_TRUE(s.scene->addShapeProgram(s.program, model, 7, kMaskCamera, error)) << error;
    EXPECT_TRUE(s.scene->commit(error)) << error;
    s.camera = lookAtCamera(eye, target, {0, 1, 0}, 0.9, kW, kH);
    return s;
}

// Closed forms in double precision (nearest t > 0; false on a miss). A shape program stores its
// parameters as 32-bit floats (the GPU's records): the closed forms take the same rounded values.
bool sphereRay(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& c, double r, double& t) {
    const glm::dvec3 oc = o - c;
    const double a = glm::dot(d, d), b = glm::dot(oc, d), cc = glm::dot(oc, oc) - r * r;
    const double disc = b * b - a * cc;
    if (disc < 0.0) return false;
    const double q = -(b + std::copysign(std::sqrt(disc), b));
    double t0 = q / a, t1 = cc / q;
    if (t0 > t1) std::swap(t0, t1);
    t = t0 > 0.0 ? t0 : t1;
    return t > 0.0;
}

// Axis-aligned box |p| <= h in the local frame of `model`: the slab test on the local ray (t is kept).
bool boxRay(const glm::dvec3& o, const glm::dvec3& d, const glm::dmat4& model, const glm::dvec3& h,
            double& t) {
    const glm::dmat4 inv = glm::inverse(model);
    const glm::dvec3 ol(inv * glm::dvec4(o, 1.0)), dl(glm::dmat3(inv) * d);
    double t0 = -kInfD, t1 = kInfD;
    for (int a = 0; a < 3; ++a) {
        double ta = (-h[a] - ol[a]) / dl[a], tb = (h[a] - ol[a]) / dl[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    if (!(t0 <= t1) || !(t0 > 0.0)) return false;
    t = t0;
    return true;
}

struct ClosedFormStats {
    size_t both = 0, mismatch = 0;
    double maxRel = 0.0;
};

template <class F>
ClosedFormStats compareClosedForm(const ProgramScene& s, F&& closed) {
    ClosedFormStats st;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            const glm::dvec3 d = s.camera.pixelRay(x + 0.5, y + 0.5);
            Hit hit;
            double t = 0.0;
            const bool a = s.scene->intersect(s.camera.eye, d, 0.0, kInfD, kMaskCamera, hit);
            const bool b = closed(s.camera.eye, d, t);
            if (a != b) {
                ++st.mismatch;
                continue;
            }
            if (!a) continue;
            ++st.both;
            st.maxRel = std::max(st.maxRel, std::abs(hit.t - t) / t);
        }
    return st;
}

TEST(ReferenceSdf, ShapeProgramsMatchClosedFormDepth) {
    struct Case {
        const char* name;
        ProgramScene scene;
        std::function<bool(const glm::dvec3&, const glm::dvec3&, double&)> closed;
    };
    const glm::dmat4 sphereModel = placement({0.3, -0.2, 0.1}, 0.4, {1, 1, 0}, glm::dvec3(1.0));
    const glm::dmat4 boxModel = placement({-0.2, 0.1, 0.3}, 0.7, {0.3, 1, 0.2}, glm::dvec3(1.0));
    const glm::dmat4 stretched = placement({0.1, 0.2, -0.1}, 0.5, {1, 0.4, 0.3}, {1.7, 0.6, 1.2});
    const glm::dmat4 planeModel = placement({0.0, -0.5, 0.0}, 0.2, {0, 0, 1}, glm::dvec3(1.0));
    std::vector<Case> cases;
    cases.push_back({"sphere r 0.8",
                     makeProgramScene(sdf::ShapeNode::sphere(0.8), sphereModel, {0, 1, 4}, {0, 0, 0}),
                     [&](const glm::dvec3& o, const glm::dvec3& d, double& t) {
                         return sphereRay(o, d, glm::dvec3(sphereModel[3]), double(0.8f), t);
                     }});
    cases.push_back(
        {"box (0.5, 0.7, 0.4), rotated",
         makeProgramScene(sdf::ShapeNode::box({0.5, 0.7, 0.4}), boxModel, {1, 1.5, 3.5}, {0, 0, 0}),
         [&](const glm::dvec3& o, const glm::dvec3& d, double& t) {
             return boxRay(o, d, boxModel, glm::dvec3(glm::vec3(0.5f, 0.7f, 0.4f)), t);
         }});
    cases.push_back(
        {"box (0.5, 0.5, 0.5) scaled (1.7, 0.6, 1.2), rotated",
         makeProgramScene(sdf::ShapeNode::box({0.5, 0.5, 0.5}), stretched, {-1, 2, 3.5}, {0, 0, 0}),
         [&](const glm::dvec3& o, const glm::dvec3& d, double& t) {
             return boxRay(o, d, stretched, {0.5, 0.5, 0.5}, t);
         }});
    cases.push_back(
        {"plane, tilted",
         makeProgramScene(sdf::ShapeNode::plane({0, 1, 0}, 0.0), planeModel, {0, 2, 3}, {0, 0, -1}),
         [&](const glm::dvec3& o, const glm::dvec3& d, double& t) {
             const glm::dvec3 n = glm::normalize(glm::dmat3(planeModel) * glm::dvec3(0, 1, 0));
             const double denom = glm::dot(n, d);
             if (denom == 0.0) return false;
             t = glm::dot(glm::dvec3(planeModel[3]) - o, n) / denom;
             return t > 0.0;
         }});
    for (Case& c : cases) {
        const ClosedFormStats st = compareClosedForm(c.scene, c.closed);
        const ReferenceScene::SdfStats stats = c.scene.scene->sdfStats();
        std::printf(
            "%-52s %5zu rays hit, max relative depth error %.3g, hit/miss mismatches %zu, "
            "iterations/ray %.1f, unconverged %llu\n",
            c.name, st.both, st.maxRel, st.mismatch,
            stats.rays ? double(stats.iterations) / double(stats.rays) : 0.0,
            (unsigned long long)stats.unconverged);
        EXPECT_GT(st.both, size_t(kW) * kH / 20) << c.name;
        // Criterion: depth equals the closed form to 1e-9 relative; no pixel hit by one only.
        EXPECT_LE(st.maxRel, 1e-9) << c.name;
        EXPECT_EQ(st.mismatch, 0u) << c.name;
        EXPECT_EQ(stats.unconverged, 0u) << c.name;
    }
}

// Shapes without a simple closed form: the hit is a root (|program distance| < 1e-9 at the hit, in
// the program's frame) and the first one (the program is > 0 at 2000 points before it on the ray).
struct RootStats {
    size_t hits = 0, notRoot = 0, notFirst = 0;
    double maxAbs = 0.0;
};

RootStats checkRoots(const ProgramScene& s) {
    RootStats st;
    const glm::dmat4 inv = glm::inverse(s.model);
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            const glm::dvec3 d = s.camera.pixelRay(x + 0.5, y + 0.5);
            Hit hit;
            if (!s.scene->intersect(s.camera.eye, d, 0.0, kInfD, kMaskCamera, hit)) continue;
            ++st.hits;
            const glm::dvec3 local(inv * glm::dvec4(hit.position, 1.0));
            const double v = std::abs(sdf::evaluateShapeProgram(s.program, local));
            st.maxAbs = std::max(st.maxAbs, v);
            st.notRoot += !(v < 1e-9);
            for (int i = 0; i < 2000; ++i) {
                const double t = hit.t * (i + 0.5) / 2000.0 * (1.0 - 1e-6);
                const glm::dvec3 p(inv * glm::dvec4(s.camera.eye + t * d, 1.0));
                if (sdf::evaluateShapeProgram(s.program, p) <= 0.0) {
                    ++st.notFirst;
                    break;
                }
            }
        }
    return st;
}

TEST(ReferenceSdf, ShapeProgramHitsAreFirstRoots) {
    using sdf::ShapeNode;
    const glm::dvec3 eye{0.5, 1.6, 4.0}, target{0, 0, 0};
    struct Case {
        const char* name;
        ShapeNode root;
        glm::dmat4 model;
    };
    std::vector<Case> cases;
    cases.push_back({"torus (0.8, 0.25)", ShapeNode::torus(0.8, 0.25),
                     placement({0, 0, 0}, 0.6, {1, 0, 0.3}, glm::dvec3(1))});
    cases.push_back({"capsule (0.3, 0.6)", ShapeNode::capsule(0.3, 0.6),
                     placement({0, 0, 0}, 0.9, {0, 0, 1}, glm::dvec3(1))});
    cases.push_back(
        {"box minus sphere",
         ShapeNode::csg(sdf::CsgOp::Subtract, {ShapeNode::box({0.6, 0.6, 0.6}), ShapeNode::sphere(0.75)}),
         placement({0, 0, 0}, 0.5, {0, 1, 0}, glm::dvec3(1))});
    cases.push_back({"repetition of spheres 5 x 1 x 3",
                     ShapeNode::repeat(ShapeNode::sphere(0.2), {0.5, 0, 0.6}, {5, 1, 3}),
                     placement({0, 0, 0}, 0.3, {0, 1, 0}, glm::dvec3(1))});
    cases.push_back({"smooth union (k 0.4), scaled (1.3, 0.8, 1)",
                     ShapeNode::csg(sdf::CsgOp::Union,
                                    {ShapeNode::sphere(0.5).placed({-0.35, 0, 0}),
                                     ShapeNode::sphere(0.4).placed({0.4, 0.2, 0}),
                                     ShapeNode::capsule(0.15, 0.5).placed(
                                         {0, 0.5, 0}, glm::angleAxis(1.5707963, glm::dvec3(0, 0, 1)))},
                                    0.4),
                     placement({0, 0, 0}, 0.2, {0, 1, 0}, {1.3, 0.8, 1.0})});
    cases.push_back(
        {"smooth subtract (k 0.2)",
         ShapeNode::csg(sdf::CsgOp::Subtract,
                        {ShapeNode::box({0.6, 0.5, 0.6}), ShapeNode::sphere(0.6).placed({0.3, 0.3, 0.3})},
                        0.2),
         placement({0, 0, 0}, 0.4, {0, 1, 0}, glm::dvec3(1))});
    for (const Case& c : cases) {
        const ProgramScene s = makeProgramScene(c.root, c.model, eye, target);
        const RootStats st = checkRoots(s);
        const ReferenceScene::SdfStats stats = s.scene->sdfStats();
        std::printf(
            "%-44s %5zu hits, max |program distance| at the hit %.3g, not a root %zu, not the first "
            "%zu, iterations/ray %.1f, unconverged %llu\n",
            c.name, st.hits, st.maxAbs, st.notRoot, st.notFirst,
            stats.rays ? double(stats.iterations) / double(stats.rays) : 0.0,
            (unsigned long long)stats.unconverged);
        EXPECT_GT(st.hits, size_t(kW) * kH / 50) << c.name;
        // Criterion: |program distance| < 1e-9 at every hit; the program is positive before it.
        EXPECT_EQ(st.notRoot, 0u) << c.name;
        EXPECT_EQ(st.notFirst, 0u) << c.name;
        EXPECT_EQ(stats.unconverged, 0u) << c.name;
    }
}

// A field (.psdf: no original geometry) is its own trilinear interpolant: the exact distance of a
// sphere sampled on a 24^3 grid, placed with non-uniform scale. Hits are roots of the interpolant
// (|SdfSampler::trilinear| < 1e-9 at the hit), the first ones (positive at 2000 points before),
// and within half a voxel of the sphere (the interpolant of an exact distance is that close).
TEST(ReferenceSdf, FieldHitsAreRootsOfTheInterpolant) {
    sdf::PsdfAsset field;
    sdf::SdfGrid& g = field.grid;
    g.dims = {24, 24, 24};
    g.voxelSize = 0.1;
    g.origin = glm::dvec3(-1.2);
    for (uint32_t k = 0; k < 24; ++k)
        for (uint32_t j = 0; j < 24; ++j)
            for (uint32_t i = 0; i < 24; ++i)
                g.distances.push_back(float(glm::length(g.voxelCenter(i, j, k)) - 0.7));
    field.header.dims = g.dims;
    field.header.origin = g.origin;
    field.header.voxelSize = g.voxelSize;
    field.header.boundsMin = glm::dvec3(-0.7);
    field.header.boundsMax = glm::dvec3(0.7);
    const glm::dmat4 model = placement({0.2, 0, 0}, 0.4, {0, 1, 0}, {1.0, 1.5, 0.8});
    std::string error;
    auto scene = ReferenceScene::create(error);
    ASSERT_TRUE(scene) << error;
    ASSERT_TRUE(scene->addSdfField(field, model, 3, kMaskCamera, error)) << error;
    ASSERT_TRUE(scene->commit(error)) << error;
    const sdf::SdfSampler sampler(field);
    const ReferenceCamera cam = lookAtCamera({0.5, 1.5, 3.5}, {0, 0, 0}, {0, 1, 0}, 0.9, kW, kH);
    const glm::dmat4 inv = glm::inverse(model);
    size_t hits = 0, notRoot = 0, notFirst = 0, farFromSphere = 0;
    double maxAbs = 0.0, maxSphere = 0.0;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            const glm::dvec3 d = cam.pixelRay(x + 0.5, y + 0.5);
            Hit hit;
            if (!scene->intersect(cam.eye, d, 0.0, kInfD, kMaskCamera, hit)) continue;
            ++hits;
            EXPECT_EQ(hit.id, 3);
            const glm::dvec3 local(inv * glm::dvec4(hit.position, 1.0));
            const double v = std::abs(sampler.trilinear(local));
            maxAbs = std::max(maxAbs, v);
            notRoot += !(v < 1e-9);
            const double s = std::abs(glm::length(local) - 0.7);
            maxSphere = std::max(maxSphere, s);
            farFromSphere += !(s <= 0.5 * g.voxelSize);
            for (int i = 0; i < 2000; ++i) {
                const double t = hit.t * (i + 0.5) / 2000.0 * (1.0 - 1e-6);
                const glm::dvec3 p(inv * glm::dvec4(cam.eye + t * d, 1.0));
                if (glm::all(glm::greaterThanEqual(p, sampler.sampleBoxMin())) &&
                    glm::all(glm::lessThanEqual(p, sampler.sampleBoxMax())) && sampler.trilinear(p) <= 0.0) {
                    ++notFirst;
                    break;
                }
            }
        }
    std::printf(
        "field (sphere 0.7 on 24^3): %zu hits, max |interpolant| at the hit %.3g, max distance to the "
        "sphere %.4g (voxel 0.1)\n",
        hits, maxAbs, maxSphere);
    EXPECT_GT(hits, size_t(kW) * kH / 20);
    // Criteria: |interpolant| < 1e-9 at every hit, positive before it; within half a voxel of the sphere.
    EXPECT_EQ(notRoot, 0u);
    EXPECT_EQ(notFirst, 0u);
    EXPECT_EQ(farFromSphere, 0u);
}

// Renders depth and ids of a world with buildFromWorld.
std::vector<AovImage> renderWorld(const ecs::World& world, const assets::AssetManager& assets,
                                  const ReferenceCamera& cam, ReferenceScene::SdfStats* stats = nullptr) {
    std::string error;
    auto scene = ReferenceScene::create(error);
    EXPECT_TRUE(scene) << error;
    EXPECT_TRUE(buildFromWorld(world, assets, *scene, error)) << error;
    EXPECT_TRUE(scene->commit(error)) << error;
    RenderDesc desc;
    EXPECT_TRUE(parseAovList("depth,ids,normal", desc.aovs, error)) << error;
    std::vector<AovImage> images;
    EXPECT_TRUE(render(*scene, cam, desc, images, error)) << error;
    if (stats) *stats = scene->sdfStats();
    return images;
}

// A MeshBake entity's reference is its original mesh: depth, ids and normals equal those of the same
// mesh file as a MeshRenderer exactly, whether the asset manager still holds the mesh or not.
TEST(ReferenceSdf, MeshBakeIsTheOriginalMesh) {
    const std::string path = kSourceDir + "/data/meshes/teapot.ply";
    const glm::vec3 position{0.2f, -0.3f, 0.1f}, scale{1.3f, 0.7f, 1.1f};
    const glm::quat rotation = glm::angleAxis(0.6f, glm::normalize(glm::vec3(0.2f, 1.0f, 0.1f)));
    std::string error;

    assets::AssetManager meshAssets;
    ecs::World meshWorld;
    const assets::AssetId mesh = meshAssets.loadMesh(path, error);
    ASSERT_NE(mesh, 0u) << error;
    const assets::MeshData& data = *meshAssets.mesh(mesh);
    glm::dvec3 lo(1e30), hi(-1e30);
    for (const glm::vec3& p : data.positions) {
        lo = glm::min(lo, glm::dvec3(p));
        hi = glm::max(hi, glm::dvec3(p));
    }
    auto place = [&](ecs::World& w) {
        const ecs::Entity pad = w.create();  // entity index 1 for the object (ids are checked)
        (void)pad;
        const ecs::Entity e = w.create();
        ecs::Transform* t = w.add<ecs::Transform>(e);
        t->position = position;
        t->rotation = rotation;
        t->scale = scale;
        return e;
    };
    const ecs::Entity meshEntity = place(meshWorld);
    meshWorld.add<ecs::MeshRenderer>(meshEntity)->mesh = mesh;
    ecs::updateTransforms(meshWorld);

    // The baked entity as the scene loader makes it: loaded, baked, the mesh released.
    assets::AssetManager bakeAssets;
    ecs::World bakeWorld;
    const assets::AssetId bakeMesh = bakeAssets.loadMesh(path, error);
    ASSERT_NE(bakeMesh, 0u) << error;
    sdf::BakeSettings settings;
    settings.resolution = 24;
    const assets::AssetId field = bakeAssets.bakeSdf(bakeMesh, settings, error);
    ASSERT_NE(field, 0u) << error;
    const ecs::Entity bakeEntity = place(bakeWorld);
    ecs::SdfRenderer sr;
    sr.sdf = field;
    sr.source = ecs::SdfSource::MeshBake;
    sr.bakeMesh = path;
    bakeWorld.add<ecs::SdfRenderer>(bakeEntity, sr);
    ecs::updateTransforms(bakeWorld);
    ASSERT_EQ(meshEntity.index, bakeEntity.index);

    const glm::dvec3 centre = glm::dvec3(meshWorld.get<ecs::Transform>(meshEntity)->worldMatrix *
                                         glm::vec4(glm::vec3(0.5 * (lo + hi)), 1.0f));
    const double size = glm::length(hi - lo) * 1.3;
    const ReferenceCamera cam =
        lookAtCamera(centre + glm::dvec3(0.3, 0.4, 0.8) * size, centre, {0, 1, 0}, 0.8, 120, 90);
    const std::vector<AovImage> expected = renderWorld(meshWorld, meshAssets, cam);
    for (int released = 0; released < 2; ++released) {
        if (released) {
            ASSERT_TRUE(bakeAssets.release(bakeMesh));  // now read from the file
        }
        ASSERT_EQ(bakeAssets.mesh(bakeMesh) != nullptr, released == 0);
        const std::vector<AovImage> got = renderWorld(bakeWorld, bakeAssets, cam);
        size_t hits = 0, differ = 0;
        for (size_t a = 0; a < got.size(); ++a)
            for (size_t i = 0; i < got[a].data.size(); ++i) differ += got[a].data[i] != expected[a].data[i];
        for (float v : got[1].data) hits += v == float(bakeEntity.index);
        std::printf("MeshBake vs MeshRenderer (%s): %zu pixels hit, %zu values of depth/ids/normal differ\n",
                    released ? "mesh read from the file" : "mesh asset held", hits, differ);
        EXPECT_GT(hits, size_t(120) * 90 / 10);
        // Criterion: bitwise equal depth, ids and normal images.
        EXPECT_EQ(differ, 0u);
    }
}

// ---- scenes/shapes.json --------------------------------------------------------------------------

// Every visible SdfRenderer entity of scenes/shapes.json is hit (its index appears in ids), in
// process through buildFromWorld with no unconverged ray.
TEST(ReferenceSdf, ShapesSceneHitsEveryObject) {
    std::string error;
    std::unique_ptr<Engine> engine = Engine::create({}, error);
    ASSERT_TRUE(engine) << error;
    ASSERT_TRUE(engine->loadScene(kSourceDir + "/scenes/shapes.json", error)) << error;
    app::FrameTime time;
    ASSERT_TRUE(engine->updateOffline(0.0, time, error)) << error;
    ReferenceCamera cam;
    const ecs::Entity camera = scene::findCamera(engine->world(), engine->settings().camera);
    ASSERT_TRUE(makeCamera(engine->world(), camera, 160, 90, cam, error)) << error;
    ReferenceScene::SdfStats stats;
    const std::vector<AovImage> images = renderWorld(engine->world(), engine->assets(), cam, &stats);
    std::set<int> seen(images[1].data.begin(), images[1].data.end());
    size_t objects = 0;
    for (auto [e, sr, t] : engine->world().view<const ecs::SdfRenderer, const ecs::Transform>()) {
        (void)t;
        if (!sr.visible) continue;
        ++objects;
        EXPECT_TRUE(seen.count(int(e.index))) << "entity " << e.index << " is not hit";
    }
    std::printf(
        "shapes.json 160x90: %zu SDF objects, %zu distinct ids (with -1), SDF rays %llu, "
        "iterations/ray %.1f, unconverged %llu\n",
        objects, seen.size(), (unsigned long long)stats.rays,
        stats.rays ? double(stats.iterations) / double(stats.rays) : 0.0,
        (unsigned long long)stats.unconverged);
    EXPECT_EQ(objects, 8u);
    // Criterion: no ray stops at the iteration cap.
    EXPECT_EQ(stats.unconverged, 0u);
}

struct CliRun {
    int status = -1;
    std::string output;
};

const std::string kCli = std::string(PENUMBRA_BINARY_DIR) + "/tools/penumbra/penumbra";

CliRun runCli(const std::string& args, const std::string& logPath) {
    const std::string cmd = fmt::format("'{}' {} > '{}' 2>&1", kCli, args, logPath);
    CliRun r;
    const int raw = std::system(cmd.c_str());
    r.status = raw == -1 ? -1 : WEXITSTATUS(raw);
    std::ifstream in(logPath);
    r.output.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    return r;
}

FloatImage readImage(const std::string& path) {
    FloatImage img;
    std::string error;
    EXPECT_TRUE(readPfm(path, img, error)) << error;
    return img;
}

std::string outDir(const std::string& name) {
    const std::string dir = fmt::format("{}/tests/reference_out/sdf/{}", PENUMBRA_BINARY_DIR, name);
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

// `penumbra reference scenes/shapes.json --aov depth,ids` hits every object.
TEST(ReferenceSdfCli, ShapesSceneIdsCoverEveryObject) {
    ASSERT_TRUE(std::filesystem::exists(kCli)) << kCli << " is missing: build the penumbra target";
    const std::string dir = outDir("shapes_ids");
    const CliRun r =
        runCli(fmt::format("reference '{}/scenes/shapes.json' --width 160 --height 90 --aov depth,ids "
                           "--samples 1 -q -o '{}'",
                           kSourceDir, dir),
               dir + "/reference.log");
    ASSERT_EQ(r.status, 0) << r.output;
    const FloatImage ids = readImage(dir + "/ids.pfm"), depth = readImage(dir + "/depth.pfm");
    std::set<int> seen(ids.data.begin(), ids.data.end());
    size_t hit = 0;
    for (float d : depth.data) hit += d > 0.0f;
    std::string error;
    std::unique_ptr<Engine> engine = Engine::create({}, error);
    ASSERT_TRUE(engine && engine->loadScene(kSourceDir + "/scenes/shapes.json", error)) << error;
    size_t objects = 0;
    for (auto [e, sr, t] : engine->world().view<const ecs::SdfRenderer, const ecs::Transform>()) {
        (void)t;
        ++objects;
        // Criterion: each SDF entity's index appears in the ids image.
        EXPECT_TRUE(seen.count(int(e.index))) << "entity " << e.index << " is not in ids.pfm";
    }
    std::printf(
        "penumbra reference shapes.json 160x90: %zu of %zu pixels hit, %zu SDF entities, ids %zu distinct\n",
        hit, depth.data.size(), objects, seen.size());
    EXPECT_EQ(objects, 8u);
}

// The reference and the GPU trace agree on conventions: `penumbra render --quality reference --aov
// depth=...` against `penumbra reference --aov depth` on scenes/shapes.json at 160 x 90.
class ReferenceSdfVsTrace : public testing::TestWithParam<rhi::Backend> {};

TEST_P(ReferenceSdfVsTrace, ShapesDepthMatchesTrace) {
    ASSERT_TRUE(std::filesystem::exists(kCli)) << kCli << " is missing: build the penumbra target";
    constexpr uint32_t kWidth = 160, kHeight = 90;
    const std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
    const std::string dir = outDir("trace_" + backend);
    const std::string scene = kSourceDir + "/scenes/shapes.json";
    const CliRun g =
        runCli(fmt::format("render '{}' --backend {} --validation --no-cache --quality reference "
                           "--width {} --height {} -o '{}/image.png' --aov 'depth={}/depth.pfm'",
                           scene, backend, kWidth, kHeight, dir, dir),
               dir + "/render.log");
    ASSERT_EQ(g.status, 0) << g.output;
    const CliRun r =
        runCli(fmt::format("reference '{}' --width {} --height {} --aov depth --samples 1 -q -o '{}/ref'",
                           scene, kWidth, kHeight, dir),
               dir + "/reference.log");
    ASSERT_EQ(r.status, 0) << r.output;
    const FloatImage trace = readImage(dir + "/depth.pfm"), ref = readImage(dir + "/ref/depth.pfm");
    ASSERT_EQ(trace.data.size(), size_t(kWidth) * kHeight);
    ASSERT_EQ(ref.data.size(), trace.data.size());
    size_t both = 0, close = 0, onlyTrace = 0, onlyRef = 0;
    double maxRel = 0.0;
    std::vector<double> rel;
    for (size_t i = 0; i < ref.data.size(); ++i) {
        const bool a = trace.data[i] > 0.0f, b = ref.data[i] > 0.0f;
        onlyTrace += a && !b;
        onlyRef += b && !a;
        if (!a || !b) continue;
        ++both;
        const double e = std::abs(double(trace.data[i]) - double(ref.data[i])) / double(ref.data[i]);
        rel.push_back(e);
        maxRel = std::max(maxRel, e);
        close += e <= 1e-3;
    }
    std::sort(rel.begin(), rel.end());
    const double fraction = both ? double(close) / double(both) : 0.0;
    std::printf(
        "[%s] shapes.json %ux%u: %zu pixels hit in both, %.3f %% depth within 1e-3 relative, median "
        "relative %.3g, p99 %.3g, max %.3g; hit by the trace only %zu, by the reference only %zu\n",
        backend.c_str(), kWidth, kHeight, both, 100.0 * fraction, rel.empty() ? 0.0 : rel[rel.size() / 2],
        rel.empty() ? 0.0 : rel[std::min(rel.size() - 1, size_t(std::ceil(0.99 * rel.size())) - 1)], maxRel,
        onlyTrace, onlyRef);
    EXPECT_GT(both, size_t(kWidth) * kHeight / 2);
    // Criterion: depth within 1e-3 relative on >= 99.5 % of the pixels hit in both.
    EXPECT_GE(fraction, 0.995);
}

INSTANTIATE_TEST_SUITE_P(Backends, ReferenceSdfVsTrace, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test
