#include "engine/ecs/world.h"

#include <algorithm>
#include <limits>

#include "engine/core/log.h"

namespace penumbra::ecs {

World::World() = default;
World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

Entity World::create() {
    if (!m_freeIndices.empty()) {
        const uint32_t index = m_freeIndices.back();
        m_freeIndices.pop_back();
        Slot& slot = m_slots[index];
        slot.alive = true;
        slot.pendingDestroy = false;
        ++m_aliveCount;
        return Entity{index, slot.generation};
    }
    if (m_slots.size() >= Entity::kNullIndex) {
        log::error("ecs: cannot create an entity: all {} entity indices are in use or retired",
                   m_slots.size());
        return kNullEntity;
    }
    const uint32_t index = uint32_t(m_slots.size());
    m_slots.push_back(Slot{0, true, false});
    ++m_aliveCount;
    return Entity{index, 0};
}

bool World::alive(Entity e) const {
    if (e.index >= m_slots.size()) return false;
    const Slot& slot = m_slots[e.index];
    return slot.alive && slot.generation == e.generation;
}

bool World::isPendingDestroy(Entity e) const { return alive(e) && m_slots[e.index].pendingDestroy; }

bool World::destroy(Entity e) {
    if (!alive(e)) return false;
    Slot& slot = m_slots[e.index];
    if (slot.pendingDestroy) return false;
    if (m_iterationDepth > 0) {
        slot.pendingDestroy = true;
        m_pending.push_back(Pending{Op::Destroy, e, nullptr, nullptr});
        return true;
    }
    destroyNow(e);
    return true;
}

void World::destroyNow(Entity e) {
    for (auto& pool : m_pools) pool->remove(e);
    Slot& slot = m_slots[e.index];
    slot.alive = false;
    slot.pendingDestroy = false;
    --m_aliveCount;
    // A slot whose generation would wrap is retired: an old handle must never match it again.
    if (slot.generation == std::numeric_limits<uint32_t>::max()) return;
    ++slot.generation;
    m_freeIndices.push_back(e.index);
}

void World::endIteration() const {
    if (--m_iterationDepth == 0 && !m_pending.empty()) {
        // Operations can only have been queued through a non-const World, so the object is not const.
        const_cast<World*>(this)->flush();
    }
}

bool World::flush() {
    if (m_iterationDepth > 0) {
        log::error(
            "ecs: World::flush() called during an iteration; queued operations are applied when it ends");
        return false;
    }
    // Applying an operation may run component destructors or moves that queue nothing (no iteration
    // is running), so one pass empties the queue; loop anyway in case a destructor destroys entities.
    while (!m_pending.empty()) {
        std::vector<Pending> pending = std::move(m_pending);
        m_pending.clear();
        for (Pending& p : pending) {
            switch (p.op) {
                case Op::Destroy:
                    if (alive(p.entity)) destroyNow(p.entity);
                    break;
                case Op::Remove:
                    if (alive(p.entity)) p.pool->remove(p.entity);
                    break;
                case Op::Add:
                    if (alive(p.entity)) p.staged->apply(*this, p.entity);
                    break;
            }
        }
    }
    return true;
}

bool World::clear() {
    if (m_iterationDepth > 0) {
        log::error("ecs: World::clear() called during an iteration; refused");
        return false;
    }
    m_pending.clear();
    for (auto& pool : m_pools) pool->clear();
    m_freeIndices.clear();
    for (uint32_t i = 0; i < m_slots.size(); ++i) {
        Slot& slot = m_slots[i];
        if (slot.alive) {
            slot.alive = false;
            slot.pendingDestroy = false;
            if (slot.generation == std::numeric_limits<uint32_t>::max()) continue;
            ++slot.generation;
        } else if (slot.generation == std::numeric_limits<uint32_t>::max()) {
            continue;  // retired
        }
        m_freeIndices.push_back(i);
    }
    // Reuse low indices first.
    std::reverse(m_freeIndices.begin(), m_freeIndices.end());
    m_aliveCount = 0;
    return true;
}

PoolBase* World::reportTypeClash(const ComponentType& type, const PoolBase& have) const {
    log::error(
        "ecs: component type '{}' ({} bytes) clashes with '{}' ({} bytes) already in this world; "
        "give component types distinct names",
        type.name, type.size, have.type().name, have.type().size);
    return nullptr;
}

PoolBase* World::insertPool(std::unique_ptr<PoolBase> pool) {
    const uint64_t key = pool->type().key;
    if ((m_pools.size() + 1) * 2 > m_poolTable.size()) {
        // Grow to keep the load at most 1/2, re-inserting every pool.
        std::vector<PoolSlot> table(std::max<size_t>(16, m_poolTable.size() * 2));
        const size_t mask = table.size() - 1;
        for (const auto& p : m_pools) {
            size_t i = size_t(p->type().key) & mask;
            while (table[i].pool) i = (i + 1) & mask;
            table[i] = PoolSlot{p->type().key, p.get()};
        }
        m_poolTable = std::move(table);
    }
    const size_t mask = m_poolTable.size() - 1;
    size_t i = size_t(key) & mask;
    for (; m_poolTable[i].pool; i = (i + 1) & mask) {
        if (m_poolTable[i].key == key) return nullptr;  // clash, already reported by findPool
    }
    PoolBase* raw = pool.get();
    m_pools.push_back(std::move(pool));
    m_poolTable[i] = PoolSlot{key, raw};
    return raw;
}

}  // namespace penumbra::ecs
