// World: entities, their components, views over component combinations.
//
//   World world;
//   Entity e = world.create();
//   world.add<Velocity>(e, 1.f, 0.f, 0.f);
//   for (auto [entity, t, v] : world.view<Transform, const Velocity>()) t.position += v.value * dt;
//   (bind with `auto` or `auto&&`: each element is a tuple of an Entity and references)
//   world.view<Transform, const Velocity>().each([&](Transform& t, const Velocity& v) { ... });
//
// Handles: every operation taking an Entity rejects null and stale handles (get -> nullptr,
// add -> nullptr, has/remove/destroy -> false); nothing is undefined for a bad handle.
//
// Changes during iteration (THE RULE): while any view iteration is in progress (a range-for over
// a view, a view's each(), World::eachEntity(), nested or not), the set of (entity, component)
// pairs does not change:
//   - destroy(e), remove<T>(e) and add<T>(e, ...) (also when e already has a T) are queued in call
//     order and applied when the outermost iteration ends (or by flush() once no iteration is
//     running). Each queued operation re-checks its entity when applied: one aimed at an entity
//     destroyed earlier in the queue is dropped. add() returns a pointer to the queued value, which
//     may still be modified until it is applied.
//   - create() takes effect at once; the new entity has no components yet, so no view visits it.
//   - Until the queue is applied, queries answer for the current state: alive(e) stays true for an
//     entity queued for destruction (isPendingDestroy(e) says it is queued); has/get do not see
//     queued adds or removes. Component values may be modified freely through references.
// So an iteration visits every entity that had the components when it began exactly once, and
// component references handed out by the iteration stay valid for the whole iteration.
//
// Outside iteration, pointers returned by get/add stay valid until the next structural change of
// that component type (adding or removing a T may move the T array).
//
// Not thread-safe: one thread uses a World at a time.
#pragma once

#include <cstdint>
#include <memory>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "engine/ecs/entity.h"
#include "engine/ecs/storage.h"

namespace penumbra::ecs {

class World;

namespace detail {

// Holds "an iteration is in progress" on a world for its lifetime (copies hold it too).
class IterationGuard {
public:
    IterationGuard() = default;
    explicit IterationGuard(const World* world);
    IterationGuard(const IterationGuard& o);
    IterationGuard(IterationGuard&& o) noexcept : m_world(std::exchange(o.m_world, nullptr)) {}
    IterationGuard& operator=(IterationGuard o) noexcept {
        std::swap(m_world, o.m_world);
        return *this;
    }
    ~IterationGuard();

private:
    const World* m_world = nullptr;
};

template <typename T>
using PoolPtr = std::conditional_t<std::is_const_v<T>, const Pool<std::remove_const_t<T>>*,
                                   Pool<std::remove_const_t<T>>*>;

}  // namespace detail

struct Sentinel {};

// Entities having all of Ts (a const T gives const access). Iterates the smallest pool and checks
// the others. Cheap to build; build it where you iterate.
template <typename... Ts>
class View {
    static_assert(sizeof...(Ts) > 0, "a view needs at least one component type");

public:
    using Pools = std::tuple<detail::PoolPtr<Ts>...>;
    using value_type = std::tuple<Entity, Ts&...>;

    class Iterator {
    public:
        using value_type = View::value_type;
        using difference_type = std::ptrdiff_t;

        value_type operator*() const { return deref(std::index_sequence_for<Ts...>{}); }
        Iterator& operator++() {
            ++m_pos;
            settle();
            return *this;
        }
        bool operator==(Sentinel) const { return m_pos >= m_end; }
        bool operator!=(Sentinel) const { return m_pos < m_end; }
        Entity entity() const { return m_entities[m_pos]; }

    private:
        friend class View;
        Iterator(const World* world, const Pools& pools, const PoolBase* lead)
            : m_guard(world),
              m_pools(pools),
              m_entities(lead ? lead->entities() : nullptr),
              m_end(lead ? lead->size() : 0),
              m_lead(lead) {
            settle();
        }

        // Moves to the first position at or after m_pos whose entity has every component.
        void settle() {
            while (m_pos < m_end && !matches(std::index_sequence_for<Ts...>{})) ++m_pos;
        }
        template <size_t... I>
        bool matches(std::index_sequence<I...>) {
            const Entity e = m_entities[m_pos];
            return (locate<I>(e) && ...);
        }
        template <size_t I>
        bool locate(Entity e) {
            const PoolBase* pool = std::get<I>(m_pools);
            if (pool == m_lead) {
                m_positions[I] = uint32_t(m_pos);
                return true;
            }
            m_positions[I] = pool->indexOf(e);
            return m_positions[I] != PoolBase::kAbsent;
        }
        template <size_t... I>
        value_type deref(std::index_sequence<I...>) const {
            return value_type(m_entities[m_pos], std::get<I>(m_pools)->components()[m_positions[I]]...);
        }

        detail::IterationGuard m_guard;
        Pools m_pools;
        const Entity* m_entities = nullptr;
        size_t m_pos = 0;
        size_t m_end = 0;
        const PoolBase* m_lead = nullptr;
        uint32_t m_positions[sizeof...(Ts)] = {};
    };

