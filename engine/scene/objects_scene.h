// The object-count benchmark scene (issue 13 item 5; `penumbra bench objects`): mTec's layout
// (reference 000, section 8.2.4 / Table 2) — rows of bunnies, dragons and teapots standing in a
// room (a floor slab, a back wall and two side walls, all analytic boxes), lit by a shadowing sun
// with cone AO, with the camera fitted so that every object is in view.
//
// The scene is produced as scene JSON text (docs/FORMATS.md), so it loads through the ordinary
// scene loader and can be written to a file (`penumbra bench objects --write-scene`). Objects are
// baked from data/meshes (tools/fetch_meshes.sh) at one low resolution (default 32 voxels on the
// longest axis: quick bakes, cached, and 1000 non-instanced copies stay ~100 MiB of atlas).
// Instanced: every object of a kind shares one field asset (the loader shares a field per mesh and
// resolution). Non-instanced: every object has "shared": false, i.e. its own field asset and atlas
// slot (AssetManager::copySdfField).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

namespace penumbra::scene {

struct ObjectsSceneDesc {
    uint32_t count = 20;                  // objects (the room is not counted): 1 .. kMaxObjectsSceneCount
    bool instanced = true;                // false: each object its own field ("shared": false)
    uint32_t resolution = 32;             // bake resolution of every mesh (sdf "resolution")
    std::string meshDir = "data/meshes";  // written as given: relative paths resolve against the
                                          // folder the scene file will be in
    float aspect = 16.0f / 9.0f;          // image width / height the camera is fitted for
    float fovYDegrees = 45.0f;
};

inline constexpr uint32_t kMaxObjectsSceneCount = 100000;

// One generated object: entity name "object <i>", kind "bunny", "dragon" or "teapot", and the
// world-space bounding sphere of its mesh (for frustum checks and tests).
struct ObjectsScenePlacement {
    std::string name;
    std::string kind;
    glm::vec3 center{0.0f};
    float radius = 0.0f;
};

struct ObjectsScene {
    std::string json;  // the scene file's text
    std::vector<ObjectsScenePlacement> objects;
    uint32_t columns = 0, rows = 0;
    glm::vec3 cameraPosition{0.0f};
    float cameraPitchDegrees = 0.0f;  // about X (eulerDegrees [pitch, 0, 0]); looks along -Z
    float cameraNear = 0.1f, cameraFar = 100.0f;
    uint32_t roomObjects = 4;  // floor, back wall, two side walls (analytic boxes)
};

// False with `error` for a count outside 1 .. kMaxObjectsSceneCount, a resolution outside the
// baker's range, or a non-positive aspect / field of view.
bool generateObjectsScene(const ObjectsSceneDesc& desc, ObjectsScene& out, std::string& error);

}  // namespace penumbra::scene
