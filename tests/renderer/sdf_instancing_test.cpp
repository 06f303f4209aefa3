// Instancing at scale and the persistent SDF object array updated from deltas (issue 13 item 4;
// renderer/features/sdf_scene.h SdfSceneStore, renderer/shaders/sdf_object_scatter.comp), on both
// backends under validation:
//   1. the store on its own (a frame graph, no renderer): after every frame the persistent buffer
//      holds exactly this frame's objects (read back, byte for byte) while only changed objects
//      travel: 0 in a static frame, 1 for one change, what shifted when objects are removed or
//      added, a full rewrite past half changed, on growth and on shrinking;
//   2. the scene renderer: one moving object uploads one record per frame (also the frame after it
//      stops: its prevModel changes), a static frame none, and every frame's image equals the one a
//      fresh renderer (which uploads everything) makes of the same world; adding and removing
//      objects re-uploads what shifted, with the same image check;
//   3. scale: 1000 instances of three shape programs (a golden per backend and Vulkan-vs-OpenGL
//      parity; every instance seen in the ids; 100 of them moving: a 100-entry delta, same image as
//      a fresh renderer) and 1000 distinct programs (1000 different records: no fixed limit;
//      sampled objects are where they should be); 256 objects (read by the trace as a uniform
//      block) and 257 (as a storage buffer) give the same image. DeltaAndFullUploadCost prints what
//      the delta and the full upload cost (the threshold between them, renderer/features/sdf_scene.h).
// Every criterion states its metric and threshold next to it; measured numbers are printed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/assets/asset_manager.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"
#include "engine/image/image.h"
#include "engine/scene/scene.h"
#include "engine/sdf/shape_program.h"
#include "renderer/core/blackboard.h"
#include "renderer/core/gpu_cache.h"
#include "renderer/features/frame_context.h"
#include "renderer/features/sdf_atlas.h"
#include "renderer/features/sdf_scene.h"
#include "renderer/frame_graph/frame_graph.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/ref_camera.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

using render::FrameDesc;
using render::GpuSdfObject;
using render::SceneRenderer;
using sdf::ShapeNode;

constexpr float kFovY = 1.0471976f;  // 60 degrees

// ---- 1. the store on its own ------------------------------------------------------------------------

// An object record whose every byte depends on (id, version): a change of either changes it.
GpuSdfObject syntheticObject(uint32_t id, uint32_t version) {
    GpuSdfObject o{};
    float* f = reinterpret_cast<float*>(&o);
    for (int k = 0; k < 48; ++k) f[k] = float(id) * 1.25f + float(version) * 1000.0f + float(k) * 0.5f;
    o.info = {0u, 0u, id, version};
    o.params = {0u, 1u, id ^ 0x5a5a5a5au, version};
    return o;
}

class StoreHarness {
public:
    explicit StoreHarness(rhi::Device& device)
        : m_device(device), m_graph(device), m_cache(device), m_store(device) {}
    ~StoreHarness() {
        m_device.waitIdle();
        m_store.release(m_graph);
    }

    // Runs one frame of `data`; the names of the executed passes go to `passes`.
    bool frame(const render::SdfSceneData& data, std::vector<std::string>& passes) {
        m_graph.reset();
        m_board.clear();
        render::FrameContext fc{m_device, m_graph, m_cache, m_board, 64, 64};
        render::addSdfSceneUpload(fc, data, m_store);
        if (!m_graph.compile()) return false;
        passes.clear();
        for (const auto& p : m_graph.compiled().passes) passes.push_back(p.name);  // kept passes
        rhi::CommandList& cmd = m_device.beginCommandList("sdf store test");
        m_graph.execute(cmd);
        m_device.submit(cmd);
        m_timings = m_graph.collectTimings();
        m_device.waitIdle();
        return true;
    }
    // GPU and recording (CPU) milliseconds of the last frame's upload passes together.
    std::pair<double, double> uploadMs() const {
        double gpu = 0.0, cpu = 0.0;
        for (const fg::PassTiming& t : m_timings)
            if (t.name == "sdf_upload" || t.name == "sdf_object_scatter") {
                gpu += t.gpuMs;
                cpu += t.cpuMs;
            }
        return {gpu, cpu};
    }
    // The first `count` objects of the persistent buffer.
    std::vector<GpuSdfObject> read(size_t count) {
        std::vector<GpuSdfObject> out(count);
        if (count > 0) {
            EXPECT_TRUE(
                m_device.readBuffer(m_store.objectBuffer(), 0, count * sizeof(GpuSdfObject), out.data()));
        }
        return out;
    }
    const render::SdfSceneStore& store() const { return m_store; }

private:
    rhi::Device& m_device;
    fg::FrameGraph m_graph;
    render::GpuCache m_cache;
    render::Blackboard m_board;
    render::SdfSceneStore m_store;
    std::vector<fg::PassTiming> m_timings;
};

