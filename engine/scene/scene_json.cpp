// The JSON scene format, versions 1 and 2 (docs/FORMATS.md, "Scene JSON"). Version 2 adds the `sdf`
// component (analytic shapes compiled to shape programs, .psdf fields, meshes to bake).
//
// Reading happens in three steps, each refusing bad input with "<file>: <json pointer>: <reason>":
//  1. a scan of the raw text for the nesting depth (brackets outside strings), before any parsing;
//  2. nlohmann's SAX parser driving our own DOM builder, which knows the JSON pointer of every value
//     it is given, so syntax errors, duplicate keys and numbers overflowing a double (1e999) are
//     reported with the pointer where they occur;
//  3. a strict schema walk: every object lists the keys it accepts (anything else is an error), every
//     value is type- and range-checked, and the scene is built into a local Scene that only replaces
//     the caller's on success (every asset reference taken on the way is released on failure).
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <filesystem>
#include <initializer_list>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "engine/assets/mesh_internal.h"
#include "engine/assets/primitives.h"
#include "engine/core/json_depth.h"
#include "engine/core/log.h"
#include "engine/scene/mesh_sdf.h"
#include "engine/scene/scene.h"
#include "engine/sdf/shape_program.h"

namespace penumbra::scene {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr uint32_t kMaxRenderDimension = 16384;
constexpr uint32_t kMinBakeResolution = 8;
constexpr uint32_t kMaxBakeResolution = 1024;
constexpr uint32_t kMaxSdfSteps = 10000;

// RFC 6901: '~' -> "~0", '/' -> "~1".
std::string pointerToken(std::string_view key) {
    std::string out;
    out.reserve(key.size());
    for (char c : key) {
        if (c == '~') {
            out += "~0";
        } else if (c == '/') {
            out += "~1";
        } else {
            out += c;
        }
    }
    return out;
}

std::string child(const std::string& ptr, std::string_view key) {
    std::string out = ptr;
    out += '/';
    out += pointerToken(key);
    return out;
}

std::string child(const std::string& ptr, size_t index) {
    std::string out = ptr;
    out += '/';
    out += std::to_string(index);
    return out;
}

// 1-based line and column of byte `offset` in `text`.
void lineColumn(std::string_view text, size_t offset, size_t& line, size_t& column) {
    line = 1;
    column = 1;
    const size_t end = std::min(offset, text.size());
    for (size_t i = 0; i < end; ++i) {
        if (text[i] == '\n') {
            ++line;
            column = 1;
        } else {
            ++column;
        }
    }
}

// Step 2: builds the DOM from nlohmann's SAX events, tracking the JSON pointer of the value being
// parsed. Rejects duplicate keys (nlohmann would silently keep the last one).
class DomBuilder {
public:
    explicit DomBuilder(std::string_view text) : m_text(text) {}

    json root;
    std::string errorPointer;
    std::string errorReason;

    bool null() { return value(json(nullptr)); }
    bool boolean(bool v) { return value(json(v)); }
    bool number_integer(json::number_integer_t v) { return value(json(v)); }
    bool number_unsigned(json::number_unsigned_t v) { return value(json(v)); }
    bool number_float(json::number_float_t v, const json::string_t&) { return value(json(v)); }
    bool string(json::string_t& v) { return value(json(std::move(v))); }
    bool binary(json::binary_t&) {
        errorPointer = pointer();
        errorReason = "binary values are not JSON";
        return false;
    }
    bool start_object(std::size_t) { return open(json::object(), true); }
    bool start_array(std::size_t) { return open(json::array(), false); }
    bool end_object() { return close(); }
    bool end_array() { return close(); }
    bool key(json::string_t& k) {
        Frame& f = m_stack.back();
        if (f.value->contains(k)) {
            f.key = k;
            f.hasKey = true;
            errorPointer = pointer();
            errorReason = fmt::format("duplicate key '{}' (each key may appear once per object)", k);
            return false;
        }
        f.key = std::move(k);
        f.hasKey = true;
        return true;
    }
    bool parse_error(std::size_t position, const std::string& lastToken,
                     const nlohmann::detail::exception& ex) {
        errorPointer = pointer();
        size_t line = 0, column = 0;
        lineColumn(m_text, position > 0 ? position - 1 : 0, line, column);
        if (ex.id == 406) {
            errorReason =
                fmt::format("number '{}' at line {}, column {} is out of range (not a finite number)",
                            lastToken, line, column);
            return false;
        }
        // nlohmann's text: "[json.exception.parse_error.101] parse error at line L, column C: <why>".
        std::string why = ex.what();
        const size_t col = why.find("column ");
        const size_t colon = col == std::string::npos ? std::string::npos : why.find(": ", col);
        if (colon != std::string::npos) {
            why = why.substr(colon + 2);
        } else if (const size_t bracket = why.find("] "); bracket != std::string::npos) {
            why = why.substr(bracket + 2);
        }
        errorReason = fmt::format("JSON syntax error at line {}, column {}: {}", line, column, why);
        return false;
    }

private:
    struct Frame {
        json* value = nullptr;
        bool object = false;
        bool hasKey = false;
        size_t index = 0;
        std::string key;
    };

    // Pointer of the value being parsed.
    std::string pointer() const {
        std::string out;
        for (const Frame& f : m_stack) {
            if (f.object) {
                if (!f.hasKey) break;
                out = child(out, f.key);
            } else {
                out = child(out, f.index);
            }
        }
        return out;
    }

    json* insert(json v) {
        if (m_stack.empty()) {
            root = std::move(v);
            return &root;
        }
        Frame& f = m_stack.back();
        if (f.object) {
            json& slot = (*f.value)[f.key];
            slot = std::move(v);
            return &slot;
        }
        f.value->push_back(std::move(v));
        return &f.value->back();
    }
    // A value of the innermost container is complete.
    void finished() {
        if (m_stack.empty()) return;
        Frame& f = m_stack.back();
        if (f.object) {
            f.hasKey = false;
        } else {
            ++f.index;
        }
    }
    bool value(json v) {
        insert(std::move(v));
        finished();
        return true;
    }
    bool open(json v, bool object) {
        json* slot = insert(std::move(v));
        m_stack.push_back(Frame{slot, object, false, 0, {}});
        return true;
    }
    bool close() {
        m_stack.pop_back();
        finished();
        return true;
    }

    std::string_view m_text;
    std::vector<Frame> m_stack;
};

const char* typeName(const json& v) {
    switch (v.type()) {
        case json::value_t::object:
            return "an object";
        case json::value_t::array:
            return "an array";
        case json::value_t::string:
            return "a string";
        case json::value_t::boolean:
            return "a boolean";
        case json::value_t::null:
            return "null";
        case json::value_t::number_integer:
        case json::value_t::number_unsigned:
        case json::value_t::number_float:
            return "a number";
        default:
            return "an unsupported value";
    }
}

std::string joinKeys(std::initializer_list<std::string_view> keys) {
    std::string out;
    for (std::string_view k : keys) {
        if (!out.empty()) out += ", ";
        out += k;
    }
    return out;
}

std::string lightTypeName(ecs::LightType t) {
    switch (t) {
        case ecs::LightType::Directional:
            return "directional";
        case ecs::LightType::Point:
            return "point";
        case ecs::LightType::Sphere:
            return "sphere";
    }
    return "unknown";
}

// A material's asset key: its content, so identical materials share one asset and two scenes that
// give different materials the same name never collide.
std::string materialKey(const ecs::Material& m) {
    return fmt::format("scene-material:bc={},{},{},{}:m={}:r={}:e={},{},{}:tex={:x},{:x},{:x},{:x},{:x}",
                       m.baseColor.r, m.baseColor.g, m.baseColor.b, m.baseColor.a, m.metallic, m.roughness,
                       m.emissive.r, m.emissive.g, m.emissive.b, m.baseColorTexture,
                       m.metallicRoughnessTexture, m.normalTexture, m.occlusionTexture, m.emissiveTexture);
}

// Step 3: the schema walk.
class SceneParser {
public:
    SceneParser(const std::string& name, const std::string& baseDir, assets::AssetManager& assets,
                const SceneLoadLimits& limits, Scene& scene, std::string& error)
        : m_name(name),
          m_baseDir(baseDir),
          m_assets(assets),
          m_limits(limits),
          m_scene(scene),
          m_error(error) {}

    bool run(const json& root);

private:
    struct EntityRecord {
        ecs::Entity entity;
        std::string parent;  // empty: none
        bool hasParent = false;
    };

    bool fail(const std::string& ptr, std::string_view reason) {
        m_error = m_name;
        m_error += ": ";
        if (!ptr.empty()) {
            m_error += ptr;
            m_error += ": ";
        }
        m_error += reason;
        return false;
    }

