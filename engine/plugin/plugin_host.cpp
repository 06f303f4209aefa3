#include "engine/plugin/plugin_host.h"

#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <system_error>
#include <utility>

#include "engine/core/log.h"

namespace penumbra::plugin {

namespace {

std::vector<const PenumbraPluginDescriptor*>& staticList() {
    static std::vector<const PenumbraPluginDescriptor*> list;
    return list;
}

bool validPluginName(std::string_view name) {
    if (name.empty() || name.size() > 128) return false;
    return std::all_of(name.begin(), name.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
               c == '.' || c == '-';
    });
}

std::string factoryKey(std::string_view kind, std::string_view name) {
    std::string key;
    key.reserve(kind.size() + 1 + name.size());
    key.append(kind);
    key.push_back('\n');
    key.append(name);
    return key;
}

// Extension of the file name part of `path`, normalised ("stl"), empty if none.
std::string pathExtension(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    const size_t dot = path.find_last_of('.');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
    return normalizeExtension(std::string_view(path).substr(dot + 1));
}

std::string dlerrorText() {
    const char* text = dlerror();
    return text ? std::string(text) : std::string("unknown error");
}

bool checkImportedMesh(const std::string& path, const assets::MeshData& mesh, std::string& error) {
    auto failWith = [&](std::string_view reason) {
        error.clear();
        error.append(path).append(": importer output rejected: ").append(reason);
        return false;
    };
    if (mesh.indices.size() % 3 != 0) return failWith("index count is not a multiple of three");
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
        return failWith("normal count differs from position count");
    if (!mesh.uvs.empty() && mesh.uvs.size() != mesh.positions.size())
        return failWith("uv count differs from position count");
    for (uint32_t index : mesh.indices) {
        if (index >= mesh.positions.size()) return failWith("index out of range");
    }
    for (const glm::vec3& p : mesh.positions) {
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            return failWith("non-finite position");
    }
    return true;
}

}  // namespace

bool registerStaticPlugin(const PenumbraPluginDescriptor* descriptor) {
    if (!descriptor || !descriptor->name || !validPluginName(descriptor->name) || !descriptor->create ||
        !descriptor->destroy) {
        log::error(
            "static plugin registration refused: invalid descriptor (needs a name of [A-Za-z0-9_.-] "
            "and create/destroy functions)");
        return false;
    }
    auto& list = staticList();
    for (const PenumbraPluginDescriptor* existing : list) {
        if (std::string_view(existing->name) == descriptor->name) {
            log::error("static plugin registration refused: a plugin named '{}' is already registered",
                       descriptor->name);
            return false;
        }
    }
    list.push_back(descriptor);
    return true;
}

const std::vector<const PenumbraPluginDescriptor*>& staticPlugins() { return staticList(); }

std::string formatApiVersion(uint32_t version) {
    return fmt::format("{}.{}", apiMajor(version), apiMinor(version));
}

// ---- FactoryRegistry ---------------------------------------------------------------------------

bool FactoryRegistry::add(std::string_view kind, std::string_view name, std::string_view signature,
                          std::shared_ptr<const void> factory, std::string_view owner, std::string& error) {
    if (kind.empty() || name.empty() || kind.find('\n') != std::string_view::npos ||
        name.find('\n') != std::string_view::npos) {
        error = "factory kind and name must be non-empty single-line strings";
        return false;
    }
    if (!factory) {
        error = fmt::format("{} '{}': null factory", kind, name);
        return false;
    }
    std::string key = factoryKey(kind, name);
    auto it = m_entries.find(key);
    if (it != m_entries.end()) {
        error = fmt::format("{} '{}' is already registered by '{}'", kind, name, it->second.owner);
        return false;
    }
    m_entries.emplace(std::move(key), Entry{std::string(signature), std::move(factory), std::string(owner)});
    return true;
}

bool FactoryRegistry::remove(std::string_view kind, std::string_view name) {
    auto it = m_entries.find(factoryKey(kind, name));
    if (it == m_entries.end()) return false;
    m_entries.erase(it);
    return true;
}

size_t FactoryRegistry::removeOwner(std::string_view owner) {
    return std::erase_if(m_entries, [&](const auto& item) { return item.second.owner == owner; });
}