class SdfInstancing : public GpuTest {};

TEST_P(SdfInstancing, StoreUploadsOnlyWhatChanged) {
    StoreHarness h(dev());
    render::SdfSceneData data;
    sdf::ShapeInstruction record{};
    record.a = glm::vec4(1, 2, 3, 4);
    data.records = {record, record};
    // Per array position: the object's identity and version (its record changes with either).
    struct Item {
        uint32_t id = 0, version = 0;
    };
    std::vector<Item> versions(100);
    for (uint32_t i = 0; i < 100; ++i) versions[i].id = i;
    uint32_t nextId = 100;
    auto rebuild = [&] {
        data.objects.clear();
        for (const Item& it : versions) data.objects.push_back(syntheticObject(it.id, it.version));
        data.tracedCount = uint32_t(data.objects.size());
    };
    std::vector<std::string> passes;
    auto has = [&](const char* name) {
        return std::find(passes.begin(), passes.end(), name) != passes.end();
    };
    // Runs a frame; checks the read-back array (exact: memcmp == 0) and returns the upload stats.
    auto step = [&](const char* what) {
        EXPECT_TRUE(h.frame(data, passes)) << what;
        const std::vector<GpuSdfObject> gpu = h.read(data.objects.size());
        // Metric: bytes of the persistent array against this frame's objects. Threshold: identical.
        EXPECT_EQ(std::memcmp(gpu.data(), data.objects.data(), gpu.size() * sizeof(GpuSdfObject)), 0) << what;
        const auto& st = h.store().stats();
        std::printf(
            "  %-28s %4zu objects: %4u uploaded (full %d, delta %6llu B, sent %7llu B), buffer %7llu B\n",
            what, data.objects.size(), st.objectsUploaded, int(st.fullUpload),
            (unsigned long long)st.deltaBytes, (unsigned long long)st.uploadBytes,
            (unsigned long long)st.objectBufferBytes);
        return st;
    };

    rebuild();
    auto st = step("first frame");
    EXPECT_EQ(st.objectsUploaded, 100u);  // threshold: all of them, one plain upload
    EXPECT_TRUE(st.fullUpload && st.recordsUploaded);
    EXPECT_TRUE(has("sdf_upload") && !has("sdf_object_scatter"));

    st = step("static");
    EXPECT_EQ(st.objectsUploaded, 0u);  // threshold: nothing sent
    EXPECT_EQ(st.uploadBytes, 0u);
    EXPECT_TRUE(has("sdf_upload") && !has("sdf_object_scatter")) << "the empty upload pass stays";

    ++versions[37].version;
    rebuild();
    st = step("one changed");
    EXPECT_EQ(st.objectsUploaded, 1u);  // threshold: exactly the changed one
    EXPECT_EQ(st.deltaBytes, 272u);     // index header + one 256-byte record
    EXPECT_FALSE(st.fullUpload || st.recordsUploaded);
    EXPECT_TRUE(has("sdf_object_scatter"));

    for (uint32_t i : {5u, 50u, 99u}) ++versions[i].version;
    rebuild();
    EXPECT_EQ(step("three changed").objectsUploaded, 3u);

    versions.erase(versions.begin() + 90);  // objects 91..99 shift down by one
    rebuild();
    st = step("removed #90");
    EXPECT_EQ(st.objectsUploaded, 9u);  // threshold: exactly the shifted ones (90..98)
    EXPECT_FALSE(st.fullUpload);

    versions.push_back({nextId++, 0});
    versions.push_back({nextId++, 0});
    rebuild();
    EXPECT_EQ(step("appended two").objectsUploaded, 2u);

    for (uint32_t i = 0; i < 60; ++i) ++versions[i].version;
    rebuild();
    st = step("60 of 101 changed");
    EXPECT_TRUE(st.fullUpload) << "more than half changed: one plain upload";
    EXPECT_EQ(st.objectsUploaded, 101u);
    EXPECT_TRUE(has("sdf_upload") && !has("sdf_object_scatter"));

    const uint64_t before = st.objectBufferBytes;
    while (versions.size() < 300) versions.push_back({nextId++, 0});
    rebuild();
    st = step("grown to 300");
    EXPECT_GE(st.objectBufferBytes, std::max<uint64_t>(2 * before, 300 * sizeof(GpuSdfObject)))
        << "capacity grows at least geometrically";
    EXPECT_TRUE(st.fullUpload);

    versions.push_back({nextId++, 0});
    rebuild();
    st = step("one more");
    EXPECT_EQ(st.objectsUploaded, 1u) << "growth within capacity: a delta";

    versions.resize(10);
    rebuild();
    st = step("shrunk to 10");
    EXPECT_LE(st.objectBufferBytes, 64u * sizeof(GpuSdfObject)) << "a far too large buffer shrinks";
    EXPECT_TRUE(st.fullUpload);

    data.records[1].b = glm::vec4(9.0f);
    st = step("records changed");
    EXPECT_TRUE(st.recordsUploaded);
    EXPECT_EQ(st.objectsUploaded, 0u);
    EXPECT_EQ(st.uploadBytes, 2u * sizeof(sdf::ShapeInstruction));

    // A field table (the atlas' slot table): sent when it first appears and when it changes.
    rhi::TextureDesc atlasDesc;
    atlasDesc.dimension = rhi::TextureDimension::Tex3D;
    atlasDesc.format = rhi::Format::R16_FLOAT;
    atlasDesc.width = atlasDesc.height = atlasDesc.depthOrLayers = 8;
    atlasDesc.debugName = "test atlas";
    const rhi::TextureHandle atlas = dev().createTexture(atlasDesc);
    ASSERT_TRUE(atlas.isValid());
    std::vector<float> fieldTable(2 * sizeof(render::GpuSdfField) / sizeof(float), 0.5f);
    data.atlas = atlas;
    data.fields = fieldTable.data();
    data.fieldBytes = fieldTable.size() * sizeof(float);
    st = step("field table appears");
    EXPECT_TRUE(st.fieldsUploaded && !st.recordsUploaded);
    EXPECT_EQ(st.uploadBytes, data.fieldBytes);  // threshold: exactly the table
    st = step("field table unchanged");
    EXPECT_FALSE(st.fieldsUploaded);
    EXPECT_EQ(st.uploadBytes, 0u);
    fieldTable[3] = 2.0f;
    st = step("field table changed");
    EXPECT_TRUE(st.fieldsUploaded);
    data.atlas = {};
    data.fields = nullptr;
    data.fieldBytes = 0;
    dev().destroy(atlas);

    data.objects.clear();
    data.tracedCount = 0;
    st = step("no objects");
    EXPECT_EQ(st.objectsUploaded, 0u);
}