    // ---- generic value readers (false after fail()) --------------------------------------------
    bool checkKeys(const json& obj, const std::string& ptr, std::initializer_list<std::string_view> allowed,
                   std::string_view what = {}) {
        for (const auto& item : obj.items()) {
            if (std::find(allowed.begin(), allowed.end(), item.key()) == allowed.end()) {
                return fail(child(ptr, item.key()),
                            fmt::format("unknown key '{}'{}{} (expected one of: {})", item.key(),
                                        what.empty() ? "" : " in ", what, joinKeys(allowed)));
            }
        }
        return true;
    }
    bool object(const json& v, const std::string& ptr) {
        return v.is_object() || fail(ptr, fmt::format("expected an object, got {}", typeName(v)));
    }
    bool string(const json& v, const std::string& ptr, std::string& out) {
        if (!v.is_string()) return fail(ptr, fmt::format("expected a string, got {}", typeName(v)));
        out = v.get<std::string>();
        return true;
    }
    bool nonEmptyString(const json& v, const std::string& ptr, std::string& out) {
        if (!string(v, ptr, out)) return false;
        return !out.empty() || fail(ptr, "must not be empty");
    }
    bool boolean(const json& v, const std::string& ptr, bool& out) {
        if (!v.is_boolean()) return fail(ptr, fmt::format("expected true or false, got {}", typeName(v)));
        out = v.get<bool>();
        return true;
    }
    bool number(const json& v, const std::string& ptr, float& out) {
        if (!v.is_number()) return fail(ptr, fmt::format("expected a number, got {}", typeName(v)));
        const double d = v.get<double>();
        if (!std::isfinite(d)) return fail(ptr, "not a finite number");
        if (std::abs(d) > double(FLT_MAX)) {
            return fail(ptr, fmt::format("{} is out of range for a 32-bit float", d));
        }
        out = float(d);
        return true;
    }
    bool integer(const json& v, const std::string& ptr, int64_t lo, int64_t hi, int64_t& out) {
        if (v.is_number_float()) {
            return fail(ptr, fmt::format("expected an integer, got {}", v.dump()));
        }
        if (!v.is_number_integer()) return fail(ptr, fmt::format("expected an integer, got {}", typeName(v)));
        if (v.is_number_unsigned() && v.get<uint64_t>() > uint64_t(INT64_MAX)) {
            return fail(ptr, fmt::format("{} is out of range [{}, {}]", v.get<uint64_t>(), lo, hi));
        }
        out = v.get<int64_t>();
        if (out < lo || out > hi) return fail(ptr, fmt::format("{} is out of range [{}, {}]", out, lo, hi));
        return true;
    }
    bool count(const json& v, const std::string& ptr, uint32_t lo, uint32_t hi, uint32_t& out) {
        int64_t i = 0;
        if (!integer(v, ptr, lo, hi, i)) return false;
        out = uint32_t(i);
        return true;
    }
    // A fixed-length array of numbers.
    bool numbers(const json& v, const std::string& ptr, size_t n, float* out) {
        if (!v.is_array() || v.size() != n) {
            return fail(ptr,
                        v.is_array()
                            ? fmt::format("expected an array of {} numbers, got {} elements", n, v.size())
                            : fmt::format("expected an array of {} numbers, got {}", n, typeName(v)));
        }
        for (size_t i = 0; i < n; ++i) {
            if (!number(v[i], child(ptr, i), out[i])) return false;
        }
        return true;
    }
    bool vec3(const json& v, const std::string& ptr, glm::vec3& out) { return numbers(v, ptr, 3, &out.x); }
    bool color(const json& v, const std::string& ptr, glm::vec3& out) {
        if (!vec3(v, ptr, out)) return false;
        for (int i = 0; i < 3; ++i) {
            if (out[i] < 0.0f)
                return fail(child(ptr, size_t(i)), fmt::format("colour component {} is negative", out[i]));
        }
        return true;
    }
    bool inRange(const std::string& ptr, float value, float lo, float hi, bool loOpen, bool hiOpen) {
        const bool ok = (loOpen ? value > lo : value >= lo) && (hiOpen ? value < hi : value <= hi);
        if (ok) return true;
        return fail(ptr, fmt::format("{} is out of range {}{}, {}{}", value, loOpen ? '(' : '[', lo, hi,
                                     hiOpen ? ')' : ']'));
    }
    bool positive(const std::string& ptr, float value, std::string_view what) {
        return value > 0.0f || fail(ptr, fmt::format("{} must be > 0 (got {})", what, value));
    }
    bool nonNegative(const std::string& ptr, float value, std::string_view what) {
        return value >= 0.0f || fail(ptr, fmt::format("{} must be >= 0 (got {})", what, value));
    }

    // ---- paths ---------------------------------------------------------------------------------
    std::string resolve(const std::string& relative) const {
        fs::path p(relative);
        if (p.is_relative()) p = fs::path(m_baseDir) / p;
        return p.lexically_normal().string();
    }
    // Resolves a referenced file and checks that it exists and is not a directory.
    bool existingFile(const std::string& ptr, const std::string& relative, std::string_view what,
                      std::string& path) {
        if (relative.empty()) return fail(ptr, fmt::format("empty {} path", what));
        path = resolve(relative);
        std::error_code ec;
        const fs::file_status st = fs::status(path, ec);
        if (ec || !fs::exists(st)) {
            std::string reason = fmt::format("{} '{}' not found (resolved to '{}')", what, relative, path);
            if (path.find("data/meshes/") != std::string::npos) {
                reason += "; the npm meshes under data/meshes are fetched by tools/fetch_meshes.sh";
            }
            return fail(ptr, reason);
        }
        if (fs::is_directory(st)) {
            return fail(ptr, fmt::format("{} '{}' is a directory, not a file (resolved to '{}')", what,
                                         relative, path));
        }
        return true;
    }

    void hold(assets::AssetId id) { m_scene.assetRefs.push_back(id); }

    // ---- sections ------------------------------------------------------------------------------
    bool parseVersion(const json& root);
    bool parseRender(const json& v, const std::string& ptr);
    bool parseShadows(const json& v, const std::string& ptr, ShadowSettings& out);
    bool parseAo(const json& v, const std::string& ptr, AoSettings& out);
    bool parseReflections(const json& v, const std::string& ptr, ReflectionSettings& out);
    bool parseAcceleration(const json& v, const std::string& ptr, AccelerationSettings& out);
    bool parseMotionBlur(const json& v, const std::string& ptr, MotionBlurSettings& out);
    bool parseTraceOverrides(const json& v, const std::string& ptr, TraceOverrides& out);
    bool parseMaterials(const json& v, const std::string& ptr);
    bool parseMaterial(const json& v, const std::string& ptr, ecs::Material& out);
    bool loadTexture(const json& v, const std::string& ptr, bool srgb, assets::AssetId& out);
    bool parseEntity(const json& v, const std::string& ptr, size_t index);
    bool parseTransform(const json& v, const std::string& ptr, ecs::Transform& t);
    bool parseMesh(const json& v, const std::string& ptr, ecs::MeshRenderer& out);
    bool parsePrimitive(const json& v, const std::string& ptr, assets::AssetId& out);
    bool parseMaterialRef(const json& v, const std::string& ptr, assets::AssetId& out);
    bool parseSdf(const json& v, const std::string& ptr, ecs::SdfRenderer& out);
    bool parseShapeNode(const json& v, const std::string& ptr, bool leaf, sdf::ShapeNode& out);
    bool parseShapeLeaf(const json& v, const std::string& ptr, sdf::ShapeNode& out);
    bool parseShapes(const json& v, const std::string& ptr, bool leaf, assets::AssetId& out);
    bool parseCamera(const json& v, const std::string& ptr, ecs::Camera& out);
    bool parseLight(const json& v, const std::string& ptr, ecs::Light& out);
    bool parseSpin(const json& v, const std::string& ptr, Spin& out);
    bool resolveParents();

    const std::string& m_name;
    const std::string& m_baseDir;
    assets::AssetManager& m_assets;
    const SceneLoadLimits& m_limits;
    Scene& m_scene;
    std::string& m_error;

