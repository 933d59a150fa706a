#include "engine/core/pipeline.hpp"

#include <algorithm>
#include <stdexcept>

namespace sinew {

const char* stage_name(Stage s) {
    switch (s) {
        case Stage::IntegrateVelocities: return "integrate_velocities";
        case Stage::DetectCollisions: return "detect_collisions";
        case Stage::SolveVelocities: return "solve_velocities";
        case Stage::IntegratePositions: return "integrate_positions";
        default: return "unknown";
    }
}

int Pipeline::add_system(System* system) {
    if (!system) throw std::invalid_argument("Pipeline::add_system: system is null");
    systems_.push_back(system);
    timers_.emplace_back();
    return static_cast<int>(systems_.size()) - 1;
}

int Pipeline::find_system(const std::string& name) const {
    for (std::size_t i = 0; i < systems_.size(); ++i)
        if (name == systems_[i]->name()) return static_cast<int>(i);
    return -1;
}

int Pipeline::add_hook(int system_index, Stage stage, HookWhen when, HookFn fn, std::string label) {
    if (system_index < 0 || system_index >= system_count())
        throw std::out_of_range("Pipeline::add_hook: no system with index " + std::to_string(system_index));
    if (static_cast<int>(stage) < 0 || stage >= Stage::Count)
        throw std::out_of_range("Pipeline::add_hook: stage out of range");
    if (!fn) throw std::invalid_argument("Pipeline::add_hook: empty hook function");
    hooks_.push_back({next_hook_id_, system_index, stage, when, std::move(fn), std::move(label)});
    return next_hook_id_++;
}

void Pipeline::remove_hook(int hook_id) {
    hooks_.erase(std::remove_if(hooks_.begin(), hooks_.end(), [&](const Hook& h) { return h.id == hook_id; }),
                 hooks_.end());
}

void Pipeline::run_hooks(int system, Stage stage, HookWhen when, const StepContext& ctx) {
    for (const Hook& h : hooks_)
        if (h.system == system && h.stage == stage && h.when == when) h.fn(ctx);
}

void Pipeline::step(Real h) {
    using clock = std::chrono::steady_clock;
    StepContext ctx{h, step_index_};
    auto step_start = clock::now();
    for (int s = 0; s < kStageCount; ++s) {
        Stage stage = static_cast<Stage>(s);
        for (int i = 0; i < system_count(); ++i) {
            run_hooks(i, stage, HookWhen::Before, ctx);
            auto t0 = clock::now();
            systems_[i]->run_stage(stage, ctx);
            double ms = std::chrono::duration<double, std::milli>(clock::now() - t0).count();
            timers_[i][s].last_ms = ms;
            timers_[i][s].total_ms += ms;
            run_hooks(i, stage, HookWhen::After, ctx);
        }
    }
    last_step_ms_ = std::chrono::duration<double, std::milli>(clock::now() - step_start).count();
    ++step_index_;
}

}  // namespace sinew
