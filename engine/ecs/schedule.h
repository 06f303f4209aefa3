// Systems are plain functions (or any callable) `void(World&, double dt)`; a Schedule runs a list of
// them in the order they were added, applying queued world operations after each one.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::ecs {

class World;

using System = std::function<void(World&, double dt)>;

class Schedule {
public:
    struct Entry {
        std::string name;
        System system;
        double lastCpuMs = 0.0;  // wall-clock time of its last run
    };

    // Appends a system. False (logged) for an empty callable or a name already in the schedule.
    bool add(std::string name, System system);
    // Inserts before the system called `before`; false (logged) if it is absent or as for add().
    bool insertBefore(std::string_view before, std::string name, System system);
    bool remove(std::string_view name);
    bool contains(std::string_view name) const;

    // Runs every system in order with the same dt, then World::flush().
    void run(World& world, double dt);

    const std::vector<Entry>& systems() const { return m_systems; }
    size_t size() const { return m_systems.size(); }

private:
    bool check(const std::string& name, const System& system) const;

    std::vector<Entry> m_systems;
};

}  // namespace penumbra::ecs
