// The generated object-count benchmark scene (engine/scene/objects_scene.h, `penumbra bench
// objects`) written into the build tree for the GPU tests: baked meshes from data/meshes
// (tools/fetch_meshes.sh) in a room of analytic boxes.
#pragma once

#include <cstdint>
#include <string>

#include "engine/scene/objects_scene.h"
#include "support/test_files.h"

namespace penumbra::test {

// Writes the scene with `count` objects (instanced or not), its camera fitted to `aspect`, to
// <build>/test_cache/<name> and returns the path; empty with `error` when it could not.
inline std::string writeObjectsScene(const std::string& name, uint32_t count, float aspect,
                                     std::string& error, bool instanced = true) {
    scene::ObjectsSceneDesc d;
    d.count = count;
    d.instanced = instanced;
    d.meshDir = PENUMBRA_SOURCE_DIR "/data/meshes";
    d.aspect = aspect;
    scene::ObjectsScene s;
    if (!scene::generateObjectsScene(d, s, error)) return {};
    const std::string path = PENUMBRA_BINARY_DIR "/test_cache/" + name;
    if (!writeTestFile(path, s.json)) {
        error = "could not write " + path;
        return {};
    }
    return path;
}

}  // namespace penumbra::test
