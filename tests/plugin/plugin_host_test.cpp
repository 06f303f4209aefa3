// Plugin host: static registration, in-process descriptors, API version rules, dlopen loading of
// the real STL importer plugin and of fixture libraries the host must refuse.
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/ecs/schedule.h"
#include "engine/ecs/world.h"
#include "engine/plugin/plugin_host.h"
#include "plugin/plugin_test_util.h"

namespace {

using namespace penumbra;
using plugin::PluginHost;
using test::LogCapture;
using test::PluginTempDir;

int g_staticSystemRuns = 0;
int g_staticUnloads = 0;

class TestStaticPlugin final : public plugin::IPlugin {
public:
    const char* name() const override { return "test_static"; }
    const char* version() const override { return "2.3.4"; }
    bool onLoad(plugin::PluginContext& context) override {
        context.log(log::Severity::Info, "hello from the static plugin");
        return context.addSystem("test_static.count", [](ecs::World&, double) { ++g_staticSystemRuns; }) &&
               context.registerFactory<int()>("test_kind", "answer", std::function<int()>([] { return 42; }));
    }
    void onUnload() override { ++g_staticUnloads; }
};

}  // namespace

PENUMBRA_STATIC_PLUGIN(TestStaticPlugin, "test_static")

namespace {

bool contains(const std::string& haystack, const std::string& needle) {
    return haystack.find(needle) != std::string::npos;
}

std::string binaryStlTriangle(std::string bytes = std::string(80, 'h')) {
    // One triangle: header, count, normal, three vertices, attribute.
    const uint32_t count = 1;
    bytes.append(reinterpret_cast<const char*>(&count), 4);
    const float data[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    bytes.append(reinterpret_cast<const char*>(data), sizeof(data));
    bytes.append(2, '\0');
    return bytes;
}

// ---- API versions --------------------------------------------------------------------------------

TEST(PluginApi, VersionRules) {
    using namespace plugin;
    EXPECT_EQ(apiMajor(makeApiVersion(3, 7)), 3);
    EXPECT_EQ(apiMinor(makeApiVersion(3, 7)), 7);
    EXPECT_EQ(formatApiVersion(makeApiVersion(3, 7)), "3.7");
    EXPECT_TRUE(isApiCompatible(makeApiVersion(1, 2), makeApiVersion(1, 2)));
    EXPECT_TRUE(isApiCompatible(makeApiVersion(1, 2), makeApiVersion(1, 0)));   // older minor: fine
    EXPECT_FALSE(isApiCompatible(makeApiVersion(1, 2), makeApiVersion(1, 3)));  // newer minor
    EXPECT_FALSE(isApiCompatible(makeApiVersion(1, 2), makeApiVersion(2, 0)));  // other major
    EXPECT_FALSE(isApiCompatible(makeApiVersion(2, 0), makeApiVersion(1, 9)));
    EXPECT_EQ(normalizeExtension(".STL"), "stl");
    EXPECT_EQ(normalizeExtension("Ply"), "ply");
}

// ---- static registration -------------------------------------------------------------------------

TEST(PluginStatic, RegisteredPluginIsListedAndLoads) {
    bool listed = false;
    for (const PenumbraPluginDescriptor* d : plugin::staticPlugins())
        listed |= std::string(d->name) == "test_static";
    ASSERT_TRUE(listed);

    LogCapture capture;
    ecs::Schedule schedule;
    ecs::World world;
    const int unloadsBefore = g_staticUnloads;
    {
        PluginHost host(&schedule);
        ASSERT_TRUE(host.loadStatic("test_static")) << host.lastError();
        EXPECT_TRUE(host.isLoaded("test_static"));
        ASSERT_EQ(host.plugins().size(), 1u);
        EXPECT_EQ(host.plugins()[0].version, "2.3.4");
        EXPECT_TRUE(host.plugins()[0].path.empty());

        // The system runs through the host's schedule; the factory is typed.
        ASSERT_TRUE(schedule.contains("test_static.count"));
        const int runs = g_staticSystemRuns;
        schedule.run(world, 1.0 / 60.0);
        EXPECT_EQ(g_staticSystemRuns, runs + 1);
        const auto* answer = host.factories().find<int()>("test_kind", "answer");
        ASSERT_NE(answer, nullptr);
        EXPECT_EQ((*answer)(), 42);
        EXPECT_EQ(host.factories().find<double()>("test_kind", "answer"), nullptr);  // wrong signature

        // The plugin's log lines carry its name.
        bool prefixed = false;
        for (const std::string& m : capture.all())
            prefixed |= m == "[test_static] hello from the static plugin";
        EXPECT_TRUE(prefixed);

        // Loading it again is a duplicate.
        EXPECT_FALSE(host.loadStatic("test_static"));
        EXPECT_TRUE(contains(host.lastError(), "already loaded"));
        EXPECT_EQ(host.loadStaticPlugins(), 0u);  // nothing new (only already-loaded ones)

        ASSERT_TRUE(host.unload("test_static"));
        EXPECT_FALSE(schedule.contains("test_static.count"));
        EXPECT_EQ(host.factories().find<int()>("test_kind", "answer"), nullptr);
        EXPECT_EQ(g_staticUnloads, unloadsBefore + 1);
        EXPECT_FALSE(host.unload("test_static"));

        EXPECT_GE(host.loadStaticPlugins(), 1u);
        EXPECT_TRUE(host.isLoaded("test_static"));
    }
    // The destructor unloaded it.
    EXPECT_EQ(g_staticUnloads, unloadsBefore + 2);
    EXPECT_FALSE(schedule.contains("test_static.count"));
}

TEST(PluginStatic, UnknownNameAndDuplicateRegistration) {
    LogCapture capture;
    PluginHost host;
    EXPECT_FALSE(host.loadStatic("no_such_static_plugin"));
    EXPECT_TRUE(contains(capture.lastError(), "no_such_static_plugin"));

    static const PenumbraPluginDescriptor duplicate = {
        plugin::kPluginApiVersion, "test_static", []() -> plugin::IPlugin* { return new TestStaticPlugin(); },
        [](plugin::IPlugin* p) { delete p; }};
    EXPECT_FALSE(plugin::registerStaticPlugin(&duplicate));
    EXPECT_TRUE(contains(capture.lastError(), "already registered"));
    EXPECT_FALSE(plugin::registerStaticPlugin(nullptr));
}

TEST(PluginStatic, SystemsNeedASchedule) {
    LogCapture capture;
    PluginHost host;  // no schedule: the static plugin's addSystem fails, so its onLoad does
    EXPECT_FALSE(host.loadStatic("test_static"));
    EXPECT_TRUE(contains(host.lastError(), "onLoad() reported failure"));
    bool explained = false;
    for (const std::string& e : capture.errors()) explained |= contains(e, "the host has no schedule");
    EXPECT_TRUE(explained);
    EXPECT_FALSE(host.isLoaded("test_static"));
}

// ---- in-process descriptors ----------------------------------------------------------------------

std::vector<std::string> g_events;

class ScriptedPlugin : public plugin::IPlugin {
public:
    ScriptedPlugin(const char* name, int mode) : m_name(name), m_mode(mode) {}
    const char* name() const override { return m_mode == 3 ? "someone_else" : m_name; }
    const char* version() const override { return "1.0.0"; }
    bool onLoad(plugin::PluginContext& context) override {
        g_events.push_back(std::string("load ") + m_name);
        context.addSystem(std::string(m_name) + ".system", [](ecs::World&, double) {});
        context.registerImporter(std::string("x") + m_name,
                                 [](const std::string&, assets::MeshData&, std::string&) { return false; });
        if (m_mode == 1) return false;
        if (m_mode == 2) throw std::runtime_error("boom");
        return true;
    }
    void onUnload() override { g_events.push_back(std::string("unload ") + m_name); }
    ~ScriptedPlugin() override { g_events.push_back(std::string("destroy ") + m_name); }

private:
    const char* m_name;
    int m_mode;  // 0 ok, 1 onLoad fails, 2 onLoad throws, 3 wrong name()
};

#define SCRIPTED_DESCRIPTOR(var, pluginName, mode, api)                                             \
    const PenumbraPluginDescriptor var = {                                                          \
        api, pluginName, []() -> plugin::IPlugin* { return new ScriptedPlugin(pluginName, mode); }, \
        [](plugin::IPlugin* p) { delete p; }}

TEST(PluginHostTest, UnloadsInReverseOrder) {
    LogCapture capture;
    ecs::Schedule schedule;
    g_events.clear();
    SCRIPTED_DESCRIPTOR(a, "alpha", 0, plugin::kPluginApiVersion);
    SCRIPTED_DESCRIPTOR(b, "beta", 0, plugin::kPluginApiVersion);
    SCRIPTED_DESCRIPTOR(c, "gamma", 0, plugin::kPluginApiVersion);
    {
        PluginHost host(&schedule);
        ASSERT_TRUE(host.loadPlugin(a));
        ASSERT_TRUE(host.loadPlugin(b));
        ASSERT_TRUE(host.loadPlugin(c));
        EXPECT_EQ(schedule.size(), 3u);
        EXPECT_EQ(host.meshImporterExtensions(), (std::vector<std::string>{"xalpha", "xbeta", "xgamma"}));
        g_events.clear();
    }
    EXPECT_EQ(g_events, (std::vector<std::string>{"unload gamma", "destroy gamma", "unload beta",
                                                  "destroy beta", "unload alpha", "destroy alpha"}));
    EXPECT_EQ(schedule.size(), 0u);
}

TEST(PluginHostTest, FailedLoadsRollBack) {
    LogCapture capture;
    ecs::Schedule schedule;
    PluginHost host(&schedule);
    SCRIPTED_DESCRIPTOR(fails, "fails", 1, plugin::kPluginApiVersion);
    SCRIPTED_DESCRIPTOR(throws, "throws", 2, plugin::kPluginApiVersion);
    SCRIPTED_DESCRIPTOR(misnamed, "misnamed", 3, plugin::kPluginApiVersion);

    g_events.clear();
    EXPECT_FALSE(host.loadPlugin(fails));
    EXPECT_TRUE(contains(host.lastError(), "plugin 'fails' refused: onLoad() reported failure"));
    EXPECT_FALSE(host.loadPlugin(throws));
    EXPECT_TRUE(contains(host.lastError(), "plugin 'throws' refused: onLoad() threw an exception"));
    EXPECT_FALSE(host.loadPlugin(misnamed));
    EXPECT_TRUE(contains(host.lastError(), "IPlugin::name() returns 'someone_else'"));
    // Nothing they registered survives, and every instance was destroyed.
    EXPECT_EQ(schedule.size(), 0u);
    EXPECT_TRUE(host.meshImporterExtensions().empty());
    EXPECT_TRUE(host.plugins().empty());
    EXPECT_EQ(g_events, (std::vector<std::string>{"load fails", "destroy fails", "load throws",
                                                  "destroy throws", "destroy misnamed"}));
}

TEST(PluginHostTest, RefusesBadDescriptors) {
    LogCapture capture;
    PluginHost host;
    using plugin::makeApiVersion;
    const uint32_t host_ = plugin::kPluginApiVersion;
    SCRIPTED_DESCRIPTOR(nextMajor, "next_major", 0, makeApiVersion(plugin::apiMajor(host_) + 1, 0));
    SCRIPTED_DESCRIPTOR(newerMinor, "newer_minor", 0,
                        makeApiVersion(plugin::apiMajor(host_), plugin::apiMinor(host_) + 1));
    SCRIPTED_DESCRIPTOR(badName, "bad name!", 0, host_);
    const PenumbraPluginDescriptor noCreate = {host_, "no_create", nullptr,
                                               [](plugin::IPlugin* p) { delete p; }};
    const PenumbraPluginDescriptor nullName = {host_, nullptr, nullptr, nullptr};

    EXPECT_FALSE(host.loadPlugin(nextMajor));
    const std::string hostText = plugin::formatApiVersion(host_);
    EXPECT_TRUE(contains(host.lastError(), "'next_major'"));
    EXPECT_TRUE(contains(host.lastError(), "plugin API " + plugin::formatApiVersion(nextMajor.apiVersion)));
    EXPECT_TRUE(contains(host.lastError(), "host provides API " + hostText));
    EXPECT_FALSE(host.loadPlugin(newerMinor));
    EXPECT_TRUE(contains(host.lastError(), plugin::formatApiVersion(newerMinor.apiVersion)));
    EXPECT_FALSE(host.loadPlugin(badName));
    EXPECT_TRUE(contains(host.lastError(), "no valid name"));
    EXPECT_FALSE(host.loadPlugin(noCreate));
    EXPECT_TRUE(contains(host.lastError(), "create or destroy"));
    EXPECT_FALSE(host.loadPlugin(nullName));
    EXPECT_EQ(capture.errors().size(), 5u);
    EXPECT_TRUE(host.plugins().empty());
}

struct Intruder final : plugin::IPlugin {
    const char* name() const override { return "intruder"; }
    const char* version() const override { return "1"; }
    bool onLoad(plugin::PluginContext& context) override {
        removedFactory = context.removeFactory(plugin::kMeshImporterKind, "xowner");
        removedSystem = context.removeSystem("owner.system");
        duplicate = context.registerImporter(
            ".XOWNER", [](const std::string&, assets::MeshData&, std::string&) { return true; });
        return true;
    }
    static inline bool removedFactory = true;
    static inline bool removedSystem = true;
    static inline bool duplicate = true;
};

TEST(PluginHostTest, PluginsCannotTouchOthersRegistrations) {
    LogCapture capture;
    ecs::Schedule schedule;
    PluginHost host(&schedule);
    SCRIPTED_DESCRIPTOR(owner, "owner", 0, plugin::kPluginApiVersion);
    ASSERT_TRUE(host.loadPlugin(owner));

    const PenumbraPluginDescriptor intruder = {plugin::kPluginApiVersion, "intruder",
                                               []() -> plugin::IPlugin* { return new Intruder(); },
                                               [](plugin::IPlugin* p) { delete p; }};
    ASSERT_TRUE(host.loadPlugin(intruder));
    EXPECT_FALSE(Intruder::removedFactory);
    EXPECT_FALSE(Intruder::removedSystem);
    EXPECT_FALSE(Intruder::duplicate);
    EXPECT_TRUE(contains(capture.lastError(), "already registered by 'owner'"));
    EXPECT_NE(host.findMeshImporter("xowner"), nullptr);
    EXPECT_TRUE(schedule.contains("owner.system"));
}

TEST(PluginHostTest, ImporterOutputIsChecked) {
    struct BadImporter final : plugin::IPlugin {
        const char* name() const override { return "bad_importer"; }
        const char* version() const override { return "1"; }
        bool onLoad(plugin::PluginContext& context) override {
            return context.registerImporter("bad",
                                            [](const std::string&, assets::MeshData& out, std::string&) {
                                                out.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
                                                out.indices = {0, 1, 7};
                                                return true;
                                            }) &&
                   context.registerImporter("throwing",
                                            [](const std::string&, assets::MeshData&, std::string&) -> bool {
                                                throw std::runtime_error("importer bug");
                                            });
        }
    };
    const PenumbraPluginDescriptor bad = {plugin::kPluginApiVersion, "bad_importer",
                                          []() -> plugin::IPlugin* { return new BadImporter(); },
                                          [](plugin::IPlugin* p) { delete p; }};
    LogCapture capture;
    PluginHost host;
    ASSERT_TRUE(host.loadPlugin(bad));
    assets::MeshData mesh;
    std::string error;
    EXPECT_FALSE(host.importMesh("model.bad", mesh, error));
    EXPECT_TRUE(contains(error, "model.bad: importer output rejected: index out of range")) << error;
    EXPECT_TRUE(mesh.positions.empty());
    EXPECT_FALSE(host.importMesh("model.throwing", mesh, error));
    EXPECT_TRUE(contains(error, "threw an exception")) << error;
    EXPECT_FALSE(host.importMesh("model.unknown", mesh, error));
    EXPECT_TRUE(contains(error, "no mesh importer for extension 'unknown' (importers: bad, throwing)"))
        << error;
    EXPECT_FALSE(host.importMesh("no_extension", mesh, error));
}

// ---- dlopen --------------------------------------------------------------------------------------

TEST(PluginDlopen, LoadsTheStlImporterAndUnloads) {
    LogCapture capture;
    PluginTempDir dir;
    const std::string stl = dir.write("tri.stl", binaryStlTriangle());
    const std::string plugin = test::pluginPath("stl_importer");
    ASSERT_TRUE(std::filesystem::exists(plugin)) << plugin << " was not built";

    PluginHost host;
    assets::MeshData mesh;
    std::string error;
    EXPECT_FALSE(host.importMesh(stl, mesh, error));  // no importer yet

    ASSERT_TRUE(host.loadLibrary(plugin)) << host.lastError();
    ASSERT_EQ(host.plugins().size(), 1u);
    EXPECT_EQ(host.plugins()[0].name, "stl_importer");
    EXPECT_EQ(host.plugins()[0].path, plugin);
    EXPECT_EQ(host.plugins()[0].apiVersion, plugin::kPluginApiVersion);
    EXPECT_NE(host.findMeshImporter(".STL"), nullptr);
    ASSERT_TRUE(host.importMesh(stl, mesh, error)) << error;
    EXPECT_EQ(mesh.triangleCount(), 1u);
    EXPECT_EQ(mesh.sourcePath, stl);

    // Duplicate: the same library again is refused and the first stays usable.
    EXPECT_FALSE(host.loadLibrary(plugin));
    EXPECT_TRUE(contains(host.lastError(),
                         "plugin 'stl_importer' refused: a plugin with this name is already loaded"));
    EXPECT_TRUE(contains(host.lastError(), plugin));
    ASSERT_TRUE(host.importMesh(stl, mesh, error)) << error;

    // Unload removes the importer (whether or not dlclose really unmaps the library).
    ASSERT_TRUE(host.unload("stl_importer"));
    EXPECT_EQ(host.findMeshImporter("stl"), nullptr);
    EXPECT_FALSE(host.importMesh(stl, mesh, error));
    EXPECT_TRUE(contains(error, "no mesh importer")) << error;

    // And it loads again.
    ASSERT_TRUE(host.loadLibrary(plugin)) << host.lastError();
    ASSERT_TRUE(host.importMesh(stl, mesh, error)) << error;
    EXPECT_EQ(mesh.triangleCount(), 1u);
}

TEST(PluginDlopen, LoadDirectory) {
    LogCapture capture;
    PluginHost host;
    const plugin::DirectoryLoadResult result = host.loadDirectory(PENUMBRA_PLUGIN_DIR);
    EXPECT_EQ(result.failed, 0u) << capture.lastError();
    EXPECT_GE(result.loaded, 1u);
    EXPECT_TRUE(host.isLoaded("stl_importer"));

    // A folder with one good plugin, one fake library and an unrelated file.
    PluginTempDir dir;
    std::filesystem::copy_file(test::pluginPath("stl_importer"), dir.file("stl_importer.so"));
    dir.write("fake.so", "this is not an ELF file\n");
    dir.write("readme.txt", "ignored\n");
    PluginHost second;
    const plugin::DirectoryLoadResult mixed = second.loadDirectory(dir.path());
    EXPECT_EQ(mixed.loaded, 1u);
    EXPECT_EQ(mixed.failed, 1u);
    EXPECT_TRUE(second.isLoaded("stl_importer"));
    EXPECT_TRUE(contains(capture.lastError(), dir.file("fake.so")));

    const plugin::DirectoryLoadResult missing = second.loadDirectory(dir.file("no_such_folder"));
    EXPECT_EQ(missing.loaded, 0u);
    EXPECT_EQ(missing.failed, 1u);
    EXPECT_TRUE(contains(second.lastError(), "not a readable directory"));
}

TEST(PluginDlopen, RefusesOtherApiVersions) {
    LogCapture capture;
    PluginHost host;
    const std::string major = test::fixturePath("fixture_api_next_major");
    ASSERT_TRUE(std::filesystem::exists(major)) << major << " was not built";
    EXPECT_FALSE(host.loadLibrary(major));
    const std::string message = host.lastError();
    const uint32_t hostVersion = plugin::kPluginApiVersion;
    const std::string pluginText = plugin::formatApiVersion(
        plugin::makeApiVersion(plugin::apiMajor(hostVersion) + 1, plugin::apiMinor(hostVersion)));
    EXPECT_TRUE(contains(message, major)) << message;
    EXPECT_TRUE(contains(message, "'fixture_api_next_major'")) << message;
    EXPECT_TRUE(contains(message, "built for plugin API " + pluginText)) << message;
    EXPECT_TRUE(contains(message, "this host provides API " + plugin::formatApiVersion(hostVersion)))
        << message;
    EXPECT_EQ(capture.lastError(), message);  // logged once, the same text

    const std::string minor = test::fixturePath("fixture_api_newer_minor");
    EXPECT_FALSE(host.loadLibrary(minor));
    EXPECT_TRUE(contains(host.lastError(), "'fixture_api_newer_minor'")) << host.lastError();
    EXPECT_TRUE(contains(host.lastError(), "host's minor must be at least")) << host.lastError();
    EXPECT_TRUE(host.plugins().empty());
}

TEST(PluginDlopen, ClearErrorsForNonPlugins) {
    LogCapture capture;
    PluginTempDir dir;
    PluginHost host;

    const std::string missing = dir.file("missing.so");
    EXPECT_FALSE(host.loadLibrary(missing));
    EXPECT_EQ(host.lastError(), "plugin library '" + missing + "': refused: no such file");

    const std::string text = dir.write("notes.so", "definitely not a shared library\n");
    EXPECT_FALSE(host.loadLibrary(text));
    EXPECT_TRUE(contains(host.lastError(), "plugin library '" + text + "': refused: dlopen failed: "))
        << host.lastError();
    EXPECT_TRUE(contains(host.lastError(), "notes.so")) << host.lastError();

    const std::string empty = dir.write("empty.so", "");
    EXPECT_FALSE(host.loadLibrary(empty));
    EXPECT_TRUE(contains(host.lastError(), "dlopen failed")) << host.lastError();

    EXPECT_FALSE(host.loadLibrary(dir.path()));
    EXPECT_TRUE(contains(host.lastError(), "not a regular file")) << host.lastError();

    const std::string noEntry = test::fixturePath("fixture_no_entry");
    ASSERT_TRUE(std::filesystem::exists(noEntry)) << noEntry << " was not built";
    EXPECT_FALSE(host.loadLibrary(noEntry));
    EXPECT_TRUE(contains(host.lastError(),
                         "not a penumbra plugin: entry point 'penumbra_plugin_descriptor' not found"))
        << host.lastError();

    EXPECT_EQ(capture.errors().size(), 5u);
    EXPECT_TRUE(host.plugins().empty());
}

}  // namespace
