// render.taa and render.motionBlur (issue 14 items 2-3; docs/FORMATS.md): values, defaults (off) and
// strict errors at their JSON pointer.
#include <gtest/gtest.h>

#include "scene/scene_test_util.h"

namespace penumbra::scene {
namespace {

using test::parseScene;

std::string withRender(const std::string& render) {
    return R"({"version": 2, "render": )" + render + R"(, "entities": []})";
}

TEST(PostSettingsJson, DefaultsAreOff) {
    assets::AssetManager assets;
    Scene s;
    std::string error;
    ASSERT_TRUE(parseScene(withRender("{}"), assets, s, error)) << error;
    EXPECT_FALSE(s.settings.taa);
    EXPECT_FALSE(s.settings.motionBlur.enabled);
}

TEST(PostSettingsJson, ParsesEveryKey) {
    assets::AssetManager assets;
    Scene s, b, o;
    std::string error;
    ASSERT_TRUE(parseScene(withRender(R"({"taa": true, "motionBlur": {"strength": 0.5, "samples": 12}})"),
                           assets, s, error))
        << error;
    EXPECT_TRUE(s.settings.taa);
    EXPECT_TRUE(s.settings.motionBlur.enabled);  // an object enables it
    EXPECT_FLOAT_EQ(s.settings.motionBlur.strength, 0.5f);
    EXPECT_EQ(s.settings.motionBlur.samples, 12u);
    ASSERT_TRUE(parseScene(withRender(R"({"motionBlur": true})"), assets, b, error)) << error;
    EXPECT_TRUE(b.settings.motionBlur.enabled);
    EXPECT_EQ(b.settings.motionBlur.samples, MotionBlurSettings{}.samples);
    ASSERT_TRUE(
        parseScene(withRender(R"({"motionBlur": {"enabled": false, "samples": 4}})"), assets, o, error))
        << error;
    EXPECT_FALSE(o.settings.motionBlur.enabled);
    EXPECT_EQ(o.settings.motionBlur.samples, 4u);
}

TEST(PostSettingsJson, RefusesBadValuesWithTheirPointer) {
    struct Case {
        const char* render;
        const char* message;
    };
    const Case cases[] = {
        {R"({"taa": 1})", "/render/taa: expected true or false, got"},
        {R"({"motionBlur": "on"})", "/render/motionBlur: expected an object, got"},
        {R"({"motionBlur": {"samples": 1}})", "/render/motionBlur/samples: 1 is out of range [2, 32]"},
        {R"({"motionBlur": {"samples": 33}})", "/render/motionBlur/samples: 33 is out of range [2, 32]"},
        {R"({"motionBlur": {"strength": 0}})", "/render/motionBlur/strength: 0 is out of range (0, 4]"},
        {R"({"motionBlur": {"shutter": 1}})",
         "/render/motionBlur/shutter: unknown key 'shutter' in motion blur settings"},
    };
    for (const Case& c : cases) {
        assets::AssetManager assets;
        Scene s;
        std::string error;
        EXPECT_FALSE(parseScene(withRender(c.render), assets, s, error)) << c.render;
        EXPECT_NE(error.find(c.message), std::string::npos) << c.render << "\n  got: " << error;
    }
}

}  // namespace
}  // namespace penumbra::scene
