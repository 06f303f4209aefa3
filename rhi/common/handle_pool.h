// Generational slot pool used by every backend to map rhi::Handle<Tag> to backend objects.
#pragma once

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "rhi/types.h"

namespace rhi::detail {

template <typename Tag, typename T>
class HandlePool {
public:
    using HandleT = Handle<Tag>;
    static constexpr uint32_t kMaxSlots = 0xffffu;

    // Stores the value and returns its handle; returns an invalid handle when the pool is full.
    HandleT insert(T value) {
        uint16_t index;
        if (!m_free.empty()) {
            index = m_free.back();
            m_free.pop_back();
        } else {
            if (m_slots.size() >= kMaxSlots) return {};
            index = uint16_t(m_slots.size());
            m_slots.emplace_back();
        }
        Slot& s = m_slots[index];
        s.value.emplace(std::move(value));
        ++m_live;
        return HandleT::make(index, s.generation);
    }

    T* get(HandleT h) {
        if (!h.isValid() || h.index() >= m_slots.size()) return nullptr;
        Slot& s = m_slots[h.index()];
        if (s.generation != h.generation() || !s.value) return nullptr;
        return &*s.value;
    }
    const T* get(HandleT h) const { return const_cast<HandlePool*>(this)->get(h); }
    bool contains(HandleT h) const { return get(h) != nullptr; }

    // Removes the value; returns it so the caller can defer its destruction. Stale: nullopt.
    std::optional<T> remove(HandleT h) {
        if (!get(h)) return std::nullopt;
        Slot& s = m_slots[h.index()];
        std::optional<T> out = std::move(s.value);
        s.value.reset();
        s.generation = uint16_t(s.generation == 0xffffu ? 1 : s.generation + 1);
        m_free.push_back(h.index());
        --m_live;
        return out;
    }

    template <typename F>
    void forEach(F&& f) {
        for (size_t i = 0; i < m_slots.size(); ++i)
            if (m_slots[i].value) f(HandleT::make(uint16_t(i), m_slots[i].generation), *m_slots[i].value);
    }

    size_t size() const { return m_live; }

private:
    struct Slot {
        std::optional<T> value;
        uint16_t generation = 1;
    };
    std::vector<Slot> m_slots;
    std::vector<uint16_t> m_free;
    size_t m_live = 0;
};

}  // namespace rhi::detail
