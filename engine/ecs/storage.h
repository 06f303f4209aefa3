// Component storage: one sparse set per component type.
//
//   sparse  entity index -> dense position, in pages of 4096 entries allocated on first use
//   dense   entity handles and components side by side in two packed arrays
//
// Removal swaps the last element into the hole (O(1), order not preserved). Lookups check the full
// handle stored in the dense array, so a stale handle (old generation) is never found.
//
// Component types are identified by their qualified type name (hashed at compile time), not by a
// per-module counter, so the host executable and plugins loaded with dlopen agree on them. Two
// distinct types with the same qualified name (e.g. the same struct name in two anonymous
// namespaces) must therefore not be used in one World.
#pragma once

#include <algorithm>
#include <concepts>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "engine/ecs/entity.h"

namespace penumbra::ecs {

// Anything that can be moved around (the dense array swap-removes with move assignment).
template <typename T>
concept Component = std::is_object_v<T> && !std::is_const_v<T> && !std::is_volatile_v<T> && std::movable<T>;

namespace detail {

template <typename T>
constexpr std::string_view prettyFunction() {
    return __PRETTY_FUNCTION__;
}

// "... [with T = ns::Name; ...]" (GCC) or "... [T = ns::Name]" (Clang) -> "ns::Name".
template <typename T>
constexpr std::string_view typeName() {
    constexpr std::string_view raw = prettyFunction<T>();
    constexpr std::string_view marker = "T = ";
    constexpr size_t start = raw.find(marker) + marker.size();
    constexpr size_t end = raw.find_first_of(";]", start);
    return raw.substr(start, end - start);
}

constexpr uint64_t fnv1a(std::string_view s) {
    uint64_t h = 0xcbf29ce484222325ull;
    for (char c : s) {
        h ^= uint8_t(c);
        h *= 0x100000001b3ull;
    }
    return h;
}

}  // namespace detail

struct ComponentType {
    uint64_t key = 0;  // hash of the qualified name
    std::string_view name;
    size_t size = 0;
    size_t align = 0;
};

template <Component T>
inline constexpr ComponentType kComponentType{detail::fnv1a(detail::typeName<T>()), detail::typeName<T>(),
                                              sizeof(T), alignof(T)};

template <Component T>
constexpr const ComponentType& componentType() {
    return kComponentType<T>;
}

// The type-independent half of a pool: the sparse set of entities.
class PoolBase {
public:
    static constexpr uint32_t kAbsent = 0xFFFFFFFFu;
    static constexpr uint32_t kPageBits = 12;
    static constexpr uint32_t kPageSize = 1u << kPageBits;

    // Keeps its own copy of the name: a plugin that registered the type may be unloaded first.
    explicit PoolBase(ComponentType type) : m_name(type.name), m_sourceName(type.name.data()), m_type(type) {
        m_type.name = m_name;
    }
    virtual ~PoolBase() = default;
    PoolBase(const PoolBase&) = delete;
    PoolBase& operator=(const PoolBase&) = delete;

    const ComponentType& type() const { return m_type; }
    // Whether `other` describes this pool's component type (same name and layout). The name's
    // address is compared first: within one module it is the same string.
    bool sameType(const ComponentType& other) const {
        if (other.key != m_type.key || other.size != m_type.size || other.align != m_type.align) return false;
        return other.name.data() == m_sourceName || other.name == m_name;
    }
    size_t size() const { return m_entities.size(); }
    bool empty() const { return m_entities.empty(); }
    // Entities that have this component, in dense order (parallel to the component array).
    const Entity* entities() const { return m_entities.data(); }

    // Dense position of e's component, or kAbsent (null, stale or without this component).
    uint32_t indexOf(Entity e) const {
        const uint32_t page = e.index >> kPageBits;
        if (page >= m_sparse.size() || !m_sparse[page]) return kAbsent;
        const uint32_t pos = m_sparse[page][e.index & (kPageSize - 1)];
        if (pos == kAbsent || m_entities[pos] != e) return kAbsent;
        return pos;
    }
    bool contains(Entity e) const { return indexOf(e) != kAbsent; }

