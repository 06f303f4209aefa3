// glTF scenes into a World: the fixtures in tests/assets/fixtures/scenes/ (written by
// tests/assets/make_scene_fixtures.py; the literals below repeat the values written there) and the
// malformed scenes in tests/malformed/gltf_scene/, which must leave World and AssetManager untouched.
#include <cmath>
#include <fstream>
#include <iterator>
#include <numbers>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "assets/assets_test_util.h"
#include "engine/assets/gltf_scene.h"
#include "engine/core/log.h"
#include "engine/ecs/components.h"
#include "engine/ecs/world.h"

namespace penumbra::assets {
namespace {

std::string scene(const std::string& name) {
    return test::sourcePath("tests/assets/fixtures/scenes/" + name);
}

std::string fileHash(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_FALSE(bytes.empty()) << path;
    return AssetManager::contentHash(bytes.data(), bytes.size());
}

class LogCapture {
public:
    LogCapture() {
        m_previous = log::setSink([this](log::Severity s, std::string_view m) {
            if (s >= log::Severity::Warning) {
                m_messages.emplace_back(m);
            }
        });
    }
    ~LogCapture() { log::setSink(m_previous); }
    const std::vector<std::string>& messages() const { return m_messages; }
    bool contains(const std::string& text) const {
        for (const std::string& m : m_messages) {
            if (m.find(text) != std::string::npos) {
                return true;
            }
        }
        return false;
    }

private:
    log::Sink m_previous;
    std::vector<std::string> m_messages;
};

ecs::Entity findByName(ecs::World& world, const std::string& name) {
    ecs::Entity found = ecs::kNullEntity;
    int matches = 0;
    world.view<ecs::Name>().each([&](ecs::Entity e, ecs::Name& n) {
        if (n.value == name) {
            found = e;
            ++matches;
        }
    });
    EXPECT_EQ(matches, 1) << "entities named '" << name << "'";
    return found;
}

// Largest absolute element difference.
float matrixDiff(const glm::mat4& a, const glm::mat4& b) {
    float worst = 0.0f;
    for (int c = 0; c < 4; ++c) {
        for (int r = 0; r < 4; ++r) {
            worst = std::max(worst, std::abs(a[c][r] - b[c][r]));
        }
    }
    return worst;
}

glm::mat4 trs(glm::vec3 t, glm::quat r, glm::vec3 s) {
    return glm::translate(glm::mat4(1.0f), t) * glm::mat4_cast(r) * glm::scale(glm::mat4(1.0f), s);
}

void expectVec(const glm::vec3& a, const glm::vec3& b, float eps = 1e-6f) {
    EXPECT_NEAR(a.x, b.x, eps);
    EXPECT_NEAR(a.y, b.y, eps);
    EXPECT_NEAR(a.z, b.z, eps);
}

void expectVec4(const glm::vec4& a, const glm::vec4& b, float eps = 1e-6f) {
    for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(a[i], b[i], eps) << "component " << i;
    }
}

// ---- hierarchy.gltf ----------------------------------------------------------------------------

TEST(GltfScene, HierarchyWorldMatrices) {
    const std::string path = scene("hierarchy.gltf");
    ecs::World world;
    AssetManager assets;
    std::vector<AssetId> acquired;
    std::string error;
    GltfSceneStats stats;
    ASSERT_TRUE(loadGltfScene(path, world, assets, acquired, error, &stats)) << error;
    // Scene 0: root, arm, mirror, hand, finger, the unnamed node 6, plus finger's second primitive.
    EXPECT_EQ(world.aliveCount(), 7u);
    EXPECT_EQ(stats.nodes, 6u);
    EXPECT_EQ(stats.meshPrimitives, 4u);
    EXPECT_EQ(stats.materials, 1u);
    EXPECT_EQ(stats.textures, 0u);
    EXPECT_EQ(stats.cameras, 0u);
    EXPECT_EQ(stats.lights, 0u);
    EXPECT_EQ(acquired.size(), 8u);  // 4 renderers x (mesh + material)
    ecs::updateTransforms(world);

    const ecs::Entity root = findByName(world, "root");
    const ecs::Entity arm = findByName(world, "arm");
    const ecs::Entity mirror = findByName(world, "mirror");
    const ecs::Entity hand = findByName(world, "hand");
    const ecs::Entity finger = findByName(world, "finger");
    const ecs::Entity unnamed = findByName(world, "node6");
    const ecs::Entity prim1 = findByName(world, "finger#prim1");
    for (const char* name : {"elsewhere"}) {
        world.view<ecs::Name>().each(
            [&](ecs::Name& n) { EXPECT_NE(n.value, name) << "node outside scene 0"; });
    }

    // Expected matrices, composed here from the values the generator wrote.
    const glm::mat4 lRoot =
        trs({1, 2, 3}, glm::angleAxis(std::numbers::pi_v<float> / 2, glm::vec3(0, 1, 0)), glm::vec3(2));
    const glm::mat4 lArm = glm::translate(glm::mat4(1.0f), {0, 1, 0}) *
                           glm::rotate(glm::mat4(1.0f), std::numbers::pi_v<float> / 2, glm::vec3(0, 0, 1)) *
                           glm::scale(glm::mat4(1.0f), {1, 2, 1});
    const glm::mat4 lMirror =
        glm::translate(glm::mat4(1.0f), {-3, 0, 0}) * glm::scale(glm::mat4(1.0f), {-1, 1, 1});
    const glm::mat4 lHand =
        trs({0, 0, 2}, glm::angleAxis(std::numbers::pi_v<float> / 4, glm::vec3(1, 0, 0)), {1, 0.5f, 1});
    const glm::mat4 lFinger = glm::translate(glm::mat4(1.0f), {0.5f, 0, 0});
    const struct {
        ecs::Entity e;
        ecs::Entity parent;
        glm::mat4 world;
        const char* name;
    } expected[] = {
        {root, ecs::kNullEntity, lRoot, "root"},
        {arm, root, lRoot * lArm, "arm"},
        {mirror, root, lRoot * lMirror, "mirror"},
        {hand, arm, lRoot * lArm * lHand, "hand"},
        {finger, hand, lRoot * lArm * lHand * lFinger, "finger"},
        {unnamed, root, lRoot, "node6"},
        {prim1, finger, lRoot * lArm * lHand * lFinger, "finger#prim1"},
    };
    for (const auto& x : expected) {
        const ecs::Transform* t = world.get<ecs::Transform>(x.e);
        ASSERT_NE(t, nullptr) << x.name;
        EXPECT_EQ(t->parent, x.parent) << x.name;
        // Metric: largest element difference; threshold 1e-5 (float products of values <= 12).
        EXPECT_LT(matrixDiff(t->worldMatrix, x.world), 1e-5f) << x.name;
    }
    // TRS nodes keep their values; matrix nodes are decomposed.
    const ecs::Transform* tr = world.get<ecs::Transform>(hand);
    expectVec(tr->position, {0, 0, 2});
    expectVec(tr->scale, {1, 0.5f, 1});
    EXPECT_LT(matrixDiff(world.get<ecs::Transform>(arm)->localMatrix(), lArm), 1e-6f);
    EXPECT_LT(matrixDiff(world.get<ecs::Transform>(mirror)->localMatrix(), lMirror), 1e-6f);
    EXPECT_LT(glm::determinant(glm::mat3(world.get<ecs::Transform>(mirror)->localMatrix())), 0.0f);

    // Renderers: mirror and hand share mesh 0; finger has mesh 1's two primitives.
    const std::string hash = fileHash(path);
    const ecs::MeshRenderer* rMirror = world.get<ecs::MeshRenderer>(mirror);
    const ecs::MeshRenderer* rHand = world.get<ecs::MeshRenderer>(hand);
    const ecs::MeshRenderer* rFinger = world.get<ecs::MeshRenderer>(finger);
    const ecs::MeshRenderer* rPrim1 = world.get<ecs::MeshRenderer>(prim1);
    ASSERT_TRUE(rMirror && rHand && rFinger && rPrim1);
    EXPECT_EQ(world.get<ecs::MeshRenderer>(root), nullptr);
    EXPECT_EQ(world.get<ecs::MeshRenderer>(arm), nullptr);
    EXPECT_EQ(rMirror->mesh, rHand->mesh);
    EXPECT_EQ(rMirror->mesh, AssetManager::stableId(AssetKind::Mesh, "gltf:" + hash + "#mesh0/prim0"));
    EXPECT_EQ(rFinger->mesh, AssetManager::stableId(AssetKind::Mesh, "gltf:" + hash + "#mesh1/prim0"));
    EXPECT_EQ(rPrim1->mesh, AssetManager::stableId(AssetKind::Mesh, "gltf:" + hash + "#mesh1/prim1"));
    EXPECT_EQ(assets.refCount(rMirror->mesh), 2u);
    EXPECT_EQ(assets.count(AssetKind::Mesh), 3u);

    const MeshData* tri = assets.mesh(rMirror->mesh);
    ASSERT_NE(tri, nullptr);
    ASSERT_EQ(tri->positions.size(), 3u);
    expectVec(tri->positions[1], {1, 0, 0});  // the primitive's own space, no node transform
    ASSERT_EQ(tri->normals.size(), 3u);
    expectVec(tri->normals[2], {0, 0, 1});
    ASSERT_EQ(tri->uvs.size(), 3u);
    EXPECT_EQ(tri->uvs[2], glm::vec2(0, 1));
    EXPECT_EQ(tri->indices, (std::vector<uint32_t>{0, 1, 2}));
    const MeshData* strip = assets.mesh(rPrim1->mesh);
    ASSERT_NE(strip, nullptr);
    EXPECT_EQ(strip->triangleCount(), 2u);  // a 4-vertex strip
    ASSERT_EQ(strip->normals.size(), 4u);   // generated: the quad faces +Z
    for (const glm::vec3& n : strip->normals) {
        expectVec(n, {0, 0, 1});
    }
    EXPECT_TRUE(strip->uvs.empty());

    // No material in the file: the glTF default material, one reference per renderer.
    const AssetId def = AssetManager::stableId(AssetKind::Material, "gltf:default-material");
    EXPECT_EQ(rMirror->material, def);
    EXPECT_EQ(rPrim1->material, def);
    EXPECT_EQ(assets.refCount(def), 4u);
    const ecs::Material* m = assets.material(def);
    ASSERT_NE(m, nullptr);
    expectVec4(m->baseColor, glm::vec4(1));
    EXPECT_EQ(m->metallic, 1.0f);
    EXPECT_EQ(m->roughness, 1.0f);

    for (AssetId id : acquired) {
        EXPECT_TRUE(assets.release(id));
    }
    EXPECT_EQ(assets.count(), 0u);
}

TEST(GltfScene, LoadsUnderAParentAndTwiceWithTheSameAssets) {
    const std::string path = scene("hierarchy.gltf");
    ecs::World world;
    AssetManager assets;
    const ecs::Entity holder = world.create();
    ecs::Transform ht;
    ht.position = {0, 10, 0};
    world.add<ecs::Transform>(holder, ht);
    std::vector<AssetId> first;
    std::vector<AssetId> second;
    std::string error;
    ASSERT_TRUE(loadGltfScene(path, world, assets, first, error, nullptr, holder)) << error;
    ASSERT_TRUE(loadGltfScene(path, world, assets, second, error)) << error;
    EXPECT_EQ(first, second);  // same ids in the same order
    EXPECT_EQ(world.aliveCount(), 1u + 7u + 7u);
    EXPECT_EQ(assets.count(), 4u);  // 3 meshes + the default material, shared
    ecs::updateTransforms(world);
    std::vector<ecs::Entity> roots;
    world.view<ecs::Name, ecs::Transform>().each([&](ecs::Entity e, ecs::Name& n, ecs::Transform&) {
        if (n.value == "root") {
            roots.push_back(e);
        }
    });
    ASSERT_EQ(roots.size(), 2u);
    int underHolder = 0;
    for (ecs::Entity r : roots) {
        const ecs::Transform* t = world.get<ecs::Transform>(r);
        if (t->parent == holder) {
            ++underHolder;
            expectVec(t->worldPosition(), {1, 12, 3}, 1e-5f);
        } else {
            EXPECT_TRUE(t->parent.isNull());
            expectVec(t->worldPosition(), {1, 2, 3}, 1e-5f);
        }
    }
    EXPECT_EQ(underHolder, 1);
    for (AssetId id : first) {
        assets.release(id);
    }
    EXPECT_EQ(assets.count(), 4u);
    for (AssetId id : second) {
        assets.release(id);
    }
    EXPECT_EQ(assets.count(), 0u);

    // A parent without a Transform is refused.
    const ecs::Entity bare = world.create();
    std::vector<AssetId> none;
    EXPECT_FALSE(loadGltfScene(path, world, assets, none, error, nullptr, bare));
    EXPECT_NE(error.find("parent"), std::string::npos) << error;
}

// ---- materials.glb -----------------------------------------------------------------------------

const std::vector<uint8_t> kImage0 = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 128};
const std::vector<uint8_t> kImage1 = {10, 20, 30, 255, 40, 50, 60, 255, 70, 80, 90, 255};

