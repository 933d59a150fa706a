// The World composes the systems (rigid, then soft) and the coupling layer between them (coupling/coupling_layer.hpp), and
// steps them through the pipeline with a fixed internal step and an accumulator for variable frame times.
#pragma once

#include <memory>

#include "coupling/coupling_layer.hpp"
#include "engine/core/pipeline.hpp"
#include "engine/core/task_system.hpp"
#include "engine/core/thread_pool.hpp"
#include "engine/world/sensor_tracker.hpp"
#include "rigid/rigid_system.hpp"
#include "soft/soft_system.hpp"

namespace sinew {

/// The largest max_steps_per_frame accepted: a frame of any length returns after at most this many steps
/// (a game that passes a huge frame time after a pause must not hang in World::advance).
constexpr int kMaxStepsPerFrame = 1000;

struct WorldSettings {
    Real time_step = Real(1) / 60;   ///< fixed internal step h (s)
    int max_steps_per_frame = 8;     ///< accumulator cap, so a slow frame cannot spiral; 1 .. kMaxStepsPerFrame
    RigidSettings rigid;
    SoftSettings soft;               ///< soft.gravity is ignored: the world's gravity is rigid.gravity
    /// Threads for one step, the calling thread included (engine/core/task_system.hpp). With 1 (the
    /// default) the world is serial; with more and no `tasks`, the world starts a ThreadPool of
    /// workers - 1 threads. Results are bit-identical for every worker count.
    int workers = 1;
    /// The host's job system. When its enqueue and finish are set, the world uses it (its worker_count
    /// counts) and starts no thread; `workers` is then ignored.
    TaskSystem tasks;
};

class World {
public:
    explicit World(const WorldSettings& settings = {});
    ~World();
    World(const World&) = delete;
    World& operator=(const World&) = delete;

    RigidSystem& rigid() { return *rigid_; }
    const RigidSystem& rigid() const { return *rigid_; }
    SoftSystem& soft() { return *soft_; }
    const SoftSystem& soft() const { return *soft_; }
    Pipeline& pipeline() { return pipeline_; }
    const Pipeline& pipeline() const { return pipeline_; }
    CouplingLayer& coupling() { return *coupling_; }
    const CouplingLayer& coupling() const { return *coupling_; }
    /// The coupling strategy and per-pair overrides from the next step (CouplingError names the problem;
    /// nothing changes then).
    void set_coupling(const CouplingSettings& s) { coupling_->set_settings(s); }
    const WorldSettings& settings() const { return settings_; }
    /// Validates (throws std::invalid_argument naming the field) and applies.
    void set_time_step(Real h);
    /// Threads for the next steps: `workers` of a pool of the world's own (1: serial), or the host's
    /// task system when `tasks` has its callbacks (then `workers` is ignored). Throws
    /// std::invalid_argument outside [1, kMaxWorkers] or during a step. Results do not depend on it.
    void set_threads(int workers, const TaskSystem& tasks = {});
    /// Workers a step uses (1: serial).
    int workers() const { return tasks_.parallel() ? tasks_.worker_count : 1; }
    /// The world's gravity (m/s^2) for rigid and soft bodies alike, from the next step; wakes every body.
    void set_gravity(const Vec3& g);

    /// One fixed step of h.
    void step();
    /// Game-loop stepping: adds frame_dt to the accumulator and runs whole fixed steps (at most
    /// max_steps_per_frame; excess time is dropped). Returns the number of steps taken.
    int advance(Real frame_dt);
    /// Fraction of a step left in the accumulator, in [0, 1): render at lerp(previous, current, alpha).
    Real interpolation_alpha() const { return accumulator_ / settings_.time_step; }
    double time() const { return time_; }
    std::uint64_t step_count() const { return pipeline_.step_count(); }
    /// True while a step is running (hooks run then); the C API rejects mutations during a step.
    bool in_step() const { return in_step_; }
    /// Bodies whose state turned non-finite in the steps of the last step() or advance() call, in the
    /// order found (rigid before soft within a step). Each was put back where its step found it, at rest
    /// (engine/core/step_fault.hpp); the world is valid and steps on.
    const std::vector<StepFault>& faults() const { return faults_; }
    /// Sensor overlaps that began or ended in the steps of the last step() or advance() call, step by step
    /// in the tracker's order (engine/world/sensor_tracker.hpp).
    const std::vector<SensorEvent>& sensor_events() const { return sensor_events_; }
    /// What overlaps each sensor after the last step.
    const SensorTracker& sensors() const { return sensors_; }
    /// FNV-1a over every rigid body slot's position, orientation, velocity and spin and every soft body's
    /// particle positions and velocities: equal hashes, equal states bit for bit (determinism checks).
    std::uint64_t state_hash() const;

private:
    void step_once();

    WorldSettings settings_;
    Pipeline pipeline_;
    std::unique_ptr<RigidSystem> rigid_;
    std::unique_ptr<SoftSystem> soft_;
    std::unique_ptr<CouplingLayer> coupling_;
    Real accumulator_ = 0;
    double time_ = 0;
    bool in_step_ = false;
    std::vector<StepFault> faults_;
    SensorTracker sensors_;
    std::vector<SensorEvent> sensor_events_;
    std::unique_ptr<ThreadPool> pool_;  // the world's own threads, when the host brings none
    TaskSystem tasks_;                  // what the systems use: the host's, the pool's, or serial
};

}  // namespace sinew
