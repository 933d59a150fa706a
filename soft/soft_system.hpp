// The soft-body system: soft bodies in slots with generational handles, run as pipeline stages.
//
// Stages (docs/ARCHITECTURE.md; each method's part is its row in soft/soft_methods.hpp):
//  - IntegrateVelocities: attached particles follow their targets, sleeping bodies wake if something near
//    them moves, and each awake body takes its forces and gravity: its predicted end-of-step positions
//    are set aside (Particles::x_next), its positions stay x_n;
//  - DetectCollisions: each awake body picks the colliders its particles may reach this step;
//  - SolveVelocities: on the predicted positions, the internal constraints (links, Liu's iterations,
//    long-range attachments) and the contacts (projection, restitution, friction), recorded as
//    ParticleContact with their impulses; the velocities are final here, the positions still x_n;
//  - IntegratePositions: positions take the predicted ones, moved further by h times any velocity change
//    a coupling layer made after the solve; forces cleared; sleeping.
// Colliders and attachment frames are written by a coupling layer before IntegrateVelocities and may be
// refined (same colliders, end-of-step poses) before SolveVelocities.
#pragma once

#include <functional>
#include <vector>

#include "engine/core/pipeline.hpp"
#include "engine/core/slots.hpp"
#include "soft/collider.hpp"
#include "soft/particle_collision.hpp"
#include "engine/core/step_fault.hpp"
#include "engine/core/task_system.hpp"
#include "soft/soft_body.hpp"
#include "soft/soft_contacts.hpp"

namespace sinew {

struct SoftSettings {
    Vec3 gravity = Vec3(0, Real(-9.81), 0);  ///< m/s^2
    bool sleeping = true;
    Real sleep_velocity = Real(0.02);  ///< m/s: a body whose particles all move slower ...
    Real sleep_time = Real(0.5);       ///< s: ... for this long falls asleep
};

class SoftSystem final : public System {
public:
    explicit SoftSystem(const SoftSettings& settings = {});
    ~SoftSystem() override;
    SoftSystem(const SoftSystem&) = delete;
    SoftSystem& operator=(const SoftSystem&) = delete;

    const char* name() const override { return "soft"; }
    /// The threads a step may use (engine/core/task_system.hpp); null or serial: one. The world sets it.
    void set_task_system(const TaskSystem* tasks) { tasks_ = tasks; }
    const TaskSystem* task_system() const { return tasks_; }
    /// The region the system's parallel stages run in (one at a time).
    ParallelRegion& region() { return region_; }
    void run_stage(Stage stage, const StepContext& ctx) override;

    const SoftSettings& settings() const { return settings_; }
    void set_settings(const SoftSettings& s);  ///< validates (throws SoftError)

    /// Sub-stepping (one-way coupling's passive rate, seed 001 §1.1): each pipeline step of h runs k soft
    /// steps of h/k. The first is the pipeline's own stages; the other k - 1 run whole at the end of
    /// IntegratePositions, each after `before_substep(j, h/k)` (j = 1 .. k-1) has placed the colliders and
    /// attachment frames where they are at the end of sub-step j + 1. Throws SoftError for k outside
    /// [1, 64] or k > 1 without a callback.
    void set_substeps(int k, std::function<void(int, Real)> before_substep);
    int substeps() const { return substeps_; }

    /// Validates def (throws SoftError naming the field and index; nothing is changed) and creates it.
    SoftBodyId create_body(SoftBodyDef def);
    void destroy_body(SoftBodyId id);
    bool valid(SoftBodyId id) const;
    std::size_t body_count() const { return slots_.count(); }
    /// Counts bodies created or destroyed (RigidSystem::structure_revision).
    std::uint64_t structure_revision() const { return structure_revision_; }
    std::vector<SoftBodyId> bodies() const;
    std::size_t slot_count() const { return bodies_.size(); }
    bool slot_alive(std::uint32_t slot) const { return slots_.alive(slot); }
    SoftBodyId id_of_slot(std::uint32_t slot) const { return {slot, slots_.generation(slot)}; }

