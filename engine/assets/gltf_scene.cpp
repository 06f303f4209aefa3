// glTF 2.0 scenes into a World (see gltf_scene.h). Parsing and the structural validation are shared
// with the mesh loader (gltf_internal.h); this file adds the scene semantics.
//
// Two phases, for atomicity: plan() reads, validates and decodes everything (meshes, textures,
// materials, transforms, cameras, lights) without touching the World or the AssetManager;
// commit() then adds the assets and creates the entities, and undoes all of it if anything fails.
//
// Choices (also in docs):
//  - Asset keys: meshes "gltf:<file content hash>#mesh<i>/prim<j>", materials
//    "gltf:<hash>#material<k>", textures "gltf:<hash>#image<n>" (colour data: base colour,
//    emissive; sRGB) and "gltf:<hash>#image<n>/linear" (metallic-roughness, normal, occlusion).
//    Primitives without a material use "gltf:default-material" (the glTF default: white,
//    metallic 1, roughness 1). Materials refer to textures by id, so `acquired` also receives one
//    reference per texture asset used by the imported materials.
//  - Node matrices are decomposed with glm::decompose; singular, projective or sheared matrices
//    (recomposition differs by more than 1e-4 relative) are refused.
//  - Perspective cameras: Camera{yfov, znear, zfar}; without zfar (infinite in glTF) the far plane
//    is znear * kGltfDefaultFarOverNear; aspectRatio is ignored (the viewport decides).
//    Camera::name is the camera's name, else the node's. Orthographic cameras are not imported
//    (warning); their node is.
//  - KHR_lights_punctual: directional and point lights; spot lights become point lights (warning).
//    color, intensity (glTF units: lux for directional, candela for point) and range are copied;
//    no range (infinite in glTF) gives kGltfInfiniteLightRange.
//  - Texture coordinate set 0 only; materials using another set get a warning and use set 0.
//  - Points and lines primitives are skipped (warning).
#include "engine/assets/gltf_scene.h"

#define GLM_ENABLE_EXPERIMENTAL
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include <fmt/format.h>
#include <glm/glm.hpp>
#include <glm/gtx/matrix_decompose.hpp>

#include "engine/assets/gltf_internal.h"
#include "engine/core/log.h"

namespace penumbra::assets {
namespace {

constexpr const char* kDefaultMaterialKey = "gltf:default-material";
constexpr int kTextureSlots = 5;
enum Slot { BaseColor, MetallicRoughness, Normal, Occlusion, Emissive };
const char* const kSlotPath[kTextureSlots] = {"pbrMetallicRoughness.baseColorTexture",
                                              "pbrMetallicRoughness.metallicRoughnessTexture",
                                              "normalTexture", "occlusionTexture", "emissiveTexture"};
const bool kSlotSrgb[kTextureSlots] = {true, false, false, false, true};

// (texture index, texCoord set) of a material's slots, in kSlotPath order.
std::array<std::pair<int, int>, kTextureSlots> textureSlots(const tinygltf::Material& m) {
    const tinygltf::PbrMetallicRoughness& pbr = m.pbrMetallicRoughness;
    return {{{pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord},
             {pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord},
             {m.normalTexture.index, m.normalTexture.texCoord},
             {m.occlusionTexture.index, m.occlusionTexture.texCoord},
             {m.emissiveTexture.index, m.emissiveTexture.texCoord}}};
}

struct TexturePlan {
    int image = -1;
    bool srgb = true;
    TextureData data;
};

struct MaterialPlan {
    ecs::Material material;
    int textures[kTextureSlots] = {-1, -1, -1, -1, -1};  // index into SceneImporter::m_textures
};

struct PrimitivePlan {
    std::string key;
    MeshData mesh;
    int material = -1;  // glTF material index, -1: the default material
};

struct NodePlan {
    int node = -1;
    int parent = -1;  // index into m_nodes, -1: a root
    std::string name;
    ecs::Transform transform;
    std::vector<int> primitives;           // indices into m_primitives
    std::vector<size_t> primitiveNumbers;  // the glTF primitive index of each
    bool hasCamera = false;
    ecs::Camera camera;
    bool hasLight = false;
    ecs::Light light;
};

struct LightPlan {
    ecs::Light light;
    std::string type;
};

bool finite(const std::vector<double>& v) {
    for (double d : v) {
        if (!std::isfinite(d)) {
            return false;
        }
    }
    return true;
}

class SceneImporter {
public:
    SceneImporter(const std::string& path, const GltfSceneLimits& limits) : m_path(path), m_limits(limits) {}