    struct NamedMaterial {
        ecs::Material material;
    };
    std::unordered_map<std::string, NamedMaterial> m_materials;
    std::unordered_map<std::string, size_t> m_entityByName;
    std::vector<EntityRecord> m_entities;
    bool m_hasRenderCamera = false;
    int64_t m_version = kSceneFormatVersion;
};

bool SceneParser::run(const json& root) {
    if (!root.is_object()) {
        return fail(
            "", fmt::format("a scene file must be a JSON object at the top level, got {}", typeName(root)));
    }
    if (!parseVersion(root)) return false;
    if (!checkKeys(root, "", {"version", "description", "render", "materials", "entities"}, "the scene")) {
        return false;
    }
    if (auto it = root.find("description"); it != root.end()) {
        std::string unused;
        if (!string(*it, "/description", unused)) return false;
    }
    if (auto it = root.find("render"); it != root.end()) {
        if (!parseRender(*it, "/render")) return false;
    }
    if (auto it = root.find("materials"); it != root.end()) {
        if (!parseMaterials(*it, "/materials")) return false;
    }
    if (auto it = root.find("entities"); it != root.end()) {
        const json& entities = *it;
        if (!entities.is_array()) {
            return fail("/entities",
                        fmt::format("expected an array of entities, got {}", typeName(entities)));
        }
        if (entities.size() > m_limits.maxEntities) {
            return fail("/entities", fmt::format("{} entities exceed the limit of {}", entities.size(),
                                                 m_limits.maxEntities));
        }
        m_entities.reserve(entities.size());
        m_scene.world.reserveEntities(entities.size());
        for (size_t i = 0; i < entities.size(); ++i) {
            if (!parseEntity(entities[i], child("/entities", i), i)) return false;
        }
        if (!resolveParents()) return false;
    }
    if (m_hasRenderCamera && findCamera(m_scene.world, m_scene.settings.camera).isNull()) {
        std::string names;
        for (auto [e, cam] : std::as_const(m_scene.world).view<ecs::Camera>()) {
            const ecs::Name* n = m_scene.world.get<ecs::Name>(e);
            const std::string& label = !cam.name.empty() ? cam.name : (n ? n->value : std::string());
            if (label.empty()) continue;
            if (!names.empty()) names += ", ";
            names += label;
        }
        return fail("/render/camera", fmt::format("no camera named '{}' (named cameras in this scene: {})",
                                                  m_scene.settings.camera, names.empty() ? "none" : names));
    }
    ecs::updateTransforms(m_scene.world);
    return true;
}

bool SceneParser::parseVersion(const json& root) {
    auto it = root.find("version");
    if (it == root.end()) {
        return fail("/version", fmt::format("missing (every scene file starts with \"version\": {})",
                                            kSceneFormatVersion));
    }
    int64_t version = 0;
    if (!integer(*it, "/version", INT64_MIN, INT64_MAX, version)) return false;
    if (version > kSceneFormatVersion) {
        return fail("/version",
                    fmt::format("scene format version {} is newer than this build supports (version {}); "
                                "update penumbra to read it",
                                version, kSceneFormatVersion));
    }
    if (version < kMinSceneFormatVersion) {
        return fail("/version", fmt::format("unsupported scene format version {} (expected {} to {})",
                                            version, kMinSceneFormatVersion, kSceneFormatVersion));
    }
    m_version = version;
    return true;
}

bool SceneParser::parseRender(const json& v, const std::string& ptr) {
    if (!object(v, ptr) ||
        !checkKeys(v, ptr, {"width",        "height",     "shading", "toneMapper", "exposure",    "ambient",
                            "ambientSky",   "background", "camera",  "fixedDt",    "quality",     "trace",
                            "debugView",    "slice",      "shadows", "ao",         "reflections", "meshSdf",
                            "acceleration", "traceMode",  "taa",     "motionBlur"},
                   "render settings")) {
        return false;
    }
    RenderSettings& s = m_scene.settings;
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        const json& value = item.value();
        const std::string p = child(ptr, key);
        if (key == "width" || key == "height") {
            uint32_t n = 0;
            if (!count(value, p, 1, kMaxRenderDimension, n)) return false;
            (key == "width" ? s.width : s.height) = n;
        } else if (key == "shading") {
            std::string name;
            if (!string(value, p, name)) return false;
            if (!parseShadingModel(name, s.shading)) {
                return fail(
                    p,
                    fmt::format("unknown shading model '{}' (expected cook-torrance or blinn-phong)", name));
            }
        } else if (key == "toneMapper") {
            std::string name;
            if (!string(value, p, name)) return false;
            if (!parseToneMapper(name, s.toneMapper)) {
                return fail(p,
                            fmt::format("unknown tone mapper '{}' (expected clamp, reinhard or aces)", name));
            }
        } else if (key == "exposure") {
            if (!number(value, p, s.exposure) || !positive(p, s.exposure, "exposure")) return false;
        } else if (key == "ambient") {
            if (!color(value, p, s.ambient)) return false;
        } else if (key == "ambientSky") {
            glm::vec3 sky(0.0f);
            if (!color(value, p, sky)) return false;
            s.ambientSky = sky;
        } else if (key == "background") {
            if (!color(value, p, s.background)) return false;
        } else if (key == "camera") {
            if (!nonEmptyString(value, p, s.camera)) return false;
            m_hasRenderCamera = true;
        } else if (key == "fixedDt") {
            float dt = 0.0f;
            if (!number(value, p, dt) || !inRange(p, dt, 0.0f, 1.0f, true, false)) return false;
            s.fixedDt = value.get<double>();
        } else if (key == "quality") {
            std::string name;
            if (!string(value, p, name)) return false;
            if (!parseTraceQuality(name, s.quality)) {
                return fail(
                    p, fmt::format("unknown quality '{}' (expected low, medium, high or reference)", name));
            }
        } else if (key == "trace") {
            if (!parseTraceOverrides(value, p, s.trace)) return false;
        } else if (key == "debugView") {
            std::string name;
            if (!string(value, p, name)) return false;
            if (!parseDebugView(name, s.debugView)) {
                return fail(
                    p, fmt::format("unknown debug view '{}' (expected none, normals, depth, albedo, "
                                   "steps, ids, field-slice, ao, shadow, bentnormal, thickness or tiles)",
                                   name));
            }
        } else if (key == "shadows") {
            if (!parseShadows(value, p, s.shadows)) return false;
        } else if (key == "ao") {
            if (!parseAo(value, p, s.ao)) return false;
        } else if (key == "reflections") {
            if (!parseReflections(value, p, s.reflections)) return false;
        } else if (key == "acceleration") {
            if (!parseAcceleration(value, p, s.acceleration)) return false;
        } else if (key == "traceMode") {
            std::string name;
            if (!string(value, p, name)) return false;
            if (!parseTraceMode(name, s.traceMode))
                return fail(p,
                            fmt::format("unknown traceMode '{}' (expected fullscreen, box or auto)", name));
        } else if (key == "taa") {
            if (!boolean(value, p, s.taa)) return false;
        } else if (key == "motionBlur") {
            if (!parseMotionBlur(value, p, s.motionBlur)) return false;
        } else if (key == "meshSdf") {
            std::string name;
            if (!string(value, p, name)) return false;
            if (!parseMeshSdfMode(name, s.meshSdf)) {
                return fail(
                    p,
                    fmt::format("unknown meshSdf mode '{}' (expected off, trace, occlusion or auto)", name));
            }
        } else if (key == "slice") {
            // The field-slice plane: {"normal": [x, y, z], "offset": d} is dot(normal / |normal|, p) = d.
            glm::vec3 n(0.0f);
            float offset = 0.0f;
            if (!object(value, p) || !checkKeys(value, p, {"normal", "offset"}, "slice plane")) return false;
            auto it = value.find("normal");
            if (it == value.end()) return fail(p, "missing \"normal\"");
            if (!vec3(*it, child(p, "normal"), n)) return false;
            if (!(glm::length(n) > 1e-20f)) return fail(child(p, "normal"), "the normal is zero");
            if (auto o = value.find("offset"); o != value.end() && !number(*o, child(p, "offset"), offset))
                return false;
            s.slice = glm::vec4(glm::normalize(n), offset);
        }
    }
    return true;
}

// The render block's "shadows" object (docs/FORMATS.md).
bool SceneParser::parseShadows(const json& v, const std::string& ptr, ShadowSettings& out) {
    if (!object(v, ptr) ||
        !checkKeys(v, ptr, {"enabled", "hard", "resolutionScale", "maxSteps"}, "shadow settings"))
        return false;
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        const std::string p = child(ptr, key);
        if (key == "enabled" || key == "hard") {
            if (!boolean(item.value(), p, key == "enabled" ? out.enabled : out.hard)) return false;
        } else if (key == "resolutionScale") {
            if (!number(item.value(), p, out.resolutionScale) ||
                !inRange(p, out.resolutionScale, 0.0f, 1.0f, true, false))
                return false;
        } else if (!count(item.value(), p, 1, kMaxSdfSteps, out.maxSteps)) {
            return false;
        }
    }
    return true;
}

// The render block's "ao" object (docs/FORMATS.md).
bool SceneParser::parseAo(const json& v, const std::string& ptr, AoSettings& out) {
    if (!object(v, ptr) ||
        !checkKeys(v, ptr, {"variant", "maxDistance", "strength", "resolutionScale", "rays"},
                   "ambient occlusion settings"))
        return false;
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        const std::string p = child(ptr, key);
        if (key == "variant") {
            std::string name;
            if (!string(item.value(), p, name)) return false;
            if (!parseAoVariant(name, out.variant))
                return fail(
                    p, fmt::format("unknown AO variant '{}' (expected off, five-tap, multi-ray or cones)",
                                   name));
        } else if (key == "maxDistance") {
            if (!number(item.value(), p, out.maxDistance) ||
                !inRange(p, out.maxDistance, 0.0f, 1e6f, true, false))
                return false;
        } else if (key == "strength") {
            if (!number(item.value(), p, out.strength) || !inRange(p, out.strength, 0.0f, 1.0f, false, false))
                return false;
        } else if (key == "resolutionScale") {
            if (!number(item.value(), p, out.resolutionScale) ||
                !inRange(p, out.resolutionScale, 0.0f, 1.0f, true, false))
                return false;
        } else if (!count(item.value(), p, 1, 4096, out.rays)) {
            return false;
        }
    }
    return true;
}

