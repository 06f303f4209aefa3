// The object-count benchmark scene (engine/scene/objects_scene.h) and the scene-format pieces it
// needs (issue 13): render.acceleration (values and strict errors) and sdf "shared": false
// (a field asset per entity). The generated scenes bake data/meshes at a low resolution; the bakes
// go to a cache folder under the build tree so that repeated runs read them back.
#include <filesystem>
#include <set>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "engine/scene/objects_scene.h"
#include "scene/scene_test_util.h"

namespace penumbra::scene {
namespace {

using test::entityNamed;
using test::parseScene;

const std::string kMeshDir = std::string(PENUMBRA_SOURCE_DIR) + "/data/meshes";

bool meshesPresent() { return std::filesystem::exists(kMeshDir + "/dragon_vrip_res3.ply"); }

assets::AssetManagerDesc cachedAssets() {
    assets::AssetManagerDesc d;
    d.cacheDir = std::string(PENUMBRA_BINARY_DIR) + "/tests/objects_scene_cache";
    return d;
}

// ---- render.acceleration ---------------------------------------------------------------------

std::string withAccel(const std::string& accel) {
    return R"({"version": 2, "render": {"acceleration": )" + accel + "}, \"entities\": []}";
}

TEST(AccelerationJson, ParsesEveryKey) {
    assets::AssetManager assets;
    Scene s;
    std::string error;
    ASSERT_TRUE(parseScene(withAccel(R"({"culling": false, "worldCache": true, "idField": true,
        "prepass": true, "cacheLevels": 6, "cacheResolution": 96, "cacheVoxel": 0.125,
        "cacheBudgetVoxels": 8192})"),
                           assets, s, error))
        << error;
    const AccelerationSettings& a = s.settings.acceleration;
    EXPECT_FALSE(a.culling);
    EXPECT_TRUE(a.worldCache);  // every value differs from its default, so each key is read
    EXPECT_TRUE(a.idField);
    EXPECT_TRUE(a.prepass);
    EXPECT_EQ(a.cacheLevels, 6u);
    EXPECT_EQ(a.cacheResolution, 96u);
    EXPECT_FLOAT_EQ(a.cacheVoxel, 0.125f);
    EXPECT_EQ(a.cacheBudgetVoxels, 8192u);

    // Omitted keys keep AccelerationSettings' defaults.
    Scene d;
    ASSERT_TRUE(parseScene(withAccel(R"({"culling": false})"), assets, d, error)) << error;
    EXPECT_FALSE(d.settings.acceleration.culling);
    EXPECT_EQ(d.settings.acceleration.worldCache, AccelerationSettings{}.worldCache);
    EXPECT_EQ(d.settings.acceleration.cacheResolution, AccelerationSettings{}.cacheResolution);
}

TEST(AccelerationJson, RefusesBadValuesWithTheirPointer) {
    struct Case {
        const char* accel;
        const char* message;
    };
    const Case cases[] = {
        {R"({"cull": true})",
         "/render/acceleration/cull: unknown key 'cull' in acceleration settings (expected one of:"},
        {R"({"culling": 1})", "/render/acceleration/culling: expected true or false, got"},
        {R"({"cacheLevels": 0})", "/render/acceleration/cacheLevels: 0 is out of range [1, 8]"},
        {R"({"cacheLevels": 9})", "/render/acceleration/cacheLevels: 9 is out of range [1, 8]"},
        {R"({"cacheLevels": 2.5})", "/render/acceleration/cacheLevels: expected an integer"},
        {R"({"cacheResolution": 8})", "/render/acceleration/cacheResolution: 8 is out of range [16, 256]"},
        {R"({"cacheResolution": 264})",
         "/render/acceleration/cacheResolution: 264 is out of range [16, 256]"},
        {R"({"cacheResolution": 20})", "/render/acceleration/cacheResolution: 20 is not a multiple of 8"},
        {R"({"cacheVoxel": -0.5})", "/render/acceleration/cacheVoxel: cacheVoxel must be >= 0"},
        {R"({"cacheVoxel": "big"})", "/render/acceleration/cacheVoxel: expected a number, got"},
        {R"({"cacheBudgetVoxels": 511})",
         "/render/acceleration/cacheBudgetVoxels: 511 is out of range [512,"},
        {R"(true)", "/render/acceleration: expected an object, got"},
    };
    for (const Case& c : cases) {
        assets::AssetManager assets;
        Scene s;
        std::string error;
        EXPECT_FALSE(parseScene(withAccel(c.accel), assets, s, error)) << c.accel;
        EXPECT_NE(error.find(c.message), std::string::npos) << c.accel << "\n  got: " << error;
    }
}

// ---- sdf "shared" ---------------------------------------------------------------------------------

TEST(SdfShared, FalseGivesEachEntityItsOwnField) {
    if (!meshesPresent()) GTEST_SKIP() << "data/meshes missing (tools/fetch_meshes.sh)";
    const std::string obj = R"({"sdf": {"mesh": "data/meshes/bunny.ply", "resolution": 16%s}})";
    auto entity = [&](const char* extra) {
        std::string e = obj;
        return e.replace(e.find("%s"), 2, extra);
    };
    const std::string text = R"({"version": 2, "entities": [)" + entity("") + "," + entity("") + "," +
                             entity(R"(, "shared": false)") + "," + entity(R"(, "shared": false)") + "]}";
    assets::AssetManager assets(cachedAssets());
    Scene s;
    std::string error;
    ASSERT_TRUE(parseScene(text, assets, s, error)) << error;
    std::vector<assets::AssetId> ids;
    for (auto [e, sr] : s.world.view<const ecs::SdfRenderer>()) ids.push_back(sr.sdf);
    ASSERT_EQ(ids.size(), 4u);
    // Two shared (one id), two copies (an id each, different from the shared one): 3 distinct.
    EXPECT_EQ(std::set<assets::AssetId>(ids.begin(), ids.end()).size(), 3u);
    for (assets::AssetId id : ids) EXPECT_NE(assets.sdfField(id), nullptr);
    EXPECT_EQ(assets.cacheStats().sdfBakes + assets.cacheStats().sdfHits, 1u);  // one bake or cache read
    unloadScene(s, assets);
    EXPECT_EQ(assets.count(assets::AssetKind::SdfField), 0u);  // every reference released

    Scene bad;
    const std::string shape = R"({"version": 2, "entities": [{"sdf": {"shape": {"shape": "sphere",
        "radius": 1}, "shared": false}}]})";
    EXPECT_FALSE(parseScene(shape, assets, bad, error));
    EXPECT_NE(error.find("/entities/0/sdf/shared: \"shared\" applies to \"mesh\" and \"psdf\" fields only"),
              std::string::npos)
        << error;
}