    bool plan(std::string& error);
    bool commit(ecs::World& world, AssetManager& assets, std::vector<AssetId>& acquired, ecs::Entity parent,
                GltfSceneStats* stats, std::string& error);
    void emitWarnings() const {
        for (const std::string& w : m_warnings) {
            log::warn("{}: {}", m_path, w);
        }
    }

private:
    bool fail(std::string& error, std::string_view message) const {
        return gltf::fail(m_path, error, message);
    }
    void warnOnce(const std::string& message) {
        if (m_warned.insert(message).second) {
            m_warnings.push_back(message);
        }
    }

    bool checkCounts(std::string& error);
    bool checkTextures(std::string& error);
    bool checkMaterials(std::string& error);
    bool planCameras(std::string& error);
    bool planLights(std::string& error);
    bool planNode(int index, int parentPlan, std::string& error);
    bool planTransform(int index, ecs::Transform& out, std::string& error);
    bool planPrimitive(int meshIndex, size_t primIndex, int& out, std::string& error);
    bool planMaterial(int index, std::string& error);
    bool planTexture(int materialIndex, Slot slot, int textureIndex, int& out, std::string& error);
    bool nodeLight(int index, int& light, std::string& error);

    const std::string& m_path;
    const GltfSceneLimits& m_limits;
    gltf::ParsedGltf m_gltf;
    std::vector<int> m_parentOf;