TEST(GltfScene, MaterialsAndTextures) {
    const std::string path = scene("materials.glb");
    ecs::World world;
    AssetManager assets;
    std::vector<AssetId> acquired;
    std::string error;
    GltfSceneStats stats;
    LogCapture logs;
    ASSERT_TRUE(loadGltfScene(path, world, assets, acquired, error, &stats)) << error;
    EXPECT_EQ(world.aliveCount(), 8u);  // 4 nodes + 2 x 2 extra primitive entities
    EXPECT_EQ(stats.nodes, 4u);
    EXPECT_EQ(stats.meshPrimitives, 8u);
    EXPECT_EQ(stats.materials, 5u);  // red, glow, maps, second set, default ("unused" is not)
    EXPECT_EQ(stats.textures, 4u);   // image 0 and 1, each as colour and as data
    EXPECT_EQ(acquired.size(), 4u + 8u + 8u);
    EXPECT_EQ(assets.count(AssetKind::Material), 5u);
    EXPECT_EQ(assets.count(AssetKind::Texture), 4u);
    EXPECT_EQ(assets.count(AssetKind::Mesh), 5u);
    // The texture coordinate set 1 warnings (material and attribute).
    EXPECT_TRUE(logs.contains("materials[4].pbrMetallicRoughness.baseColorTexture.texCoord 1"))
        << logs.messages().size();
    EXPECT_TRUE(logs.contains("TEXCOORD_1"));

    const std::string hash = fileHash(path);
    auto rendererOf = [&](const std::string& name) {
        const ecs::MeshRenderer* r = world.get<ecs::MeshRenderer>(findByName(world, name));
        EXPECT_NE(r, nullptr) << name;
        return r ? *r : ecs::MeshRenderer{};
    };
    const ecs::MeshRenderer red = rendererOf("multi");
    const ecs::MeshRenderer glow = rendererOf("multi#prim1");
    const ecs::MeshRenderer maps = rendererOf("multi#prim2");
    const ecs::MeshRenderer second = rendererOf("second");
    const ecs::MeshRenderer plain = rendererOf("plain");
    const ecs::MeshRenderer again = rendererOf("again");
    const ecs::MeshRenderer again2 = rendererOf("again#prim2");

    // Material "red": factors and a bufferView PNG as sRGB base colour.
    EXPECT_EQ(red.material, AssetManager::stableId(AssetKind::Material, "gltf:" + hash + "#material0"));
    const ecs::Material* mRed = assets.material(red.material);
    ASSERT_NE(mRed, nullptr);
    expectVec4(mRed->baseColor, {0.8f, 0.1f, 0.1f, 1.0f});
    EXPECT_FLOAT_EQ(mRed->metallic, 0.25f);
    EXPECT_FLOAT_EQ(mRed->roughness, 0.75f);
    expectVec(mRed->emissive, {0, 0, 0});
    EXPECT_EQ(mRed->baseColorTexture, AssetManager::stableId(AssetKind::Texture, "gltf:" + hash + "#image0"));
    EXPECT_EQ(mRed->metallicRoughnessTexture, 0u);
    EXPECT_EQ(mRed->normalTexture, 0u);
    EXPECT_EQ(mRed->occlusionTexture, 0u);
    EXPECT_EQ(mRed->emissiveTexture, 0u);
    const TextureData* t0 = assets.texture(mRed->baseColorTexture);
    ASSERT_NE(t0, nullptr);
    EXPECT_EQ(t0->width, 2u);
    EXPECT_EQ(t0->height, 2u);
    EXPECT_TRUE(t0->srgb);
    EXPECT_EQ(t0->rgba8, kImage0);

    // Material "glow": emissive factor and a data: URI PNG as sRGB emissive texture.
    const ecs::Material* mGlow = assets.material(glow.material);
    ASSERT_NE(mGlow, nullptr);
    expectVec(mGlow->emissive, {1.0f, 0.5f, 0.25f});
    expectVec4(mGlow->baseColor, glm::vec4(1));
    EXPECT_EQ(mGlow->metallic, 0.0f);
    EXPECT_EQ(mGlow->roughness, 1.0f);
    EXPECT_EQ(mGlow->baseColorTexture, 0u);
    const TextureData* t1 = assets.texture(mGlow->emissiveTexture);
    ASSERT_NE(t1, nullptr);
    EXPECT_EQ(t1->width, 3u);
    EXPECT_EQ(t1->height, 1u);
    EXPECT_TRUE(t1->srgb);
    EXPECT_EQ(t1->rgba8, kImage1);

    // Material "maps": the same images as linear data; occlusion shares the metallic-roughness one.
    const ecs::Material* mMaps = assets.material(maps.material);
    ASSERT_NE(mMaps, nullptr);
    EXPECT_EQ(mMaps->metallicRoughnessTexture,
              AssetManager::stableId(AssetKind::Texture, "gltf:" + hash + "#image0/linear"));
    EXPECT_EQ(mMaps->occlusionTexture, mMaps->metallicRoughnessTexture);
    EXPECT_EQ(mMaps->normalTexture,
              AssetManager::stableId(AssetKind::Texture, "gltf:" + hash + "#image1/linear"));
    EXPECT_EQ(mMaps->baseColorTexture, 0u);
    EXPECT_EQ(mMaps->metallic, 1.0f);   // glTF default factor
    EXPECT_EQ(mMaps->roughness, 1.0f);  // glTF default factor
    ASSERT_NE(assets.texture(mMaps->normalTexture), nullptr);
    EXPECT_FALSE(assets.texture(mMaps->normalTexture)->srgb);
    EXPECT_EQ(assets.texture(mMaps->normalTexture)->rgba8, kImage1);
    EXPECT_FALSE(assets.texture(mMaps->occlusionTexture)->srgb);
    EXPECT_EQ(assets.texture(mMaps->occlusionTexture)->rgba8, kImage0);

    // "second set": texCoord 1 falls back to set 0 (warned above), same sRGB image-0 texture.
    const ecs::Material* mSecond = assets.material(second.material);
    ASSERT_NE(mSecond, nullptr);
    expectVec4(mSecond->baseColor, glm::vec4(0.5f));
    EXPECT_EQ(mSecond->baseColorTexture, mRed->baseColorTexture);
    EXPECT_EQ(assets.mesh(second.mesh)->uvs.size(), 3u);

    // No material: the shared default.
    EXPECT_EQ(plain.material, AssetManager::stableId(AssetKind::Material, "gltf:default-material"));

    // "again" instances mesh 0: the same mesh and material assets as "multi".
    EXPECT_EQ(again.mesh, red.mesh);
    EXPECT_EQ(again.material, red.material);
    EXPECT_EQ(again2.material, maps.material);
    EXPECT_EQ(assets.refCount(red.mesh), 2u);
    EXPECT_EQ(assets.refCount(red.material), 2u);
    EXPECT_EQ(red.mesh, AssetManager::stableId(AssetKind::Mesh, "gltf:" + hash + "#mesh0/prim0"));
    EXPECT_NE(glow.mesh, red.mesh);

    for (AssetId id : acquired) {
        EXPECT_TRUE(assets.release(id));
    }
    EXPECT_EQ(assets.count(), 0u);
}

