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
    // The new pool first: if starting its threads fails, the world keeps the threads it had.
    std::unique_ptr<ThreadPool> pool;
    if (!host && workers > 1 && !(pool_ && pool_->worker_count() == workers)) pool = std::make_unique<ThreadPool>(workers);
    if (host) {
        tasks_ = tasks;
        pool_.reset();
    } else if (workers == 1) {
        tasks_ = TaskSystem{};
        pool_.reset();
    } else if (pool) {
        tasks_ = pool->task_system();
        pool_ = std::move(pool);
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

std::uint64_t World::state_hash() const {
    std::uint64_t h = 1469598103934665603ull;
    auto mix = [&h](const void* p, std::size_t n) {
        const unsigned char* c = static_cast<const unsigned char*>(p);
        for (std::size_t i = 0; i < n; ++i) {
            h ^= c[i];
            h *= 1099511628211ull;
        }
    };
    const RigidSystem::State& st = rigid_->state();
    for (std::size_t s = 0; s < st.x.size(); ++s) {
        mix(st.x[s].data(), sizeof(Real) * 3);
        mix(st.q[s].coeffs().data(), sizeof(Real) * 4);
        mix(st.v[s].data(), sizeof(Real) * 3);
        mix(st.w[s].data(), sizeof(Real) * 3);
    }
    for (SoftBodyId id : soft_->bodies()) {
        const Particles& p = soft_->body(id).p;
        for (std::size_t i = 0; i < p.size(); ++i) {
            mix(p.x[i].data(), sizeof(Real) * 3);
            mix(p.v[i].data(), sizeof(Real) * 3);
        }
    }
    return h;
}

void World::step() {
    faults_.clear();
    sensor_events_.clear();
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
    // After the whole step, coupling layers' last hooks included: every position is final.
    sensors_.update(*rigid_, *soft_, *coupling_, index + 1);
    sensor_events_.insert(sensor_events_.end(), sensors_.step_events().begin(), sensors_.step_events().end());
}

int World::advance(Real frame_dt) {
    if (!is_finite(frame_dt) || frame_dt < 0)
        throw std::invalid_argument("frame_dt must be finite and >= 0, got " + std::to_string(frame_dt));
    accumulator_ += frame_dt;
    faults_.clear();
    sensor_events_.clear();
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