    std::vector<NodePlan> m_nodes;
    std::vector<PrimitivePlan> m_primitives;
    std::map<std::pair<int, size_t>, int> m_primitiveIndex;  // (mesh, primitive) -> m_primitives
    std::vector<bool> m_primitiveIsSurface;
    std::map<int, MaterialPlan> m_materials;  // used glTF materials
    bool m_needsDefaultMaterial = false;
    std::vector<TexturePlan> m_textures;
    std::map<std::pair<int, bool>, int> m_textureIndex;  // (image, srgb) -> m_textures
    std::vector<bool> m_cameraValid;                     // perspective cameras (others are skipped)
    std::vector<ecs::Camera> m_cameras;
    std::vector<LightPlan> m_lights;
    uint64_t m_vertexTotal = 0;
    uint64_t m_triangleTotal = 0;
    std::vector<std::string> m_warnings;
    std::set<std::string> m_warned;
};

bool SceneImporter::plan(std::string& error) {
    gltf::ParseOptions options;
    options.maxFileBytes = m_limits.mesh.maxFileBytes;
    options.collectImages = true;
    options.keepJson = true;
    options.hashContent = true;
    if (!gltf::parseGltfFile(m_path, options, m_gltf, error)) {
        return false;
    }
    const tinygltf::Model& model = m_gltf.model;
    if (!checkCounts(error) || !gltf::checkBufferViews(m_path, model, error) ||
        !gltf::checkNodeGraph(m_path, model, m_parentOf, error) || !checkTextures(error) ||
        !checkMaterials(error) || !planCameras(error) || !planLights(error)) {
        return false;
    }
    std::vector<int> roots;
    if (!gltf::chooseRoots(m_path, model, m_parentOf, roots, error)) {
        return false;
    }
    // Depth-first, parents before children, in file order; iterative (depth is unbounded).
    struct Item {
        int node;
        int parentPlan;
    };
    std::vector<Item> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) {
        stack.push_back({*it, -1});
    }
    while (!stack.empty()) {
        const Item item = stack.back();
        stack.pop_back();
        if (!planNode(item.node, item.parentPlan, error)) {
            return false;
        }
        const int self = int(m_nodes.size()) - 1;
        const auto& children = model.nodes[size_t(item.node)].children;
        for (auto c = children.rbegin(); c != children.rend(); ++c) {
            stack.push_back({*c, self});
        }
    }
    for (auto& [index, material] : m_materials) {
        (void)material;
        if (!planMaterial(index, error)) {
            return false;
        }
    }
    return true;
}

bool SceneImporter::checkCounts(std::string& error) {
    const tinygltf::Model& model = m_gltf.model;
    if (model.nodes.size() > m_limits.maxNodes) {
        return fail(error, fmt::format("nodes: {} nodes exceed the limit of {}", model.nodes.size(),
                                       m_limits.maxNodes));
    }
    if (model.materials.size() > m_limits.maxMaterials) {
        return fail(error, fmt::format("materials: {} materials exceed the limit of {}",
                                       model.materials.size(), m_limits.maxMaterials));
    }
    return true;
}

bool SceneImporter::checkTextures(std::string& error) {
    const tinygltf::Model& model = m_gltf.model;
    for (size_t t = 0; t < model.textures.size(); ++t) {
        const tinygltf::Texture& tex = model.textures[t];
        if (tex.source < -1 || (tex.source >= 0 && size_t(tex.source) >= model.images.size())) {
            return fail(error, fmt::format("textures[{}].source {} out of range ({} images)", t, tex.source,
                                           model.images.size()));
        }
        if (tex.sampler < -1 || (tex.sampler >= 0 && size_t(tex.sampler) >= model.samplers.size())) {
            return fail(error, fmt::format("textures[{}].sampler {} out of range ({} samplers)", t,
                                           tex.sampler, model.samplers.size()));
        }
    }
    for (size_t i = 0; i < model.images.size(); ++i) {
        const tinygltf::Image& image = model.images[i];
        if (image.bufferView < -1 ||
            (image.bufferView >= 0 && size_t(image.bufferView) >= model.bufferViews.size())) {
            return fail(error, fmt::format("images[{}].bufferView {} out of range ({} bufferViews)", i,
                                           image.bufferView, model.bufferViews.size()));
        }
    }
    return true;
}

bool SceneImporter::checkMaterials(std::string& error) {
    const tinygltf::Model& model = m_gltf.model;
    const size_t textureCount = model.textures.size();
    for (size_t k = 0; k < model.materials.size(); ++k) {
        const tinygltf::Material& m = model.materials[k];
        const auto& pbr = m.pbrMetallicRoughness;
        const std::string at = fmt::format("materials[{}]", k);
        if (pbr.baseColorFactor.size() != 4 || !finite(pbr.baseColorFactor)) {
            return fail(error,
                        fmt::format("{}.pbrMetallicRoughness.baseColorFactor must be 4 finite numbers", at));
        }
        for (double c : pbr.baseColorFactor) {
            if (c < 0.0 || c > 1.0) {
                return fail(
                    error,
                    fmt::format("{}.pbrMetallicRoughness.baseColorFactor component {} is outside [0, 1]", at,
                                c));
            }
        }
        const std::pair<const char*, double> factors[] = {{"metallicFactor", pbr.metallicFactor},
                                                          {"roughnessFactor", pbr.roughnessFactor}};
        for (const auto& [name, value] : factors) {
            if (!std::isfinite(value) || value < 0.0 || value > 1.0) {
                return fail(error, fmt::format("{}.pbrMetallicRoughness.{} {} must be a number in [0, 1]", at,
                                               name, value));
            }
        }
        if (m.emissiveFactor.size() != 3 || !finite(m.emissiveFactor)) {
            return fail(error, fmt::format("{}.emissiveFactor must be 3 finite numbers", at));
        }
        for (double e : m.emissiveFactor) {
            if (e < 0.0) {
                return fail(error, fmt::format("{}.emissiveFactor component {} is negative", at, e));
            }
        }
        const std::array<std::pair<int, int>, kTextureSlots> infos = textureSlots(m);
        for (int s = 0; s < kTextureSlots; ++s) {
            const auto [index, texCoord] = infos[s];
            if (index < -1 || (index >= 0 && size_t(index) >= textureCount)) {
                return fail(error, fmt::format("{}.{}.index {} out of range ({} textures)", at, kSlotPath[s],
                                               index, textureCount));
            }
            if (index >= 0 && texCoord < 0) {
                return fail(error, fmt::format("{}.{}.texCoord {} is negative", at, kSlotPath[s], texCoord));
            }
        }
    }
    return true;
}

bool SceneImporter::planCameras(std::string& error) {
    const tinygltf::Model& model = m_gltf.model;
    const nlohmann::json* jsonCameras = nullptr;
    if (const auto it = m_gltf.json.find("cameras"); it != m_gltf.json.end() && it->is_array()) {
        jsonCameras = &*it;
    }
    m_cameraValid.assign(model.cameras.size(), false);
    m_cameras.assign(model.cameras.size(), ecs::Camera{});
    for (size_t c = 0; c < model.cameras.size(); ++c) {
        const tinygltf::Camera& cam = model.cameras[c];
        const std::string at = fmt::format("cameras[{}]", c);
        if (cam.type == "orthographic") {
            continue;  // warned about where a node uses it
        }
        if (cam.type != "perspective") {
            return fail(error,
                        fmt::format("{}.type '{}' is not 'perspective' or 'orthographic'", at, cam.type));
        }
        const tinygltf::PerspectiveCamera& p = cam.perspective;
        if (!std::isfinite(p.yfov) || p.yfov <= 0.0 || p.yfov >= std::numbers::pi) {
            return fail(error, fmt::format("{}.perspective.yfov {} must be in (0, pi) radians", at, p.yfov));
        }
        if (!std::isfinite(p.znear) || p.znear <= 0.0) {
            return fail(error, fmt::format("{}.perspective.znear {} must be greater than 0", at, p.znear));
        }
        bool hasFar = false;
        if (jsonCameras && c < jsonCameras->size()) {
            const nlohmann::json& jc = (*jsonCameras)[c];
            if (const auto persp = jc.find("perspective"); persp != jc.end() && persp->is_object()) {
                hasFar = persp->contains("zfar");
            }
        }
        ecs::Camera out;
        out.fovY = float(p.yfov);
        out.nearPlane = float(p.znear);
        if (hasFar) {
            if (!std::isfinite(p.zfar) || p.zfar <= p.znear) {
                return fail(error, fmt::format("{}.perspective.zfar {} must be greater than znear {}", at,
                                               p.zfar, p.znear));
            }
            out.farPlane = float(p.zfar);
        } else {
            out.farPlane = float(p.znear) * kGltfDefaultFarOverNear;
        }
        if (!std::isfinite(out.farPlane) || !(out.nearPlane > 0.0f) || !(out.farPlane > out.nearPlane)) {
            return fail(error, fmt::format("{}.perspective: znear {} / zfar {} are outside the float range",
                                           at, p.znear, p.zfar));
        }
        out.name = cam.name;
        m_cameras[c] = out;
        m_cameraValid[c] = true;
    }
    return true;
}

bool SceneImporter::planLights(std::string& error) {
    const nlohmann::json& doc = m_gltf.json;
    const auto ext = doc.find("extensions");
    if (ext == doc.end()) {
        return true;
    }
    if (!ext->is_object()) {
        return fail(error, "extensions is not an object");
    }
    const auto khr = ext->find("KHR_lights_punctual");
    if (khr == ext->end()) {
        return true;
    }
    if (!khr->is_object()) {
        return fail(error, "extensions.KHR_lights_punctual is not an object");
    }
    const auto lights = khr->find("lights");
    if (lights == khr->end()) {
        return true;
    }
    if (!lights->is_array()) {
        return fail(error, "extensions.KHR_lights_punctual.lights is not an array");
    }
    for (size_t i = 0; i < lights->size(); ++i) {
        const nlohmann::json& l = (*lights)[i];
        const std::string at = fmt::format("extensions.KHR_lights_punctual.lights[{}]", i);
        if (!l.is_object()) {
            return fail(error, fmt::format("{} is not an object", at));
        }
        const auto type = l.find("type");
        if (type == l.end() || !type->is_string()) {
            return fail(error, fmt::format("{}.type is missing or not a string", at));
        }
        LightPlan plan;
        plan.type = type->get<std::string>();
        if (plan.type == "directional") {
            plan.light.type = ecs::LightType::Directional;
        } else if (plan.type == "point" || plan.type == "spot") {
            plan.light.type = ecs::LightType::Point;
        } else {
            return fail(error, fmt::format("{}.type '{}' is not one of 'directional', 'point', 'spot'", at,
                                           plan.type));
        }
        if (const auto color = l.find("color"); color != l.end()) {
            if (!color->is_array() || color->size() != 3) {
                return fail(error, fmt::format("{}.color must be an array of 3 numbers", at));
            }
            for (int k = 0; k < 3; ++k) {
                const nlohmann::json& v = (*color)[size_t(k)];
                if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0.0) {
                    return fail(error, fmt::format("{}.color[{}] must be a finite number >= 0", at, k));
                }
                plan.light.color[k] = float(v.get<double>());
            }
        }
        if (const auto intensity = l.find("intensity"); intensity != l.end()) {
            if (!intensity->is_number() || !std::isfinite(intensity->get<double>()) ||
                intensity->get<double>() < 0.0) {
                return fail(error, fmt::format("{}.intensity must be a finite number >= 0", at));
            }
            plan.light.intensity = float(intensity->get<double>());
        }
        plan.light.range = kGltfInfiniteLightRange;
        if (const auto range = l.find("range"); range != l.end()) {
            if (!range->is_number() || !std::isfinite(range->get<double>()) || range->get<double>() <= 0.0) {
                return fail(error, fmt::format("{}.range must be a finite number > 0", at));
            }
            plan.light.range = std::min(float(range->get<double>()), kGltfInfiniteLightRange);
        }
        if (plan.type == "spot") {
            const auto spot = l.find("spot");
            if (spot != l.end() && !spot->is_object()) {
                return fail(error, fmt::format("{}.spot is not an object", at));
            }
        }
        m_lights.push_back(std::move(plan));
    }
    return true;
}