// The render block's "reflections" object (docs/FORMATS.md).
bool SceneParser::parseReflections(const json& v, const std::string& ptr, ReflectionSettings& out) {
    if (!object(v, ptr) || !checkKeys(v, ptr, {"roughnessCutoff", "maxSteps"}, "reflection settings"))
        return false;
    for (const auto& item : v.items()) {
        const std::string p = child(ptr, item.key());
        if (item.key() == "roughnessCutoff") {
            if (!number(item.value(), p, out.roughnessCutoff) ||
                !inRange(p, out.roughnessCutoff, 0.0f, 1.0f, false, false))
                return false;
        } else if (!count(item.value(), p, 1, kMaxSdfSteps, out.maxSteps)) {
            return false;
        }
    }
    return true;
}

// The render block's "acceleration" object (docs/FORMATS.md): the issue-13 toggles and the world
// cache's clipmap shape; each key is optional and replaces the default of AccelerationSettings.
bool SceneParser::parseAcceleration(const json& v, const std::string& ptr, AccelerationSettings& out) {
    if (!object(v, ptr) || !checkKeys(v, ptr,
                                      {"culling", "worldCache", "idField", "prepass", "cacheLevels",
                                       "cacheResolution", "cacheVoxel", "cacheBudgetVoxels"},
                                      "acceleration settings"))
        return false;
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        const std::string p = child(ptr, key);
        const json& value = item.value();
        if (key == "culling" || key == "worldCache" || key == "idField" || key == "prepass") {
            bool& flag = key == "culling"      ? out.culling
                         : key == "worldCache" ? out.worldCache
                         : key == "idField"    ? out.idField
                                               : out.prepass;
            if (!boolean(value, p, flag)) return false;
        } else if (key == "cacheLevels") {
            if (!count(value, p, 1, 8, out.cacheLevels)) return false;
        } else if (key == "cacheResolution") {
            // Multiples of 8: the cache's compute passes work on 8^3 bricks.
            if (!count(value, p, 16, 256, out.cacheResolution)) return false;
            if (out.cacheResolution % 8 != 0)
                return fail(p, fmt::format("{} is not a multiple of 8", out.cacheResolution));
        } else if (key == "cacheVoxel") {
            if (!number(value, p, out.cacheVoxel) || !nonNegative(p, out.cacheVoxel, "cacheVoxel"))
                return false;
        } else if (!count(value, p, 512, UINT32_MAX, out.cacheBudgetVoxels)) {
            return false;
        }
    }
    return true;
}

// The render block's "motionBlur": a boolean (enabled with the defaults) or an object.
bool SceneParser::parseMotionBlur(const json& v, const std::string& ptr, MotionBlurSettings& out) {
    if (v.is_boolean()) return boolean(v, ptr, out.enabled);
    if (!object(v, ptr) || !checkKeys(v, ptr, {"enabled", "strength", "samples"}, "motion blur settings"))
        return false;
    out.enabled = true;
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        const std::string p = child(ptr, key);
        if (key == "enabled") {
            if (!boolean(item.value(), p, out.enabled)) return false;
        } else if (key == "strength") {
            if (!number(item.value(), p, out.strength) || !inRange(p, out.strength, 0.0f, 4.0f, true, false))
                return false;
        } else if (!count(item.value(), p, 2, 32, out.samples)) {
            return false;
        }
    }
    return true;
}

// The render block's "trace" object: any of the trace settings, each over the quality preset.
bool SceneParser::parseTraceOverrides(const json& v, const std::string& ptr, TraceOverrides& out) {
    if (!object(v, ptr) || !checkKeys(v, ptr,
                                      {"maxSteps", "refineSteps", "hitEpsilon", "normalEpsilon",
                                       "overRelaxation", "fieldSafety"},
                                      "trace settings")) {
        return false;
    }
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        const std::string p = child(ptr, key);
        uint32_t n = 0;
        float x = 0.0f;
        if (key == "maxSteps") {
            if (!count(item.value(), p, 1, kMaxSdfSteps, n)) return false;
            out.maxSteps = n;
        } else if (key == "refineSteps") {
            if (!count(item.value(), p, 0, 64, n)) return false;
            out.refineSteps = n;
        } else if (key == "overRelaxation") {
            // Keinert et al.: omega in [1, 2); beyond, the fallback would trigger on every step.
            if (!number(item.value(), p, x) || !inRange(p, x, 1.0f, 2.0f, false, true)) return false;
            out.overRelaxation = x;
        } else if (key == "fieldSafety") {
            if (!number(item.value(), p, x) || !inRange(p, x, 0.0f, 1.0f, false, false)) return false;
            out.fieldSafety = x;
        } else {
            if (!number(item.value(), p, x) || !inRange(p, x, 0.0f, 100.0f, true, false)) return false;
            (key == "hitEpsilon" ? out.hitEpsilon : out.normalEpsilon) = x;
        }
    }
    return true;
}

bool SceneParser::parseMaterials(const json& v, const std::string& ptr) {
    if (!v.is_object()) {
        return fail(
            ptr, fmt::format("expected an object mapping material names to materials, got {}", typeName(v)));
    }
    if (v.size() > m_limits.maxMaterials) {
        return fail(ptr, fmt::format("{} materials exceed the limit of {}", v.size(), m_limits.maxMaterials));
    }
    for (const auto& item : v.items()) {
        const std::string p = child(ptr, item.key());
        if (item.key().empty()) return fail(p, "material names must not be empty");
        ecs::Material m;
        if (!parseMaterial(item.value(), p, m)) return false;
        m_materials.emplace(item.key(), NamedMaterial{m});
    }
    return true;
}

bool SceneParser::loadTexture(const json& v, const std::string& ptr, bool srgb, assets::AssetId& out) {
    std::string relative, path;
    if (!string(v, ptr, relative) || !existingFile(ptr, relative, "texture file", path)) return false;
    std::string err;
    const assets::AssetId id = m_assets.loadTexture(path, srgb, err);
    if (id == 0) return fail(ptr, err);
    hold(id);
    out = id;
    return true;
}

bool SceneParser::parseMaterial(const json& v, const std::string& ptr, ecs::Material& m) {
    if (!object(v, ptr) ||
        !checkKeys(v, ptr,
                   {"baseColor", "metallic", "roughness", "emissive", "baseColorTexture",
                    "metallicRoughnessTexture", "normalTexture", "occlusionTexture", "emissiveTexture",
                    "triplanarScale", "subsurface", "subsurfaceColor", "subsurfaceRadius", "reflections"},
                   "a material")) {
        return false;
    }
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        const json& value = item.value();
        const std::string p = child(ptr, key);
        if (key == "baseColor") {
            if (!value.is_array() || (value.size() != 3 && value.size() != 4)) {
                return fail(
                    p, value.is_array()
                           ? fmt::format("expected [r, g, b] or [r, g, b, a], got {} elements", value.size())
                           : fmt::format("expected [r, g, b] or [r, g, b, a], got {}", typeName(value)));
            }
            glm::vec4 c(1.0f);
            if (!numbers(value, p, value.size(), &c.x)) return false;
            for (size_t i = 0; i < value.size(); ++i) {
                if (!inRange(child(p, i), c[int(i)], 0.0f, 1.0f, false, false)) return false;
            }
            m.baseColor = c;
        } else if (key == "metallic") {
            if (!number(value, p, m.metallic) || !inRange(p, m.metallic, 0.0f, 1.0f, false, false))
                return false;
        } else if (key == "roughness") {
            if (!number(value, p, m.roughness) || !inRange(p, m.roughness, 0.0f, 1.0f, false, false))
                return false;
        } else if (key == "emissive") {
            if (!color(value, p, m.emissive)) return false;
        } else if (key == "baseColorTexture") {
            if (!loadTexture(value, p, true, m.baseColorTexture)) return false;
        } else if (key == "metallicRoughnessTexture") {
            if (!loadTexture(value, p, false, m.metallicRoughnessTexture)) return false;
        } else if (key == "normalTexture") {
            if (!loadTexture(value, p, false, m.normalTexture)) return false;
        } else if (key == "occlusionTexture") {
            if (!loadTexture(value, p, false, m.occlusionTexture)) return false;
        } else if (key == "emissiveTexture") {
            if (!loadTexture(value, p, true, m.emissiveTexture)) return false;
        } else if (key == "triplanarScale") {
            if (!number(value, p, m.triplanarScale) || !inRange(p, m.triplanarScale, 0.0f, 1e6f, true, false))
                return false;
        } else if (key == "subsurface") {
            if (!number(value, p, m.subsurface) || !inRange(p, m.subsurface, 0.0f, 1.0f, false, false))
                return false;
        } else if (key == "subsurfaceColor") {
            if (!color(value, p, m.subsurfaceColor)) return false;
        } else if (key == "subsurfaceRadius") {
            if (!number(value, p, m.subsurfaceRadius) ||
                !inRange(p, m.subsurfaceRadius, 0.0f, 1e6f, true, false))
                return false;
        } else if (key == "reflections") {
            if (!boolean(value, p, m.reflections)) return false;
        }
    }
    return true;
}