    SoftBody& body(SoftBodyId id);
    const SoftBody& body(SoftBodyId id) const;
    /// Body by slot (no check), for layers that iterate slots.
    SoftBody& slot_body(std::uint32_t slot) { return bodies_[slot]; }
    const SoftBody& slot_body(std::uint32_t slot) const { return bodies_[slot]; }

    void wake(SoftBodyId id);
    /// Which rigid bodies the particles meet, from the next step (the body is woken). Throws SoftError.
    void set_filter(SoftBodyId id, const CollisionFilter& filter);
    /// Puts a body to sleep now, its velocities zero (a coupling layer whose proxy of it fell asleep with
    /// its rigid island). Throws SoftError for a bad id.
    void put_to_sleep(SoftBodyId id);
    bool awake(SoftBodyId id) const;
    /// Moves particle `i` (and its previous position, so it gains no velocity). Throws SoftError.
    void set_particle_position(SoftBodyId id, std::uint32_t i, const Vec3& x);
    /// Adds a force (N) to particle `i` for the next step; wakes the body.
    void apply_particle_force(SoftBodyId id, std::uint32_t i, const Vec3& f);
    /// Pins (inverse mass 0) or frees particle `i` and rebuilds the body's long-range attachments if it
    /// has them. Throws SoftError for an attached particle (its attachment decides).
    void set_pinned(SoftBodyId id, std::uint32_t i, bool pinned);
    /// Attaches particle `i` to the point `local_point` of an outside body `target` (an opaque 64-bit id,
    /// a packed rigid BodyId for the coupling layers), replacing an earlier attachment of that particle.
    /// The particle becomes kinematic: the coupling layer writes the frame before the next soft step and
    /// the particle follows it. Throws SoftError (nothing changed) for a bad id, index or point.
    void attach(SoftBodyId id, std::uint32_t i, std::uint64_t target, const Vec3& local_point);
    /// Frees an attached particle (it becomes dynamic again). Throws SoftError if it is not attached.
    void detach(SoftBodyId id, std::uint32_t i);
    /// Is particle `i` attached to an outside body? Throws SoftError for a bad id or index.
    bool attached(SoftBodyId id, std::uint32_t i) const;

    /// The colliders of this step. A coupling layer (or a test) fills it before IntegrateVelocities and may
    /// update their poses and velocities (not their number or order) before SolveVelocities. Their
    /// shape pointers are valid during the step only (they point into the rigid system, whose arrays may
    /// move when bodies are created between steps): read colliders from hooks, not between steps.
    std::vector<Collider>& colliders() { return colliders_; }
    const std::vector<Collider>& colliders() const { return colliders_; }
    /// Body `slot`'s collision planes of this step (found in DetectCollisions), or null if the body is
    /// not stepping: a coupling layer reads them between DetectCollisions and SolveVelocities.
    const ParticleCollision* collision(std::uint32_t slot) const;
    /// A coupling layer's velocity change of particle i of the stepping body `slot`, between
    /// DetectCollisions and SolveVelocities (an impulse the rigid solve gave it): the body's method moves
    /// its prediction as if the impulse had been one of its forces. After SolveVelocities, change
    /// Particles::v directly: IntegratePositions moves the particle by h times the change.
    void change_predicted_velocity(std::uint32_t slot, std::uint32_t i, const Vec3& dv, Real h);
    /// Particle contacts found in the last step, body slot order.
    const std::vector<ParticleContact>& contacts() const { return contacts_; }
    /// Contacts between soft bodies in the last (sub-)step (soft/soft_contacts.hpp).
    const std::vector<SoftSoftContact>& soft_contacts() const { return soft_contacts_.contacts(); }
    /// The edge-edge contacts between soft bodies of the last step (a body with itself: none, they are off).
    const std::vector<SoftEdgeContact>& soft_edge_contacts() const { return soft_contacts_.edge_contacts(); }
    /// Bodies whose particles were not finite at the end of the last step: each was put back where the
    /// step found it, at rest (engine/core/step_fault.hpp).
    const std::vector<StepFault>& faults() const { return faults_; }

