// Tests of the primary tile lists (issue 13 item 3; renderer/features/sdf_cull.h,
// renderer/shaders/sdf_tile_cull.comp) on both backends under validation:
//   1. conservativeness: on a scene of 40 objects (spheres, boxes, tori, capsules with rotations
//      and non-uniform scale, some across the screen edges, an unbounded floor) every object whose
//      bounds box a pixel's camera ray meets between the near and far planes (a CPU slab test in
//      double, the maths of sdf_scene.glsl sdfRayInterval) is in the list of the pixel's tile; the
//      lists cull (mean length < 50 % of the objects), are ascending, stay within the indices and
//      never take the "all objects" fallback;
//   2. memory: the lists' bytes (FrameStats::tileListBytes) follow the scene - 1 object uses far less
//      than 80 - and culling off builds nothing;
//   3. the tiles debug view: a golden per backend;
//   4. the trace's tile dispatch (SdfTileLists::dispatch): on the generated objects scene (baked
//      meshes in a room of analytic boxes, sky above) every tile is in exactly one class, the class
//      its list says (empty; a baked field listed; shape objects only), each class's dispatch
//      arguments count its tiles, and the empty tiles, which sdf_trace skips, hold the G-buffer's
//      "nothing hit" values exactly, as the same pixels do with culling off.
// Every assertion states its metric and threshold; measured numbers are printed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"
#include "engine/engine.h"
#include "engine/scene/scene.h"
#include "engine/sdf/shape_program.h"
#include "renderer/features/sdf_cull.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/objects_scene_file.h"
#include "support/ref_camera.h"
#include "support/test_device.h"
#include "support/test_files.h"

namespace penumbra::test {
namespace {

using render::FrameDesc;
using render::SceneRenderer;
using sdf::ShapeNode;

constexpr float kFovY = 1.0471976f;  // 60 degrees
constexpr uint32_t kW = 160, kH = 96;

// ---- scene ----------------------------------------------------------------------------------------

struct CullScene {
    ecs::World world;
    assets::AssetManager assets;
    ecs::Entity camera;

