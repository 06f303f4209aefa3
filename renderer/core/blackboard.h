// A typed blackboard: feature modules publish what they produced this frame (a struct of
// frame-graph refs and settings) and later modules read it by type, so the frame function only
// orders modules and no module needs to know who produced its inputs.
//
//     bb.add<GBuffer>() = {...};                     // the mesh G-buffer module
//     if (const GBuffer* gb = bb.find<GBuffer>())    // the lighting module
//
// One value per type; add() replaces an earlier value of that type. Cleared every frame.
#pragma once

#include <any>
#include <typeindex>
#include <unordered_map>

namespace penumbra::render {

class Blackboard {
public:
    template <typename T>
    T& add(T value = T{}) {
        std::any& slot = m_values[std::type_index(typeid(T))];
        slot = std::move(value);
        return std::any_cast<T&>(slot);
    }
    template <typename T>
    const T* find() const {
        auto it = m_values.find(std::type_index(typeid(T)));
        return it == m_values.end() ? nullptr : std::any_cast<T>(&it->second);
    }
    template <typename T>
    bool has() const {
        return find<T>() != nullptr;
    }
    void clear() { m_values.clear(); }

private:
    std::unordered_map<std::type_index, std::any> m_values;
};

}  // namespace penumbra::render