// The light a node refers to through KHR_lights_punctual (-1: none).
bool SceneImporter::nodeLight(int index, int& light, std::string& error) {
    light = -1;
    const auto nodes = m_gltf.json.find("nodes");
    if (nodes == m_gltf.json.end() || !nodes->is_array() || size_t(index) >= nodes->size()) {
        return true;
    }
    const nlohmann::json& node = (*nodes)[size_t(index)];
    const auto ext = node.find("extensions");
    if (ext == node.end() || !ext->is_object()) {
        return true;
    }
    const auto khr = ext->find("KHR_lights_punctual");
    if (khr == ext->end()) {
        return true;
    }
    const std::string at = fmt::format("nodes[{}].extensions.KHR_lights_punctual", index);
    if (!khr->is_object()) {
        return fail(error, fmt::format("{} is not an object", at));
    }
    const auto l = khr->find("light");
    if (l == khr->end() || !l->is_number_integer()) {
        return fail(error, fmt::format("{}.light is missing or not an integer", at));
    }
    const int64_t value = l->get<int64_t>();
    if (value < 0 || uint64_t(value) >= m_lights.size()) {
        return fail(error, fmt::format("{}.light {} out of range ({} lights)", at, value, m_lights.size()));
    }
    light = int(value);
    return true;
}

