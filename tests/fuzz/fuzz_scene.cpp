// The scene loader under fuzzing: see fuzz_input.hpp.
#include <chrono>
#include <exception>
#include <memory>

#include "engine/world/scene.hpp"
#include "engine/world/world.hpp"
#include "tests/fuzz/fuzz_input.hpp"

namespace sinew::fuzz {

namespace {
// Worlds the fuzzer steps stay small, so one input takes milliseconds under the sanitizers; larger
// accepted scenes are parsed and built but not stepped.
constexpr std::size_t kMaxBodies = 64;
constexpr std::size_t kMaxParticles = 2048;
constexpr int kSteps = 20;
/// Steps stop early past this much time (an accepted implicit FEM beam at 300 CG iterations takes
/// seconds under the sanitizers), so slow but valid inputs do not read as hangs.
constexpr double kBudgetSeconds = 1.0;
}  // namespace

std::string check_scene_input(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    SceneDesc desc;
    try {
        // No such folder: a mesh file the scene names is never read from the machine.
        desc = parse_scene_string(text, "/nonexistent-fuzz-dir/scene.json");
    } catch (const SceneError&) {
        return {};
    } catch (const std::exception& e) {
        return std::string("parse threw something other than SceneError: ") + e.what();
    }
    if (desc.bodies.size() > kMaxBodies) return {};
    std::unique_ptr<World> world;
    try {
        world = build_world(desc);
    } catch (const SceneError&) {
        return {};
    } catch (const std::exception& e) {
        return std::string("build_world threw something other than SceneError: ") + e.what();
    }
    if (world->soft().particle_count() > kMaxParticles) return {};
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kSteps; ++i) {
        if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > kBudgetSeconds) break;
        try {
            world->step();
        } catch (const std::exception& e) {
            return "step " + std::to_string(i) + " of an accepted scene threw: " + e.what();
        }
        // A fault is the step saying so (a method past its stability limit): reported, so handled.
        if (!world->faults().empty()) return {};
        if (!world->rigid().all_finite() || !world->soft().all_finite())
            return "an accepted scene turned non-finite at step " + std::to_string(i) + " and no fault was reported";
    }
    return {};
}

}  // namespace sinew::fuzz