// ---- camera_lights.gltf ------------------------------------------------------------------------

TEST(GltfScene, CamerasAndLights) {
    const std::string path = scene("camera_lights.gltf");
    ecs::World world;
    AssetManager assets;
    std::vector<AssetId> acquired;
    std::string error;
    GltfSceneStats stats;
    LogCapture logs;
    ASSERT_TRUE(loadGltfScene(path, world, assets, acquired, error, &stats)) << error;
    EXPECT_EQ(stats.nodes, 6u);
    EXPECT_EQ(stats.cameras, 2u);
    EXPECT_EQ(stats.lights, 3u);
    EXPECT_EQ(stats.meshPrimitives, 1u);
    EXPECT_EQ(world.aliveCount(), 6u);
    EXPECT_EQ(world.count<ecs::Camera>(), 2u);
    EXPECT_EQ(world.count<ecs::Light>(), 3u);
    ecs::updateTransforms(world);

    const ecs::Camera* main = world.get<ecs::Camera>(findByName(world, "MainCamNode"));
    ASSERT_NE(main, nullptr);
    EXPECT_FLOAT_EQ(main->fovY, 0.8f);
    EXPECT_FLOAT_EQ(main->nearPlane, 0.05f);
    EXPECT_FLOAT_EQ(main->farPlane, 200.0f);
    EXPECT_EQ(main->name, "Main");
    const ecs::Entity topNode = findByName(world, "TopCamNode");
    const ecs::Camera* top = world.get<ecs::Camera>(topNode);
    ASSERT_NE(top, nullptr);
    EXPECT_FLOAT_EQ(top->fovY, 1.2f);
    EXPECT_FLOAT_EQ(top->nearPlane, 0.5f);
    EXPECT_FLOAT_EQ(top->farPlane, 0.5f * kGltfDefaultFarOverNear);  // no zfar in the file
    EXPECT_EQ(top->name, "Overview");
    expectVec(world.get<ecs::Transform>(topNode)->worldForward(), {0, -1, 0}, 1e-6f);
    expectVec(world.get<ecs::Transform>(topNode)->worldPosition(), {0, 20, 0}, 1e-6f);
    // The orthographic camera is not imported; its node is.
    EXPECT_EQ(world.get<ecs::Camera>(findByName(world, "FlatCamNode")), nullptr);
    EXPECT_TRUE(logs.contains("cameras[2] is orthographic"));

    const ecs::Entity sunNode = findByName(world, "SunNode");
    const ecs::Light* sun = world.get<ecs::Light>(sunNode);
    ASSERT_NE(sun, nullptr);
    EXPECT_EQ(sun->type, ecs::LightType::Directional);
    expectVec(sun->color, {1.0f, 0.9f, 0.8f});
    EXPECT_FLOAT_EQ(sun->intensity, 3.0f);
    EXPECT_EQ(sun->range, kGltfInfiniteLightRange);
    expectVec(world.get<ecs::Transform>(sunNode)->worldForward(), {0, -1, 0}, 1e-6f);

    const ecs::Entity bulbNode = findByName(world, "BulbNode");
    const ecs::Light* bulb = world.get<ecs::Light>(bulbNode);
    ASSERT_NE(bulb, nullptr);
    EXPECT_EQ(bulb->type, ecs::LightType::Point);
    expectVec(bulb->color, {0.2f, 0.4f, 1.0f});
    EXPECT_FLOAT_EQ(bulb->intensity, 20.0f);
    EXPECT_FLOAT_EQ(bulb->range, 15.0f);
    expectVec(world.get<ecs::Transform>(bulbNode)->worldPosition(), {1, 2, 3});
    EXPECT_NE(world.get<ecs::MeshRenderer>(bulbNode), nullptr);

    const ecs::Light* spot = world.get<ecs::Light>(findByName(world, "SpotNode"));
    ASSERT_NE(spot, nullptr);
    EXPECT_EQ(spot->type, ecs::LightType::Point);  // spot -> point, with a warning
    expectVec(spot->color, {1, 1, 1});
    EXPECT_FLOAT_EQ(spot->intensity, 5.0f);
    EXPECT_EQ(spot->range, kGltfInfiniteLightRange);
    EXPECT_TRUE(logs.contains("lights[2] is a spot light: imported as a point light"));
    EXPECT_EQ(logs.messages().size(), 2u);
    for (const std::string& m : logs.messages()) {
        EXPECT_EQ(m.rfind(path, 0), 0u) << "warning does not start with the file: " << m;
    }
    for (AssetId id : acquired) {
        assets.release(id);
    }
    EXPECT_EQ(assets.count(), 0u);
}