bool SceneParser::parseEntity(const json& v, const std::string& ptr, size_t index) {
    if (!object(v, ptr) ||
        !checkKeys(v, ptr, {"name", "parent", "transform", "mesh", "sdf", "camera", "light", "spin", "gltf"},
                   "an entity")) {
        return false;
    }
    ecs::World& world = m_scene.world;
    const ecs::Entity e = world.create();
    if (e.isNull()) return fail(ptr, "the world has no room for another entity");
    m_entities.push_back(EntityRecord{e, {}, false});
    ecs::Transform* transform = world.add<ecs::Transform>(e);

    std::string name;
    if (auto it = v.find("name"); it != v.end()) {
        const std::string p = child(ptr, "name");
        if (!nonEmptyString(*it, p, name)) return false;
        auto [where, inserted] = m_entityByName.emplace(name, index);
        if (!inserted) {
            return fail(p, fmt::format("duplicate entity name '{}' (also used by /entities/{})", name,
                                       where->second));
        }
        world.add<ecs::Name>(e, name);
    }
    if (auto it = v.find("parent"); it != v.end()) {
        if (!nonEmptyString(*it, child(ptr, "parent"), m_entities.back().parent)) return false;
        m_entities.back().hasParent = true;
    }
    if (auto it = v.find("transform"); it != v.end()) {
        ecs::Transform t;
        if (!parseTransform(*it, child(ptr, "transform"), t)) return false;
        *transform = t;
    }
    if (auto it = v.find("mesh"); it != v.end()) {
        ecs::MeshRenderer mr;
        if (!parseMesh(*it, child(ptr, "mesh"), mr)) return false;
        world.add<ecs::MeshRenderer>(e, mr);
    }
    if (auto it = v.find("sdf"); it != v.end()) {
        const std::string p = child(ptr, "sdf");
        if (m_version < 2) {
            return fail(
                p, fmt::format("the sdf component needs scene format version 2 (this file is version {})",
                               m_version));
        }
        ecs::SdfRenderer sr;
        if (!parseSdf(*it, p, sr)) return false;
        world.add<ecs::SdfRenderer>(e, std::move(sr));
    }
    if (auto it = v.find("camera"); it != v.end()) {
        ecs::Camera cam;
        if (!parseCamera(*it, child(ptr, "camera"), cam)) return false;
        cam.name = name;
        world.add<ecs::Camera>(e, std::move(cam));
    }
    if (auto it = v.find("light"); it != v.end()) {
        ecs::Light light;
        if (!parseLight(*it, child(ptr, "light"), light)) return false;
        world.add<ecs::Light>(e, light);
    }
    if (auto it = v.find("spin"); it != v.end()) {
        Spin spin;
        if (!parseSpin(*it, child(ptr, "spin"), spin)) return false;
        world.add<Spin>(e, spin);
    }
    if (auto it = v.find("gltf"); it != v.end()) {
        const std::string p = child(ptr, "gltf");
        std::string relative, path, err;
        if (!string(*it, p, relative) || !existingFile(p, relative, "glTF file", path)) return false;
        if (!assets::loadGltfScene(path, world, m_assets, m_scene.assetRefs, err, nullptr, e,
                                   m_limits.gltf)) {
            return fail(p, err);
        }
    }
    return true;
}

bool SceneParser::parseTransform(const json& v, const std::string& ptr, ecs::Transform& t) {
    if (!object(v, ptr) ||
        !checkKeys(v, ptr, {"position", "rotation", "eulerDegrees", "scale"}, "a transform")) {
        return false;
    }
    if (v.contains("rotation") && v.contains("eulerDegrees")) {
        return fail(child(ptr, "eulerDegrees"),
                    "give either \"rotation\" (a quaternion) or \"eulerDegrees\", not both");
    }
    if (auto it = v.find("position"); it != v.end()) {
        if (!vec3(*it, child(ptr, "position"), t.position)) return false;
    }
    if (auto it = v.find("rotation"); it != v.end()) {
        const std::string p = child(ptr, "rotation");
        float q[4] = {};
        if (!numbers(*it, p, 4, q)) return false;
        const double len =
            std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
        if (!(len > 1e-6) || !std::isfinite(len)) {
            return fail(p,
                        fmt::format("the quaternion [x, y, z, w] has length {} (it must be non-zero; it is "
                                    "normalised)",
                                    len));
        }
        t.rotation = glm::quat(float(q[3] / len), float(q[0] / len), float(q[1] / len), float(q[2] / len));
    }
    if (auto it = v.find("eulerDegrees"); it != v.end()) {
        glm::vec3 deg(0.0f);
        if (!vec3(*it, child(ptr, "eulerDegrees"), deg)) return false;
        const glm::vec3 rad = glm::radians(deg);
        // X first, then Y, then Z, about the parent's fixed axes.
        t.rotation = glm::normalize(glm::angleAxis(rad.z, glm::vec3(0, 0, 1)) *
                                    glm::angleAxis(rad.y, glm::vec3(0, 1, 0)) *
                                    glm::angleAxis(rad.x, glm::vec3(1, 0, 0)));
    }
    if (auto it = v.find("scale"); it != v.end()) {
        const std::string p = child(ptr, "scale");
        if (it->is_number()) {
            float s = 0.0f;
            if (!number(*it, p, s) || !positive(p, s, "scale")) return false;
            t.scale = glm::vec3(s);
        } else {
            if (!it->is_array()) {
                return fail(p,
                            fmt::format("expected a number or an array of 3 numbers, got {}", typeName(*it)));
            }
            if (!vec3(*it, p, t.scale)) return false;
            for (size_t i = 0; i < 3; ++i) {
                if (!positive(child(p, i), t.scale[int(i)], "scale")) return false;
            }
        }
    }
    return true;
}

bool SceneParser::parseMesh(const json& v, const std::string& ptr, ecs::MeshRenderer& out) {
    if (!object(v, ptr) ||
        !checkKeys(v, ptr, {"file", "primitive", "material", "castShadows", "visible"}, "a mesh")) {
        return false;
    }
    const bool hasFile = v.contains("file");
    const bool hasPrimitive = v.contains("primitive");
    if (hasFile == hasPrimitive) {
        return fail(ptr, hasFile
                             ? "give either \"file\" or \"primitive\", not both"
                             : "a mesh needs \"file\" (a mesh file) or \"primitive\" (a procedural shape)");
    }
    if (hasFile) {
        const std::string p = child(ptr, "file");
        std::string relative, path, err;
        if (!string(v["file"], p, relative) || !existingFile(p, relative, "mesh file", path)) return false;
        const assets::AssetId id = m_assets.loadMesh(path, err);
        if (id == 0) return fail(p, err);
        hold(id);
        out.mesh = id;
    } else {
        if (!parsePrimitive(v["primitive"], child(ptr, "primitive"), out.mesh)) return false;
    }
    if (auto it = v.find("material"); it != v.end()) {
        if (!parseMaterialRef(*it, child(ptr, "material"), out.material)) return false;
    }
    if (auto it = v.find("castShadows"); it != v.end()) {
        if (!boolean(*it, child(ptr, "castShadows"), out.castShadows)) return false;
    }
    if (auto it = v.find("visible"); it != v.end()) {
        if (!boolean(*it, child(ptr, "visible"), out.visible)) return false;
    }
    return true;
}

bool SceneParser::parseMaterialRef(const json& v, const std::string& p, assets::AssetId& out) {
    ecs::Material m;
    if (v.is_string()) {
        const std::string name = v.get<std::string>();
        auto found = m_materials.find(name);
        if (found == m_materials.end()) {
            return fail(p, fmt::format("unknown material '{}' (not defined in /materials)", name));
        }
        m = found->second.material;
    } else if (v.is_object()) {
        if (!parseMaterial(v, p, m)) return false;
    } else {
        return fail(p, fmt::format("expected a material name or a material object, got {}", typeName(v)));
    }
    out = m_assets.addMaterial(materialKey(m), m);
    if (out == 0) return fail(p, "the asset manager refused the material");
    hold(out);
    return true;
}