// The cost behind the full-rewrite threshold (more than half changed: one plain upload), printed
// for docs; only the upload paths are asserted (times never are). 8192 objects; each row changes
// a fraction of them (distinct objects every frame) and reports the median of 3 frames.
TEST_P(SdfInstancing, DeltaAndFullUploadCost) {
    constexpr uint32_t n = 8192;
    StoreHarness h(dev());
    render::SdfSceneData data;
    data.records.resize(1);
    std::vector<uint32_t> versions(n, 0);
    auto rebuild = [&] {
        data.objects.clear();
        for (uint32_t i = 0; i < n; ++i) data.objects.push_back(syntheticObject(i, versions[i]));
        data.tracedCount = n;
    };
    std::vector<std::string> passes;
    rebuild();
    ASSERT_TRUE(h.frame(data, passes));  // the first, full upload
    uint32_t round = 0;
    for (uint32_t changed : {n / 64, n / 8, n / 4, n / 2, n / 2 + 1, n}) {
        std::vector<double> gpu, cpu;
        for (int k = 0; k < 3; ++k, ++round) {
            for (uint32_t i = 0; i < changed; ++i) ++versions[(i + round * 997u) % n];
            rebuild();
            ASSERT_TRUE(h.frame(data, passes));
            const auto [g, c] = h.uploadMs();
            gpu.push_back(g);
            cpu.push_back(c);
            EXPECT_EQ(h.store().stats().objectsUploaded, changed > n / 2 ? n : changed);
            EXPECT_EQ(h.store().stats().fullUpload, changed > n / 2);
        }
        std::sort(gpu.begin(), gpu.end());
        std::sort(cpu.begin(), cpu.end());
        const auto& st = h.store().stats();
        std::printf("  %5u of %u changed: %s, %8llu B sent, upload passes GPU %.3f ms, recording %.3f ms\n",
                    changed, n, st.fullUpload ? "full " : "delta", (unsigned long long)st.uploadBytes, gpu[1],
                    cpu[1]);
    }
}