// ---- jpeg_texture.gltf: an image file next to the scene, read through the confined callbacks ------

TEST(GltfScene, ExternalJpegTexture) {
    const std::string path = scene("jpeg_texture.gltf");
    ecs::World world;
    AssetManager assets;
    std::vector<AssetId> acquired;
    std::string error;
    GltfSceneStats stats;
    ASSERT_TRUE(loadGltfScene(path, world, assets, acquired, error, &stats)) << error;
    EXPECT_EQ(stats.textures, 1u);
    const ecs::MeshRenderer* r = world.get<ecs::MeshRenderer>(findByName(world, "picture"));
    ASSERT_NE(r, nullptr);
    const ecs::Material* m = assets.material(r->material);
    ASSERT_NE(m, nullptr);
    const TextureData* t = assets.texture(m->baseColorTexture);
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(assets.info(m->baseColorTexture)->key, "gltf:" + fileHash(path) + "#image0");
    ASSERT_EQ(t->width, 16u);
    ASSERT_EQ(t->height, 16u);
    EXPECT_TRUE(t->srgb);
    // Metric: largest channel difference from the quadrant colours the generator encoded (top-left
    // red, top-right green, bottom-left blue, bottom-right white); threshold 6 levels (rounding).
    const int colours[4][3] = {{200, 30, 30}, {30, 200, 30}, {30, 30, 200}, {240, 240, 240}};
    int worst = 0;
    for (uint32_t y = 0; y < 16; ++y) {
        for (uint32_t x = 0; x < 16; ++x) {
            const int* c = colours[(y / 8) * 2 + x / 8];
            for (int k = 0; k < 3; ++k) {
                worst = std::max(worst, std::abs(int(t->rgba8[(y * 16 + x) * 4 + k]) - c[k]));
            }
        }
    }
    EXPECT_LE(worst, 6);
}

