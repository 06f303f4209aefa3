// The render block's effect settings and the material keys of issue 12 (docs/FORMATS.md, "render"
// and "materials"): defaults, every key parsed, and out-of-range or unknown values refused with
// the JSON pointer of the element.
#include <string>

#include <gtest/gtest.h>

#include "engine/assets/asset_manager.h"
#include "engine/scene/scene.h"
#include "scene/scene_test_util.h"

namespace penumbra::test {
namespace {

using scene::AoVariant;
using scene::MeshSdfMode;

TEST(SceneEffects, DefaultsWhenTheSceneSetsNothing) {
    assets::AssetManager assets;
    scene::Scene s;
    std::string error;
    ASSERT_TRUE(parseScene(R"({"version": 2})", assets, s, error)) << error;
    const scene::RenderSettings& r = s.settings;
    EXPECT_TRUE(r.shadows.enabled);
    EXPECT_FALSE(r.shadows.hard);
    EXPECT_FLOAT_EQ(r.shadows.resolutionScale, 0.5f);
    EXPECT_EQ(r.ao.variant, AoVariant::Off);
    EXPECT_FLOAT_EQ(r.ao.resolutionScale, 0.25f);
    EXPECT_FLOAT_EQ(r.ao.maxDistance, 1.0f);
    EXPECT_FLOAT_EQ(r.reflections.roughnessCutoff, 0.5f);
    EXPECT_EQ(r.meshSdf, MeshSdfMode::Auto);
    EXPECT_FALSE(r.ambientSky.has_value());
}

TEST(SceneEffects, ParsesEveryKey) {
    assets::AssetManager assets;
    scene::Scene s;
    std::string error;
    const char* text = R"({"version": 2,
        "render": {"shadows": {"enabled": false, "hard": true, "resolutionScale": 1, "maxSteps": 40},
                   "ao": {"variant": "cones", "maxDistance": 2.5, "strength": 0.75, "resolutionScale": 0.5,
                          "rays": 12},
                   "reflections": {"roughnessCutoff": 0.3, "maxSteps": 99},
                   "meshSdf": "occlusion", "ambientSky": [0.1, 0.2, 0.3]},
        "materials": {"skin": {"subsurface": 0.6, "subsurfaceColor": [1, 0.2, 0.1], "subsurfaceRadius": 0.05,
                               "reflections": true, "triplanarScale": 4}},
        "entities": [{"name": "a", "mesh": {"primitive": {"shape": "box"}, "material": "skin"}}]})";
    ASSERT_TRUE(parseScene(text, assets, s, error)) << error;
    const scene::RenderSettings& r = s.settings;
    EXPECT_FALSE(r.shadows.enabled);
    EXPECT_TRUE(r.shadows.hard);
    EXPECT_FLOAT_EQ(r.shadows.resolutionScale, 1.0f);
    EXPECT_EQ(r.shadows.maxSteps, 40u);
    EXPECT_EQ(r.ao.variant, AoVariant::Cones);
    EXPECT_FLOAT_EQ(r.ao.maxDistance, 2.5f);
    EXPECT_FLOAT_EQ(r.ao.strength, 0.75f);
    EXPECT_FLOAT_EQ(r.ao.resolutionScale, 0.5f);
    EXPECT_EQ(r.ao.rays, 12u);
    EXPECT_FLOAT_EQ(r.reflections.roughnessCutoff, 0.3f);
    EXPECT_EQ(r.reflections.maxSteps, 99u);
    EXPECT_EQ(r.meshSdf, MeshSdfMode::Occlusion);
    ASSERT_TRUE(r.ambientSky.has_value());
    EXPECT_FLOAT_EQ(r.ambientSky->z, 0.3f);

    const ecs::MeshRenderer* mr = s.world.get<ecs::MeshRenderer>(entityNamed(s.world, "a"));
    ASSERT_NE(mr, nullptr);
    const ecs::Material* m = assets.material(mr->material);
    ASSERT_NE(m, nullptr);
    EXPECT_FLOAT_EQ(m->subsurface, 0.6f);
    EXPECT_FLOAT_EQ(m->subsurfaceColor.y, 0.2f);
    EXPECT_FLOAT_EQ(m->subsurfaceRadius, 0.05f);
    EXPECT_TRUE(m->reflections);
    EXPECT_FLOAT_EQ(m->triplanarScale, 4.0f);
    scene::unloadScene(s, assets);
}

// Criterion: each bad value fails the load with its JSON pointer and the reason in the message.
TEST(SceneEffects, RefusesBadValuesNamingTheElement) {
    struct Case {
        const char* render;
        const char* expected;
    };
    const Case cases[] = {
        {R"({"shadows": {"resolutionScale": 0}})", "/render/shadows/resolutionScale"},
        {R"({"shadows": {"resolutionScale": 1.5}})", "/render/shadows/resolutionScale"},
        {R"({"shadows": {"soft": true}})", "/render/shadows"},
        {R"({"shadows": {"maxSteps": 0}})", "/render/shadows/maxSteps"},
        {R"({"ao": {"variant": "ssao"}})", "unknown AO variant 'ssao'"},
        {R"({"ao": {"strength": 2}})", "/render/ao/strength"},
        {R"({"ao": {"maxDistance": -1}})", "/render/ao/maxDistance"},
        {R"({"ao": {"rays": 0}})", "/render/ao/rays"},
        {R"({"reflections": {"roughnessCutoff": 1.5}})", "/render/reflections/roughnessCutoff"},
        {R"({"meshSdf": "always"})", "unknown meshSdf mode 'always'"},
        {R"({"ambientSky": [0, -1, 0]})", "/render/ambientSky"},
    };
    for (const Case& c : cases) {
        assets::AssetManager assets;
        scene::Scene s;
        std::string error;
        const std::string text = std::string(R"({"version": 2, "render": )") + c.render + "}";
        EXPECT_FALSE(parseScene(text, assets, s, error)) << c.render;
        EXPECT_NE(error.find(c.expected), std::string::npos) << c.render << " -> " << error;
    }
}

TEST(SceneEffects, AoVariantNames) {
    for (AoVariant v : {AoVariant::Off, AoVariant::FiveTap, AoVariant::MultiRay, AoVariant::Cones}) {
        AoVariant parsed = AoVariant::Off;
        EXPECT_TRUE(scene::parseAoVariant(scene::toString(v), parsed));
        EXPECT_EQ(parsed, v);
    }
    AoVariant keep = AoVariant::Cones;
    EXPECT_FALSE(scene::parseAoVariant("Cones", keep));
    EXPECT_EQ(keep, AoVariant::Cones);
}

}  // namespace
}  // namespace penumbra::test
