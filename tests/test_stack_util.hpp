// Runs an issue-3 stacking scene (demos/scenes, shared with `sinew bench rigid`) and measures what the
// stacking tests assert: the largest distance any dynamic box moved from its start, and the kinetic
// energy over the second half of the run (a resting stack must not gain energy).
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include "engine/world/scene.hpp"

namespace sinew::test {

struct StackRun {
    double max_drift = 0;
    double final_kinetic_energy = 0;
    double max_kinetic_energy_late = 0;  // over the second half of the run
};

inline SceneDesc load_stack_scene(const std::string& name) {
    return parse_scene_file(std::string(SINEW_SOURCE_DIR) + "/demos/scenes/" + name + ".json");
}

inline StackRun run_stack(const SceneDesc& scene, int steps) {
    std::vector<BodyId> ids;
    auto world = build_world(scene, &ids);
    std::vector<Vec3> start;
    std::vector<BodyId> dyn;
    for (std::size_t i = 0; i < ids.size(); ++i)
        if (scene.bodies[i].def.type == BodyType::Dynamic) {
            dyn.push_back(ids[i]);
            start.push_back(world->rigid().transform(ids[i]).p);
        }
    StackRun r;
    for (int s = 0; s < steps; ++s) {
        world->step();
        for (std::size_t i = 0; i < dyn.size(); ++i)
            r.max_drift = std::max(r.max_drift, double((world->rigid().transform(dyn[i]).p - start[i]).norm()));
        if (s >= steps / 2)
            r.max_kinetic_energy_late = std::max(r.max_kinetic_energy_late, world->rigid().kinetic_energy());
    }
    r.final_kinetic_energy = world->rigid().kinetic_energy();
    return r;
}

}  // namespace sinew::test
