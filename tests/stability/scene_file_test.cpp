// Hard cases of scene input (issue 11 item 4):
//   11 NaN / inf anywhere in a scene file: a clear load error naming the JSON pointer, never a crash.
// The base scene tests/stability/scenes/finite_base.json (every number distinct) loads and renders;
// each of its 24 numbers (transforms, camera, lights, material, render block, shape parameters, CSG
// smooth radius, a node transform, plane normal) is replaced in turn by 1e999, -1e999 (overflow a
// double), 1e300, -1e300 (finite doubles that overflow a float), NaN, Infinity, -Infinity and nan
// (not JSON), and the file is loaded through scene::loadScene. Criteria (192 loads): every load fails
// without a crash; the message starts with the file's path; for the number tokens it names the
// element's JSON pointer; for the non-JSON tokens it gives the line and column; the output Scene and
// the asset manager are unchanged (atomic load). Then, on each backend, the base scene still renders.
#include <filesystem>
#include <fstream>

#include "stability/stability_util.h"

namespace penumbra::test::stability {
namespace {

struct Location {
    const char* context;  // unique text of the base file containing the number
    const char* number;   // the number inside `context`
    const char* pointer;  // its JSON pointer
};

const Location kLocations[] = {
    {"[0.25, 1.75, 6.5]", "6.5", "/entities/0/transform/position/2"},
    {"[-12.5, 0, 0]", "-12.5", "/entities/0/transform/eulerDegrees/0"},
    {"\"fovYDegrees\": 47.5", "47.5", "/entities/0/camera/fovYDegrees"},
    {"\"near\": 0.0875", "0.0875", "/entities/0/camera/near"},
    {"\"far\": 62.5", "62.5", "/entities/0/camera/far"},
    {"0, 0.9]", "0.9", "/entities/1/transform/rotation/3"},
    {"\"intensity\": 2.25", "2.25", "/entities/1/light/intensity"},
    {"\"angularRadiusDegrees\": 0.265", "0.265", "/entities/1/light/angularRadiusDegrees"},
    {"[1.5, 3.25, 2.75]", "3.25", "/entities/2/transform/position/1"},
    {"[1, 0.875, 0.6875]", "0.875", "/entities/2/light/color/1"},
    {"\"range\": 13.5", "13.5", "/entities/2/light/range"},
    {"\"radius\": 0.1875", "0.1875", "/entities/2/light/radius"},
    {"\"scale\": 1.0625", "1.0625", "/entities/3/transform/scale"},
    {"\"radius\": 0.5312", "0.5312", "/entities/3/sdf/shape/radius"},
    {"[1.03125, 0.96875, 1.015625]", "0.96875", "/entities/4/transform/scale/1"},
    {"\"smoothRadius\": 0.1406", "0.1406", "/entities/4/sdf/csg/smoothRadius"},
    {"[0.4219, 0.3594, 0.3906]", "0.3594", "/entities/4/sdf/csg/children/0/halfExtents/1"},
    {"[0, 0.3281, 0]", "0.3281", "/entities/4/sdf/csg/children/1/transform/position/1"},
    {"[0, 1, 0.0156]", "0.0156", "/entities/5/sdf/shape/normal/2"},
    {"\"offset\": -0.0078", "-0.0078", "/entities/5/sdf/shape/offset"},
    {"\"roughness\": 0.4375", "0.4375", "/materials/red/roughness"},
    {"[0.8125, 0.1875, 0.15625]", "0.8125", "/materials/red/baseColor/0"},
    {"\"exposure\": 1.125", "1.125", "/render/exposure"},
    {"[0.05, 0.0625, 0.075]", "0.0625", "/render/ambient/1"},
};

struct BadValue {
    const char* text;
    bool jsonNumber;  // a JSON number token (then the pointer is required), else not JSON at all
};
const BadValue kBadValues[] = {{"1e999", true}, {"-1e999", true},    {"1e300", true},      {"-1e300", true},
                               {"NaN", false},  {"Infinity", false}, {"-Infinity", false}, {"nan", false}};

std::string readText(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

class StabilitySceneFile : public GpuTest {};

TEST_P(StabilitySceneFile, Case11_NonFiniteNumbersAreClearLoadErrors) {
    const std::string basePath = std::string(PENUMBRA_STABILITY_SCENES) + "/finite_base.json";
    const std::string base = readText(basePath);
    ASSERT_FALSE(base.empty()) << basePath;
    const std::string dir = std::string(PENUMBRA_STABILITY_TMP) + "/case11_" + backendLabel(GetParam());
    std::filesystem::create_directories(dir);

    assets::AssetManager assets;
    scene::Scene good;
    std::string error;
    ASSERT_TRUE(scene::loadScene(basePath, assets, good, error)) << error;
    const size_t assetsBefore = assets.count();

    size_t loads = 0, failed = 0, namedFile = 0, namedPointer = 0, needPointer = 0, lineColumn = 0,
           needLine = 0, untouched = 0;
    std::string firstNumberMessage, firstTokenMessage;
    for (const Location& loc : kLocations) {
        const size_t at = base.find(loc.context);
        ASSERT_NE(at, std::string::npos) << loc.context;
        ASSERT_EQ(base.find(loc.context, at + 1), std::string::npos) << loc.context << " is not unique";
        const size_t numberAt = at + std::string(loc.context).find(loc.number);
        for (const BadValue& bad : kBadValues) {
            std::string text = base;
            text.replace(numberAt, std::strlen(loc.number), bad.text);
            const std::string path = dir + "/" + std::to_string(loads) + ".json";
            {
                std::ofstream out(path, std::ios::binary | std::ios::trunc);
                out << text;
            }
            ++loads;
            scene::Scene out;
            out.sourcePath = "untouched";
            std::string message;
            const bool ok = scene::loadScene(path, assets, out, message);
            failed += !ok;
            namedFile += message.rfind(path, 0) == 0;
            if (bad.jsonNumber) {
                ++needPointer;
                const bool named = message.find(std::string(loc.pointer) + ":") != std::string::npos;
                namedPointer += named;
                if (!named) ADD_FAILURE() << bad.text << " at " << loc.pointer << ": " << message;
                if (firstNumberMessage.empty()) firstNumberMessage = message;
            } else {
                ++needLine;
                const bool has =
                    message.find("line") != std::string::npos && message.find("column") != std::string::npos;
                lineColumn += has;
                if (!has) ADD_FAILURE() << bad.text << " at " << loc.pointer << ": " << message;
                if (firstTokenMessage.empty()) firstTokenMessage = message;
            }
            untouched += out.sourcePath == "untouched" && out.world.aliveCount() == 0 &&
                         assets.count() == assetsBefore;
            EXPECT_FALSE(ok) << bad.text << " at " << loc.pointer << " loaded";
        }
    }
    summary("11 non-finite scene file", GetParam(),
            "%zu loads: %zu failed (all), %zu messages start with the file (all), pointer named %zu / %zu, "
            "line+column "
            "%zu / %zu, untouched output %zu (all)",
            loads, failed, namedFile, namedPointer, needPointer, lineColumn, needLine, untouched);
    std::printf("  e.g. %s\n  e.g. %s\n", firstNumberMessage.c_str(), firstTokenMessage.c_str());
    EXPECT_EQ(failed, loads);
    EXPECT_EQ(namedFile, loads);
    EXPECT_EQ(namedPointer, needPointer);
    EXPECT_EQ(lineColumn, needLine);
    EXPECT_EQ(untouched, loads);

    // The base scene still renders on this backend.
    render::SceneRenderer r(dev());
    render::FrameDesc d;
    d.width = 64;
    d.height = 48;
    d.camera = scene::findCamera(good.world, good.settings.camera);
    d.settings = good.settings;
    d.aux = true;
    ecs::updateTransforms(good.world);
    ASSERT_TRUE(r.render(good.world, assets, d, error)) << error;
    std::vector<uint8_t> raw = readRaw(r, "gbuffer.depth", rhi::Format::R32_FLOAT);
    size_t hits = 0;
    for (size_t i = 0; i + 4 <= raw.size(); i += 4) {
        float v;
        std::memcpy(&v, &raw[i], 4);
        hits += v > 0.0f;
    }
    EXPECT_GT(hits, raw.size() / 4 / 4);
    scene::unloadScene(good, assets);
}

INSTANTIATE_TEST_SUITE_P(Backends, StabilitySceneFile, testing::ValuesIn(gpuBackends()), backendName);

}  // namespace
}  // namespace penumbra::test::stability
