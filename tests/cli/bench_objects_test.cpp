// `penumbra bench objects` (tools/penumbra/bench_objects.h) and `--accel` (cli_common.h):
//   - help, bad flags (exit 2 with the reason), the --accel list;
//   - --write-scene: the file loads with the scene loader, has N baked SDF objects (instanced: 3
//     field assets; --no-instancing: N) and every object's bounds lie in the camera frustum;
//   - a tiny real run on each backend writes the Table-2 markdown and the CSV with one row set per
//     configuration.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "cli_common.h"
#include "engine/assets/asset_manager.h"
#include "engine/scene/scene.h"
#include "support/test_device.h"

namespace penumbra::test {
namespace {

struct CliRun {
    int status = -1;
    std::string output;
};

std::string outDir(const std::string& name) {
    std::string n = name;
    for (char& c : n)
        if (c == '/') c = '_';
    const std::string dir = fmt::format("{}/tests/cli_out/bench_objects/{}", PENUMBRA_BINARY_DIR, n);
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

// Runs the CLI from the source root (the default --mesh-dir data/meshes is relative to it).
CliRun cli(const std::string& args, const std::string& dir) {
    const std::string log = dir + "/log.txt";
    const std::string cmd =
        fmt::format("cd '{}' && '{}' {} > '{}' 2>&1", PENUMBRA_SOURCE_DIR, PENUMBRA_CLI_PATH, args, log);
    CliRun r;
    const int raw = std::system(cmd.c_str());
    r.status = raw == -1 ? -1 : WEXITSTATUS(raw);
    std::ifstream in(log);
    r.output.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    return r;
}

std::string readText(const std::string& path) {
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

bool meshesPresent() {
    return std::filesystem::exists(std::string(PENUMBRA_SOURCE_DIR) + "/data/meshes/dragon_vrip_res3.ply");
}

TEST(BenchObjectsCli, HelpNamesEveryOption) {
    const CliRun r = cli("bench objects --help", outDir("help"));
    EXPECT_EQ(r.status, 0) << r.output;
    for (const char* opt :
         {"--counts", "--configs", "--backend", "--frames", "--warmup", "--moving", "--instancing",
          "--write-scene", "--count", "--no-instancing", "--csv", "--markdown"})
        EXPECT_NE(r.output.find(opt), std::string::npos) << opt;
}

TEST(BenchObjectsCli, BadFlagsExitTwoWithTheReason) {
    struct Case {
        const char* args;
        const char* message;
    };
    const Case cases[] = {
        {"--counts 0", "--counts: '0' is not a count in [1, 100000]"},
        {"--counts 20,x", "--counts: 'x' is not a count"},
        {"--counts 20,,40", "--counts '20,,40': expected comma-separated object counts"},
        {"--configs none,fast", "unknown configuration 'fast' (expected none, culling, id, world, all)"},
        {"--instancing maybe", "--instancing"},
        {"--moving 2", "--moving"},
        {"--backend metal", "--backend"},
    };
    for (const Case& c : cases) {
        const CliRun r = cli(fmt::format("bench objects {}", c.args), outDir("bad"));
        EXPECT_EQ(r.status, 2) << c.args << ": " << r.output;
        EXPECT_NE(r.output.find(c.message), std::string::npos) << c.args << ": " << r.output;
    }
    // --accel on render and bench trace: an unknown toggle is a usage error before any work.
    for (const char* cmd : {"render scenes/default.json -o /tmp/never.png", "bench trace"}) {
        const CliRun r = cli(fmt::format("{} --accel culling,fast", cmd), outDir("accel"));
        EXPECT_EQ(r.status, 2) << cmd << ": " << r.output;
        EXPECT_NE(r.output.find("--accel 'culling,fast': unknown toggle 'fast'"), std::string::npos)
            << r.output;
    }
}

TEST(AccelOption, TurnsOnExactlyTheListedToggles) {
    scene::AccelerationSettings a;
    a.cacheLevels = 3;
    std::string error;
    ASSERT_TRUE(cli::applyAccelOption("cache,id", a, error)) << error;
    EXPECT_FALSE(a.culling);
    EXPECT_TRUE(a.worldCache);
    EXPECT_TRUE(a.idField);
    EXPECT_FALSE(a.prepass);
    EXPECT_EQ(a.cacheLevels, 3u);  // sizes untouched
    ASSERT_TRUE(cli::applyAccelOption("all", a, error));
    EXPECT_TRUE(a.culling && a.worldCache && a.idField);
    EXPECT_FALSE(a.prepass);  // all = the Table-2 toggles (the optional cone prepass is its own)
    ASSERT_TRUE(cli::applyAccelOption("none", a, error));
    EXPECT_FALSE(a.culling || a.worldCache || a.idField || a.prepass);
    ASSERT_TRUE(cli::applyAccelOption("prepass", a, error));
    EXPECT_TRUE(a.prepass && !a.culling);
    const scene::AccelerationSettings before = a;
    ASSERT_TRUE(cli::applyAccelOption("", a, error));  // empty: the scene's settings stay
    EXPECT_EQ(a.prepass, before.prepass);
    EXPECT_FALSE(cli::applyAccelOption("culling,", a, error));
    EXPECT_NE(error.find("unknown toggle ''"), std::string::npos) << error;
}

// --write-scene output through the ordinary loader: N baked objects, all in the camera frustum.
class WriteScene : public testing::TestWithParam<std::tuple<uint32_t, bool>> {};

TEST_P(WriteScene, LoadsWithEveryObjectInView) {
    if (!meshesPresent()) GTEST_SKIP() << "data/meshes missing (tools/fetch_meshes.sh)";
    const auto [count, instanced] = GetParam();
    const std::string dir = outDir(fmt::format("write_{}_{}", count, instanced));
    const std::string path = dir + "/sub/objects.json";
    const CliRun r = cli(fmt::format("bench objects --write-scene '{}' --count {}{}", path, count,
                                     instanced ? "" : " --no-instancing"),
                         dir);
    ASSERT_EQ(r.status, 0) << r.output;
    assets::AssetManagerDesc desc;
    desc.cacheDir = std::string(PENUMBRA_BINARY_DIR) + "/tests/objects_scene_cache";
    assets::AssetManager assets(desc);
    scene::Scene s;
    std::string error;
    ASSERT_TRUE(scene::loadScene(path, assets, s, error)) << error;  // relative mesh paths resolve
    const ecs::Entity camera = scene::findCamera(s.world, s.settings.camera);
    ASSERT_NE(camera, ecs::kNullEntity);
    const ecs::Camera* c = s.world.get<ecs::Camera>(camera);
    const glm::mat4 viewProj = glm::perspectiveRH_ZO(c->fovY, 320.0f / 180.0f, c->nearPlane, c->farPlane) *
                               glm::inverse(s.world.get<ecs::Transform>(camera)->worldMatrix);
    uint32_t baked = 0, outside = 0;
    std::set<assets::AssetId> fields;
    for (auto [e, sr] : s.world.view<const ecs::SdfRenderer>()) {
        if (sr.source != ecs::SdfSource::MeshBake) continue;
        ++baked;
        fields.insert(sr.sdf);
        const sdf::PsdfAsset* f = assets.sdfField(sr.sdf);
        ASSERT_NE(f, nullptr);
        const glm::mat4& m = s.world.get<ecs::Transform>(e)->worldMatrix;
        for (int k = 0; k < 8; ++k) {
            const glm::dvec3 lo = f->header.boundsMin, hi = f->header.boundsMax;
            const glm::vec4 clip =
                viewProj * m * glm::vec4(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z, 1.0f);
            const glm::vec3 ndc = glm::vec3(clip) / clip.w;
            if (!(clip.w > 0 && std::abs(ndc.x) <= 1 && std::abs(ndc.y) <= 1 && ndc.z >= 0 && ndc.z <= 1))
                ++outside;
        }
    }
    fmt::print(
        "{} objects ({}): {} baked SDF objects, {} field assets, {} bound corners outside the frustum\n",
        count, instanced ? "instanced" : "non-instanced", baked, fields.size(), outside);
    EXPECT_EQ(baked, count);  // exactly N objects (the room's boxes are analytic)
    EXPECT_EQ(outside, 0u);   // metric: mesh-bound corners outside the 320x180 frustum; threshold 0
    EXPECT_EQ(fields.size(), instanced ? 3u : size_t(count));
}

INSTANTIATE_TEST_SUITE_P(Counts, WriteScene,
                         testing::Values(std::make_tuple(40u, true), std::make_tuple(60u, false)));

// A tiny real run per backend: markdown and CSV with the expected rows.
class BenchObjectsRun : public testing::TestWithParam<rhi::Backend> {};

TEST_P(BenchObjectsRun, WritesTheTablesAndCsv) {
    if (!meshesPresent()) GTEST_SKIP() << "data/meshes missing (tools/fetch_meshes.sh)";
    const std::string backend = GetParam() == rhi::Backend::Vulkan ? "vulkan" : "gl";
    const std::string dir = outDir("run_" + backend);
    const CliRun r =
        cli(fmt::format("bench objects --counts 2 --frames 1 --warmup 0 --width 64 --height 36 "
                        "--backend {} --moving 1 --csv '{}/o.csv' --markdown '{}/o.md' --cache-dir "
                        "'{}/tests/objects_scene_cache'",
                        backend, dir, dir, PENUMBRA_BINARY_DIR),
            dir);
    ASSERT_EQ(r.status, 0) << r.output;
    const std::string md = readText(dir + "/o.md"), csv = readText(dir + "/o.csv");
    EXPECT_NE(md.find("| N | none | culling | id | world | all |"), std::string::npos) << md;
    EXPECT_NE(md.find("Trace speed-up against none"), std::string::npos) << md;
    for (const char* config : {"none", "culling", "id", "world", "all"}) {
        EXPECT_NE(md.find(fmt::format("| 2 | {} | 6 |", config)),
                  std::string::npos)  // N + 4 room boxes traced
            << config << "\n"
            << md;
        for (const char* measure : {"trace_total", "shadow_total", "ao_total", "frame_total", "update_share"})
            EXPECT_NE(csv.find(fmt::format(",2,{},1,64,36,1,{},", config, measure)), std::string::npos)
                << config << " " << measure;
    }
    EXPECT_EQ(
        csv.rfind("backend,device,instanced,count,config,moving,width,height,frames,measure,gpu_ms_median\n",
                  0),
        0u);
}

INSTANTIATE_TEST_SUITE_P(Backends, BenchObjectsRun,
                         testing::Values(rhi::Backend::Vulkan, rhi::Backend::OpenGL),
                         [](const testing::TestParamInfo<rhi::Backend>& info) {
                             return std::string(info.param == rhi::Backend::Vulkan ? "Vulkan" : "OpenGL");
                         });

}  // namespace
}  // namespace penumbra::test