// ---- scenes ----------------------------------------------------------------------------------------

glm::quat lookRotation(glm::vec3 dir) {
    return glm::quat_cast(glm::inverse(glm::lookAtRH(glm::vec3(0), dir, glm::vec3(0, 1, 0))));
}

struct Scene {
    ecs::World world;
    assets::AssetManager assets;
    ecs::Entity camera;
    std::vector<assets::AssetId> materials;

    Scene(glm::vec3 eye, glm::vec3 target) {
        camera = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(camera);
        t->position = eye;
        t->rotation = lookRotation(target - eye);
        ecs::Camera c;
        c.fovY = kFovY;
        c.nearPlane = 0.1f;
        c.farPlane = 100.0f;
        world.add<ecs::Camera>(camera, c);
        const glm::vec3 colours[] = {
            {0.8f, 0.2f, 0.15f}, {0.2f, 0.7f, 0.25f}, {0.2f, 0.35f, 0.85f}, {0.85f, 0.75f, 0.2f}};
        for (int i = 0; i < 4; ++i) {
            ecs::Material m;
            m.baseColor = glm::vec4(colours[i], 1.0f);
            m.roughness = 0.5f;
            materials.push_back(assets.addMaterial("instancing-material-" + std::to_string(i), m));
        }
        ecs::Entity sun = world.create();
        ecs::Transform* st = world.add<ecs::Transform>(sun);
        st->rotation = lookRotation(glm::vec3(-0.4f, -0.6f, -0.7f));
        ecs::Light l;
        l.type = ecs::LightType::Directional;
        l.intensity = 3.0f;
        l.castShadows = false;  // shadows are switched on per test
        world.add<ecs::Light>(sun, l);
        light = sun;
    }
    assets::AssetId program(const ShapeNode& root) {
        sdf::ShapeProgram p;
        std::string error;
        EXPECT_TRUE(sdf::compileShapeProgram(root, p, error)) << error;
        const std::string key = assets::AssetManager::shapeProgramKey(p);
        assets::AssetId id = assets.addShapeProgram(key, std::move(p), error);
        EXPECT_NE(id, 0u) << error;
        return id;
    }
    ecs::Entity object(assets::AssetId program, glm::vec3 position, uint32_t material, float scale = 1.0f) {
        ecs::Entity e = world.create();
        ecs::Transform* t = world.add<ecs::Transform>(e);
        t->position = position;
        t->rotation = glm::quat(glm::radians(glm::vec3(20.0f, 35.0f, 0.0f)));
        t->scale = glm::vec3(scale);
        ecs::SdfRenderer sr;
        sr.sdf = program;
        sr.source = ecs::SdfSource::Shapes;
        sr.material = materials[material % materials.size()];
        world.add<ecs::SdfRenderer>(e, sr);
        return e;
    }
    FrameDesc frame(uint32_t w, uint32_t h) const {
        FrameDesc d;
        d.width = w;
        d.height = h;
        d.camera = camera;
        d.aux = true;
        d.settings.background = glm::vec3(0.05f, 0.06f, 0.08f);
        return d;
    }
    ecs::Entity light;
};

bool renderImage(Scene& s, SceneRenderer& r, const FrameDesc& d, ImageRGBA8& image) {
    std::string error;
    ecs::updateTransforms(s.world);
    const bool ok = r.render(s.world, s.assets, d, error) && r.readPixels(image, error);
    EXPECT_TRUE(ok) << error;
    return ok;
}

// The same frame from a renderer that has never uploaded anything (so it uploads everything).
ImageRGBA8 freshImage(rhi::Device& device, Scene& s, const FrameDesc& d) {
    SceneRenderer fresh(device);
    ImageRGBA8 image;
    renderImage(s, fresh, d, image);
    device.waitIdle();
    return image;
}

bool ranPass(const SceneRenderer& r, const std::string& name) {
    for (const auto& p : r.lastFrameStats().passes)
        if (p.name == name) return true;
    return false;
}