const FactoryRegistry::Entry* FactoryRegistry::findEntry(std::string_view kind, std::string_view name) const {
    auto it = m_entries.find(factoryKey(kind, name));
    return it == m_entries.end() ? nullptr : &it->second;
}

std::vector<std::string> FactoryRegistry::names(std::string_view kind) const {
    std::vector<std::string> out;
    for (const auto& [key, entry] : m_entries) {
        const size_t split = key.find('\n');
        if (std::string_view(key).substr(0, split) == kind) out.push_back(key.substr(split + 1));
    }
    return out;  // std::map order: sorted by kind then name
}

// ---- PluginHost::Context -----------------------------------------------------------------------

class PluginHost::Context final : public PluginContext {
public:
    Context(PluginHost& host, std::string name) : m_host(host), m_name(std::move(name)) {}

    const char* pluginName() const override { return m_name.c_str(); }
    uint32_t hostApiVersion() const override { return kPluginApiVersion; }

    void log(log::Severity severity, std::string_view message) override {
        std::string line;
        line.reserve(m_name.size() + 3 + message.size());
        line.append("[").append(m_name).append("] ").append(message);
        log::write(severity, line);
    }

    bool addSystem(std::string_view name, ecs::System system) override {
        if (!m_host.m_schedule) {
            log::error("plugin '{}': cannot add system '{}': the host has no schedule", m_name, name);
            return false;
        }
        if (!m_host.m_schedule->add(std::string(name), std::move(system))) return false;  // logged
        m_systems.emplace_back(name);
        return true;
    }

    bool removeSystem(std::string_view name) override {
        auto it = std::find(m_systems.begin(), m_systems.end(), name);
        if (it == m_systems.end()) {
            log::error("plugin '{}': cannot remove system '{}': it was not added by this plugin", m_name,
                       name);
            return false;
        }
        m_systems.erase(it);
        return m_host.m_schedule && m_host.m_schedule->remove(name);
    }

    bool addFactory(std::string_view kind, std::string_view name, std::string_view signature,
                    std::shared_ptr<const void> factory) override {
        std::string error;
        if (!m_host.m_factories.add(kind, name, signature, std::move(factory), m_name, error)) {
            log::error("plugin '{}': {}", m_name, error);
            return false;
        }
        return true;
    }

    bool removeFactory(std::string_view kind, std::string_view name) override {
        const FactoryRegistry::Entry* entry = m_host.m_factories.findEntry(kind, name);
        if (!entry || entry->owner != m_name) {
            log::error("plugin '{}': cannot remove {} '{}': it was not registered by this plugin", m_name,
                       kind, name);
            return false;
        }
        return m_host.m_factories.remove(kind, name);
    }

    // Drops everything this plugin registered (before its code may go away).
    void removeAll() {
        if (m_host.m_schedule) {
            for (const std::string& system : m_systems) m_host.m_schedule->remove(system);
        }
        m_systems.clear();
        m_host.m_factories.removeOwner(m_name);
    }

private:
    PluginHost& m_host;
    std::string m_name;
    std::vector<std::string> m_systems;
};

// ---- PluginHost --------------------------------------------------------------------------------

struct PluginHost::Loaded {
    std::string name;
    std::string version;
    uint32_t apiVersion = 0;
    std::string path;
    void* library = nullptr;
    void (*destroy)(IPlugin*) = nullptr;
    IPlugin* instance = nullptr;
    std::unique_ptr<Context> context;
};

PluginHost::PluginHost(ecs::Schedule* schedule) : m_schedule(schedule) {}

PluginHost::~PluginHost() { unloadAll(); }

bool PluginHost::fail(std::string message) {
    log::error("{}", message);
    m_lastError = std::move(message);
    return false;
}

bool PluginHost::loadPlugin(const PenumbraPluginDescriptor& descriptor) {
    return instantiate(descriptor, nullptr, std::string());
}

bool PluginHost::loadStatic(std::string_view name) {
    for (const PenumbraPluginDescriptor* descriptor : staticList()) {
        if (name == descriptor->name) return instantiate(*descriptor, nullptr, std::string());
    }
    return fail(fmt::format("plugin '{}': no statically registered plugin has this name", name));
}

size_t PluginHost::loadStaticPlugins() {
    size_t loaded = 0;
    for (const PenumbraPluginDescriptor* descriptor : staticList()) {
        if (isLoaded(descriptor->name)) continue;
        if (instantiate(*descriptor, nullptr, std::string())) ++loaded;
    }
    return loaded;
}