    View(const World* world, Pools pools) : m_world(world), m_pools(pools) {}

    Iterator begin() const { return Iterator(m_world, m_pools, lead()); }
    Sentinel end() const { return {}; }

    // fn(Entity, Ts&...) or fn(Ts&...), called for every matching entity.
    template <typename Fn>
    void each(Fn&& fn) const {
        for (auto it = begin(); it != end(); ++it) {
            if constexpr (std::is_invocable_v<Fn&, Entity, Ts&...>) {
                std::apply(fn, *it);
            } else {
                static_assert(std::is_invocable_v<Fn&, Ts&...>,
                              "each() takes fn(Entity, Components&...) or fn(Components&...)");
                std::apply([&](Entity, Ts&... c) { fn(c...); }, *it);
            }
        }
    }

    // Upper bound on the number of matches (size of the smallest pool).
    size_t sizeHint() const {
        const PoolBase* l = lead();
        return l ? l->size() : 0;
    }
    // Exact number of matching entities (walks the view).
    size_t count() const {
        size_t n = 0;
        for (auto it = begin(); it != end(); ++it) ++n;
        return n;
    }

private:
    // The smallest pool, or null when a component type has no pool (nothing matches).
    const PoolBase* lead() const {
        const PoolBase* best = nullptr;
        bool missing = false;
        std::apply(
            [&](auto... pool) {
                ((pool == nullptr
                      ? (missing = true)
                      : (best == nullptr || pool->size() < best->size() ? (best = pool, false) : false)),
                 ...);
            },
            m_pools);
        return missing ? nullptr : best;
    }

    const World* m_world;
    Pools m_pools;
};

class World {
public:
    World();
    ~World();
    World(const World&) = delete;
    World& operator=(const World&) = delete;
    // Moving is allowed while no iteration is running; pools keep their addresses.
    World(World&&) noexcept;
    World& operator=(World&&) noexcept;

    // ---- entities ---------------------------------------------------------------------------
    // A new entity with no components (a freed index is reused, with a higher generation). Null
    // only when all 2^32-1 indices are in use or retired (logged).
    Entity create();
    // Destroys e and all its components; during iteration it is queued (see the rule above).
    // False for null, stale, or already queued handles.
    bool destroy(Entity e);
    bool alive(Entity e) const;
    // True between destroy(e) during iteration and the flush that applies it.
    bool isPendingDestroy(Entity e) const;
    size_t aliveCount() const { return m_aliveCount; }
    // Room for n entity slots in total (avoids regrowth when creating many entities at once).
    void reserveEntities(size_t n) { m_slots.reserve(n); }
    // Calls fn(Entity) for every live entity, in index order (counts as an iteration).
    template <typename Fn>
    void eachEntity(Fn&& fn) const;

    // ---- components -------------------------------------------------------------------------
    // Constructs T for e (aggregates brace-initialised from args), replacing an existing T.
    // Returns the component (during iteration: the queued value), or null for a dead handle.
    template <Component T, typename... Args>
    T* add(Entity e, Args&&... args);
    template <Component T>
    T* get(Entity e);
    template <Component T>
    const T* get(Entity e) const;
    template <Component T>
    bool has(Entity e) const;
    // Removes e's T; false when e is dead or has no T. During iteration: queued, true if e has T now.
    template <Component T>
    bool remove(Entity e);
    // Number of entities with a T.
    template <Component T>
    size_t count() const;
    // Room for n components of type T (avoids regrowth; creates the pool).
    template <Component T>
    void reserve(size_t n);

    // Raw storage for systems that want dense arrays (null if no T was ever added). Changing the
    // set of entities through it bypasses the iteration rule: only read or modify values.
    template <Component T>
    Pool<T>* pool();
    template <Component T>
    const Pool<T>* pool() const;

    // ---- views ------------------------------------------------------------------------------
    template <typename... Ts>
    View<Ts...> view();
    template <typename... Ts>
    View<const Ts...> view() const;

    // ---- deferred operations ----------------------------------------------------------------
    bool iterating() const { return m_iterationDepth > 0; }
    size_t pendingCount() const { return m_pending.size(); }
    // Applies queued operations now. Refused (false, logged) while an iteration is running.
    bool flush();

    // Destroys every entity and component, keeping allocated storage; freed indices are reused from
    // 0 up with bumped generations (handles from before stay stale). Refused (false, logged) during
    // iteration.
    bool clear();

private:
    friend class detail::IterationGuard;

    struct Slot {
        uint32_t generation = 0;
        bool alive = false;
        bool pendingDestroy = false;
    };

    struct Staged {
        virtual ~Staged() = default;
        virtual void apply(World& world, Entity e) = 0;
    };
    template <typename T>
    struct StagedComponent final : Staged {
        template <typename... Args>
        explicit StagedComponent(Args&&... args) : value(Pool<T>::make(std::forward<Args>(args)...)) {}
        void apply(World& world, Entity e) override {
            if (Pool<T>* p = world.getOrCreatePool<T>()) p->emplace(e, std::move(value));
        }
        T value;
    };