TEST(GltfScene, LimitsAreEnforced) {
    ecs::World world;
    AssetManager assets;
    std::vector<AssetId> acquired;
    std::string error;
    GltfSceneLimits limits;
    limits.maxNodes = 2;
    EXPECT_FALSE(loadGltfScene(scene("hierarchy.gltf"), world, assets, acquired, error, nullptr,
                               ecs::kNullEntity, limits));
    EXPECT_NE(error.find("nodes: 7 nodes exceed the limit of 2"), std::string::npos) << error;
    limits = {};
    limits.maxMaterials = 3;
    EXPECT_FALSE(loadGltfScene(scene("materials.glb"), world, assets, acquired, error, nullptr,
                               ecs::kNullEntity, limits));
    EXPECT_NE(error.find("materials: 5 materials exceed the limit of 3"), std::string::npos) << error;
    limits = {};
    limits.texture.maxDimension = 2;
    EXPECT_FALSE(loadGltfScene(scene("materials.glb"), world, assets, acquired, error, nullptr,
                               ecs::kNullEntity, limits));
    EXPECT_NE(error.find("images[1]: PNG image dimensions 3 x 1 exceed the limit of 2"), std::string::npos)
        << error;
    limits = {};
    limits.mesh.maxTriangles = 3;
    EXPECT_FALSE(loadGltfScene(scene("hierarchy.gltf"), world, assets, acquired, error, nullptr,
                               ecs::kNullEntity, limits));
    EXPECT_NE(error.find("triangles"), std::string::npos) << error;
    EXPECT_EQ(world.aliveCount(), 0u);
    EXPECT_EQ(assets.count(), 0u);
    EXPECT_TRUE(acquired.empty());
}

