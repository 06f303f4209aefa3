// Deferred destruction: callbacks that release GPU objects once the submission serial that was
// current when they were destroyed has completed on the GPU.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <utility>

namespace rhi::detail {

class DeferredReleaseQueue {
public:
    // `serial`: the last submission that may still use the object (usually the next serial to be
    // submitted, since the object may be referenced by a list that is still being recorded).
    void push(uint64_t serial, std::function<void()> release) {
        m_items.push_back({serial, std::move(release)});
    }
    // Runs every release whose serial is <= completedSerial, in destruction order.
    void collect(uint64_t completedSerial) {
        while (!m_items.empty() && m_items.front().serial <= completedSerial) {
            auto fn = std::move(m_items.front().release);
            m_items.pop_front();
            fn();
        }
    }
    void releaseAll() { collect(~uint64_t(0)); }
    size_t pending() const { return m_items.size(); }

private:
    struct Item {
        uint64_t serial;
        std::function<void()> release;
    };
    std::deque<Item> m_items;
};

}  // namespace rhi::detail
