// The plugin ABI: what a plugin sees of the engine. Built-in plugins (static registration, see
// engine/plugin/plugin_host.h) and shared-library plugins (loaded with dlopen) implement the same
// IPlugin interface and extend the engine only through the PluginContext handed to onLoad().
//
// A shared-library plugin defines its class and exports the one C entry point with
//
//   class MyPlugin final : public penumbra::plugin::IPlugin { ... };
//   PENUMBRA_DEFINE_PLUGIN(MyPlugin, "my_plugin")
//
// which makes `penumbra_plugin_descriptor()` return a PenumbraPluginDescriptor (API version, name,
// create and destroy functions). The host refuses a library whose API version is incompatible
// (major must be equal, the host's minor >= the plugin's), that lacks the entry point, or whose
// name is already loaded.
//
// THE RULE for shared-library plugins: the engine is a static library, so linking it into a plugin
// would give the plugin private copies of every engine global (log sink, static plugin list,
// registries) that the host never sees. A plugin therefore
//   - talks to the engine only through PluginContext (pure virtual: calls go through the vtable of
//     the host's object, no engine symbol is needed at link time) and the IPlugin it implements;
//   - may use engine headers for plain data types and inline/template code (assets::MeshData,
//     ecs::System, glm), but calls no non-inline engine function and touches no engine global;
//   - logs with PluginContext::log(), never with penumbra::log::* (that would be its own sink);
//   - is linked with -z defs (plugins/CMakeLists.txt) so a stray engine call fails at link time;
//   - is built with the same compiler and standard library as the host (std::string,
//     std::function and std::shared_ptr cross the boundary; their layout is part of the API).
// No exception may leave a plugin: create(), onLoad(), onUnload(), registered systems and
// factories report failure through return values and PluginContext::log(). (The host catches
// escaping exceptions as a safety net and treats them as failures.)
//
// Everything a plugin registers (systems, factories) is recorded under its name and removed by the
// host when the plugin unloads: after onUnload(), before the plugin object is destroyed and before
// dlclose. Code outside the plugin must not keep copies of registered callables past an unload.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <new>
#include <string>
#include <string_view>
#include <utility>

#include "engine/assets/mesh.h"
#include "engine/core/log.h"
#include "engine/ecs/schedule.h"
#include "engine/ecs/storage.h"

namespace penumbra::plugin {

// API versions pack major (high 16 bits) and minor (low 16 bits). Bump the minor for additive
// changes (new virtual functions at the end of PluginContext, new factory kinds), the major for
// anything that changes existing layouts or meanings.
constexpr uint32_t makeApiVersion(uint16_t major, uint16_t minor) {
    return (uint32_t(major) << 16) | uint32_t(minor);
}
constexpr uint16_t apiMajor(uint32_t version) { return uint16_t(version >> 16); }
constexpr uint16_t apiMinor(uint32_t version) { return uint16_t(version & 0xffffu); }

inline constexpr uint32_t kPluginApiVersion = makeApiVersion(1, 0);

// A plugin built for `pluginVersion` runs on a host providing `hostVersion` when the majors are
// equal and the host's minor is at least the plugin's.
constexpr bool isApiCompatible(uint32_t hostVersion, uint32_t pluginVersion) {
    return apiMajor(hostVersion) == apiMajor(pluginVersion) &&
           apiMinor(hostVersion) >= apiMinor(pluginVersion);
}

// Factory kinds known to the engine. A kind fixes the callable's signature; the registry checks it.
inline constexpr std::string_view kMeshImporterKind = "mesh_importer";
// Reads `path` into `out`; on failure returns false with one message naming the file and reason.
using MeshImporterFn = bool(const std::string& path, assets::MeshData& out, std::string& error);
using MeshImporter = std::function<MeshImporterFn>;

// Lower-case extension without a leading dot: ".STL" -> "stl", "Ply" -> "ply".
inline std::string normalizeExtension(std::string_view extension) {
    if (!extension.empty() && extension.front() == '.') extension.remove_prefix(1);
    std::string out(extension);
    for (char& c : out) {
        if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
    }
    return out;
}

// Identifies a factory signature by its spelled type, the same in every module.
template <typename Signature>
constexpr std::string_view signatureName() {
    return ecs::detail::typeName<Signature>();
}

// The host's side of the boundary, one object per loaded plugin (registrations are recorded under
// that plugin). Valid from onLoad() until onUnload() returns; do not keep it longer.
class PluginContext {
public:
    virtual const char* pluginName() const = 0;
    virtual uint32_t hostApiVersion() const = 0;