bool SceneParser::parseSdf(const json& v, const std::string& ptr, ecs::SdfRenderer& out) {
    if (!object(v, ptr) || !checkKeys(v, ptr,
                                      {"shape", "csg", "psdf", "mesh", "resolution", "material",
                                       "castShadows", "visible", "maxSteps", "shared"},
                                      "an sdf component")) {
        return false;
    }
    const char* sources[] = {"shape", "csg", "psdf", "mesh"};
    std::string given;
    for (const char* s : sources) {
        if (!v.contains(s)) continue;
        if (!given.empty()) {
            return fail(child(ptr, s), fmt::format("give one of \"shape\", \"csg\", \"psdf\" or \"mesh\" "
                                                   "(this component already has \"{}\")",
                                                   given));
        }
        given = s;
    }
    if (given.empty()) {
        return fail(ptr,
                    "an sdf component needs \"shape\" (one analytic shape), \"csg\" (a tree of "
                    "shapes), \"psdf\" (a .psdf file) or \"mesh\" (a mesh file to bake)");
    }
    if (v.contains("resolution") && given != "mesh") {
        return fail(child(ptr, "resolution"),
                    "\"resolution\" applies to \"mesh\" only (the bake resolution)");
    }
    const std::string p = child(ptr, given);
    if (given == "shape" || given == "csg") {
        out.source = ecs::SdfSource::Shapes;
        if (!parseShapes(v[given], p, given == "shape", out.sdf)) return false;
    } else if (given == "psdf") {
        std::string relative, path, err;
        if (!string(v[given], p, relative) || !existingFile(p, relative, ".psdf file", path)) return false;
        out.source = ecs::SdfSource::Field;
        out.sdf = m_assets.loadPsdf(path, err);
        if (out.sdf == 0) return fail(p, err);
        hold(out.sdf);
    } else {
        std::string relative;
        if (!string(v[given], p, relative) || !existingFile(p, relative, "mesh file", out.bakeMesh))
            return false;
        const std::string ext = assets::detail::lowerExtension(out.bakeMesh);
        if (ext != "ply" && ext != "obj" && ext != "gltf" && ext != "glb") {
            return fail(p,
                        fmt::format("unknown mesh format '.{}' (supported: .ply, .obj, .gltf, .glb)", ext));
        }
        out.source = ecs::SdfSource::MeshBake;
        if (auto it = v.find("resolution"); it != v.end()) {
            if (!count(*it, child(ptr, "resolution"), kMinBakeResolution, kMaxBakeResolution,
                       out.bakeResolution)) {
                return false;
            }
        }
        // Baked now (AssetManager::bakeSdf: one asset per mesh and resolution, disk-cached); the
        // scene holds the field, not the mesh.
        std::string err;
        const assets::AssetId mesh = m_assets.loadMesh(out.bakeMesh, err);
        if (mesh == 0) return fail(p, err);
        sdf::BakeSettings settings;
        settings.resolution = out.bakeResolution;  // 0: automatic, medium quality
        out.sdf = m_assets.bakeSdf(mesh, settings, err);
        m_assets.release(mesh);
        if (out.sdf == 0) return fail(p, err);
        hold(out.sdf);
    }
    // "shared": false gives this entity its own copy of the field (its own atlas slot: the
    // non-instanced objects of penumbra bench objects); by default one field per source is shared.
    // The scene keeps its reference to the shared field too, so the next copy reuses it.
    if (auto it = v.find("shared"); it != v.end()) {
        bool shared = true;
        if (!boolean(*it, child(ptr, "shared"), shared)) return false;
        if (!shared) {
            if (out.source == ecs::SdfSource::Shapes)
                return fail(child(ptr, "shared"), "\"shared\" applies to \"mesh\" and \"psdf\" fields only");
            std::string err;
            out.sdf = m_assets.copySdfField(out.sdf, m_name + ptr, err);
            if (out.sdf == 0) return fail(child(ptr, "shared"), err);
            hold(out.sdf);
        }
    }
    if (auto it = v.find("material"); it != v.end()) {
        if (!parseMaterialRef(*it, child(ptr, "material"), out.material)) return false;
    }
    if (auto it = v.find("castShadows"); it != v.end()) {
        if (!boolean(*it, child(ptr, "castShadows"), out.castShadows)) return false;
    }
    if (auto it = v.find("visible"); it != v.end()) {
        if (!boolean(*it, child(ptr, "visible"), out.visible)) return false;
    }
    if (auto it = v.find("maxSteps"); it != v.end()) {
        if (!count(*it, child(ptr, "maxSteps"), 1, kMaxSdfSteps, out.maxSteps)) return false;
    }
    return true;
}

bool SceneParser::parseShapes(const json& v, const std::string& ptr, bool leaf, assets::AssetId& out) {
    sdf::ShapeNode root;
    if (!parseShapeNode(v, ptr, leaf, root)) return false;
    sdf::ShapeProgram program;
    std::string err;
    if (!sdf::compileShapeProgram(root, program, err)) {
        // The compiler names the node below the root as a JSON pointer ("/children/1: reason").
        if (!err.empty() && err[0] == '/') {
            const size_t colon = err.find(": ");
            if (colon != std::string::npos) return fail(ptr + err.substr(0, colon), err.substr(colon + 2));
        }
        return fail(ptr, err);
    }
    const std::string key = assets::AssetManager::shapeProgramKey(program);
    const assets::AssetId existing = assets::AssetManager::stableId(assets::AssetKind::ShapeProgram, key);
    if (m_assets.refCount(existing) > 0 && m_assets.shapeProgram(existing) != nullptr) {
        m_assets.retain(existing);  // an identical program is shared (instancing)
        hold(existing);
        out = existing;
        return true;
    }
    out = m_assets.addShapeProgram(key, std::move(program), err);
    if (out == 0) return fail(ptr, err);
    hold(out);
    return true;
}

// A leaf node: "shape" and its parameters (the transform is parsed by parseShapeNode).
bool SceneParser::parseShapeLeaf(const json& v, const std::string& ptr, sdf::ShapeNode& out) {
    auto num = [&](std::string_view key, double& dst, bool required) {
        auto it = v.find(key);
        if (it == v.end()) return !required || fail(ptr, fmt::format("missing \"{}\"", key));
        float f = 0.0f;
        if (!number(*it, child(ptr, key), f)) return false;
        dst = double(f);
        return true;
    };
    std::string name;
    if (!string(v["shape"], child(ptr, "shape"), name)) return false;
    out.type = sdf::ShapeNode::Type::Shape;
    if (!sdf::parseShapeKind(name, out.shape)) {
        return fail(child(ptr, "shape"), fmt::format("unknown shape '{}' (expected sphere, box, roundedBox, "
                                                     "capsule, cylinder, torus, cone or plane)",
                                                     name));
    }
    const std::string what = fmt::format("a {} shape", name);
    glm::dvec4& q = out.params;
    switch (out.shape) {
        case sdf::ShapeKind::Sphere:
            return checkKeys(v, ptr, {"shape", "transform", "radius"}, what) && num("radius", q.x, true);
        case sdf::ShapeKind::Box:
        case sdf::ShapeKind::RoundedBox: {
            const bool rounded = out.shape == sdf::ShapeKind::RoundedBox;
            if (!(rounded ? checkKeys(v, ptr, {"shape", "transform", "halfExtents", "rounding"}, what)
                          : checkKeys(v, ptr, {"shape", "transform", "halfExtents"}, what))) {
                return false;
            }
            auto it = v.find("halfExtents");
            if (it == v.end()) return fail(ptr, "missing \"halfExtents\"");
            glm::vec3 h(0.0f);
            if (it->is_number()) {
                if (!number(*it, child(ptr, "halfExtents"), h.x)) return false;
                h = glm::vec3(h.x);
            } else if (!vec3(*it, child(ptr, "halfExtents"), h)) {
                return false;
            }
            q = glm::dvec4(glm::dvec3(h), 0.0);
            return !rounded || num("rounding", q.w, true);
        }
        case sdf::ShapeKind::Capsule:
            return checkKeys(v, ptr, {"shape", "transform", "radius", "halfLength"}, what) &&
                   num("radius", q.x, true) && num("halfLength", q.y, true);
        case sdf::ShapeKind::Cylinder:
            return checkKeys(v, ptr, {"shape", "transform", "radius", "halfHeight"}, what) &&
                   num("radius", q.x, true) && num("halfHeight", q.y, true);
        case sdf::ShapeKind::Torus:
            return checkKeys(v, ptr, {"shape", "transform", "majorRadius", "minorRadius"}, what) &&
                   num("majorRadius", q.x, true) && num("minorRadius", q.y, true);
        case sdf::ShapeKind::Cone:
            return checkKeys(v, ptr, {"shape", "transform", "bottomRadius", "topRadius", "halfHeight"},
                             what) &&
                   num("bottomRadius", q.x, true) && num("topRadius", q.y, false) &&
                   num("halfHeight", q.z, true);
        case sdf::ShapeKind::Plane: {
            if (!checkKeys(v, ptr, {"shape", "transform", "normal", "offset"}, what)) return false;
            auto it = v.find("normal");
            if (it == v.end()) return fail(ptr, "missing \"normal\"");
            glm::vec3 n(0.0f);
            if (!vec3(*it, child(ptr, "normal"), n)) return false;
            q = glm::dvec4(glm::dvec3(n), 0.0);
            return num("offset", q.w, false);
        }
    }
    return false;
}