bool PluginHost::instantiate(const PenumbraPluginDescriptor& descriptor, void* library,
                             const std::string& path) {
    // Messages start with the library (if any) and the plugin's name.
    const std::string prefix = path.empty() ? std::string() : fmt::format("plugin library '{}': ", path);
    if (!descriptor.name || !validPluginName(descriptor.name)) {
        return fail(
            fmt::format("{}plugin refused: the descriptor has no valid name ([A-Za-z0-9_.-], 1-128 "
                        "characters)",
                        prefix));
    }
    const std::string name = descriptor.name;
    auto refuse = [&](std::string_view reason) {
        return fail(fmt::format("{}plugin '{}' refused: {}", prefix, name, reason));
    };
    if (!isApiCompatible(kPluginApiVersion, descriptor.apiVersion)) {
        return refuse(
            fmt::format("built for plugin API {}, this host provides API {} (the major versions must "
                        "match and the host's minor must be at least the plugin's)",
                        formatApiVersion(descriptor.apiVersion), formatApiVersion(kPluginApiVersion)));
    }
    if (!descriptor.create || !descriptor.destroy)
        return refuse("the descriptor lacks a create or destroy function");
    if (isLoaded(name)) return refuse("a plugin with this name is already loaded");

    IPlugin* instance = nullptr;
    try {
        instance = descriptor.create();
    } catch (...) {
        instance = nullptr;
    }
    if (!instance) return refuse("create() failed");

    const char* reportedName = instance->name();
    if (!reportedName || name != reportedName) {
        const std::string reported = reportedName ? reportedName : "(null)";
        descriptor.destroy(instance);
        return refuse(fmt::format("its IPlugin::name() returns '{}'", reported));
    }

    auto loaded = std::make_unique<Loaded>();
    loaded->name = name;
    const char* version = instance->version();
    loaded->version = version ? version : "";
    loaded->apiVersion = descriptor.apiVersion;
    loaded->path = path;
    loaded->library = library;
    loaded->destroy = descriptor.destroy;
    loaded->instance = instance;
    loaded->context = std::make_unique<Context>(*this, name);

    bool ok = false;
    bool threw = false;
    try {
        ok = instance->onLoad(*loaded->context);
    } catch (...) {
        threw = true;
    }
    if (!ok) {
        loaded->context->removeAll();
        loaded->destroy(loaded->instance);
        return refuse(threw ? "onLoad() threw an exception" : "onLoad() reported failure");
    }
    if (path.empty()) {
        log::info("loaded plugin '{}' {} (API {})", name, loaded->version,
                  formatApiVersion(descriptor.apiVersion));
    } else {
        log::info("loaded plugin '{}' {} (API {}) from '{}'", name, loaded->version,
                  formatApiVersion(descriptor.apiVersion), path);
    }
    m_plugins.push_back(std::move(loaded));
    return true;
}

bool PluginHost::loadLibrary(const std::string& path) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (ec || !std::filesystem::exists(status)) {
        return fail(fmt::format("plugin library '{}': refused: no such file", path));
    }
    if (!std::filesystem::is_regular_file(status)) {
        return fail(fmt::format("plugin library '{}': refused: not a regular file", path));
    }

    // A name without a slash would make dlopen search the library path instead of opening the file.
    const std::string openPath = path.find('/') == std::string::npos ? "./" + path : path;
    dlerror();
    void* library = dlopen(openPath.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!library) {
        return fail(fmt::format("plugin library '{}': refused: dlopen failed: {}", path, dlerrorText()));
    }

    dlerror();
    void* symbol = dlsym(library, PENUMBRA_PLUGIN_ENTRY_NAME);
    if (!symbol) {
        const std::string reason = dlerrorText();
        dlclose(library);
        return fail(fmt::format(
            "plugin library '{}': refused: not a penumbra plugin: entry point '{}' not found ({})", path,
            PENUMBRA_PLUGIN_ENTRY_NAME, reason));
    }
    auto entry = reinterpret_cast<PenumbraPluginEntryFn>(symbol);
    const PenumbraPluginDescriptor* descriptor = nullptr;
    try {
        descriptor = entry();
    } catch (...) {
        descriptor = nullptr;
    }
    if (!descriptor) {
        dlclose(library);
        return fail(fmt::format("plugin library '{}': refused: '{}' returned no descriptor", path,
                                PENUMBRA_PLUGIN_ENTRY_NAME));
    }
    if (!instantiate(*descriptor, library, path)) {
        dlclose(library);
        return false;
    }
    return true;
}