bool SceneImporter::planTransform(int index, ecs::Transform& out, std::string& error) {
    gltf::NodeTransform local;
    if (!gltf::readNodeTransform(m_path, m_gltf.model, index, local, error)) {
        return false;
    }
    glm::dvec3 t = local.translation;
    glm::dquat r = local.rotation;
    glm::dvec3 s = local.scale;
    if (local.isMatrix) {
        const glm::dmat4& m = local.matrix;
        const std::string at = fmt::format("nodes[{}].matrix", index);
        if (m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0) {
            return fail(error, fmt::format("{} is not affine (its last row is not 0 0 0 1)", at));
        }
        const glm::dmat3 linear(m);
        double largest = 0.0;
        for (int c = 0; c < 3; ++c) {
            largest = std::max(largest, glm::length(linear[c]));
        }
        const double det = glm::determinant(linear);
        if (!(std::abs(det) > 1e-12 * largest * largest * largest) || !(largest > 0.0)) {
            return fail(
                error, fmt::format(
                           "{} is singular (determinant {}): it cannot be decomposed into rotation and scale",
                           at, det));
        }
        glm::dvec3 skew;
        glm::dvec4 perspective;
        if (!glm::decompose(m, s, r, t, skew, perspective)) {
            return fail(error,
                        fmt::format("{} cannot be decomposed into translation, rotation and scale", at));
        }
        r = glm::normalize(r);
        gltf::NodeTransform check;
        check.translation = t;
        check.rotation = r;
        check.scale = s;
        const glm::dmat4 back = check.toMatrix();
        double worst = 0.0;
        double magnitude = 1.0;
        for (int c = 0; c < 4; ++c) {
            for (int row = 0; row < 4; ++row) {
                worst = std::max(worst, std::abs(back[c][row] - m[c][row]));
                magnitude = std::max(magnitude, std::abs(m[c][row]));
            }
        }
        if (!(worst <= 1e-4 * magnitude)) {
            return fail(error,
                        fmt::format("{} has shear (it is not translation * rotation * scale; the closest "
                                    "such transform differs by {})",
                                    at, worst));
        }
    }
    out = ecs::Transform{};
    out.position = glm::vec3(t);
    out.rotation = glm::quat(float(r.w), float(r.x), float(r.y), float(r.z));
    out.scale = glm::vec3(s);
    const glm::vec3 check[] = {out.position, out.scale};
    for (const glm::vec3& v : check) {
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) {
            return fail(error, fmt::format("nodes[{}]: transform outside the float range", index));
        }
    }
    return true;
}

bool SceneImporter::planNode(int index, int parentPlan, std::string& error) {
    const tinygltf::Model& model = m_gltf.model;
    const tinygltf::Node& node = model.nodes[size_t(index)];
    NodePlan plan;
    plan.node = index;
    plan.parent = parentPlan;
    plan.name = node.name.empty() ? fmt::format("node{}", index) : node.name;
    if (!planTransform(index, plan.transform, error)) {
        return false;
    }
    if (node.camera < -1 || (node.camera >= 0 && size_t(node.camera) >= model.cameras.size())) {
        return fail(error, fmt::format("nodes[{}].camera {} out of range ({} cameras)", index, node.camera,
                                       model.cameras.size()));
    }
    if (node.camera >= 0) {
        if (m_cameraValid[size_t(node.camera)]) {
            plan.hasCamera = true;
            plan.camera = m_cameras[size_t(node.camera)];
            if (plan.camera.name.empty()) {
                plan.camera.name = plan.name;
            }
        } else {
            warnOnce(fmt::format("cameras[{}] is orthographic: not imported (node '{}' is)", node.camera,
                                 plan.name));
        }
    }
    int light = -1;
    if (!nodeLight(index, light, error)) {
        return false;
    }
    if (light >= 0) {
        plan.hasLight = true;
        plan.light = m_lights[size_t(light)].light;
        if (m_lights[size_t(light)].type == "spot") {
            warnOnce(
                fmt::format("extensions.KHR_lights_punctual.lights[{}] is a spot light: imported as a point "
                            "light (the cone is ignored)",
                            light));
        }
    }
    if (node.mesh >= 0) {
        const tinygltf::Mesh& mesh = model.meshes[size_t(node.mesh)];
        for (size_t j = 0; j < mesh.primitives.size(); ++j) {
            int prim = -1;
            if (!planPrimitive(node.mesh, j, prim, error)) {
                return false;
            }
            if (prim >= 0) {
                plan.primitives.push_back(prim);
                plan.primitiveNumbers.push_back(j);
            }
        }
    }
    m_nodes.push_back(std::move(plan));
    return true;
}

