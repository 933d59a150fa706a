#include "engine/world/world.hpp"

#include <stdexcept>
#include <string>

namespace sinew {

namespace {
void check_time_step(Real h) {
    if (!is_finite(h) || h <= 0 || h > 1)
        throw std::invalid_argument("time_step must be finite and in (0, 1] s, got " + std::to_string(h));
}
}  // namespace

World::World(const WorldSettings& settings) : settings_(settings) {
    check_time_step(settings.time_step);
    if (settings.max_steps_per_frame < 1 || settings.max_steps_per_frame > kMaxStepsPerFrame)
        throw std::invalid_argument("max_steps_per_frame must be in [1, " + std::to_string(kMaxStepsPerFrame) +
                                    "], got " + std::to_string(settings.max_steps_per_frame));
    rigid_ = std::make_unique<RigidSystem>(settings.rigid);
    pipeline_.add_system(rigid_.get());
    SoftSettings soft = settings.soft;
    soft.gravity = settings.rigid.gravity;
    settings_.soft.gravity = soft.gravity;
    soft_ = std::make_unique<SoftSystem>(soft);
    pipeline_.add_system(soft_.get());
    coupling_ = std::make_unique<CouplingLayer>(pipeline_, *rigid_, *soft_);
    set_threads(settings.workers, settings.tasks);
}

World::~World() = default;

void World::set_time_step(Real h) {
    check_time_step(h);
    settings_.time_step = h;
}

void World::set_threads(int workers, const TaskSystem& tasks) {
    if (in_step_) throw std::invalid_argument("set_threads: not during a step");
    const bool host = tasks.enqueue != nullptr || tasks.finish != nullptr;
    if (host && (tasks.enqueue == nullptr || tasks.finish == nullptr))
        throw std::invalid_argument("set_threads: a task system needs both enqueue and finish");
    const int count = host ? tasks.worker_count : workers;
    if (count < 1 || count > kMaxWorkers)
        throw std::invalid_argument(std::string(host ? "tasks.worker_count" : "workers") + " must be in [1, " +
                                    std::to_string(kMaxWorkers) + "], got " + std::to_string(count));
    if (host) {
        pool_.reset();
        tasks_ = tasks;
    } else if (workers == 1) {
        pool_.reset();
        tasks_ = TaskSystem{};
    } else if (!pool_ || pool_->worker_count() != workers) {
        pool_.reset();
        pool_ = std::make_unique<ThreadPool>(workers);
        tasks_ = pool_->task_system();
    }
    settings_.workers = count;
    settings_.tasks = host ? tasks : TaskSystem{};
    rigid_->set_task_system(&tasks_);
    soft_->set_task_system(&tasks_);
}

void World::set_gravity(const Vec3& g) {
    RigidSettings r = rigid_->settings();
    r.gravity = g;
    rigid_->set_settings(r);  // validates (RigidError names the value)
    SoftSettings s = soft_->settings();
    s.gravity = g;
    soft_->set_settings(s);
    settings_.rigid.gravity = g;
    settings_.soft.gravity = g;
    // Everything asleep rests under the old gravity: wake it so the new one acts.
    for (BodyId id : rigid_->bodies())
        if (rigid_->type(id) == BodyType::Dynamic) rigid_->wake(id);
    for (SoftBodyId id : soft_->bodies()) soft_->wake(id);
}

void World::step() {
    faults_.clear();
    step_once();
}

void World::step_once() {
    const std::uint64_t index = pipeline_.step_count();
    struct Guard {
        bool& flag;
        explicit Guard(bool& f) : flag(f) { flag = true; }
        ~Guard() { flag = false; }
    } guard(in_step_);
    pipeline_.step(settings_.time_step);
    time_ += settings_.time_step;
    for (const std::vector<StepFault>* found : {&rigid_->faults(), &soft_->faults()})
        for (const StepFault& f : *found) {
            faults_.push_back(f);
            faults_.back().step = index;
        }
}

int World::advance(Real frame_dt) {
    if (!is_finite(frame_dt) || frame_dt < 0)
        throw std::invalid_argument("frame_dt must be finite and >= 0, got " + std::to_string(frame_dt));
    accumulator_ += frame_dt;
    faults_.clear();
    int steps = 0;
    while (accumulator_ >= settings_.time_step && steps < settings_.max_steps_per_frame) {
        step_once();
        accumulator_ -= settings_.time_step;
        ++steps;
    }
    // Spiral-of-death guard: time we could not simulate is dropped, keeping less than one step.
    if (accumulator_ >= settings_.time_step) accumulator_ = std::fmod(accumulator_, settings_.time_step);
    return steps;
}

}  // namespace sinew