    // Removes e's component (swap with the last one). False if e has none.
    bool remove(Entity e) {
        const uint32_t pos = indexOf(e);
        if (pos == kAbsent) return false;
        const uint32_t last = uint32_t(m_entities.size() - 1);
        if (pos != last) {
            const Entity moved = m_entities[last];
            m_entities[pos] = moved;
            slot(moved.index) = pos;
        }
        slot(e.index) = kAbsent;
        m_entities.pop_back();
        swapRemoveComponent(pos);
        return true;
    }

    // Capacity for n entities in the dense array (and the components, in the derived pool).
    void reserve(size_t n) {
        m_entities.reserve(n);
        reserveComponents(n);
    }

    // Removes everything; allocated pages and capacity are kept for reuse.
    void clear() {
        for (auto& page : m_sparse) {
            if (page) std::fill_n(page.get(), kPageSize, kAbsent);
        }
        m_entities.clear();
        clearComponents();
    }

protected:
    // Appends e at the end of the dense array; the caller appends the component. e must be absent.
    uint32_t insertEntity(Entity e) {
        const uint32_t page = e.index >> kPageBits;
        if (page >= m_sparse.size()) m_sparse.resize(page + 1);
        if (!m_sparse[page]) {
            m_sparse[page] = std::make_unique<uint32_t[]>(kPageSize);
            std::fill_n(m_sparse[page].get(), kPageSize, kAbsent);
        }
        const uint32_t pos = uint32_t(m_entities.size());
        m_sparse[page][e.index & (kPageSize - 1)] = pos;
        m_entities.push_back(e);
        return pos;
    }
    // Undoes insertEntity for the last element (used when constructing the component threw).
    void popLastEntity() {
        slot(m_entities.back().index) = kAbsent;
        m_entities.pop_back();
    }

    virtual void swapRemoveComponent(uint32_t pos) = 0;
    virtual void clearComponents() = 0;
    virtual void reserveComponents(size_t n) = 0;

private:
    uint32_t& slot(uint32_t index) { return m_sparse[index >> kPageBits][index & (kPageSize - 1)]; }

    std::string m_name;
    const char* m_sourceName;  // compared, never dereferenced (its module may be unloaded)
    ComponentType m_type;
    std::vector<std::unique_ptr<uint32_t[]>> m_sparse;
    std::vector<Entity> m_entities;
};

template <Component T>
class Pool final : public PoolBase {
public:
    Pool() : PoolBase(componentType<T>()) {}

    // Components in dense order, parallel to entities().
    T* components() { return m_components.data(); }
    const T* components() const { return m_components.data(); }

    T* get(Entity e) {
        const uint32_t pos = indexOf(e);
        return pos == kAbsent ? nullptr : &m_components[pos];
    }
    const T* get(Entity e) const {
        const uint32_t pos = indexOf(e);
        return pos == kAbsent ? nullptr : &m_components[pos];
    }

    // Constructs the component, replacing (move-assigning over) an existing one. The caller
    // guarantees e is alive.
    template <typename... Args>
    T& emplace(Entity e, Args&&... args) {
        const uint32_t pos = indexOf(e);
        if (pos != kAbsent) {
            m_components[pos] = make(std::forward<Args>(args)...);
            return m_components[pos];
        }
        insertEntity(e);
        try {
            return m_components.emplace_back(make(std::forward<Args>(args)...));
        } catch (...) {
            popLastEntity();
            throw;
        }
    }

    // Aggregates are brace-initialised (add<Velocity>(e, 1.f, 2.f)), other types use a constructor.
    template <typename... Args>
    static T make(Args&&... args) {
        if constexpr (std::is_aggregate_v<T>) {
            return T{std::forward<Args>(args)...};
        } else {
            return T(std::forward<Args>(args)...);
        }
    }

private:
    void swapRemoveComponent(uint32_t pos) override {
        if (pos + 1 != m_components.size()) m_components[pos] = std::move(m_components.back());
        m_components.pop_back();
    }
    void clearComponents() override { m_components.clear(); }
    void reserveComponents(size_t n) override { m_components.reserve(n); }

    std::vector<T> m_components;
};

}  // namespace penumbra::ecs