// A floor (array position 0: created first) under 24 objects of three programs in a 6x4 grid in
// front of the camera, sun shadows on (so the effects see moved objects too: their shadows move).
std::vector<ecs::Entity> buildSmallScene(Scene& s) {
    const ecs::Entity floor =
        s.object(s.program(ShapeNode::plane(glm::dvec3(0, 1, 0), 0.0)), {0, -1.8f, 0}, 3);
    s.world.get<ecs::Transform>(floor)->rotation = glm::quat(1, 0, 0, 0);  // level
    const assets::AssetId programs[] = {s.program(ShapeNode::sphere(0.3)),
                                        s.program(ShapeNode::box(glm::dvec3(0.25))),
                                        s.program(ShapeNode::torus(0.25, 0.08))};
    std::vector<ecs::Entity> out;
    for (int i = 0; i < 24; ++i)
        out.push_back(s.object(
            programs[i % 3], {-2.0f + 0.8f * float(i % 6), -1.2f + 0.8f * float(i / 6), -5.0f}, uint32_t(i)));
    s.world.get<ecs::Light>(s.light)->castShadows = true;
    return out;
}

// The delta frames isolate the object upload: the world cache and id field keep their own history
// (tested by their module), so they are off here; the picture must not depend on how objects came.
FrameDesc deltaFrame(const Scene& s) {
    FrameDesc d = s.frame(128, 96);
    d.settings.acceleration.worldCache = false;
    d.settings.acceleration.idField = false;
    return d;
}

// Metric: per-channel |delta| between the incrementally updated renderer's image and a fresh
// renderer's. Threshold: identical or at most 1/255 anywhere.
void expectSameAsFresh(rhi::Device& device, Scene& s, const FrameDesc& d, const ImageRGBA8& image,
                       const char* what) {
    const ImageRGBA8 fresh = freshImage(device, s, d);
    ImageRule rule;
    rule.perChannelTolerance = 1;
    rule.maxFractionOver = 0.0;
    rule.hardLimit = 1;
    const ImageDiff diff = compareImages(image, fresh, rule);
    std::printf("  %-34s vs a fresh renderer: %s\n", what, diff.summary().c_str());
    EXPECT_TRUE(diff.pass) << what << ": " << diff.summary();
    EXPECT_LE(diff.maxDelta, 1) << what;
}

// ---- 2. deltas in the scene renderer ---------------------------------------------------------------

