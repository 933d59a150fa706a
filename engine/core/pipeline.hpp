// The step pipeline: systems (rigid, soft, ...) run their step as explicit stages, interleaved stage by
// stage across systems, with hook points before and after every stage of every system.
//
// Why interleave: seed 001 (ch.5, Figure 9) interrupts each system's update so a coupling layer can
// change velocities after every system solved its constraints and before any system integrates
// positions. With stages run "all systems' stage k, then all systems' stage k+1", a coupling layer that
// hooks "after SolveVelocities of the last system" sees every system's new velocities and acts before
// any IntegratePositions. One-way, two-way, hybrid and interleaved layers are hooks placed differently.
//
// Virtual calls happen once per stage per system per step, never inside solver loops.
#pragma once

#include <array>
#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "engine/core/math.hpp"

namespace sinew {

enum class Stage : int {
    IntegrateVelocities = 0,  ///< forces and gravity into velocities (Guendelman: collision passes first)
    DetectCollisions,         ///< broad and narrow phase, contact cache update
    SolveVelocities,          ///< velocity constraints: contacts, joints, (Guendelman: contact + shock passes)
    IntegratePositions,       ///< velocities into positions, position correction, sleeping
    Count
};
constexpr int kStageCount = static_cast<int>(Stage::Count);
const char* stage_name(Stage s);

/// What a stage is told about the step in progress.
struct StepContext {
    Real h = Real(1) / 60;    ///< fixed step (s)
    std::uint64_t step_index = 0;
};

/// A simulated system: owns its state and runs each stage of its step.
class System {
public:
    virtual ~System() = default;
    virtual const char* name() const = 0;
    virtual void run_stage(Stage stage, const StepContext& ctx) = 0;
};

enum class HookWhen { Before, After };
using HookFn = std::function<void(const StepContext&)>;

/// Milliseconds spent per stage and system (last step and running total).
struct StageTimer {
    double last_ms = 0;
    double total_ms = 0;
};

class Pipeline {
public:
    /// Registers a system; systems run in registration order within each stage. Returns its index.
    int add_system(System* system);
    int system_count() const { return static_cast<int>(systems_.size()); }
    System* system(int i) const { return systems_[i]; }
    int find_system(const std::string& name) const;

    /// Runs `fn` before or after `stage` of system `system_index`. Returns a hook id for remove_hook().
    int add_hook(int system_index, Stage stage, HookWhen when, HookFn fn, std::string label = {});
    void remove_hook(int hook_id);

    /// One fixed step: for each stage, for each system: before-hooks, stage, after-hooks.
    void step(Real h);

    std::uint64_t step_count() const { return step_index_; }
    const StageTimer& timer(int system_index, Stage s) const { return timers_[system_index][static_cast<int>(s)]; }
    double last_step_ms() const { return last_step_ms_; }

private:
    struct Hook {
        int id;
        int system;
        Stage stage;
        HookWhen when;
        HookFn fn;
        std::string label;
    };
    void run_hooks(int system, Stage stage, HookWhen when, const StepContext& ctx);

    std::vector<System*> systems_;
    std::vector<std::array<StageTimer, kStageCount>> timers_;
    std::vector<Hook> hooks_;
    int next_hook_id_ = 1;
    std::uint64_t step_index_ = 0;
    double last_step_ms_ = 0;
};

}  // namespace sinew
