// Shared by the TAA and motion blur tests (taa_test.cpp, motion_blur_test.cpp): the scene
// tests/renderer/taa_scene.json loaded through the Engine, posed per frame, rendered with a chosen
// renderer, and the image metrics the acceptance criteria use.
#pragma once

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "engine/engine.h"
#include "engine/scene/scene.h"
#include "renderer/scene_renderer.h"
#include "support/golden.h"
#include "support/test_device.h"

namespace penumbra::test {

struct TaaScene {
    std::unique_ptr<Engine> engine;
    ecs::Entity camera, mover;
    glm::vec3 cameraStart{0.0f}, moverStart{0.0f};

    bool load(std::string& error) {
        EngineDesc desc;
        desc.loadStaticPlugins = false;
        desc.cacheDir = PENUMBRA_BINARY_DIR "/test_cache";
        engine = Engine::create(desc, error);
        if (!engine || !engine->loadScene(PENUMBRA_SOURCE_DIR "/tests/renderer/taa_scene.json", error))
            return false;
        ecs::World& world = engine->world();
        camera = scene::findCamera(world, engine->settings().camera);
        for (auto [e, name] : world.view<ecs::Name>())
            if (name.value == "mover") mover = e;
        if (camera.isNull() || mover.isNull()) {
            error = "taa_scene.json: no camera 'main' or entity 'mover'";
            return false;
        }
        cameraStart = world.get<ecs::Transform>(camera)->position;
        moverStart = world.get<ecs::Transform>(mover)->position;
        ecs::updateTransforms(world);
        return true;
    }
    // Camera and mover moved by these offsets from their scene positions.
    void pose(glm::vec3 cameraOffset, glm::vec3 moverOffset) {
        ecs::World& world = engine->world();
        world.get<ecs::Transform>(camera)->position = cameraStart + cameraOffset;
        world.get<ecs::Transform>(mover)->position = moverStart + moverOffset;
        ecs::updateTransforms(world);
    }
    void showMover(bool visible) { engine->world().get<ecs::SdfRenderer>(mover)->visible = visible; }

    struct Options {
        bool taa = false;
        bool motionBlur = false;
        bool resetHistory = false;
        bool effects = false;  // sun shadows (half resolution) and cone AO (quarter resolution) on
    };
    bool render(render::SceneRenderer& r, uint32_t width, uint32_t height, const Options& o, ImageRGBA8& out,
                std::string& error) {
        render::FrameDesc f;
        f.width = width;
        f.height = height;
        f.settings = engine->settings();
        f.settings.taa = o.taa;
        f.settings.motionBlur.enabled = o.motionBlur;
        f.camera = camera;
        f.resetHistory = o.resetHistory;
        if (o.effects) {
            f.settings.shadows.enabled = true;
            f.settings.ao.variant = scene::AoVariant::Cones;
        }
        return r.render(engine->world(), engine->assets(), f, error) && r.readPixels(out, error);
    }
};

inline TaaScene::Options withTaa(bool resetHistory = false) {
    TaaScene::Options o;
    o.taa = true;
    o.resetHistory = resetHistory;
    return o;
}
inline TaaScene::Options withEffects(TaaScene::Options o) {
    o.effects = true;
    return o;
}
inline TaaScene::Options withMotionBlur(bool on) {
    TaaScene::Options o;
    o.motionBlur = on;
    return o;
}

// Vulkan against OpenGL on the TAA scene by the golden rule (support/golden.h): `frame(device,
// scene, image, error)` renders one backend's image; `name` names the images written on failure.
template <typename FrameFn>
void expectTaaSceneParity(const char* name, FrameFn frame) {
    BackendPair pair;
    ASSERT_TRUE(pair.ready());
    TaaScene scene;
    std::string error;
    ASSERT_TRUE(scene.load(error)) << error;
    ImageRGBA8 vk, gl;
    ASSERT_TRUE(frame(*pair.vk, scene, vk, error)) << error;
    ASSERT_TRUE(frame(*pair.gl, scene, gl, error)) << error;
    pair.expectNoErrors();
    const ImageDiff d = compareBackends(name, vk, gl);
    std::printf("Vulkan vs OpenGL, %s: %s\n", name, d.summary().c_str());
    EXPECT_TRUE(d.pass) << d.summary();
}

inline float srgbToLinear(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}
inline float linearToSrgb(float c) {
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

// The 16x supersampled reference of a `factor` x `factor` larger rendering: per output pixel the
// mean of its factor^2 samples in linear (tone-mapped) colour - what TAA averages - re-encoded to
// sRGB in [0, 1]; RGB, row-major.
inline std::vector<float> downsampleReference(const ImageRGBA8& big, uint32_t factor) {
    const uint32_t w = big.width / factor, h = big.height / factor;
    std::vector<float> out(size_t(w) * h * 3);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x)
            for (uint32_t c = 0; c < 3; ++c) {
                double sum = 0.0;
                for (uint32_t j = 0; j < factor; ++j)
                    for (uint32_t i = 0; i < factor; ++i)
                        sum += srgbToLinear(
                            big.pixels[(size_t(y * factor + j) * big.width + x * factor + i) * 4 + c] /
                            255.0f);
                out[(size_t(y) * w + x) * 3 + c] = linearToSrgb(float(sum / (factor * factor)));
            }
    return out;
}

// Mean squared error of the displayed (sRGB-encoded) RGB values in [0, 1].
inline double meanSquaredError(const ImageRGBA8& image, const std::vector<float>& reference) {
    double sum = 0.0;
    const size_t n = size_t(image.width) * image.height;
    for (size_t p = 0; p < n; ++p)
        for (size_t c = 0; c < 3; ++c) {
            const double d = image.pixels[p * 4 + c] / 255.0 - reference[p * 3 + c];
            sum += d * d;
        }
    return sum / double(n * 3);
}

// Mean absolute difference of the RGB values, in 8-bit steps.
// Mean absolute difference in 8-bit steps over RGB, over the pixels `mask` selects (all if empty).
inline double meanAbsoluteDifference(const ImageRGBA8& a, const ImageRGBA8& b,
                                     const std::vector<uint8_t>& mask = {}) {
    double sum = 0.0;
    size_t count = 0;
    const size_t n = size_t(a.width) * a.height;
    for (size_t p = 0; p < n; ++p) {
        if (!mask.empty() && !mask[p]) continue;
        for (size_t c = 0; c < 3; ++c) sum += std::abs(int(a.pixels[p * 4 + c]) - int(b.pixels[p * 4 + c]));
        ++count;
    }
    return count ? sum / double(count * 3) : 0.0;
}

}  // namespace penumbra::test