    CullScene(glm::vec3 eye, glm::vec3 target) {
        camera = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(camera);
        t->position = eye;
        t->rotation =
            glm::quat_cast(glm::inverse(glm::lookAtRH(glm::vec3(0), target - eye, glm::vec3(0, 1, 0))));
        ecs::Camera c;
        c.fovY = kFovY;
        c.nearPlane = 0.1f;
        c.farPlane = 100.0f;
        world.add<ecs::Camera>(camera, c);
    }
    void add(const ShapeNode& root, glm::vec3 position, glm::quat rotation, glm::vec3 scale) {
        sdf::ShapeProgram p;
        std::string error;
        ASSERT_TRUE(sdf::compileShapeProgram(root, p, error)) << error;
        const std::string key = assets::AssetManager::shapeProgramKey(p);
        const assets::AssetId id = assets.addShapeProgram(key, std::move(p), error);
        ASSERT_NE(id, 0u) << error;
        ecs::Entity e = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = position;
        t->rotation = rotation;
        t->scale = scale;
        ecs::SdfRenderer sr;
        sr.sdf = id;
        sr.source = ecs::SdfSource::Shapes;
        world.add<ecs::SdfRenderer>(e, sr);
    }
    FrameDesc frame(bool culling = true) const {
        FrameDesc d;
        d.width = kW;
        d.height = kH;
        d.camera = camera;
        d.settings.quality = scene::TraceQuality::Low;
        d.settings.acceleration.culling = culling;
        d.aux = true;
        return d;
    }
    bool render(SceneRenderer& r, const FrameDesc& d, std::string& error) {
        ecs::updateTransforms(world);
        return r.render(world, assets, d, error);
    }
};

// Deterministic pseudo-random numbers in [0, 1) (the scene is the same on every run).
struct Lcg {
    uint32_t state;
    float next() {
        state = state * 1664525u + 1013904223u;
        return float(state >> 8) / float(1u << 24);
    }
    float range(float a, float b) { return a + (b - a) * next(); }
};

// An unbounded floor, a box through the near plane and the camera plane at the right edge, and
// `count - 2` shapes scattered over (and past) the view of a camera at (0, 3, 9) looking at
// (0, 0.5, -2).
// Everything moved by `offset` (precision far from the origin).
void buildScene(CullScene& s, int count, glm::vec3 offset = glm::vec3(0.0f)) {
    s.add(ShapeNode::plane({0, 1, 0}, 0.0), offset, {1, 0, 0, 0}, glm::vec3(1));
    s.add(ShapeNode::box({0.7, 0.5, 0.8}), offset + glm::vec3(1.6f, 2.6f, 8.6f), {1, 0, 0, 0}, glm::vec3(1));
    Lcg rng{12345u};
    for (int i = 2; i < count; ++i) {
        const ShapeNode shapes[4] = {ShapeNode::sphere(0.8), ShapeNode::box({0.7, 0.5, 0.8}),
                                     ShapeNode::torus(0.7, 0.2), ShapeNode::capsule(0.35, 0.6)};
        // x beyond the frustum's half width at that depth: some objects cross the screen edges.
        const glm::vec3 p(rng.range(-10.0f, 10.0f), rng.range(0.3f, 3.0f), rng.range(-12.0f, 3.0f));
        const glm::quat q(glm::radians(glm::vec3(rng.range(0, 360), rng.range(0, 360), rng.range(0, 360))));
        const glm::vec3 scale(rng.range(0.6f, 2.0f), rng.range(0.6f, 2.0f), rng.range(0.6f, 2.0f));
        s.add(shapes[i % 4], offset + p, q, scale);
    }
}

// ---- CPU side -------------------------------------------------------------------------------------

// One traced object as the renderer uploads it: sorted by entity index, bounds with the renderer's
// relative margin (scene_renderer.cpp fillSdfData), an infinite side unbounded.
struct CpuObject {
    glm::dmat4 inv{1.0};
    glm::dvec3 lo, hi;
    bool unbounded = false;
    uint32_t entity = 0;
};

std::vector<CpuObject> cpuObjects(const ecs::World& world, const assets::AssetManager& assets) {
    std::vector<CpuObject> out;
    for (auto [e, sr, t] : world.view<ecs::SdfRenderer, ecs::Transform>()) {
        const sdf::ShapeProgram* p = assets.shapeProgram(sr.sdf);
        if (!sr.visible || sr.occluderOnly || !p) continue;  // the scenes here trace shape programs only
        CpuObject o;
        o.inv = glm::inverse(glm::dmat4(t.worldMatrix));
        o.entity = e.index;
        for (int a = 0; a < 3; ++a) {
            const double lo = p->bounds.min[a], hi = p->bounds.max[a];
            o.unbounded = o.unbounded || !std::isfinite(lo) || !std::isfinite(hi) || std::abs(lo) > 1e29 ||
                          std::abs(hi) > 1e29;
            const double margin = 1e-4 * std::max(std::abs(lo), std::abs(hi)) + 1e-6;
            o.lo[a] = lo - margin;
            o.hi[a] = hi + margin;
        }
        out.push_back(o);
    }
    std::sort(out.begin(), out.end(),
              [](const CpuObject& a, const CpuObject& b) { return a.entity < b.entity; });
    return out;
}

// Whether the ray o + t d (d unit) meets the object's box for some t in [t0, t1].
bool rayMeetsBox(const CpuObject& obj, const glm::dvec3& o, const glm::dvec3& d, double t0, double t1) {
    if (obj.unbounded) return true;
    const glm::dvec3 lo(obj.inv * glm::dvec4(o, 1.0)), ld(glm::dmat3(obj.inv) * d);
    for (int a = 0; a < 3; ++a) {
        if (ld[a] == 0.0) {
            if (lo[a] < obj.lo[a] || lo[a] > obj.hi[a]) return false;
            continue;
        }
        double ta = (obj.lo[a] - lo[a]) / ld[a], tb = (obj.hi[a] - lo[a]) / ld[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    return t0 <= t1;
}

struct Lists {
    uint32_t tilesX = 0, tilesY = 0;
    std::vector<glm::uvec2> ranges;
    std::vector<uint32_t> indices;
};

Lists readLists(SceneRenderer& r) {
    Lists l;
    l.tilesX = (kW + 7) / 8;
    l.tilesY = (kH + 7) / 8;
    std::vector<uint8_t> bytes;
    std::string error;
    EXPECT_TRUE(r.readBuffer("sdf.tile_ranges", bytes, error)) << error;
    l.ranges.resize(bytes.size() / 8);
    std::memcpy(l.ranges.data(), bytes.data(), l.ranges.size() * 8);
    EXPECT_EQ(l.ranges.size(), size_t(l.tilesX) * l.tilesY) << "ranges: one uvec2 per tile";
    EXPECT_TRUE(r.readBuffer("sdf.tile_indices", bytes, error)) << error;
    l.indices.resize(bytes.size() / 4);
    std::memcpy(l.indices.data(), bytes.data(), l.indices.size() * 4);
    return l;
}

// An engine with the scene file at `path` loaded and updated once (fields baked into the shared
// test cache); null with `error` when it could not.
std::unique_ptr<Engine> loadSceneEngine(const std::string& path, std::string& error) {
    EngineDesc desc;
    desc.loadStaticPlugins = false;
    desc.cacheDir = PENUMBRA_BINARY_DIR "/test_cache";
    std::unique_ptr<Engine> engine = Engine::create(desc, error);
    if (!engine || !engine->loadScene(path, error)) return nullptr;
    engine->update(0.0);
    return engine;
}

// A kW x kH frame of the engine's scene with culling on and the aux target.
FrameDesc culledFrame(Engine& engine) {
    FrameDesc frame;
    frame.width = kW;
    frame.height = kH;
    frame.settings = engine.settings();
    frame.settings.acceleration.culling = true;
    frame.camera = scene::findCamera(engine.world(), engine.settings().camera);
    frame.aux = true;
    return frame;
}

class SdfCull : public GpuTest {
protected:
    std::string backend() const { return GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl"; }
    // Test 1 on the 40-object scene moved by `offset`, seen from `eye`.
    // Test 1 on a world of `count` objects rendered with `frame` (kW x kH, culling on);
    // `minHitFraction` of the pixels must hit an object.
    void checkLists(const ecs::World& world, const assets::AssetManager& assets, const FrameDesc& frame,
                    size_t count, double minHitFraction);
    void checkLists(CullScene& s, size_t count, double minHitFraction) {
        ecs::updateTransforms(s.world);
        checkLists(s.world, s.assets, s.frame(), count, minHitFraction);
    }
};

// ---- 1. conservativeness ---------------------------------------------------------------------------

TEST_P(SdfCull, ListsHoldEveryObjectAPixelRayMeetsAndCull) {
    struct Case {
        const char* name;
        glm::vec3 offset, eye, target;
    };
    const Case cases[] = {{"front view", glm::vec3(0.0f), {0, 3, 9}, {0, 0.5f, -2}},
                          {"far from the origin, oblique", {4000, 0, -3000}, {-6, 6, 7}, {3, 0, -5}}};
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        std::printf("  %s:\n", c.name);
        CullScene s(c.offset + c.eye, c.offset + c.target);
        buildScene(s, 40, c.offset);
        checkLists(s, 40, 0.5);  // the floor and the shapes cover most pixels
    }
}

// 2500 overlapping small spheres inside one 8x8 tile (pixels 80..87 x 48..55 of the 160x96 frame;
// 0.1203 units per pixel at the distance 10): lists longer than the 32 x 64 candidates whose
// results the pass keeps in a register (the rest are tested again when written).
TEST_P(SdfCull, DenseClusterListsStayConservative) {
    CullScene s({0, 0, 10}, {0, 0, 0});
    const glm::vec2 centre(0.481f, -0.481f);  // pixel (84, 52)
    for (int i = 0; i < 2500; ++i)
        s.add(ShapeNode::sphere(0.05),
              {centre.x - 0.392f + 0.016f * float(i % 50), centre.y - 0.392f + 0.016f * float(i / 50), 0.0f},
              {1, 0, 0, 0}, glm::vec3(1));
    checkLists(s, 2500, 0.003);  // the cluster covers about 7 x 7 pixels
}

// The scene file scenes/shapes.json (CSG, a repeat, a plane; its own camera).
TEST_P(SdfCull, ShapesSceneListsAreConservative) {
    std::string error;
    std::unique_ptr<Engine> engine = loadSceneEngine(PENUMBRA_SOURCE_DIR "/scenes/shapes.json", error);
    ASSERT_TRUE(engine) << error;
    const FrameDesc frame = culledFrame(*engine);
    size_t count = 0;
    for (auto [e, sr] : engine->world().view<ecs::SdfRenderer>()) count += sr.visible && !sr.occluderOnly;
    checkLists(engine->world(), engine->assets(), frame, count, 0.5);
}

void SdfCull::checkLists(const ecs::World& world, const assets::AssetManager& assets, const FrameDesc& frame,
                         size_t count, double minHitFraction) {
    SceneRenderer r(dev());
    std::string error;
    ASSERT_TRUE(r.render(world, assets, frame, error)) << error;
    const std::vector<CpuObject> objects = cpuObjects(world, assets);
    ASSERT_EQ(objects.size(), count);
    const Lists l = readLists(r);
    ASSERT_FALSE(l.ranges.empty());

    // Every list: no fallback, inside the indices, strictly ascending object indices < 40.
    uint64_t fallback = 0, outside = 0, unordered = 0, total = 0, longest = 0;
    for (const glm::uvec2& range : l.ranges) {
        if (range.y == render::kSdfTileAllObjects) {
            ++fallback;
            continue;
        }
        total += range.y;
        longest = std::max<uint64_t>(longest, range.y);
        if (uint64_t(range.x) + range.y > l.indices.size()) {
            ++outside;
            continue;
        }
        for (uint32_t k = 0; k < range.y; ++k)
            unordered += l.indices[range.x + k] >= objects.size() ||
                         (k > 0 && l.indices[range.x + k] <= l.indices[range.x + k - 1]);
    }
    const double mean = double(total) / double(l.ranges.size());
    std::printf(
        "  [%s] %zu tiles, indices capacity %zu, listed %llu, mean list %.2f of %zu objects (%.1f %%), "
        "longest %llu\n",
        backend().c_str(), l.ranges.size(), l.indices.size(), (unsigned long long)total, mean, objects.size(),
        100.0 * mean / double(objects.size()), (unsigned long long)longest);
    EXPECT_EQ(fallback, 0u)
        << "tiles on the 'all objects' fallback: 0 allowed (the capacity bounds the total)";
    EXPECT_EQ(outside, 0u) << "lists reaching past the indices buffer: 0 allowed";
    EXPECT_EQ(unordered, 0u) << "entries out of ascending order or >= the object count: 0 allowed";
    EXPECT_LT(mean, 0.5 * double(objects.size())) << "mean list length must be < 50 % of the objects";
    if (fallback || outside) return;
    if (count > 2048) {
        EXPECT_GT(longest, 2048u) << "the dense case must list more than 32 x 64 objects in a tile";
    }

    // Every pixel ray's boxes are in its tile's list.
    const RefCamera cam(world, frame.camera, kW, kH);
    uint64_t missing = 0, met = 0;
    std::vector<std::vector<bool>> needed(l.ranges.size(), std::vector<bool>(objects.size(), false));
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            const glm::dvec3 dir = cam.dir(x, y);
            const double len = glm::length(dir);
            const glm::uvec2 range = l.ranges[(y / 8) * l.tilesX + x / 8];
            const auto first = l.indices.begin() + range.x, last = first + range.y;
            for (uint32_t i = 0; i < objects.size(); ++i) {
                if (!rayMeetsBox(objects[i], cam.eye, dir / len, cam.nearPlane * len, cam.farPlane * len))
                    continue;
                ++met;
                needed[(y / 8) * l.tilesX + x / 8][i] = true;
                if (!std::binary_search(first, last, i)) {
                    if (missing < 5) std::printf("  missing: pixel (%u, %u) object %u\n", x, y, i);
                    ++missing;
                }
            }
        }
    std::printf("  [%s] pixel/box pairs met %llu, missing from their tile's list %llu\n", backend().c_str(),
                (unsigned long long)met, (unsigned long long)missing);
    EXPECT_EQ(missing, 0u) << "objects a pixel ray meets but its tile does not list: 0 allowed";
    uint64_t exact = 0;  // the smallest correct lists: the objects some pixel ray of the tile meets
    for (const std::vector<bool>& tile : needed)
        exact += uint64_t(std::count(tile.begin(), tile.end(), true));
    std::printf("  [%s] exact lists would hold %llu (mean %.2f); the pass lists %.2fx that\n",
                backend().c_str(), (unsigned long long)exact, double(exact) / double(l.ranges.size()),
                double(total) / double(exact));

    // The object order is the renderer's: the traced object index of each hit pixel (gbuffer.material
    // b, a = index + 1) names the entity gbuffer.aux reports.
    std::vector<uint8_t> material, aux;
    rhi::Format format{};
    ASSERT_TRUE(r.readTarget("gbuffer.material", material, format, error)) << error;
    ASSERT_TRUE(r.readTarget("gbuffer.aux", aux, format, error)) << error;
    uint64_t hits = 0, mismatched = 0;
    for (size_t p = 0; p < size_t(kW) * kH; ++p) {
        const uint32_t index1 = material[p * 4 + 2] | uint32_t(material[p * 4 + 3]) << 8;
        float entity;
        std::memcpy(&entity, &aux[p * 8], 4);
        if (index1 == 0 || entity < 0.0f) continue;
        ++hits;
        mismatched +=
            index1 - 1 >= objects.size() || objects[index1 - 1].entity != uint32_t(std::lround(entity));
    }
    std::printf("  [%s] hit pixels %llu, object index / entity mismatches %llu\n", backend().c_str(),
                (unsigned long long)hits, (unsigned long long)mismatched);
    EXPECT_GT(double(hits), minHitFraction * kW * kH) << "hit pixels: at least the stated fraction";
    EXPECT_EQ(mismatched, 0u) << "the test's object order must be the renderer's: 0 mismatches allowed";
}

// ---- 2. memory ------------------------------------------------------------------------------------

TEST_P(SdfCull, ListBytesFollowTheScene) {
    uint64_t bytes[2] = {};
    const int counts[2] = {1, 80};
    for (int k = 0; k < 2; ++k) {
        CullScene s({0, 3, 9}, {0, 0.5f, -2});
        if (counts[k] == 1)
            s.add(ShapeNode::sphere(0.5), {0, 0.5f, 0}, {1, 0, 0, 0}, glm::vec3(1));
        else
            buildScene(s, counts[k]);
        SceneRenderer r(dev());
        std::string error;
        ASSERT_TRUE(s.render(r, s.frame(), error)) << error;
        bytes[k] = r.lastFrameStats().tileListBytes;
        std::printf("  [%s] %d objects: tile lists %llu bytes\n", backend().c_str(), counts[k],
                    (unsigned long long)bytes[k]);
        // Culling off: no lists, no pass.
        ASSERT_TRUE(s.render(r, s.frame(false), error)) << error;
        EXPECT_EQ(r.lastFrameStats().tileListBytes, 0u) << "culling off builds no lists";
        for (const auto& p : r.lastFrameStats().passes) EXPECT_NE(p.name, "sdf_tile_cull");
    }
    const uint64_t rangeBytes = uint64_t((kW + 7) / 8) * ((kH + 7) / 8) * 8;
    EXPECT_GT(bytes[0], rangeBytes) << "ranges plus at least one index";
    // The indices follow the objects: 1 object needs under a tenth of 80 objects' index bytes.
    EXPECT_LT(10 * (bytes[0] - rangeBytes), bytes[1] - rangeBytes)
        << "index bytes: 1 object < 80 objects / 10";
}

// ---- 3. the tiles debug view ----------------------------------------------------------------------

TEST_P(SdfCull, TilesDebugViewMatchesGolden) {
    CullScene s({0, 3, 9}, {0, 0.5f, -2});
    buildScene(s, 40);
    SceneRenderer r(dev());
    FrameDesc d = s.frame(false);  // the view builds the lists whatever the culling toggle says
    d.debugView = render::DebugView::Tiles;
    std::string error;
    ASSERT_TRUE(s.render(r, d, error)) << error;
    ImageRGBA8 image;
    ASSERT_TRUE(r.readPixels(image, error)) << error;
    // Every pixel of a tile has one colour; tiles show at least a few different lengths.
    std::vector<uint32_t> colours;
    uint64_t uneven = 0;
    auto at = [&](uint32_t x, uint32_t y) {
        uint32_t c;
        std::memcpy(&c, &image.pixels[(size_t(y) * kW + x) * 4], 4);
        return c;
    };
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            uneven += at(x, y) != at(x & ~7u, y & ~7u);
            if (std::find(colours.begin(), colours.end(), at(x, y)) == colours.end())
                colours.push_back(at(x, y));
        }
    std::printf("  [%s] tiles view: %zu colours, %llu pixels unlike their tile's first\n", backend().c_str(),
                colours.size(), (unsigned long long)uneven);
    EXPECT_EQ(uneven, 0u) << "one colour per tile: 0 pixels differing from their tile allowed";
    EXPECT_GE(colours.size(), 6u) << "at least 6 distinct list lengths shown";
    const std::string failure = checkGolden(backend(), "sdf_cull_tiles", image);
    EXPECT_TRUE(failure.empty()) << failure;
}

// ---- 4. the trace's tile dispatch ------------------------------------------------------------------

// The G-buffer of the frame just rendered: depth, material and aux texels.
struct GBufferTexels {
    std::vector<float> depth, aux;  // aux: x id, y steps (two floats per pixel)
    std::vector<uint8_t> material;  // RGBA8
};

bool readGBuffer(SceneRenderer& r, GBufferTexels& g, std::string& error) {
    std::vector<uint8_t> texels;
    rhi::Format format{};
    if (!r.readTarget("gbuffer.depth", texels, format, error)) return false;
    g.depth.resize(texels.size() / 4);
    std::memcpy(g.depth.data(), texels.data(), texels.size());
    if (!r.readTarget("gbuffer.material", g.material, format, error)) return false;
    if (!r.readTarget("gbuffer.aux", texels, format, error)) return false;
    g.aux.resize(texels.size() / 4);
    std::memcpy(g.aux.data(), texels.data(), texels.size());
    return true;
}

TEST_P(SdfCull, TileDispatchSortsEveryTileByItsList) {
    if (!std::filesystem::exists(PENUMBRA_SOURCE_DIR "/data/meshes/bunny.ply"))
        GTEST_SKIP() << "data/meshes is missing: run tools/fetch_meshes.sh";
    std::string error;
    const std::string path = writeObjectsScene("cull_objects20.json", 20, float(kW) / float(kH), error);
    ASSERT_FALSE(path.empty()) << error;
    std::unique_ptr<Engine> engine = loadSceneEngine(path, error);
    ASSERT_TRUE(engine) << error;
    FrameDesc frame = culledFrame(*engine);

    SceneRenderer r(dev());
    ASSERT_TRUE(r.render(engine->world(), engine->assets(), frame, error)) << error;
    const Lists l = readLists(r);
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(r.readBuffer("sdf.objects", bytes, error)) << error;
    std::vector<render::GpuSdfObject> objects(bytes.size() / sizeof(render::GpuSdfObject));
    std::memcpy(objects.data(), bytes.data(), objects.size() * sizeof(render::GpuSdfObject));
    ASSERT_TRUE(r.readBuffer("sdf.tile_dispatch", bytes, error)) << error;
    const size_t tiles = size_t(l.tilesX) * l.tilesY;
    ASSERT_EQ(bytes.size(), (render::kSdfTileDispatchHeader + render::kSdfTileClasses * tiles) * 4);
    std::vector<uint32_t> dispatch(bytes.size() / 4);
    std::memcpy(dispatch.data(), bytes.data(), bytes.size());
    GBufferTexels culled;
    ASSERT_TRUE(readGBuffer(r, culled, error)) << error;

    // The class each tile's list calls for.
    auto expectedClass = [&](size_t tile) {
        const glm::uvec2 range = l.ranges[tile];
        if (range.y == render::kSdfTileAllObjects) return render::SdfTileClass::Fields;
        if (range.y == 0) return render::SdfTileClass::Empty;
        for (uint32_t k = 0; k < range.y; ++k)
            if (objects.at(l.indices.at(range.x + k)).info.x == uint32_t(render::SdfKind::Field))
                return render::SdfTileClass::Fields;
        return render::SdfTileClass::Shapes;
    };
    std::vector<int> seen(tiles, 0);
    uint64_t wrongClass = 0, outOfRange = 0;
    uint32_t counts[render::kSdfTileClasses] = {};
    for (uint32_t c = 0; c < render::kSdfTileClasses; ++c) {
        const render::SdfTileClass cls = render::SdfTileClass(c);
        const uint32_t* record = &dispatch[render::sdfTileDispatchRecord(cls) / 4];
        counts[c] = record[0];
        EXPECT_EQ(record[1], 1u) << "class " << c << ": dispatch arguments (tiles, 1, 1)";
        EXPECT_EQ(record[2], 1u) << "class " << c << ": dispatch arguments (tiles, 1, 1)";
        ASSERT_LE(counts[c], tiles) << "class " << c;
        const uint32_t first = render::sdfTileDispatchFirst(cls, l.tilesX, l.tilesY);
        for (uint32_t k = 0; k < counts[c]; ++k) {
            const uint32_t tile = dispatch[first + k];
            if (tile >= tiles) {
                ++outOfRange;
                continue;
            }
            ++seen[tile];
            wrongClass += expectedClass(tile) != cls;
        }
    }
    const uint64_t missing = uint64_t(std::count(seen.begin(), seen.end(), 0));
    const uint64_t repeated = uint64_t(std::count_if(seen.begin(), seen.end(), [](int n) { return n > 1; }));
    std::printf("  [%s] %zu tiles: %u with a field, %u shapes only, %u empty\n", backend().c_str(), tiles,
                counts[0], counts[1], counts[2]);
    EXPECT_EQ(uint64_t(counts[0]) + counts[1] + counts[2], tiles)
        << "the classes' counts add up to the tiles";
    EXPECT_EQ(outOfRange, 0u) << "tile indices < tilesX * tilesY";
    EXPECT_EQ(missing, 0u) << "every tile in a class: 0 missing allowed";
    EXPECT_EQ(repeated, 0u) << "no tile in two places: 0 allowed";
    EXPECT_EQ(wrongClass, 0u) << "each tile in the class its list calls for: 0 mismatches allowed";
    // The scene has all three: objects (fields), floor and walls alone (shapes), sky (empty).
    EXPECT_GT(counts[0], 0u) << "tiles with a baked field";
    EXPECT_GT(counts[1], 0u) << "tiles of shape objects only";
    EXPECT_GT(counts[2], 0u) << "empty tiles";

    // The empty tiles' pixels (which sdf_trace did not run on) hold "nothing hit" exactly, as they
    // do with culling off (every tile traced).
    frame.settings.acceleration.culling = false;
    SceneRenderer unculled(dev());
    ASSERT_TRUE(unculled.render(engine->world(), engine->assets(), frame, error)) << error;
    GBufferTexels all;
    ASSERT_TRUE(readGBuffer(unculled, all, error)) << error;
    ASSERT_EQ(culled.depth.size(), size_t(kW) * kH);
    ASSERT_EQ(all.depth.size(), culled.depth.size());
    uint64_t emptyPixels = 0, notMiss = 0, differ = 0;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            if (expectedClass((y / 8) * l.tilesX + x / 8) != render::SdfTileClass::Empty) continue;
            const size_t p = size_t(y) * kW + x;
            ++emptyPixels;
            const bool miss = culled.depth[p] == 0.0f && culled.aux[2 * p] == -1.0f &&
                              culled.aux[2 * p + 1] == 0.0f &&
                              std::all_of(&culled.material[4 * p], &culled.material[4 * p + 4],
                                          [](uint8_t v) { return v == 0; });
            notMiss += !miss;
            differ += culled.depth[p] != all.depth[p] || culled.aux[2 * p] != all.aux[2 * p] ||
                      culled.aux[2 * p + 1] != all.aux[2 * p + 1] ||
                      !std::equal(&culled.material[4 * p], &culled.material[4 * p + 4], &all.material[4 * p]);
        }
    std::printf("  [%s] %llu pixels in empty tiles: %llu not \"nothing hit\", %llu unlike culling off\n",
                backend().c_str(), (unsigned long long)emptyPixels, (unsigned long long)notMiss,
                (unsigned long long)differ);
    EXPECT_GT(emptyPixels, 0u);
    EXPECT_EQ(notMiss, 0u) << "depth 0, material 0, aux (-1, 0): 0 other pixels allowed";
    EXPECT_EQ(differ, 0u) << "the same texels as with culling off: 0 pixels differing allowed";
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfCull, testing::ValuesIn(gpuBackends()), backendName);

// ---- the CPU capacity bound -------------------------------------------------------------------------

TEST(SdfTileListCapacity, CountsEachObjectsScreenRectangle) {
    // Camera at the origin looking down -Z, 60 degrees, 160x96: 20 x 12 tiles.
    const glm::mat4 view(1.0f);
    glm::mat4 proj = glm::perspectiveRH_ZO(kFovY, float(kW) / float(kH), 0.1f, 100.0f);
    proj[1][1] *= -1.0f;
    auto object = [](glm::vec3 position, float half, bool unbounded = false) {
        render::GpuSdfObject o{};
        o.model = glm::translate(glm::mat4(1.0f), position);
        o.worldToLocal = glm::inverse(o.model);
        o.boundsMin = glm::vec4(glm::vec3(unbounded ? -render::kSdfUnbounded : -half), 1.0f);
        o.boundsMax = glm::vec4(glm::vec3(unbounded ? render::kSdfUnbounded : half), 0.0f);
        return o;
    };
    auto capacity = [&](const render::GpuSdfObject& o) {
        const std::vector<render::GpuSdfObject> objects{o};
        return render::sdfTileListCapacity({objects, view, proj, 0.1f, 100.0f}, kW, kH);
    };
    const uint64_t all = 20 * 12;
    const uint64_t centre = capacity(object({0, 0, -10}, 0.05f));  // a few pixels wide
    const uint64_t big = capacity(object({0, 0, -10}, 2.0f));
    std::printf("  tiles: unbounded %llu, small %llu, large %llu of %llu\n",
                (unsigned long long)capacity(object({0, 0, 0}, 1, true)), (unsigned long long)centre,
                (unsigned long long)big, (unsigned long long)all);
    EXPECT_EQ(capacity(object({0, 0, 0}, 1, true)), all) << "unbounded: every tile";
    EXPECT_EQ(capacity(object({0, 0, 0.5f}, 1.0f)), all) << "around the camera plane: every tile";
    EXPECT_EQ(capacity(object({0, 0, 5}, 0.5f)), 1u)
        << "wholly behind the camera: none (the minimum 1 entry)";
    EXPECT_EQ(capacity(object({0, 0, -150}, 0.5f)), 1u) << "wholly behind the far plane: none";
    EXPECT_EQ(capacity(object({100, 0, -10}, 0.5f)), 1u) << "far outside the view: none";
    // A sphere inside one tile, grown by a tile each way: at most 3 x 3 (a tile corner: 4 x 4).
    EXPECT_GE(centre, 1u);
    EXPECT_LE(centre, 16u) << "a few-pixel object: its tile and the ring around it";
    EXPECT_GT(big, centre);
    EXPECT_LT(big, all) << "a 4-unit box at 10 units covers part of the frame";
}

}  // namespace
}  // namespace penumbra::test
