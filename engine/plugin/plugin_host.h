// The plugin host: loads built-in plugins (static registration) and shared-library plugins
// (dlopen), owns the registries they extend, and unloads them in reverse load order.
//
//   ecs::Schedule schedule;
//   plugin::PluginHost host(&schedule);
//   host.loadStaticPlugins();                      // every PENUMBRA_STATIC_PLUGIN in the program
//   host.loadDirectory(pluginDir);                 // every *.so in the folder, sorted by name
//   assets::MeshData mesh; std::string error;
//   host.importMesh("part.stl", mesh, error);      // dispatches on the extension
//
// Errors (refused loads, failing importers) return false and are logged once through
// engine/core/log.h; lastError() repeats the last message. Not thread-safe.
//
// Static registration: PENUMBRA_STATIC_PLUGIN(Class, "name") in a .cpp adds a descriptor to a
// list built on first use (a function-local static, so the order of static initialisation does
// not matter). Note that a linker drops an object file of a static library that nothing
// references, registrar included: register plugins that live in static libraries from an object
// file that is referenced, or call registerStaticPlugin() explicitly.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "engine/plugin/plugin.h"

namespace penumbra::plugin {

// Adds a descriptor to the static plugin list (false, logged, for an invalid descriptor or a name
// already listed). The descriptor must outlive the program (use a static object).
bool registerStaticPlugin(const PenumbraPluginDescriptor* descriptor);
// The static list in registration order.
const std::vector<const PenumbraPluginDescriptor*>& staticPlugins();

// "1.0"
std::string formatApiVersion(uint32_t version);

// The generic named-factory registry: (kind, name) -> a std::function of the kind's signature.
// Owned by the host; plugins add to it through their PluginContext.
class FactoryRegistry {
public:
    struct Entry {
        std::string signature;
        std::shared_ptr<const void> factory;  // points to a std::function<Signature>
        std::string owner;                    // plugin that registered it
    };

    // False with `error` set when the pair is taken, the name empty or the factory null.
    bool add(std::string_view kind, std::string_view name, std::string_view signature,
             std::shared_ptr<const void> factory, std::string_view owner, std::string& error);
    bool remove(std::string_view kind, std::string_view name);
    // Removes every entry of `owner`; returns how many.
    size_t removeOwner(std::string_view owner);

    // The callable registered under (kind, name) if its signature is `Signature`, else null. Valid
    // until the registry changes (a load or unload); do not keep copies past an unload.
    template <typename Signature>
    const std::function<Signature>* find(std::string_view kind, std::string_view name) const {
        const Entry* entry = findEntry(kind, name);
        if (!entry || entry->signature != signatureName<Signature>()) return nullptr;
        return static_cast<const std::function<Signature>*>(entry->factory.get());
    }
    const Entry* findEntry(std::string_view kind, std::string_view name) const;
    // Names registered for a kind, sorted.
    std::vector<std::string> names(std::string_view kind) const;
    size_t size() const { return m_entries.size(); }

private:
    // kind + '\n' + name -> entry (kinds and names contain no newline)
    std::map<std::string, Entry, std::less<>> m_entries;
};

struct PluginInfo {
    std::string name;
    std::string version;
    uint32_t apiVersion = 0;
    std::string path;  // the shared library; empty for an in-process plugin
};

struct DirectoryLoadResult {
    size_t loaded = 0;
    size_t failed = 0;
};

class PluginHost {
public:
    // `schedule` (optional) receives the systems plugins add; it must outlive the host or
    // unloadAll() must run first.
    explicit PluginHost(ecs::Schedule* schedule = nullptr);
    ~PluginHost();  // unloadAll()
    PluginHost(const PluginHost&) = delete;
    PluginHost& operator=(const PluginHost&) = delete;

    // Instantiates a plugin from a descriptor in this process (static list or any other source).
    bool loadPlugin(const PenumbraPluginDescriptor& descriptor);
    // Loads the statically registered plugin called `name`.
    bool loadStatic(std::string_view name);
    // Loads every statically registered plugin not loaded yet; returns how many were loaded.
    size_t loadStaticPlugins();

    // dlopen(RTLD_NOW | RTLD_LOCAL) + `penumbra_plugin_descriptor()`. Refused (logged, false): a
    // missing file, a dlopen error (its dlerror text), a missing entry point, an invalid
    // descriptor, an incompatible API version, a name already loaded, create() or onLoad() failing.
    bool loadLibrary(const std::string& path);
    // Every regular file named *.so in `dir`, in name order; failures are logged and counted.
    DirectoryLoadResult loadDirectory(const std::string& dir);

    // onUnload(), removal of its registrations, destroy, dlclose. False if not loaded.
    bool unload(std::string_view name);
    // Unloads everything in reverse load order.
    void unloadAll();

    bool isLoaded(std::string_view name) const;
    std::vector<PluginInfo> plugins() const;  // load order

    FactoryRegistry& factories() { return m_factories; }
    const FactoryRegistry& factories() const { return m_factories; }
    ecs::Schedule* schedule() const { return m_schedule; }

    // The importer registered for a file extension (any case, with or without the dot), or null.
    const MeshImporter* findMeshImporter(std::string_view extension) const;
    std::vector<std::string> meshImporterExtensions() const;
    // Imports through the importer for the path's extension and checks its output (indices in
    // range and a multiple of three, attribute counts, finite positions).
    bool importMesh(const std::string& path, assets::MeshData& out, std::string& error) const;

    const std::string& lastError() const { return m_lastError; }

private:
    class Context;
    struct Loaded;

    bool instantiate(const PenumbraPluginDescriptor& descriptor, void* library, const std::string& path);
    void release(Loaded& plugin);
    bool fail(std::string message);

    ecs::Schedule* m_schedule = nullptr;
    FactoryRegistry m_factories;
    std::vector<std::unique_ptr<Loaded>> m_plugins;
    std::string m_lastError;
};

}  // namespace penumbra::plugin

// Registers `Class` (default-constructible IPlugin) under `pluginName` in the static plugin list.
#define PENUMBRA_STATIC_PLUGIN(Class, pluginName)                                      \
    namespace {                                                                        \
    [[maybe_unused]] const bool penumbraStaticPluginRegistered_##Class = [] {          \
        static const PenumbraPluginDescriptor descriptor = {                           \
            penumbra::plugin::kPluginApiVersion, pluginName,                           \
            []() -> penumbra::plugin::IPlugin* { return new (std::nothrow) Class(); }, \
            [](penumbra::plugin::IPlugin* p) { delete p; }};                           \
        return penumbra::plugin::registerStaticPlugin(&descriptor);                    \
    }();                                                                               \
    }
