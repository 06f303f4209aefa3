// Entity handles: a 32-bit slot index plus a 32-bit generation. A World bumps a slot's generation
// every time the entity living in it is destroyed, so a handle kept after destruction (a "stale"
// handle) never matches the slot's new occupant: every World operation rejects it (null / false).
// A slot whose generation reaches 0xFFFFFFFF is retired instead of wrapping around, so a stale
// handle can never become valid again.
#pragma once

#include <compare>
#include <cstddef>
#include <cstdint>
#include <functional>

namespace penumbra::ecs {

struct Entity {
    static constexpr uint32_t kNullIndex = 0xFFFFFFFFu;

    uint32_t index = kNullIndex;
    uint32_t generation = 0;

    constexpr bool isNull() const { return index == kNullIndex; }

    // Packs the handle into 64 bits (generation high, index low), e.g. for serialization or hashing.
    constexpr uint64_t toBits() const { return (uint64_t(generation) << 32) | index; }
    static constexpr Entity fromBits(uint64_t bits) { return Entity{uint32_t(bits), uint32_t(bits >> 32)}; }

    friend constexpr bool operator==(Entity, Entity) = default;
    friend constexpr auto operator<=>(Entity a, Entity b) { return a.toBits() <=> b.toBits(); }
};

// The null entity: never alive; its components are always absent.
inline constexpr Entity kNullEntity{};

}  // namespace penumbra::ecs

template <>
struct std::hash<penumbra::ecs::Entity> {
    size_t operator()(penumbra::ecs::Entity e) const noexcept { return std::hash<uint64_t>{}(e.toBits()); }
};
