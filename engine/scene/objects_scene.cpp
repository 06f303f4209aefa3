// The object-count benchmark scene (objects_scene.h): grid layout, camera fit and JSON text.
#include "engine/scene/objects_scene.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <nlohmann/json.hpp>

namespace penumbra::scene {
namespace {

using json = nlohmann::ordered_json;

// The three meshes of mTec's scene, each scaled to about one unit wide. Bounds are the files'
// vertex bounds (data/meshes, tools/fetch_meshes.sh); they place each object on the floor (y = 0)
// and give its bounding sphere.
struct MeshKind {
    const char* kind;
    const char* file;
    const char* material;
    float scale;
    glm::vec3 lo, hi;
};
constexpr MeshKind kKinds[3] = {
    {"bunny", "bunny.ply", "terracotta", 0.1f, {-4.9585f, -0.00315f, -3.7298f}, {4.9489f, 9.6547f, 3.8106f}},
    {"dragon",
     "dragon_vrip_res3.ply",
     "jade",
     5.0f,
     {-0.10767f, 0.05277f, -0.05005f},
     {0.09598f, 0.19664f, 0.04083f}},
    {"teapot", "teapot.ply", "gold", 0.03f, {-16.0703f, -7.875f, -10.0f}, {16.0703f, 7.875f, 10.0f}},
};
constexpr float kSpacing = 1.5f;         // grid pitch in x and z (objects are ~1 unit wide)
constexpr float kPitchDegrees = -35.0f;  // camera looks down at the rows
constexpr float kWallHeight = 2.5f;

struct Grid {
    uint32_t columns = 0, rows = 0;
    float halfWidth = 0, halfDepth = 0;  // of the objects' area
};

// Wider than deep (about 2:1), like the thesis' figure; the last (back) row may be partial.
Grid gridFor(uint32_t count) {
    Grid g;
    g.columns = std::max(1u, uint32_t(std::ceil(std::sqrt(2.0 * count))));
    g.rows = (count + g.columns - 1) / g.columns;
    g.halfWidth = 0.5f * float(g.columns - 1) * kSpacing + 0.6f;
    g.halfDepth = 0.5f * float(g.rows - 1) * kSpacing + 0.6f;
    return g;
}

// Places object i: rows of one kind each (bunnies, dragons, teapots, repeating), front row first,
// a deterministic yaw so that the instances do not all look alike.
ObjectsScenePlacement place(const Grid& g, uint32_t count, uint32_t i, glm::vec3& position, float& yaw) {
    const uint32_t row = i / g.columns, col = i % g.columns;
    const uint32_t inRow = std::min(g.columns, count - row * g.columns);
    const MeshKind& k = kKinds[row % 3];
    const float x = (float(col) - 0.5f * float(inRow - 1)) * kSpacing;
    const float z = (0.5f * float(g.rows - 1) - float(row)) * kSpacing;
    position = glm::vec3(x, -k.lo.y * k.scale, z);
    yaw = float(int((i * 47u) % 91u) - 45);
    const glm::vec3 c = 0.5f * (k.lo + k.hi) * k.scale;
    const float r = 0.5f * glm::length(k.hi - k.lo) * k.scale;
    // Rotation about Y moves the centre's xz offset; the sphere radius covers any yaw.
    const float a = glm::radians(yaw);
    const glm::vec3 rc(std::cos(a) * c.x + std::sin(a) * c.z, c.y, -std::sin(a) * c.x + std::cos(a) * c.z);
    return {fmt::format("object {}", i), k.kind, position + rc, r};
}

// True when the sphere (world space) lies inside the frustum of a camera at `eye` looking along
// pitch (about X, no yaw) with half angles tanY / tanX and the given near plane.
bool sphereInView(const glm::vec3& eye, float pitch, float tanX, float tanY, float near, const glm::vec3& c,
                  float r) {
    const glm::vec3 d = c - eye;
    // View space: x right, y up, z back (the camera looks along -z).
    // Camera axes: forward (0, sin p, -cos p), up (0, cos p, sin p), right (1, 0, 0).
    const float vx = d.x;
    const float vy = std::cos(pitch) * d.y + std::sin(pitch) * d.z;
    const float depth = std::sin(pitch) * d.y - std::cos(pitch) * d.z;
    const float cx = 1.0f / std::sqrt(1.0f + tanX * tanX), cy = 1.0f / std::sqrt(1.0f + tanY * tanY);
    return depth - r > near && std::abs(vx) <= depth * tanX - r / cx && std::abs(vy) <= depth * tanY - r / cy;
}

json box(const std::string& name, glm::vec3 center, glm::vec3 half) {
    return {
        {"name", name},
        {"transform", {{"position", {center.x, center.y, center.z}}}},
        {"sdf",
         {{"shape", {{"shape", "box"}, {"halfExtents", {half.x, half.y, half.z}}}}, {"material", "room"}}}};
}

}  // namespace

bool generateObjectsScene(const ObjectsSceneDesc& desc, ObjectsScene& out, std::string& error) {
    if (desc.count < 1 || desc.count > kMaxObjectsSceneCount) {
        error = fmt::format("object count {} is out of range [1, {}]", desc.count, kMaxObjectsSceneCount);
        return false;
    }
    if (desc.resolution < 8 || desc.resolution > 1024) {
        error = fmt::format("bake resolution {} is out of range [8, 1024]", desc.resolution);
        return false;
    }
    if (!(desc.aspect > 0.0f) || !(desc.fovYDegrees > 1.0f && desc.fovYDegrees < 170.0f)) {
        error = fmt::format("aspect {} / field of view {} degrees invalid", desc.aspect, desc.fovYDegrees);
        return false;
    }
    out = {};
    const Grid g = gridFor(desc.count);
    out.columns = g.columns;
    out.rows = g.rows;

    json entities = json::array();
    std::vector<std::pair<glm::vec3, float>> poses;
    for (uint32_t i = 0; i < desc.count; ++i) {
        glm::vec3 position;
        float yaw = 0;
        out.objects.push_back(place(g, desc.count, i, position, yaw));
        poses.emplace_back(position, yaw);
    }

    // Camera: fixed pitch, centred on the grid; the smallest distance (bisection; moving back along
    // the view direction only adds depth, so "all in view" is monotone) with every bounding sphere
    // 5 % larger inside the frustum.
    const float pitch = glm::radians(kPitchDegrees);
    const float tanY = std::tan(glm::radians(desc.fovYDegrees) * 0.5f), tanX = tanY * desc.aspect;
    const glm::vec3 forward(0.0f, std::sin(pitch), -std::cos(pitch));
    const glm::vec3 target(0.0f, 0.35f, 0.0f);
    auto allInView = [&](float dist) {
        const glm::vec3 eye = target - forward * dist;
        for (const ObjectsScenePlacement& o : out.objects)
            if (!sphereInView(eye, pitch, tanX, tanY, out.cameraNear, o.center, o.radius * 1.05f))
                return false;
        return true;
    };
    float lo = 0.5f, hi = 1.0f;
    while (!allInView(hi)) hi *= 2.0f;
    for (int it = 0; it < 40; ++it) {
        const float mid = 0.5f * (lo + hi);
        (allInView(mid) ? hi : lo) = mid;
    }
    out.cameraPosition = target - forward * hi;
    out.cameraPitchDegrees = kPitchDegrees;
    out.cameraFar = hi + 2.0f * (g.halfWidth + g.halfDepth) + 10.0f;

    const glm::vec3& eye = out.cameraPosition;
    entities.push_back(
        {{"name", "camera"},
         {"transform", {{"position", {eye.x, eye.y, eye.z}}, {"eulerDegrees", {kPitchDegrees, 0, 0}}}},
         {"camera", {{"fovYDegrees", desc.fovYDegrees}, {"near", out.cameraNear}, {"far", out.cameraFar}}}});
    entities.push_back({{"name", "sun"},
                        {"transform", {{"eulerDegrees", {-50, -30, 0}}}},
                        {"light",
                         {{"type", "directional"},
                          {"color", {1.0, 0.96, 0.9}},
                          {"intensity", 2.5},
                          {"castShadows", true},
                          {"angularRadiusDegrees", 1.0}}}});
    // The room: floor slab, back wall, side walls (analytic boxes, 1 unit beyond the objects).
    const float w = g.halfWidth + 1.0f, d = g.halfDepth + 1.0f;
    entities.push_back(box("floor", {0, -0.1f, 0}, {w + 0.2f, 0.1f, d + 0.2f}));
    entities.push_back(
        box("back wall", {0, 0.5f * kWallHeight, -d - 0.1f}, {w + 0.2f, 0.5f * kWallHeight, 0.1f}));
    entities.push_back(box("left wall", {-w - 0.1f, 0.5f * kWallHeight, 0}, {0.1f, 0.5f * kWallHeight, d}));
    entities.push_back(box("right wall", {w + 0.1f, 0.5f * kWallHeight, 0}, {0.1f, 0.5f * kWallHeight, d}));

    const std::string dir =
        desc.meshDir.empty() || desc.meshDir.back() == '/' ? desc.meshDir : desc.meshDir + "/";
    for (uint32_t i = 0; i < desc.count; ++i) {
        const MeshKind& k = kKinds[(i / g.columns) % 3];
        const auto& [p, yaw] = poses[i];
        json sdf = {{"mesh", dir + k.file}, {"resolution", desc.resolution}, {"material", k.material}};
        if (!desc.instanced) sdf["shared"] = false;
        entities.push_back(
            {{"name", out.objects[i].name},
             {"transform",
              {{"position", {p.x, p.y, p.z}}, {"eulerDegrees", {0, yaw, 0}}, {"scale", k.scale}}},
             {"sdf", sdf}});
    }

    json scene = {
        {"version", 2},
        {"description",
         fmt::format(
             "penumbra bench objects: {} objects ({} columns x {} rows of bunnies, dragons and teapots, "
             "{}; bake resolution {}) in a room, all in view (mTec, reference 000 section 8.2.4)",
             desc.count, g.columns, g.rows,
             desc.instanced ? "instanced" : "non-instanced: each its own field", desc.resolution)},
        {"render",
         {{"width", 320},
          {"height", 180},
          {"shading", "cook-torrance"},
          {"toneMapper", "aces"},
          {"ambient", {0.03, 0.03, 0.035}},
          {"background", {0.05, 0.06, 0.08}},
          {"camera", "camera"},
          {"quality", "medium"},
          {"shadows", {{"enabled", true}}},
          {"ao", {{"variant", "cones"}}}}},
        {"materials",
         {{"room", {{"baseColor", {0.55, 0.55, 0.52}}, {"roughness", 0.9}}},
          {"terracotta", {{"baseColor", {0.78, 0.33, 0.22}}, {"roughness", 0.6}}},
          {"jade", {{"baseColor", {0.18, 0.55, 0.34}}, {"roughness", 0.25}}},
          {"gold", {{"baseColor", {1.0, 0.77, 0.34}}, {"metallic", 1.0}, {"roughness", 0.3}}}}},
        {"entities", entities}};
    out.json = scene.dump(1) + "\n";
    return true;
}

}  // namespace penumbra::scene