    std::size_t particle_count() const;
    double kinetic_energy() const;
    bool all_finite() const;
    /// World box of a body's particles, fattened by its thickness.
    Aabb bounds(std::uint32_t slot) const;

private:
    void check(SoftBodyId id, const char* where) const;
    void integrate_velocities(Real h);
    /// The IntegrateVelocities part of one body (it is awake and advances this step).
    void integrate_velocities_in_region(Real h);
    /// Particles from which a body's method runs its large loops on the workers.
    static constexpr std::size_t kParallelParticles = 2048;
    /// Particles of the other awake bodies from which they are stepped one body per worker item: four
    /// 16 x 16 Verlet cloths (1,024) stepped 0.96-1.04x as fast on 2 workers (four regions a step, each
    /// waking a helper, against 0.5 ms of work), eight (2,048) 1.04-1.68x median, 1.82x best chunk.
    static constexpr std::size_t kParallelBodyParticles = 2048;
    /// Whether body b's method splits its own loops among the workers (FEM, fast mass-spring, implicit
    /// Euler at kParallelParticles particles or more).
    static bool splits_loops(const SoftBody& b);
    /// The workers for a stage: the task system when an awake body splits its loops, or when at least two
    /// other awake bodies have kParallelBodyParticles particles between them; else none.
    const TaskSystem* tasks_for_stage() const;
    /// fn(slot) for each of `slots` (ascending), inside the stage's region: a body that splits its loops
    /// on this thread with the region (SoftBody::region), the others one body per item on the workers
    /// with none. Bodies share nothing a stage writes, so the order they run in does not change a bit.
    template <class Fn>
    void for_bodies(const std::vector<std::uint32_t>& slots, Fn&& fn);
    /// IntegrateVelocities for body b (awake, or woken): its method's prediction, x_n kept in x.
    void begin_step(SoftBody& b, Real h);
    /// A sleeping body woken during the step (on the calling thread): its sleep timer reset, then begin_step.
    void wake_into_step(SoftBody& b, Real h);
    /// stage_slots_ = the alive bodies stepping this (sub-)step, ascending.
    void collect_stepping_slots();
    void detect_collisions(Real h);
    /// DetectCollisions: sleeping bodies a moving soft body reaches wake and take this step's forces.
    void wake_touched_by_soft_bodies(Real h);
    void solve_velocities(Real h);
    /// The SolveVelocities part of each stepping body: its method's solve and its contact pass.
    void solve_bodies_in_region(Real h);
    void integrate_positions(Real h);
    void update_sleep(SoftBody& b, Real h);
    /// The IntegratePositions part of each stepping body.
    void integrate_positions_in_region(Real h);
    /// IntegratePositions: puts body `s` back where the (sub-)step found it when particle `bad` (its
    /// first, if any: bad < its particle count) is not finite or too fast; it then sits out the step's
    /// other sub-steps, so the step ends with it there.
    void contain_non_finite(std::uint32_t s, Real h, std::size_t bad);
    /// Keeps a body's contacts from its contact pass as its per-particle contact normals and collider
    /// speeds, for the next step's implicit solve.
    void record_contacts(SoftBody& b, const std::vector<ParticleContact>& contacts);

    SoftSettings settings_;
    int substeps_ = 1;
    std::function<void(int, Real)> before_substep_;
    std::vector<SoftBody> bodies_;
    Slots slots_;  ///< body slots and generations (engine/core/slots.hpp)
    std::uint64_t structure_revision_ = 0;
    std::vector<Collider> colliders_;
    std::vector<ParticleContact> contacts_;
    std::vector<std::vector<ParticleContact>> body_contacts_;  ///< by slot: this sub-step's contact pass
    std::vector<std::uint32_t> stage_slots_, small_slots_;     ///< scratch: the bodies a stage steps
    std::vector<std::size_t> first_bad_;                       ///< by slot: IntegratePositions' first bad particle
    std::vector<StepFault> faults_;
    std::vector<std::uint8_t> faulted_;  ///< by slot: put back this step (contain_non_finite), sits out its sub-steps
    std::vector<ParticleCollision> collision_;  ///< by slot: the colliders each body may touch this step
    SoftContactPass soft_contacts_;
    std::vector<SoftContactPass::Entry> contact_entries_;
    std::vector<Aabb> moving_boxes_;  ///< by slot, scratch of wake_touched_by_soft_bodies
    const TaskSystem* tasks_ = nullptr;
    ParallelRegion region_;
};

}  // namespace sinew
