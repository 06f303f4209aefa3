#include "engine/ecs/components.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>

#include "engine/core/log.h"
#include "engine/ecs/world.h"

namespace penumbra::ecs {

glm::mat4 Transform::localMatrix() const {
    const glm::mat3 r = glm::mat3_cast(rotation);
    glm::mat4 m(1.0f);
    m[0] = glm::vec4(r[0] * scale.x, 0.0f);
    m[1] = glm::vec4(r[1] * scale.y, 0.0f);
    m[2] = glm::vec4(r[2] * scale.z, 0.0f);
    m[3] = glm::vec4(position, 1.0f);
    return m;
}

glm::vec3 Transform::worldForward() const {
    const glm::vec3 f = -glm::vec3(worldMatrix[2]);
    const float len = glm::length(f);
    return len > 0.0f ? f / len : glm::vec3(0.0f, 0.0f, -1.0f);
}

// ---- SDF objects -------------------------------------------------------------------------------

const char* sdfSourceName(SdfSource s) {
    switch (s) {
        case SdfSource::None:
            return "none";
        case SdfSource::Shapes:
            return "shapes";
        case SdfSource::Field:
            return "field";
        case SdfSource::MeshBake:
            return "mesh";
    }
    return "unknown";
}

// ---- hierarchy ----------------------------------------------------------------------------------

TransformUpdateStats updateTransforms(World& world) {
    TransformUpdateStats stats;
    Pool<Transform>* pool = world.pool<Transform>();
    if (!pool || pool->empty()) return stats;

    const size_t n = pool->size();
    Transform* transforms = pool->components();
    const Entity* entities = pool->entities();

    enum : uint8_t { kUnvisited, kOnPath, kDone };
    std::vector<uint8_t> state(n, kUnvisited);
    std::vector<uint32_t> path;  // a chain child -> ancestors still to compute

    // Dense position of the parent's Transform, or kAbsent for a root.
    auto parentOf = [&](uint32_t pos) { return pool->indexOf(transforms[pos].parent); };

    for (uint32_t start = 0; start < n; ++start) {
        if (state[start] == kDone) continue;
        // Walk up until a root or an already computed ancestor.
        uint32_t cur = start;
        for (;;) {
            state[cur] = kOnPath;
            path.push_back(cur);
            const uint32_t parent = parentOf(cur);
            if (parent == PoolBase::kAbsent || state[parent] == kDone) break;
            if (state[parent] == kOnPath) {
                const Entity e = entities[cur];
                log::warn(
                    "ecs: Transform parent cycle: entity {}:{} leads back to entity {}:{}; its parent "
                    "link is cleared",
                    e.index, e.generation, entities[parent].index, entities[parent].generation);
                transforms[cur].parent = kNullEntity;
                ++stats.cyclesBroken;
                break;
            }
            cur = parent;
        }
        // Compute from the topmost ancestor down.
        while (!path.empty()) {
            const uint32_t pos = path.back();
            path.pop_back();
            const uint32_t parent = parentOf(pos);
            Transform& t = transforms[pos];
            t.worldMatrix = parent == PoolBase::kAbsent ? t.localMatrix()
                                                        : transforms[parent].worldMatrix * t.localMatrix();
            state[pos] = kDone;
            ++stats.updated;
        }
    }
    return stats;
}

void transformSystem(World& world, double) { updateTransforms(world); }

bool setParent(World& world, Entity child, Entity parent) {
    Transform* ct = world.get<Transform>(child);
    if (!ct) {
        log::error("ecs: setParent: child entity {}:{} is not alive or has no Transform", child.index,
                   child.generation);
        return false;
    }
    if (parent.isNull()) {
        ct->parent = kNullEntity;
        return true;
    }
    if (!world.has<Transform>(parent)) {
        log::error("ecs: setParent: parent entity {}:{} is not alive or has no Transform", parent.index,
                   parent.generation);
        return false;
    }
    // Walk up from the new parent; meeting the child means the link would close a cycle. The walk is
    // bounded by the number of transforms, so an existing cycle above the parent cannot trap it.
    const size_t limit = world.count<Transform>();
    Entity cur = parent;
    for (size_t steps = 0; steps <= limit; ++steps) {
        if (cur == child) {
            log::error("ecs: setParent: making entity {}:{} the parent of entity {}:{} would create a cycle",
                       parent.index, parent.generation, child.index, child.generation);
            return false;
        }
        const Transform* t = world.get<Transform>(cur);
        if (!t) {
            ct->parent = parent;
            return true;
        }
        cur = t->parent;
    }
    log::error("ecs: setParent: the ancestors of entity {}:{} already form a cycle", parent.index,
               parent.generation);
    return false;
}

}  // namespace penumbra::ecs