TEST(GltfScene, MissingFile) {
    ecs::World world;
    AssetManager assets;
    std::vector<AssetId> acquired;
    std::string error;
    const std::string path = scene("no_such_scene.gltf");
    EXPECT_FALSE(loadGltfScene(path, world, assets, acquired, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
}

// ---- malformed scenes --------------------------------------------------------------------------

struct BadScene {
    const char* file;     // in tests/malformed/gltf_scene/
    const char* keyword;  // must appear in the error
};

void PrintTo(const BadScene& b, std::ostream* os) { *os << b.file; }

class MalformedGltfScene : public testing::TestWithParam<BadScene> {};

TEST_P(MalformedGltfScene, IsRefusedAtomically) {
    const std::string path = test::sourcePath(std::string("tests/malformed/gltf_scene/") + GetParam().file);
    ASSERT_TRUE(std::filesystem::is_regular_file(path)) << path;
    ecs::World world;
    AssetManager assets;
    std::vector<AssetId> acquired = {42};
    std::string error;
    GltfSceneStats stats;
    stats.nodes = 99;
    EXPECT_FALSE(loadGltfScene(path, world, assets, acquired, error, &stats));
    EXPECT_NE(error.find(path), std::string::npos) << "error does not name the file: " << error;
    EXPECT_NE(error.find(GetParam().keyword), std::string::npos)
        << "error lacks '" << GetParam().keyword << "': " << error;
    EXPECT_EQ(world.aliveCount(), 0u);
    EXPECT_EQ(assets.count(), 0u);
    EXPECT_EQ(acquired, std::vector<AssetId>{42});
    EXPECT_EQ(stats.nodes, 99u);
}

TEST_P(MalformedGltfScene, LeavesExistingContentAlone) {
    const std::string path = test::sourcePath(std::string("tests/malformed/gltf_scene/") + GetParam().file);
    ecs::World world;
    AssetManager assets;
    std::vector<AssetId> acquired;
    std::string error;
    // A good scene first, then the bad one: nothing may change.
    ASSERT_TRUE(loadGltfScene(scene("materials.glb"), world, assets, acquired, error)) << error;
    const size_t entities = world.aliveCount();
    const std::vector<AssetInfo> before = assets.list();
    const std::vector<AssetId> held = acquired;
    EXPECT_FALSE(loadGltfScene(path, world, assets, acquired, error));
    EXPECT_EQ(world.aliveCount(), entities);
    EXPECT_EQ(acquired, held);
    const std::vector<AssetInfo> after = assets.list();
    ASSERT_EQ(after.size(), before.size());
    for (size_t i = 0; i < after.size(); ++i) {
        EXPECT_EQ(after[i].id, before[i].id);
        EXPECT_EQ(after[i].refCount, before[i].refCount);
    }
}

INSTANTIATE_TEST_SUITE_P(
    Files, MalformedGltfScene,
    testing::Values(
        BadScene{"material_index_out_of_range.gltf",
                 "meshes[0].primitives[0].material 3 out of range (1 materials)"},
        BadScene{"texture_index_out_of_range.gltf",
                 "materials[0].pbrMetallicRoughness.baseColorTexture.index 2 out of range (1 textures)"},
        BadScene{"emissive_texture_index_negative.gltf",
                 "materials[0].emissiveTexture.index -4 out of range"},
        BadScene{"texture_source_out_of_range.gltf", "textures[0].source 5 out of range (1 images)"},
        BadScene{"texture_sampler_out_of_range.gltf", "textures[0].sampler 1 out of range (1 samplers)"},
        BadScene{"texture_without_source.gltf", "textures[0] has no source image"},
        BadScene{"image_not_an_image.gltf", "images[0]: unrecognised image format"},
        BadScene{"image_huge_dimensions.gltf",
                 "images[0]: PNG image dimensions 100000 x 100000 exceed the limit"},
        BadScene{"image_truncated_png.gltf", "images[0]: corrupt PNG"},
        BadScene{"image_missing_file.gltf", "images[0]: cannot read 'missing.png'"},
        BadScene{"image_view_out_of_buffer.glb", "out of range of buffer"},
        BadScene{"texture_uri_escape.gltf", "escapes the asset directory"},
        BadScene{"material_factor_out_of_range.gltf",
                 "materials[0].pbrMetallicRoughness.metallicFactor 2 must be a number in [0, 1]"},
        BadScene{"camera_znear_zero.gltf", "cameras[0].perspective.znear 0 must be greater than 0"},
        BadScene{"camera_zfar_below_znear.gltf",
                 "cameras[0].perspective.zfar 0.5 must be greater than znear 1"},
        BadScene{"camera_yfov_too_large.gltf", "cameras[0].perspective.yfov 3.5 must be in (0, pi)"},
        BadScene{"camera_yfov_overflow.gltf", "number overflow"},
        BadScene{"camera_index_out_of_range.gltf", "nodes[0].camera 3 out of range (1 cameras)"},
        BadScene{"light_index_out_of_range.gltf",
                 "nodes[1].extensions.KHR_lights_punctual.light 4 out of range (1 lights)"},
        BadScene{"light_unknown_type.gltf",
                 "extensions.KHR_lights_punctual.lights[0].type 'area' is not one of"},
        BadScene{"lights_not_an_array.gltf", "extensions.KHR_lights_punctual.lights is not an array"},
        BadScene{"light_negative_intensity.gltf", "lights[0].intensity must be a finite number >= 0"},
        BadScene{"node_singular_matrix.gltf", "nodes[1].matrix is singular"},
        BadScene{"node_sheared_matrix.gltf", "nodes[0].matrix has shear"},
        BadScene{"node_projective_matrix.gltf", "nodes[0].matrix is not affine"},
        BadScene{"node_cycle.gltf", "cycle"},
        BadScene{"indices_accessor_out_of_range.gltf", "primitive indices accessor out of bounds"},
        BadScene{
            "position_accessor_out_of_view.gltf",
            "accessor 0 (POSITION): byteOffset 0 + count 1000 x stride 12 is out of range of bufferView 0"},
        BadScene{"nan_position.gltf", "accessor 0 (POSITION): element 1 is not a finite number"}),
    [](const testing::TestParamInfo<BadScene>& info) {
        std::string name = info.param.file;
        name = name.substr(0, name.find('.'));
        return name;
    });

}  // namespace
}  // namespace penumbra::assets