    enum class Op : uint8_t { Destroy, Remove, Add };
    struct Pending {
        Op op;
        Entity entity;
        PoolBase* pool = nullptr;        // Remove
        std::unique_ptr<Staged> staged;  // Add
    };

    void beginIteration() const { ++m_iterationDepth; }
    void endIteration() const;
    void destroyNow(Entity e);

    // Open-addressing table keyed by ComponentType::key (linear probing, power-of-two size).
    struct PoolSlot {
        uint64_t key = 0;
        PoolBase* pool = nullptr;  // null: empty slot
    };
    PoolBase* findPool(const ComponentType& type) const {
        if (m_poolTable.empty()) return nullptr;
        const size_t mask = m_poolTable.size() - 1;
        for (size_t i = size_t(type.key) & mask;; i = (i + 1) & mask) {
            const PoolSlot& slot = m_poolTable[i];
            if (!slot.pool) return nullptr;
            if (slot.key == type.key)
                return slot.pool->sameType(type) ? slot.pool : reportTypeClash(type, *slot.pool);
        }
    }
    PoolBase* reportTypeClash(const ComponentType& type, const PoolBase& have) const;
    PoolBase* insertPool(std::unique_ptr<PoolBase> pool);
    // Null only when another type with the same name but a different layout owns the slot (logged).
    template <Component T>
    Pool<T>* getOrCreatePool();

    std::vector<Slot> m_slots;
    std::vector<uint32_t> m_freeIndices;
    size_t m_aliveCount = 0;

    std::vector<std::unique_ptr<PoolBase>> m_pools;
    std::vector<PoolSlot> m_poolTable;

    mutable uint32_t m_iterationDepth = 0;
    std::vector<Pending> m_pending;
};

// ---- implementation of the templates ------------------------------------------------------------

template <Component T>
Pool<T>* World::pool() {
    return static_cast<Pool<T>*>(findPool(componentType<T>()));
}

template <Component T>
const Pool<T>* World::pool() const {
    return static_cast<const Pool<T>*>(findPool(componentType<T>()));
}

template <Component T>
Pool<T>* World::getOrCreatePool() {
    if (Pool<T>* p = pool<T>()) return p;
    return static_cast<Pool<T>*>(insertPool(std::make_unique<Pool<T>>()));
}

template <Component T, typename... Args>
T* World::add(Entity e, Args&&... args) {
    if (!alive(e)) return nullptr;
    Pool<T>* p = getOrCreatePool<T>();
    if (!p) return nullptr;
    if (m_iterationDepth > 0) {
        auto staged = std::make_unique<StagedComponent<T>>(std::forward<Args>(args)...);
        T* value = &staged->value;
        m_pending.push_back(Pending{Op::Add, e, nullptr, std::move(staged)});
        return value;
    }
    return &p->emplace(e, std::forward<Args>(args)...);
}

template <Component T>
T* World::get(Entity e) {
    Pool<T>* p = pool<T>();
    return p ? p->get(e) : nullptr;
}

template <Component T>
const T* World::get(Entity e) const {
    const Pool<T>* p = pool<T>();
    return p ? p->get(e) : nullptr;
}

template <Component T>
bool World::has(Entity e) const {
    const Pool<T>* p = pool<T>();
    return p && p->contains(e);
}

template <Component T>
bool World::remove(Entity e) {
    Pool<T>* p = pool<T>();
    if (!p || !alive(e)) return false;
    if (m_iterationDepth > 0) {
        if (!p->contains(e)) return false;
        m_pending.push_back(Pending{Op::Remove, e, p, nullptr});
        return true;
    }
    return p->remove(e);
}

template <Component T>
size_t World::count() const {
    const Pool<T>* p = pool<T>();
    return p ? p->size() : 0;
}

template <Component T>
void World::reserve(size_t n) {
    if (Pool<T>* p = getOrCreatePool<T>()) p->reserve(n);
}

template <typename... Ts>
View<Ts...> World::view() {
    // Pools are created on demand so that a view built before the first add<T> still sees later ones.
    return View<Ts...>(this, typename View<Ts...>::Pools(getOrCreatePool<std::remove_const_t<Ts>>()...));
}

template <typename... Ts>
View<const Ts...> World::view() const {
    return View<const Ts...>(this, typename View<const Ts...>::Pools(pool<std::remove_const_t<Ts>>()...));
}

namespace detail {
inline IterationGuard::IterationGuard(const World* world) : m_world(world) {
    if (m_world) m_world->beginIteration();
}
inline IterationGuard::IterationGuard(const IterationGuard& o) : m_world(o.m_world) {
    if (m_world) m_world->beginIteration();
}
inline IterationGuard::~IterationGuard() {
    if (m_world) m_world->endIteration();
}
}  // namespace detail

template <typename Fn>
void World::eachEntity(Fn&& fn) const {
    detail::IterationGuard guard(this);
    const size_t n = m_slots.size();
    for (size_t i = 0; i < n; ++i) {
        if (m_slots[i].alive) fn(Entity{uint32_t(i), m_slots[i].generation});
    }
}

}  // namespace penumbra::ecs