// Reads (once per file) primitive j of mesh m into a MeshData; `out` = -1 for points / lines.
bool SceneImporter::planPrimitive(int meshIndex, size_t primIndex, int& out, std::string& error) {
    const auto known = m_primitiveIndex.find({meshIndex, primIndex});
    if (known != m_primitiveIndex.end()) {
        out = known->second;
        return true;
    }
    const tinygltf::Model& model = m_gltf.model;
    const tinygltf::Primitive& prim = model.meshes[size_t(meshIndex)].primitives[primIndex];
    const std::string at = fmt::format("meshes[{}].primitives[{}]", meshIndex, primIndex);
    gltf::PrimitiveData data;
    const uint64_t vertexBudget =
        m_limits.mesh.maxVertices - std::min(m_vertexTotal, m_limits.mesh.maxVertices);
    if (!gltf::readPrimitive(m_path, model, meshIndex, primIndex, m_limits.mesh, vertexBudget, true, true,
                             data, error)) {
        return false;
    }
    if (!data.triangles) {
        warnOnce(fmt::format("{} has mode {} (points or lines): skipped", at, prim.mode));
        m_primitiveIndex[{meshIndex, primIndex}] = -1;
        out = -1;
        return true;
    }
    if (prim.material < -1 || (prim.material >= 0 && size_t(prim.material) >= model.materials.size())) {
        return fail(error, fmt::format("{}.material {} out of range ({} materials)", at, prim.material,
                                       model.materials.size()));
    }
    for (const auto& [name, accessor] : prim.attributes) {
        (void)accessor;
        if (name.rfind("TEXCOORD_", 0) == 0 && name != "TEXCOORD_0") {
            warnOnce(fmt::format("{} has {}: only texture coordinate set 0 is imported", at, name));
        }
    }
    m_triangleTotal += data.indices.size() / 3;
    m_vertexTotal += data.positions.size() / 3;
    if (m_triangleTotal > m_limits.mesh.maxTriangles) {
        return fail(error, fmt::format("{}: more than {} triangles in the scene (limit)", at,
                                       m_limits.mesh.maxTriangles));
    }
    PrimitivePlan plan;
    plan.key = fmt::format("gltf:{}#mesh{}/prim{}", m_gltf.contentHash, meshIndex, primIndex);
    plan.material = prim.material;
    MeshData& mesh = plan.mesh;
    mesh.sourcePath = m_path;
    const size_t vcount = data.positions.size() / 3;
    mesh.positions.resize(vcount);
    for (size_t v = 0; v < vcount; ++v) {
        mesh.positions[v] = {data.positions[3 * v], data.positions[3 * v + 1], data.positions[3 * v + 2]};
    }
    if (!data.normals.empty()) {
        mesh.normals.resize(vcount);
        for (size_t v = 0; v < vcount; ++v) {
            glm::vec3 n(data.normals[3 * v], data.normals[3 * v + 1], data.normals[3 * v + 2]);
            const float len = glm::length(n);
            mesh.normals[v] = len > 0.0f ? n / len : glm::vec3(0.0f, 1.0f, 0.0f);
        }
    }
    if (!data.uvs.empty()) {
        mesh.uvs.resize(vcount);
        for (size_t v = 0; v < vcount; ++v) {
            mesh.uvs[v] = {data.uvs[2 * v], data.uvs[2 * v + 1]};
        }
    }
    mesh.indices = std::move(data.indices);
    std::string invalid;
    if (!validateMesh(mesh, fmt::format("{}: {}", m_path, at), invalid)) {
        error = invalid;
        return false;
    }
    if (plan.material >= 0) {
        m_materials.try_emplace(plan.material);
    } else {
        m_needsDefaultMaterial = true;
    }
    out = int(m_primitives.size());
    m_primitiveIndex[{meshIndex, primIndex}] = out;
    m_primitives.push_back(std::move(plan));
    return true;
}