bool SceneParser::parseShapeNode(const json& v, const std::string& ptr, bool leaf, sdf::ShapeNode& out) {
    if (!object(v, ptr)) return false;
    if (auto it = v.find("transform"); it != v.end()) {
        const std::string p = child(ptr, "transform");
        if (it->is_object()) {
            if (auto s = it->find("scale"); s != it->end() && !s->is_number()) {
                return fail(
                    child(p, "scale"),
                    fmt::format("a shape's scale is one number (uniform), got {}; non-uniform scale goes "
                                "on the entity's transform",
                                typeName(*s)));
            }
        }
        ecs::Transform t;
        if (!parseTransform(*it, p, t)) return false;
        out.transform.translation = glm::dvec3(t.position);
        out.transform.rotation = glm::dquat(t.rotation);
        out.transform.scale = double(t.scale.x);
    }
    const bool isShape = v.contains("shape");
    const bool isOp = v.contains("op");
    if (isShape == isOp || (leaf && !isShape)) {
        if (leaf)
            return fail(ptr,
                        "expected a shape node with \"shape\" (sphere, box, roundedBox, capsule, "
                        "cylinder, torus, cone or plane)");
        return fail(ptr, isShape ? "give either \"shape\" or \"op\", not both"
                                 : "expected an operation node with \"op\" (union, subtract, intersect or "
                                   "repeat) or a shape node with \"shape\"");
    }
    if (isShape) return parseShapeLeaf(v, ptr, out);
    std::string opName;
    if (!string(v["op"], child(ptr, "op"), opName)) return false;
    const bool repeat = opName == "repeat";
    if (!repeat && !sdf::parseCsgOp(opName, out.op)) {
        return fail(
            child(ptr, "op"),
            fmt::format("unknown operation '{}' (expected union, subtract, intersect or repeat)", opName));
    }
    if (repeat ? !checkKeys(v, ptr, {"op", "transform", "spacing", "count", "children"}, "a repeat node")
               : !checkKeys(v, ptr, {"op", "transform", "smoothRadius", "children"}, "an operation node")) {
        return false;
    }
    auto kids = v.find("children");
    if (kids == v.end()) return fail(ptr, "missing \"children\"");
    const std::string kp = child(ptr, "children");
    if (!kids->is_array())
        return fail(kp, fmt::format("expected an array of nodes, got {}", typeName(*kids)));
    if (repeat) {
        out.type = sdf::ShapeNode::Type::Repeat;
        if (kids->size() != 1)
            return fail(kp, fmt::format("a repeat node has one child (got {})", kids->size()));
        auto sp = v.find("spacing");
        if (sp == v.end()) return fail(ptr, "missing \"spacing\"");
        glm::vec3 spacing(0.0f);
        if (!vec3(*sp, child(ptr, "spacing"), spacing)) return false;
        out.spacing = glm::dvec3(spacing);
        auto ct = v.find("count");
        if (ct == v.end()) return fail(ptr, "missing \"count\"");
        const std::string cp = child(ptr, "count");
        if (!ct->is_array() || ct->size() != 3) {
            return fail(cp,
                        fmt::format("expected an array of 3 integers, got {}",
                                    ct->is_array() ? fmt::format("{} elements", ct->size()) : typeName(*ct)));
        }
        for (size_t k = 0; k < 3; ++k) {
            if (!count((*ct)[k], child(cp, k), 1, 1024, out.count[int(k)])) return false;
        }
    } else {
        out.type = sdf::ShapeNode::Type::Csg;
        if (kids->size() < 2) {
            return fail(kp,
                        fmt::format("a {} node needs at least two children (got {})", opName, kids->size()));
        }
        if (auto it = v.find("smoothRadius"); it != v.end()) {
            const std::string p = child(ptr, "smoothRadius");
            float k = 0.0f;
            if (!number(*it, p, k) || !positive(p, k, "smoothRadius")) return false;
            out.smoothRadius = double(k);
        }
    }
    out.children.resize(kids->size());
    for (size_t i = 0; i < kids->size(); ++i) {
        if (!parseShapeNode((*kids)[i], child(kp, i), false, out.children[i])) return false;
    }
    return true;
}

bool SceneParser::parsePrimitive(const json& v, const std::string& ptr, assets::AssetId& out) {
    if (!object(v, ptr)) return false;
    auto shapeIt = v.find("shape");
    if (shapeIt == v.end()) {
        return fail(ptr, "missing \"shape\" (sphere, box, plane, cylinder or torus)");
    }
    std::string shapeName;
    assets::PrimitiveDesc d;
    if (!string(*shapeIt, child(ptr, "shape"), shapeName)) return false;
    if (!assets::parsePrimitiveShape(shapeName, d.shape)) {
        return fail(child(ptr, "shape"),
                    fmt::format("unknown primitive shape '{}' (expected sphere, box, plane, "
                                "cylinder or torus)",
                                shapeName));
    }
    const std::string what = fmt::format("a {} primitive", shapeName);
    bool keysOk = true;
    switch (d.shape) {
        case assets::PrimitiveShape::Sphere:
            keysOk = checkKeys(v, ptr, {"shape", "radius", "segments", "rings"}, what);
            break;
        case assets::PrimitiveShape::Box:
            keysOk = checkKeys(v, ptr, {"shape", "halfExtents"}, what);
            break;
        case assets::PrimitiveShape::Plane:
            keysOk = checkKeys(v, ptr, {"shape", "halfSize"}, what);
            break;
        case assets::PrimitiveShape::Cylinder:
            keysOk = checkKeys(v, ptr, {"shape", "radius", "halfHeight", "segments"}, what);
            break;
        case assets::PrimitiveShape::Torus:
            keysOk = checkKeys(v, ptr, {"shape", "majorRadius", "minorRadius", "rings", "sides"}, what);
            break;
    }
    if (!keysOk) return false;
    if (d.shape == assets::PrimitiveShape::Torus) d.rings = 48;  // torus default: finer around the ring
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        const json& value = item.value();
        const std::string p = child(ptr, key);
        bool ok = true;
        if (key == "radius") {
            ok = number(value, p, d.radius) && positive(p, d.radius, "radius");
        } else if (key == "majorRadius") {
            ok = number(value, p, d.majorRadius) && positive(p, d.majorRadius, "majorRadius");
        } else if (key == "minorRadius") {
            ok = number(value, p, d.minorRadius) && positive(p, d.minorRadius, "minorRadius");
        } else if (key == "halfHeight") {
            ok = number(value, p, d.halfHeight) && positive(p, d.halfHeight, "halfHeight");
        } else if (key == "segments") {
            ok = count(value, p, assets::kMinPrimitiveSegments, assets::kMaxPrimitiveSegments, d.segments);
        } else if (key == "rings") {
            const uint32_t lo = d.shape == assets::PrimitiveShape::Sphere ? assets::kMinSphereRings
                                                                          : assets::kMinPrimitiveSegments;
            ok = count(value, p, lo, assets::kMaxPrimitiveSegments, d.rings);
        } else if (key == "sides") {
            ok = count(value, p, assets::kMinPrimitiveSegments, assets::kMaxPrimitiveSegments, d.sides);
        } else if (key == "halfExtents") {
            if (value.is_number()) {
                float h = 0.0f;
                ok = number(value, p, h) && positive(p, h, "halfExtents");
                d.halfExtents = glm::vec3(h);
            } else {
                ok = vec3(value, p, d.halfExtents);
                for (size_t i = 0; ok && i < 3; ++i)
                    ok = positive(child(p, i), d.halfExtents[int(i)], "halfExtents");
            }
        } else if (key == "halfSize") {
            if (value.is_number()) {
                float h = 0.0f;
                ok = number(value, p, h) && positive(p, h, "halfSize");
                d.halfSize = glm::vec2(h);
            } else {
                ok = numbers(value, p, 2, &d.halfSize.x);
                for (size_t i = 0; ok && i < 2; ++i)
                    ok = positive(child(p, i), d.halfSize[int(i)], "halfSize");
            }
        }
        if (!ok) return false;
    }
    // An identical primitive already loaded: share it.
    const std::string key = assets::primitiveKey(d);
    const assets::AssetId existing = assets::AssetManager::stableId(assets::AssetKind::Mesh, key);
    if (m_assets.refCount(existing) > 0 && m_assets.mesh(existing) != nullptr) {
        m_assets.retain(existing);
        hold(existing);
        out = existing;
        return true;
    }
    assets::MeshData mesh;
    std::string err;
    if (!assets::makePrimitive(d, mesh, err)) return fail(ptr, err);
    const assets::AssetId id = m_assets.addMesh(key, std::move(mesh), err);
    if (id == 0) return fail(ptr, err);
    hold(id);
    out = id;
    return true;
}