    // Writes to the host's log sink, prefixed with the plugin's name.
    virtual void log(log::Severity severity, std::string_view message) = 0;

    // Adds a system to the host's schedule (false, logged: the host has no schedule, the name is
    // taken, or the callable is empty). Removed automatically when the plugin unloads.
    virtual bool addSystem(std::string_view name, ecs::System system) = 0;
    virtual bool removeSystem(std::string_view name) = 0;

    // Generic named-factory registry: `factory` points to a std::function whose signature is named
    // by `signature` (see registerFactory). False (logged) for an empty name, a null factory, or a
    // (kind, name) pair already registered by anyone.
    virtual bool addFactory(std::string_view kind, std::string_view name, std::string_view signature,
                            std::shared_ptr<const void> factory) = 0;
    virtual bool removeFactory(std::string_view kind, std::string_view name) = 0;

    // Typed front ends (inline: they compile into the plugin and call the virtual functions).
    template <typename Signature>
    bool registerFactory(std::string_view kind, std::string_view name, std::function<Signature> fn) {
        if (!fn) {
            log(log::Severity::Error, "refused an empty factory callable");
            return false;
        }
        auto holder = std::make_shared<const std::function<Signature>>(std::move(fn));
        return addFactory(kind, name, signatureName<Signature>(), std::move(holder));
    }

    // A mesh importer for files with this extension (case-insensitive, with or without the dot).
    bool registerImporter(std::string_view extension, MeshImporter fn) {
        return registerFactory<MeshImporterFn>(kMeshImporterKind, normalizeExtension(extension),
                                               std::move(fn));
    }

protected:
    ~PluginContext() = default;
};

class IPlugin {
public:
    virtual ~IPlugin() = default;

    virtual const char* name() const = 0;     // must equal the descriptor's name
    virtual const char* version() const = 0;  // the plugin's own version, e.g. "1.2.0"

    // Registers what the plugin provides. Returning false refuses the load: the host removes
    // whatever was registered, destroys the plugin and unloads the library.
    virtual bool onLoad(PluginContext& context) = 0;
    // Called before the host removes the plugin's registrations and destroys it.
    virtual void onUnload() {}
};

}  // namespace penumbra::plugin

extern "C" {

// Returned by the entry point. The first two fields keep their place in every API version, so a
// host can name a plugin built for another version when refusing it.
struct PenumbraPluginDescriptor {
    uint32_t apiVersion;  // kPluginApiVersion the plugin was built against
    const char* name;     // unique among loaded plugins; [A-Za-z0-9_.-]
    penumbra::plugin::IPlugin* (*create)();
    void (*destroy)(penumbra::plugin::IPlugin*);
};

typedef const PenumbraPluginDescriptor* (*PenumbraPluginEntryFn)(void);
}

#define PENUMBRA_PLUGIN_ENTRY_NAME "penumbra_plugin_descriptor"
#define PENUMBRA_PLUGIN_EXPORT extern "C" __attribute__((visibility("default")))

// Defines the entry point of a shared-library plugin implemented by `Class` (default-constructible).
#define PENUMBRA_DEFINE_PLUGIN(Class, pluginName)                                             \
    PENUMBRA_PLUGIN_EXPORT const PenumbraPluginDescriptor* penumbra_plugin_descriptor(void) { \
        static const PenumbraPluginDescriptor descriptor = {                                  \
            penumbra::plugin::kPluginApiVersion, pluginName,                                  \
            []() -> penumbra::plugin::IPlugin* { return new (std::nothrow) Class(); },        \
            [](penumbra::plugin::IPlugin* p) { delete p; }};                                  \
        return &descriptor;                                                                   \
    }