bool SceneImporter::planMaterial(int index, std::string& error) {
    const tinygltf::Material& m = m_gltf.model.materials[size_t(index)];
    const auto& pbr = m.pbrMetallicRoughness;
    MaterialPlan& plan = m_materials[index];
    plan.material.baseColor = glm::vec4(float(pbr.baseColorFactor[0]), float(pbr.baseColorFactor[1]),
                                        float(pbr.baseColorFactor[2]), float(pbr.baseColorFactor[3]));
    plan.material.metallic = float(pbr.metallicFactor);
    plan.material.roughness = float(pbr.roughnessFactor);
    plan.material.emissive =
        glm::vec3(float(m.emissiveFactor[0]), float(m.emissiveFactor[1]), float(m.emissiveFactor[2]));
    const std::array<std::pair<int, int>, kTextureSlots> infos = textureSlots(m);
    for (int s = 0; s < kTextureSlots; ++s) {
        const auto [textureIndex, texCoord] = infos[s];
        if (textureIndex < 0) {
            continue;
        }
        if (texCoord != 0) {
            warnOnce(
                fmt::format("materials[{}].{}.texCoord {}: only texture coordinate set 0 is imported (used "
                            "instead)",
                            index, kSlotPath[s], texCoord));
        }
        if (!planTexture(index, Slot(s), textureIndex, plan.textures[s], error)) {
            return false;
        }
    }
    return true;
}

bool SceneImporter::planTexture(int materialIndex, Slot slot, int textureIndex, int& out,
                                std::string& error) {
    const tinygltf::Model& model = m_gltf.model;
    const tinygltf::Texture& texture = model.textures[size_t(textureIndex)];
    if (texture.source < 0) {
        return fail(error, fmt::format("materials[{}].{}: textures[{}] has no source image", materialIndex,
                                       kSlotPath[slot], textureIndex));
    }
    const int image = texture.source;
    const bool srgb = kSlotSrgb[slot];
    if (const auto known = m_textureIndex.find({image, srgb}); known != m_textureIndex.end()) {
        out = known->second;
        return true;
    }
    const tinygltf::Image& img = model.images[size_t(image)];
    const uint8_t* bytes = nullptr;
    size_t size = 0;
    if (img.bufferView >= 0) {
        // In range: checkTextures() and checkBufferViews() ran first.
        const tinygltf::BufferView& view = model.bufferViews[size_t(img.bufferView)];
        bytes = model.buffers[size_t(view.buffer)].data.data() + view.byteOffset;
        size = view.byteLength;
    } else if (size_t(image) < m_gltf.imageRead.size() && m_gltf.imageRead[size_t(image)]) {
        bytes = m_gltf.imageBytes[size_t(image)].data();
        size = m_gltf.imageBytes[size_t(image)].size();
    } else {
        return fail(error,
                    fmt::format("images[{}]: cannot read '{}' (missing or unreadable file)", image, img.uri));
    }
    TexturePlan plan;
    plan.image = image;
    plan.srgb = srgb;
    plan.data.srgb = srgb;
    const std::string name = fmt::format("{}: images[{}]", m_path, image);
    if (!decodeTexture(bytes, size, name, plan.data, error, m_limits.texture)) {
        return false;
    }
    plan.data.srgb = srgb;
    plan.data.sourcePath = m_path;
    out = int(m_textures.size());
    m_textureIndex[{image, srgb}] = out;
    m_textures.push_back(std::move(plan));
    return true;
}