TEST_P(SdfInstancing, MovingObjectUploadsOneRecordPerFrame) {
    Scene s({0, 0, 0}, {0, 0, -1});
    const std::vector<ecs::Entity> objects = buildSmallScene(s);
    SceneRenderer r(dev());
    const FrameDesc d = deltaFrame(s);
    ImageRGBA8 image;
    ASSERT_TRUE(renderImage(s, r, d, image));
    const ImageRGBA8 first = image;
    EXPECT_EQ(r.lastFrameStats().sdfUpload.objectsUploaded, 25u);  // threshold: the first frame sends all
    EXPECT_TRUE(r.lastFrameStats().sdfUpload.fullUpload);
    // Frames 1, 2: object 9 moves; frame 3: it stops (its prevModel still changes); frame 4: static.
    const uint32_t expected[] = {1, 1, 1, 0};
    for (int f = 1; f <= 4; ++f) {
        if (f <= 2) s.world.get<ecs::Transform>(objects[9])->position += glm::vec3(0.15f, 0.1f, 0.0f);
        ASSERT_TRUE(renderImage(s, r, d, image));
        const render::SdfUploadReport& up = r.lastFrameStats().sdfUpload;
        std::printf("  frame %d: %u objects uploaded, delta %llu B, object buffer %llu B\n", f,
                    up.objectsUploaded, (unsigned long long)up.deltaBytes,
                    (unsigned long long)up.objectBufferBytes);
        // Metric: records sent this frame. Threshold: exactly 1 while the object's matrices change
        // (moving, and the frame after it stops), 0 once everything is static.
        EXPECT_EQ(up.objectsUploaded, expected[f - 1]) << "frame " << f;
        EXPECT_FALSE(up.fullUpload) << "frame " << f;
        EXPECT_EQ(ranPass(r, "sdf_object_scatter"), expected[f - 1] > 0) << "frame " << f;
        EXPECT_TRUE(ranPass(r, "sdf_upload")) << "frame " << f;
        const std::string what = "frame " + std::to_string(f);
        expectSameAsFresh(dev(), s, d, image, what.c_str());
    }
    // The motion is visible (object and shadow), so the comparisons above could see a stale record.
    const ImageDiff moved = compareImages(image, first);
    std::printf("  last frame vs the first: %s\n", moved.summary().c_str());
    EXPECT_GT(moved.pixelsOver, 100u);  // threshold: over 100 px changed by more than 5/255
    const std::string dir = goldenOutDir("instancing");
    std::filesystem::create_directories(dir);
    writePng(dir + "/moving_last_" + (GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl") + ".png", image);
}

TEST_P(SdfInstancing, AddingAndRemovingObjectsReuploadsWhatShifted) {
    Scene s({0, 0, 0}, {0, 0, -1});
    std::vector<ecs::Entity> objects = buildSmallScene(s);
    SceneRenderer r(dev());
    const FrameDesc d = deltaFrame(s);
    ImageRGBA8 image;
    ASSERT_TRUE(renderImage(s, r, d, image));

    // Remove the object at array position 21 of 25: positions 21..23 now hold other objects.
    s.world.destroy(objects[20]);
    ASSERT_TRUE(renderImage(s, r, d, image));
    // Metric: records sent. Threshold: exactly the 3 that shifted.
    EXPECT_EQ(r.lastFrameStats().sdfUpload.objectsUploaded, 3u);
    EXPECT_EQ(r.lastFrameStats().sdfObjects, 24u);
    expectSameAsFresh(dev(), s, d, image, "removed one of 25");

    // Add one: it lands at the position of its entity index among the others (the renderer orders
    // objects by entity index), and every object from there on shifts up.
    const ecs::Entity added =
        s.object(s.world.get<ecs::SdfRenderer>(objects[0])->sdf, {0.4f, 0.0f, -3.5f}, 3);
    uint32_t position = 0;
    for (auto [e, sr] : s.world.view<ecs::SdfRenderer>())
        if (e.index < added.index) ++position;
    ASSERT_TRUE(renderImage(s, r, d, image));
    // Metric: records sent. Threshold: exactly the new one and those after it (25 - position).
    EXPECT_EQ(r.lastFrameStats().sdfUpload.objectsUploaded, 25u - position) << "added at " << position;
    expectSameAsFresh(dev(), s, d, image, "added one");

    // Remove the first object: everything shifts, more than half: one plain upload of all 24.
    s.world.destroy(objects[0]);
    ASSERT_TRUE(renderImage(s, r, d, image));
    EXPECT_TRUE(r.lastFrameStats().sdfUpload.fullUpload);
    EXPECT_EQ(r.lastFrameStats().sdfUpload.objectsUploaded, 24u);
    expectSameAsFresh(dev(), s, d, image, "removed the first (full rewrite)");

    ASSERT_TRUE(renderImage(s, r, d, image));
    EXPECT_EQ(r.lastFrameStats().sdfUpload.objectsUploaded, 0u);  // threshold: a static frame sends nothing
    EXPECT_EQ(r.lastFrameStats().sdfUpload.uploadBytes, 0u);
}

// ---- 3. scale ----------------------------------------------------------------------------------------

constexpr uint32_t kGoldenW = 192, kGoldenH = 108;

// 1000 instances of three programs in a 40 x 25 grid that fills the view.
void buildThousandInstances(Scene& s) {
    const assets::AssetId programs[] = {s.program(ShapeNode::sphere(0.11)),
                                        s.program(ShapeNode::box(glm::dvec3(0.085))),
                                        s.program(ShapeNode::torus(0.09, 0.035))};
    for (int i = 0; i < 1000; ++i) {
        const int x = i % 40, y = i / 40;
        s.object(programs[(x + y) % 3], {-5.85f + 0.3f * float(x), -3.6f + 0.3f * float(y), -7.0f},
                 uint32_t(i / 3 + y));
    }
}

struct Rendered {
    bool ok = false;
    ImageRGBA8 image;
    std::set<int> ids;  // entity indices seen in gbuffer.aux
    uint32_t sdfObjects = 0, uploaded = 0;
};

Rendered renderThousand(rhi::Device& device) {
    Scene s({0, 0, 0}, {0, 0, -1});
    buildThousandInstances(s);
    SceneRenderer r(device);
    Rendered out;
    out.ok = renderImage(s, r, s.frame(kGoldenW, kGoldenH), out.image);
    out.sdfObjects = r.lastFrameStats().sdfObjects;
    out.uploaded = r.lastFrameStats().sdfUpload.objectsUploaded;
    std::vector<uint8_t> aux;
    rhi::Format format{};
    std::string error;
    if (out.ok && r.readTarget("gbuffer.aux", aux, format, error)) {
        for (size_t i = 0; i + 8 <= aux.size(); i += 8) {
            float id;
            std::memcpy(&id, &aux[i], 4);
            if (id >= 0.0f) out.ids.insert(int(std::lround(id)));
        }
    }
    device.waitIdle();
    return out;
}

TEST_P(SdfInstancing, ThousandInstancesGolden) {
    const Rendered r = renderThousand(dev());
    ASSERT_TRUE(r.ok);
    EXPECT_EQ(r.sdfObjects, 1000u);
    EXPECT_EQ(r.uploaded, 1000u);
    std::printf("  1000 instances of 3 programs: %zu distinct objects in the ids\n", r.ids.size());
    // Metric: distinct entity ids in gbuffer.aux. Threshold: all 1000 (the camera sees every one).
    EXPECT_EQ(r.ids.size(), 1000u);
    // Metric: the golden rule (tests/support/golden.h default ImageRule).
    const std::string failure =
        checkGolden(GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl", "instancing_1000", r.image);
    EXPECT_TRUE(failure.empty()) << failure;
}

TEST(SdfInstancingParity, ThousandInstancesVulkanMatchesOpenGL) {
    BackendPair pair;
    ASSERT_TRUE(pair.ready());
    auto& vkDevice = pair.vk;
    auto& glDevice = pair.gl;
    const Rendered vk = renderThousand(*vkDevice);
    const Rendered gl = renderThousand(*glDevice);
    ASSERT_TRUE(vk.ok && gl.ok);
    pair.expectNoErrors();
    // Metric and threshold: the parity rule (default ImageRule).
    const ImageDiff d = compareImages(vk.image, gl.image);
    std::printf("Vulkan vs OpenGL, 1000 instances (%ux%u): %s\n", kGoldenW, kGoldenH, d.summary().c_str());
    if (!d.pass) {
        const std::string dir = goldenOutDir("parity");
        std::filesystem::create_directories(dir);
        writePng(dir + "/instancing_1000.vulkan.png", vk.image);
        writePng(dir + "/instancing_1000.gl.png", gl.image);
        writePng(dir + "/instancing_1000.diff.png", d.diffImage);
    }
    EXPECT_TRUE(d.pass) << d.summary();
}

// The trace, shadows, AO and the world-cache update read the objects of a frame with at most
// kSdfObjectsUniformCapacity (256) of them as a uniform block (their SDF_OBJECTS_UBO variants: a
// CPU device loads a storage buffer lane by lane), of a larger frame as a storage buffer: the same
// records either way, so the same picture (sun shadows and cone AO on).
TEST_P(SdfInstancing, UniformAndStorageObjectReadsAgree) {
    static_assert(render::kSdfObjectsUniformCapacity == 256);
    Scene s({0, 0, 0}, {0, 0, -1});
    const assets::AssetId programs[] = {s.program(ShapeNode::sphere(0.11)),
                                        s.program(ShapeNode::box(glm::dvec3(0.085)))};
    for (int i = 0; i < 256; ++i) {
        const int x = i % 16, y = i / 16;
        s.object(programs[(x + y) % 2], {-2.25f + 0.3f * float(x), -2.25f + 0.3f * float(y), -6.0f},
                 uint32_t(i));
    }
    s.world.get<ecs::Light>(s.light)->castShadows = true;
    SceneRenderer r(dev());
    FrameDesc d = s.frame(128, 96);
    d.settings.ao.variant = scene::AoVariant::Cones;
    ImageRGBA8 uniform, storage;
    ASSERT_TRUE(renderImage(s, r, d, uniform));
    EXPECT_EQ(r.lastFrameStats().sdfObjects, 256u);
    EXPECT_TRUE(r.lastFrameStats().traceObjectsUniform);  // threshold: 256 objects fit the block
    // One more object, far behind the camera and below (no ray, shadow ray or AO cone reaches it):
    // 257 objects.
    s.object(programs[0], {0.0f, -40.0f, 50.0f}, 0);
    ASSERT_TRUE(renderImage(s, r, d, storage));
    EXPECT_EQ(r.lastFrameStats().sdfObjects, 257u);
    EXPECT_FALSE(r.lastFrameStats().traceObjectsUniform);  // threshold: 257 do not
    // Metric: byte equality of the two images. Threshold: identical (the same records, read two ways).
    const ImageDiff diff = compareImages(uniform, storage);
    EXPECT_TRUE(diff.identical && !diff.sizeMismatch) << diff.summary();
}

// At scale: 100 of 1000 instances move in one frame; the delta carries exactly them and the image
// is the one a fresh renderer makes.
TEST_P(SdfInstancing, HundredOfThousandInstancesMove) {
    Scene s({0, 0, 0}, {0, 0, -1});
    buildThousandInstances(s);
    SceneRenderer r(dev());
    FrameDesc d = s.frame(kGoldenW, kGoldenH);
    d.settings.acceleration.worldCache = false;  // as in deltaFrame: the upload alone is under test
    d.settings.acceleration.idField = false;
    ImageRGBA8 image;
    ASSERT_TRUE(renderImage(s, r, d, image));
    uint32_t moved = 0;
    for (auto [e, sr, t] : s.world.view<ecs::SdfRenderer, ecs::Transform>())
        if (e.index % 10 == 0) {
            t.position.y += 0.07f;
            ++moved;
        }
    ASSERT_TRUE(renderImage(s, r, d, image));
    const render::SdfUploadReport& up = r.lastFrameStats().sdfUpload;
    std::printf("  %u of 1000 moved: %u uploaded, delta %llu B\n", moved, up.objectsUploaded,
                (unsigned long long)up.deltaBytes);
    // Metric: records sent and delta bytes. Threshold: exactly the moved ones, 272 bytes each.
    EXPECT_EQ(up.objectsUploaded, moved);
    EXPECT_EQ(up.deltaBytes, uint64_t(moved) * 272u);
    EXPECT_TRUE(ranPass(r, "sdf_object_scatter"));
    expectSameAsFresh(dev(), s, d, image, "100 of 1000 moved");
}

// 1000 spheres of 1000 different radii: 1000 programs, so 1000 distinct record sets.
TEST_P(SdfInstancing, ThousandDistinctProgramsRender) {
    Scene s({0, 0, 0}, {0, 0, -1});
    std::vector<ecs::Entity> objects;
    std::vector<glm::vec3> centres;
    for (int i = 0; i < 1000; ++i) {
        const int x = i % 40, y = i / 40;
        const glm::vec3 c(-5.85f + 0.3f * float(x), -3.6f + 0.3f * float(y), -7.0f);
        objects.push_back(s.object(s.program(ShapeNode::sphere(0.06 + 0.00006 * i)), c, uint32_t(i)));
        centres.push_back(c);
    }
    EXPECT_EQ(s.assets.count(assets::AssetKind::ShapeProgram), 1000u);
    // The only bound on the object count: one storage binding of the array (informational).
    std::printf("  device storage buffer range %llu B: up to %llu SDF objects\n",
                (unsigned long long)dev().info().limits.maxStorageBufferRange,
                (unsigned long long)(dev().info().limits.maxStorageBufferRange / sizeof(GpuSdfObject)));
    SceneRenderer r(dev());
    const FrameDesc d = s.frame(kGoldenW, kGoldenH);
    ImageRGBA8 image;
    ASSERT_TRUE(renderImage(s, r, d, image));
    EXPECT_EQ(r.lastFrameStats().sdfObjects, 1000u);
    std::vector<uint8_t> aux, depth;
    rhi::Format format{};
    std::string error;
    ASSERT_TRUE(r.readTarget("gbuffer.aux", aux, format, error)) << error;
    ASSERT_TRUE(r.readTarget("gbuffer.depth", depth, format, error)) << error;
    const RefCamera cam(s.world, s.camera, kGoldenW, kGoldenH);
    // Every 7th sphere: the pixel under its projected centre shows it at about its depth.
    uint32_t sampled = 0, right = 0;
    double worstDepth = 0.0;
    for (size_t i = 0; i < objects.size(); i += 7) {
        const glm::dvec2 p = cam.project(glm::dvec3(centres[i]));
        const int px = int(std::floor(p.x)), py = int(std::floor(p.y));
        if (px < 0 || py < 0 || px >= int(kGoldenW) || py >= int(kGoldenH)) continue;
        const size_t at = size_t(py) * kGoldenW + size_t(px);
        float id, z;
        std::memcpy(&id, &aux[at * 8], 4);
        std::memcpy(&z, &depth[at * 4], 4);
        ++sampled;
        const double radius = 0.06 + 0.00006 * double(i);
        // The nearest point of a sphere 7 units away lies at 7 - radius (plus a little off-axis).
        const double err = std::abs(double(z) - (7.0 - radius)) / 7.0;
        worstDepth = std::max(worstDepth, err);
        right += int(std::lround(id)) == int(objects[i].index) && err < 0.01;
    }
    std::printf(
        "  1000 distinct programs: %u of %u sampled centres show their sphere, worst depth error %.4f\n",
        right, sampled, worstDepth);
    EXPECT_EQ(sampled, 143u);  // every 7th of 1000 lies inside the view
    // Metric: sampled centre pixels whose entity id is the sphere's and whose depth is within 1 %
    // of the sphere's front. Threshold: all of them.
    EXPECT_EQ(right, sampled);
}

INSTANTIATE_TEST_SUITE_P(Backends, SdfInstancing, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test