DirectoryLoadResult PluginHost::loadDirectory(const std::string& dir) {
    DirectoryLoadResult result;
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) {
        fail(fmt::format("plugin directory '{}': not a readable directory", dir));
        ++result.failed;
        return result;
    }
    std::vector<std::string> files;
    for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        std::error_code fileError;
        if (it->path().extension() == ".so" && it->is_regular_file(fileError))
            files.push_back(it->path().string());
    }
    if (ec) {
        fail(fmt::format("plugin directory '{}': cannot list it: {}", dir, ec.message()));
        ++result.failed;
        return result;
    }
    std::sort(files.begin(), files.end());
    for (const std::string& file : files) {
        if (loadLibrary(file)) {
            ++result.loaded;
        } else {
            ++result.failed;
        }
    }
    return result;
}

void PluginHost::release(Loaded& plugin) {
    try {
        plugin.instance->onUnload();
    } catch (...) {
        log::error("plugin '{}': onUnload() threw an exception", plugin.name);
    }
    plugin.context->removeAll();
    plugin.destroy(plugin.instance);
    plugin.instance = nullptr;
    if (plugin.library && dlclose(plugin.library) != 0) {
        log::warn("plugin '{}': dlclose failed: {}", plugin.name, dlerrorText());
    }
    plugin.library = nullptr;
    log::info("unloaded plugin '{}'", plugin.name);
}

bool PluginHost::unload(std::string_view name) {
    auto it =
        std::find_if(m_plugins.begin(), m_plugins.end(), [&](const auto& p) { return p->name == name; });
    if (it == m_plugins.end()) return fail(fmt::format("plugin '{}': cannot unload: not loaded", name));
    std::unique_ptr<Loaded> plugin = std::move(*it);
    m_plugins.erase(it);
    release(*plugin);
    return true;
}

void PluginHost::unloadAll() {
    while (!m_plugins.empty()) {
        std::unique_ptr<Loaded> plugin = std::move(m_plugins.back());
        m_plugins.pop_back();
        release(*plugin);
    }
}

bool PluginHost::isLoaded(std::string_view name) const {
    return std::any_of(m_plugins.begin(), m_plugins.end(), [&](const auto& p) { return p->name == name; });
}

std::vector<PluginInfo> PluginHost::plugins() const {
    std::vector<PluginInfo> out;
    out.reserve(m_plugins.size());
    for (const auto& p : m_plugins) out.push_back({p->name, p->version, p->apiVersion, p->path});
    return out;
}

const MeshImporter* PluginHost::findMeshImporter(std::string_view extension) const {
    return m_factories.find<MeshImporterFn>(kMeshImporterKind, normalizeExtension(extension));
}

std::vector<std::string> PluginHost::meshImporterExtensions() const {
    return m_factories.names(kMeshImporterKind);
}

bool PluginHost::importMesh(const std::string& path, assets::MeshData& out, std::string& error) const {
    out = assets::MeshData{};
    const std::string extension = pathExtension(path);
    const MeshImporter* importer = extension.empty() ? nullptr : findMeshImporter(extension);
    if (!importer) {
        const std::vector<std::string> known = meshImporterExtensions();
        error = fmt::format("{}: no mesh importer for extension '{}' (importers: {})", path, extension,
                            known.empty() ? std::string("none") : fmt::format("{}", fmt::join(known, ", ")));
        return false;
    }
    bool ok = false;
    try {
        ok = (*importer)(path, out, error);
    } catch (...) {
        ok = false;
        error = fmt::format("{}: the '{}' importer threw an exception", path, extension);
    }
    if (ok) ok = checkImportedMesh(path, out, error);
    if (!ok) {
        if (error.empty())
            error = fmt::format("{}: the '{}' importer failed without a message", path, extension);
        out = assets::MeshData{};
        return false;
    }
    if (out.sourcePath.empty()) out.sourcePath = path;
    return true;
}

}  // namespace penumbra::plugin
