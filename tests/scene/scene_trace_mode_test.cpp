// The render block's "traceMode" (issue 14 item 1; docs/FORMATS.md): default fullscreen, the three
// names read, anything else refused at its JSON pointer.
#include <string>

#include <gtest/gtest.h>

#include "engine/assets/asset_manager.h"
#include "engine/scene/scene.h"
#include "scene/scene_test_util.h"

namespace penumbra::test {
namespace {

using scene::TraceMode;

TEST(SceneTraceMode, DefaultIsFullscreen) {
    assets::AssetManager assets;
    scene::Scene s;
    std::string error;
    ASSERT_TRUE(parseScene(R"({"version": 2})", assets, s, error)) << error;
    EXPECT_EQ(s.settings.traceMode, TraceMode::Fullscreen);
}

TEST(SceneTraceMode, ReadsEveryMode) {
    for (TraceMode m : {TraceMode::Fullscreen, TraceMode::Box, TraceMode::Auto}) {
        assets::AssetManager assets;
        scene::Scene s;
        std::string error;
        const std::string text =
            std::string(R"({"version": 2, "render": {"traceMode": ")") + scene::toString(m) + R"("}})";
        ASSERT_TRUE(parseScene(text, assets, s, error)) << error;
        EXPECT_EQ(s.settings.traceMode, m);
    }
}

TEST(SceneTraceMode, RefusesOtherValuesAtThePointer) {
    for (const char* value : {R"("boxes")", R"("Box")", "1", "true"}) {
        assets::AssetManager assets;
        scene::Scene s;
        std::string error;
        const std::string text = std::string(R"({"version": 2, "render": {"traceMode": )") + value + "}}";
        EXPECT_FALSE(parseScene(text, assets, s, error)) << value;
        EXPECT_NE(error.find("/render/traceMode"), std::string::npos) << value << " -> " << error;
    }
    TraceMode keep = TraceMode::Box;
    EXPECT_FALSE(scene::parseTraceMode("full-screen", keep));
    EXPECT_EQ(keep, TraceMode::Box);
}

}  // namespace
}  // namespace penumbra::test