bool SceneParser::parseCamera(const json& v, const std::string& ptr, ecs::Camera& cam) {
    if (!object(v, ptr) || !checkKeys(v, ptr, {"fovYDegrees", "near", "far"}, "a camera")) return false;
    if (auto it = v.find("fovYDegrees"); it != v.end()) {
        const std::string p = child(ptr, "fovYDegrees");
        float fov = 0.0f;
        if (!number(*it, p, fov) || !inRange(p, fov, 0.0f, 180.0f, true, true)) return false;
        cam.fovY = glm::radians(fov);
    }
    if (auto it = v.find("near"); it != v.end()) {
        const std::string p = child(ptr, "near");
        if (!number(*it, p, cam.nearPlane) || !positive(p, cam.nearPlane, "near")) return false;
    }
    if (auto it = v.find("far"); it != v.end()) {
        if (!number(*it, child(ptr, "far"), cam.farPlane)) return false;
    }
    if (!(cam.farPlane > cam.nearPlane)) {
        return fail(child(ptr, "far"),
                    fmt::format("far ({}) must be greater than near ({})", cam.farPlane, cam.nearPlane));
    }
    return true;
}

bool SceneParser::parseLight(const json& v, const std::string& ptr, ecs::Light& light) {
    if (!object(v, ptr)) return false;
    auto typeIt = v.find("type");
    if (typeIt == v.end()) return fail(ptr, "missing \"type\" (directional, point or sphere)");
    std::string type;
    const std::string tp = child(ptr, "type");
    if (!string(*typeIt, tp, type)) return false;
    if (type == "directional") {
        light.type = ecs::LightType::Directional;
    } else if (type == "point") {
        light.type = ecs::LightType::Point;
    } else if (type == "sphere") {
        light.type = ecs::LightType::Sphere;
        light.radius = 0.1f;
    } else {
        return fail(tp, fmt::format("unknown light type '{}' (expected directional, point or sphere)", type));
    }
    const std::string what = fmt::format("a {} light", lightTypeName(light.type));
    bool keysOk = true;
    switch (light.type) {
        case ecs::LightType::Directional:
            keysOk = checkKeys(v, ptr, {"type", "color", "intensity", "castShadows", "angularRadiusDegrees"},
                               what);
            break;
        case ecs::LightType::Point:
            keysOk = checkKeys(v, ptr, {"type", "color", "intensity", "castShadows", "range"}, what);
            break;
        case ecs::LightType::Sphere:
            keysOk =
                checkKeys(v, ptr, {"type", "color", "intensity", "castShadows", "range", "radius"}, what);
            break;
    }
    if (!keysOk) return false;
    for (const auto& item : v.items()) {
        const std::string& key = item.key();
        const json& value = item.value();
        const std::string p = child(ptr, key);
        bool ok = true;
        if (key == "color") {
            ok = color(value, p, light.color);
        } else if (key == "intensity") {
            ok = number(value, p, light.intensity) && nonNegative(p, light.intensity, "intensity");
        } else if (key == "castShadows") {
            ok = boolean(value, p, light.castShadows);
        } else if (key == "range") {
            ok = number(value, p, light.range) && positive(p, light.range, "range");
        } else if (key == "radius") {
            ok = number(value, p, light.radius) && positive(p, light.radius, "radius");
        } else if (key == "angularRadiusDegrees") {
            float deg = 0.0f;
            ok = number(value, p, deg) && inRange(p, deg, 0.0f, 90.0f, false, true);
            light.angularRadius = glm::radians(deg);
        }
        if (!ok) return false;
    }
    return true;
}

bool SceneParser::parseSpin(const json& v, const std::string& ptr, Spin& spin) {
    if (!object(v, ptr) || !checkKeys(v, ptr, {"axis", "degreesPerSecond"}, "a spin")) return false;
    if (auto it = v.find("axis"); it != v.end()) {
        const std::string p = child(ptr, "axis");
        glm::vec3 axis(0.0f);
        if (!vec3(*it, p, axis)) return false;
        const float len = glm::length(axis);
        if (!(len > 1e-6f) || !std::isfinite(len)) {
            return fail(p,
                        fmt::format("the axis has length {} (it must be non-zero; it is normalised)", len));
        }
        spin.axis = axis / len;
    }
    auto rate = v.find("degreesPerSecond");
    if (rate == v.end()) return fail(ptr, "missing \"degreesPerSecond\"");
    float deg = 0.0f;
    if (!number(*rate, child(ptr, "degreesPerSecond"), deg)) return false;
    spin.radiansPerSecond = glm::radians(deg);
    return true;
}

bool SceneParser::resolveParents() {
    const size_t n = m_entities.size();
    std::vector<size_t> parentOf(n, SIZE_MAX);
    for (size_t i = 0; i < n; ++i) {
        if (!m_entities[i].hasParent) continue;
        const std::string p = child(child("/entities", i), "parent");
        auto it = m_entityByName.find(m_entities[i].parent);
        if (it == m_entityByName.end()) {
            return fail(p,
                        fmt::format("unknown parent '{}' (no entity has this name)", m_entities[i].parent));
        }
        parentOf[i] = it->second;
    }
    // Cycle check: walk each chain once (0 = unvisited, 1 = on the current walk, 2 = done).
    std::vector<uint8_t> state(n, 0);
    std::vector<size_t> walk;
    for (size_t start = 0; start < n; ++start) {
        walk.clear();
        size_t i = start;
        while (i != SIZE_MAX && state[i] == 0) {
            state[i] = 1;
            walk.push_back(i);
            i = parentOf[i];
        }
        if (i != SIZE_MAX && state[i] == 1) {
            // i is on the current walk: the cycle is walk[pos(i)..] -> i.
            std::string chain;
            const auto pos = std::find(walk.begin(), walk.end(), i);
            for (auto w = pos; w != walk.end(); ++w) {
                const ecs::Name* nm = m_scene.world.get<ecs::Name>(m_entities[*w].entity);
                chain += nm ? nm->value : std::string("?");
                chain += " -> ";
            }
            const ecs::Name* nm = m_scene.world.get<ecs::Name>(m_entities[i].entity);
            chain += nm ? nm->value : std::string("?");
            return fail(child(child("/entities", walk.back()), "parent"),
                        fmt::format("parent cycle: {}", chain));
        }
        for (size_t w : walk) state[w] = 2;
    }
    for (size_t i = 0; i < n; ++i) {
        if (parentOf[i] == SIZE_MAX) continue;
        m_scene.world.get<ecs::Transform>(m_entities[i].entity)->parent = m_entities[parentOf[i]].entity;
    }
    return true;
}

}  // namespace

bool parseJsonScene(std::string_view text, const std::string& name, const std::string& baseDir,
                    assets::AssetManager& assets, Scene& out, std::string& error,
                    const SceneLoadLimits& limits) {
    if (text.empty()) {
        error = fmt::format("{}: empty file (a scene file is a JSON object)", name);
        return false;
    }
    if (text.size() > limits.maxFileBytes) {
        error = fmt::format("{}: scene text too large ({} bytes, limit {} bytes)", name, text.size(),
                            limits.maxFileBytes);
        return false;
    }
    size_t deepAt = 0;
    if (!jsonDepthWithin(text, limits.maxJsonDepth, deepAt)) {
        size_t line = 0, column = 0;
        lineColumn(text, deepAt, line, column);
        error = fmt::format(
            "{}: JSON nested deeper than {} levels at line {}, column {} (refused before parsing)", name,
            limits.maxJsonDepth, line, column);
        return false;
    }
    DomBuilder dom(text);
    bool parsed = false;
    try {
        parsed = json::sax_parse(text.begin(), text.end(), &dom, json::input_format_t::json, true);
    } catch (const std::exception& e) {
        error = fmt::format("{}: JSON parser error: {}", name, e.what());
        return false;
    }
    if (!parsed) {
        error = name;
        error += ": ";
        if (!dom.errorPointer.empty()) {
            error += dom.errorPointer;
            error += ": ";
        }
        error += dom.errorReason;
        return false;
    }

    Scene local;
    local.sourcePath = name;
    bool ok = false;
    try {
        SceneParser parser(name, baseDir, assets, limits, local, error);
        ok = parser.run(dom.root);
    } catch (const std::exception& e) {
        error = fmt::format("{}: {}", name, e.what());
        ok = false;
    }
    if (!ok) {
        for (assets::AssetId id : local.assetRefs) assets.release(id);
        return false;
    }
    out = std::move(local);
    return true;
}

bool loadJsonScene(const std::string& path, assets::AssetManager& assets, Scene& out, std::string& error,
                   const SceneLoadLimits& limits) {
    assets::detail::FileBytes bytes;
    if (!assets::detail::readWholeFile(path, limits.maxFileBytes, bytes, error)) return false;
    std::string baseDir = fs::path(path).parent_path().string();
    if (baseDir.empty()) baseDir = ".";
    return parseJsonScene(std::string_view(bytes.data(), bytes.size()), path, baseDir, assets, out, error,
                          limits);
}

}  // namespace penumbra::scene