// ---- the generator -------------------------------------------------------------------------------

TEST(ObjectsScene, RefusesBadDescriptions) {
    ObjectsScene out;
    std::string error;
    ObjectsSceneDesc d;
    d.count = 0;
    EXPECT_FALSE(generateObjectsScene(d, out, error));
    EXPECT_NE(error.find("object count 0 is out of range"), std::string::npos) << error;
    d = {};
    d.resolution = 4;
    EXPECT_FALSE(generateObjectsScene(d, out, error));
    EXPECT_NE(error.find("bake resolution 4"), std::string::npos) << error;
}

// N objects of three kinds in rows, the room's four boxes, every object's bounds inside the camera
// frustum (at the aspect the camera was fitted for), and the field assets: 3 when instanced, N when not.
class ObjectsSceneCounts : public testing::TestWithParam<std::tuple<uint32_t, bool>> {};

TEST_P(ObjectsSceneCounts, LoadsWithEveryObjectInView) {
    if (!meshesPresent()) GTEST_SKIP() << "data/meshes missing (tools/fetch_meshes.sh)";
    const auto [count, instanced] = GetParam();
    ObjectsSceneDesc desc;
    desc.count = count;
    desc.instanced = instanced;
    desc.meshDir = kMeshDir;
    ObjectsScene gen;
    std::string error;
    ASSERT_TRUE(generateObjectsScene(desc, gen, error)) << error;
    ASSERT_EQ(gen.objects.size(), count);

    assets::AssetManager assets(cachedAssets());
    Scene s;
    ASSERT_TRUE(parseScene(gen.json, assets, s, error)) << error;
    const ecs::Entity camera = findCamera(s.world, s.settings.camera);
    ASSERT_NE(camera, ecs::kNullEntity);
    const glm::mat4 viewProj = test::viewProjection(s.world, camera, desc.aspect);

    uint32_t fieldObjects = 0, shapeObjects = 0, outside = 0;
    std::set<assets::AssetId> fields;
    std::map<std::string, uint32_t> kinds;
    for (auto [e, sr] : s.world.view<const ecs::SdfRenderer>()) {
        if (sr.source == ecs::SdfSource::Shapes) {
            ++shapeObjects;
            continue;
        }
        ++fieldObjects;
        fields.insert(sr.sdf);
        kinds[sr.bakeMesh.substr(sr.bakeMesh.rfind('/') + 1)]++;
        const sdf::PsdfAsset* f = assets.sdfField(sr.sdf);
        ASSERT_NE(f, nullptr);
        // The 8 corners of the mesh bounds through the world matrix: all inside the frustum.
        const ecs::Transform* t = s.world.get<ecs::Transform>(e);
        const glm::dvec3 lo = f->header.boundsMin, hi = f->header.boundsMax;
        for (int c = 0; c < 8; ++c) {
            const glm::vec3 local(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z);
            if (!test::inView(viewProj, glm::vec3(t->worldMatrix * glm::vec4(local, 1.0f)))) ++outside;
        }
    }
    fmt::print(
        "{} objects ({}): {} columns x {} rows, {} field objects, {} room boxes, {} field assets, "
        "{} corners outside the frustum, camera at ({:.2f}, {:.2f}, {:.2f})\n",
        count, instanced ? "instanced" : "non-instanced", gen.columns, gen.rows, fieldObjects, shapeObjects,
        fields.size(), outside, gen.cameraPosition.x, gen.cameraPosition.y, gen.cameraPosition.z);
    EXPECT_EQ(fieldObjects, count);  // exactly N baked objects
    EXPECT_EQ(shapeObjects, 4u);     // floor, back wall, two side walls
    EXPECT_EQ(outside, 0u);          // metric: mesh-bound corners outside the frustum; threshold 0
    // Instanced: one field per mesh kind present; non-instanced: one per object.
    EXPECT_EQ(fields.size(), instanced ? std::min<size_t>(3, kinds.size()) : size_t(count));
    if (count >= 3 * gen.columns) {  // at least three rows: every kind present
        EXPECT_EQ(kinds.size(), 3u);
    }
}

INSTANTIATE_TEST_SUITE_P(Counts, ObjectsSceneCounts,
                         testing::Values(std::make_tuple(1u, true), std::make_tuple(20u, true),
                                         std::make_tuple(20u, false), std::make_tuple(80u, true),
                                         std::make_tuple(200u, false), std::make_tuple(1000u, true)),
                         [](const testing::TestParamInfo<std::tuple<uint32_t, bool>>& info) {
                             return fmt::format("N{}_{}", std::get<0>(info.param),
                                                std::get<1>(info.param) ? "instanced" : "copies");
                         });

}  // namespace
}  // namespace penumbra::scene
