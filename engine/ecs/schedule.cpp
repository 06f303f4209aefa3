#include "engine/ecs/schedule.h"

#include <algorithm>
#include <chrono>

#include "engine/core/log.h"
#include "engine/ecs/world.h"

namespace penumbra::ecs {

bool Schedule::check(const std::string& name, const System& system) const {
    if (!system) {
        log::error("ecs: Schedule: system '{}' has no function", name);
        return false;
    }
    if (contains(name)) {
        log::error("ecs: Schedule: a system named '{}' is already scheduled", name);
        return false;
    }
    return true;
}

bool Schedule::add(std::string name, System system) {
    if (!check(name, system)) return false;
    m_systems.push_back(Entry{std::move(name), std::move(system), 0.0});
    return true;
}

bool Schedule::insertBefore(std::string_view before, std::string name, System system) {
    auto it =
        std::find_if(m_systems.begin(), m_systems.end(), [&](const Entry& e) { return e.name == before; });
    if (it == m_systems.end()) {
        log::error("ecs: Schedule: cannot insert '{}' before '{}': no such system", name, before);
        return false;
    }
    if (!check(name, system)) return false;
    m_systems.insert(it, Entry{std::move(name), std::move(system), 0.0});
    return true;
}

bool Schedule::remove(std::string_view name) {
    auto it =
        std::find_if(m_systems.begin(), m_systems.end(), [&](const Entry& e) { return e.name == name; });
    if (it == m_systems.end()) return false;
    m_systems.erase(it);
    return true;
}

bool Schedule::contains(std::string_view name) const {
    return std::any_of(m_systems.begin(), m_systems.end(), [&](const Entry& e) { return e.name == name; });
}

void Schedule::run(World& world, double dt) {
    using Clock = std::chrono::steady_clock;
    // By index: a system may add or remove systems; those take part from the next position on.
    for (size_t i = 0; i < m_systems.size(); ++i) {
        const auto t0 = Clock::now();
        const System system = m_systems[i].system;  // survives the entry being removed meanwhile
        system(world, dt);
        if (!world.iterating()) world.flush();
        if (i < m_systems.size()) {
            m_systems[i].lastCpuMs = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        }
    }
}

}  // namespace penumbra::ecs
