// The issue-13 acceleration toggles as the renderer tests switch them (scene::AccelerationSettings:
// tile culling, world cache, id field, cone prepass; the cache sizes stay as the scene has them).
#pragma once

#include "engine/scene/scene.h"

namespace penumbra::test {

struct AccelToggles {
    const char* name;
    bool culling, worldCache, idField;
    bool prepass = false;

    void applyTo(scene::AccelerationSettings& a) const {
        a.culling = culling;
        a.worldCache = worldCache;
        a.idField = idField;
        a.prepass = prepass;
    }
};

}  // namespace penumbra::test