bool SceneImporter::commit(ecs::World& world, AssetManager& assets, std::vector<AssetId>& acquired,
                           ecs::Entity parent, GltfSceneStats* stats, std::string& error) {
    std::vector<AssetId> taken;
    std::vector<ecs::Entity> created;
    auto rollback = [&]() {
        for (auto it = created.rbegin(); it != created.rend(); ++it) {
            world.destroy(*it);
        }
        for (auto it = taken.rbegin(); it != taken.rend(); ++it) {
            assets.release(*it);
        }
    };
    try {
        const std::string& hash = m_gltf.contentHash;
        std::vector<AssetId> textureIds(m_textures.size(), 0);
        for (size_t i = 0; i < m_textures.size(); ++i) {
            const TexturePlan& t = m_textures[i];
            const std::string key = t.srgb ? fmt::format("gltf:{}#image{}", hash, t.image)
                                           : fmt::format("gltf:{}#image{}/linear", hash, t.image);
            const AssetId id = assets.addTexture(key, std::move(m_textures[i].data), error);
            if (id == 0) {
                rollback();
                return false;
            }
            taken.push_back(id);
            textureIds[i] = id;
        }
        std::map<int, AssetId> materialIds;  // -1: the default material; first reference only
        auto materialFor = [&](int index) -> AssetId {
            if (const auto it = materialIds.find(index); it != materialIds.end()) {
                return assets.retain(it->second) ? it->second : 0;
            }
            AssetId id = 0;
            if (index < 0) {
                ecs::Material def;  // glTF 2.0 default material
                def.baseColor = glm::vec4(1.0f);
                def.metallic = 1.0f;
                def.roughness = 1.0f;
                id = assets.addMaterial(kDefaultMaterialKey, def);
            } else {
                MaterialPlan& plan = m_materials[index];
                ecs::AssetId* slots[kTextureSlots] = {
                    &plan.material.baseColorTexture, &plan.material.metallicRoughnessTexture,
                    &plan.material.normalTexture, &plan.material.occlusionTexture,
                    &plan.material.emissiveTexture};
                for (int s = 0; s < kTextureSlots; ++s) {
                    *slots[s] = plan.textures[s] >= 0 ? textureIds[size_t(plan.textures[s])] : 0;
                }
                id = assets.addMaterial(fmt::format("gltf:{}#material{}", hash, index), plan.material);
            }
            if (id != 0) {
                materialIds[index] = id;
            }
            return id;
        };
        std::vector<AssetId> meshIds(m_primitives.size(), 0);
        auto meshFor = [&](int prim) -> AssetId {
            if (meshIds[size_t(prim)] != 0) {
                return assets.retain(meshIds[size_t(prim)]) ? meshIds[size_t(prim)] : 0;
            }
            PrimitivePlan& plan = m_primitives[size_t(prim)];
            const AssetId id = assets.addMesh(plan.key, std::move(plan.mesh), error);
            meshIds[size_t(prim)] = id;
            return id;
        };

        size_t renderers = 0;
        size_t cameras = 0;
        size_t lights = 0;
        std::vector<ecs::Entity> nodeEntities(m_nodes.size());
        for (size_t n = 0; n < m_nodes.size(); ++n) {
            const NodePlan& plan = m_nodes[n];
            const ecs::Entity e = world.create();
            created.push_back(e);
            nodeEntities[n] = e;
            ecs::Transform transform = plan.transform;
            transform.parent = plan.parent >= 0 ? nodeEntities[size_t(plan.parent)] : parent;
            world.add<ecs::Transform>(e, transform);
            world.add<ecs::Name>(e, ecs::Name{plan.name});
            if (plan.hasCamera) {
                world.add<ecs::Camera>(e, plan.camera);
                ++cameras;
            }
            if (plan.hasLight) {
                world.add<ecs::Light>(e, plan.light);
                ++lights;
            }
            for (size_t p = 0; p < plan.primitives.size(); ++p) {
                const int prim = plan.primitives[p];
                const AssetId mesh = meshFor(prim);
                if (mesh == 0) {
                    if (error.empty()) {
                        error = fmt::format("{}: cannot add mesh asset {}", m_path,
                                            m_primitives[size_t(prim)].key);
                    }
                    rollback();
                    return false;
                }
                taken.push_back(mesh);
                const AssetId material = materialFor(m_primitives[size_t(prim)].material);
                if (material == 0) {
                    error =
                        fmt::format("{}: cannot add the material of meshes primitive {} (asset id collision)",
                                    m_path, m_primitives[size_t(prim)].key);
                    rollback();
                    return false;
                }
                taken.push_back(material);
                ecs::MeshRenderer renderer;
                renderer.mesh = mesh;
                renderer.material = material;
                ecs::Entity target = e;
                if (p > 0) {
                    target = world.create();
                    created.push_back(target);
                    ecs::Transform child;
                    child.parent = e;
                    world.add<ecs::Transform>(target, child);
                    world.add<ecs::Name>(
                        target, ecs::Name{fmt::format("{}#prim{}", plan.name, plan.primitiveNumbers[p])});
                }
                world.add<ecs::MeshRenderer>(target, renderer);
                ++renderers;
            }
        }
        acquired.insert(acquired.end(), taken.begin(), taken.end());
        if (stats) {
            stats->nodes = m_nodes.size();
            stats->meshPrimitives = renderers;
            stats->materials = materialIds.size();
            stats->textures = m_textures.size();
            stats->cameras = cameras;
            stats->lights = lights;
        }
        return true;
    } catch (const std::exception& e) {
        rollback();
        error = fmt::format("{}: cannot import the glTF scene: {}", m_path, e.what());
        return false;
    }
}

}  // namespace

bool loadGltfScene(const std::string& path, ecs::World& world, AssetManager& assets,
                   std::vector<AssetId>& acquired, std::string& error, GltfSceneStats* stats,
                   ecs::Entity parent, const GltfSceneLimits& limits) {
    if (world.iterating()) {
        error = fmt::format("{}: cannot import a glTF scene while the world is being iterated", path);
        return false;
    }
    if (!parent.isNull() && (!world.alive(parent) || !world.has<ecs::Transform>(parent))) {
        error =
            fmt::format("{}: the parent entity for the glTF scene is not alive or has no Transform", path);
        return false;
    }
    try {
        SceneImporter importer(path, limits);
        if (!importer.plan(error)) {
            return false;
        }
        error.clear();
        if (!importer.commit(world, assets, acquired, parent, stats, error)) {
            return false;
        }
        importer.emitWarnings();
        return true;
    } catch (const std::exception& e) {
        error = fmt::format("{}: cannot load glTF scene: {}", path, e.what());
        return false;
    }
}

}  // namespace penumbra::assets
