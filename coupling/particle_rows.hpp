// Two-way coupling's rows: soft particles touching dynamic rigid bodies, solved inside the rigid solver
// as point masses (Sifakis et al. 2007, hard-bound particles; seed 001 ch.5 §6: a particle is a body with
// inverse mass w_p and no rotation; ../shared/THEORY.md §7 "Two-way contact between a particle and a
// rigid body").
//
// Per contact (particle p, rigid body B, unit normal n from B towards p, arm r from B's centre of mass
// to the surface point under p):
//   v_n = (v_p - v_B - w_B x r) . n,   m_n = 1 / (w_p + w_B + (r x n) . I_B^-1 (r x n)),
// a unilateral row with the accumulated impulse clamped at zero, speculative while the particle is
// still a gap g > 0 away (it may approach at g / h), Baumgarte's or Catto's soft bias while it
// penetrates (whichever the solver asks for); two friction rows bounded together by mu times the normal
// impulse (a circle). The impulse goes +w_p J to the particle and -J at r to the body: momentum is
// exchanged exactly, and angular momentum too (the particle sits on the normal through the surface point).
//
// Built once per step in prepare() from the collision planes the soft system found in DetectCollisions
// (ParticleCollision::plane), so no second narrow phase runs. A particle's velocity in the rows is its
// predicted end-of-step velocity (x_next - x_n) / h, whatever its method; several rows of one particle
// (two bodies) share it. Everything is plain arrays reused from step to step; the passes have no virtual
// call and allocate nothing.
#pragma once

#include <cstdint>
#include <vector>

#include "coupling/coupling_settings.hpp"
#include "rigid/constraint_rows.hpp"
#include "rigid/rigid_system.hpp"
#include "soft/soft_system.hpp"

namespace sinew {

/// What one soft-rigid contact did to the rigid body during a step (the two-way rows, or a soft
/// contact's reaction sent back): reported to the world and the C API's contact events.
struct CouplingImpulse {
    std::uint32_t rigid = 0;     ///< rigid body slot
    std::uint32_t soft = 0;      ///< soft body slot
    std::uint32_t particle = 0;  ///< index in that soft body
    Vec3 point = Vec3::Zero();   ///< on the rigid body's surface (world)
    Vec3 normal = Vec3::UnitY(); ///< unit, from the rigid body towards the particle
    Vec3 impulse = Vec3::Zero(); ///< received by the rigid body over the step (N s)
    bool held = false;           ///< the impulse implicit Euler's contact constraint took (sent before the rigid solve)
};

class ParticleRows final : public ConstraintRows {
public:
    ParticleRows(SoftSystem& soft, const CouplingSettings& settings) : soft_(soft), settings_(settings) {}

    void prepare(RigidSystem& sys, const RowStep& step) override;
    void warm_start(const RigidSystem& sys, const BodyVelocities& vel) override;
    void solve(const RigidSystem& sys, const BodyVelocities& vel, bool use_bias) override;
    void positions_advanced(const RigidSystem& sys, const BodyVelocities& vel, Real h) override;
    void finish(RigidSystem& sys, Real h) override;

    /// After the rigid solve, before the soft one: gives the soft particles the velocity the rows gave
    /// them since the last hand-over (SoftSystem::change_predicted_velocity).
    void hand_to_soft_prediction(Real h);
    /// After the soft solve: the rows' particles take the soft system's velocities (what its own solve
    /// and contact pass did to them).
    void take_soft_velocities();
    /// One more pass over the rows on the system's velocity arrays (an exchange iteration after the soft
    /// solve), then the particles' changes handed to the soft velocities.
    void exchange_pass(RigidSystem& sys);
    bool empty() const { return rows_.empty(); }
    /// At the start of a step: last step's rows and pushes dropped (their bodies may be gone), so nothing
    /// stale is handed on if the rigid solver does not prepare this step. The warm-start impulses stay.
    void reset() {
        particles_.clear();
        rows_.clear();
        pushes_.clear();
        push_parts_left_ = 0;
    }
    std::size_t row_count() const { return rows_.size(); }
    /// An impulse j (N s) on rigid body `rigid` at `arm` from its centre of mass, given to the body inside
    /// the next rigid solve: spread evenly over its sub-steps, as gravity is (the soft step adds gravity
    /// per sub-step; given all at once, a box resting on a block hopped g h^2 / 2 every step).
    void queue_push(std::uint32_t rigid, const Vec3& j, const Vec3& arm) { pushes_.push_back({rigid, j, arm}); }
    /// Appends what every row did to its rigid body this step (after finish()).
    void report(std::vector<CouplingImpulse>& out) const;
    /// Calls f(soft slot, particle, rigid slot, normal) for every row that pushed this step.
    template <class F>
    void for_each_pushing(F&& f) const {
        for (const Row& r : rows_)
            if (r.total.dot(r.n) > 0) f(particles_[r.particle].soft, particles_[r.particle].index, r.rigid, r.n);
    }

private:
    struct Particle {
        std::uint32_t soft = 0, index = 0;  ///< soft body slot, particle index
        Real inv_mass = 0;
        Vec3 v = Vec3::Zero();       ///< velocity in the rows
        Vec3 v_handed = Vec3::Zero();///< velocity the soft system last took from (or gave to) the rows
    };
    struct Row {
        std::uint32_t particle = 0;  ///< into particles_
        std::uint32_t rigid = 0;     ///< rigid body slot
        Vec3 n = Vec3::UnitY(), t1 = Vec3::UnitX(), t2 = Vec3::UnitZ();  ///< normal (from the body towards the particle), tangents
        Vec3 point = Vec3::Zero();   ///< surface point (world)
        Vec3 arm = Vec3::Zero();     ///< surface point - centre of mass
        Vec3 irn = Vec3::Zero(), irt1 = Vec3::Zero(), irt2 = Vec3::Zero();  ///< I_B^-1 (r x n), (r x t1), (r x t2)
        Real inv_mb = 0;
        Real mass_n = 0, mass_t1 = 0, mass_t2 = 0;
        Real gap = 0;                ///< separation at the start of the (sub-)step, thickness removed (m)
        Real mu = 0;
        Real lambda_n = 0, lambda_t1 = 0, lambda_t2 = 0;  ///< accumulated over the (sub-)step
        Vec3 total = Vec3::Zero();   ///< impulse given to the particle over the step (N s)
    };
    void build(RigidSystem& sys, Real h);
    /// Gives the queued pushes' next share to the bodies (once per sub-step).
    void apply_pushes(const BodyVelocities& vel);
    void apply(Row& r, Particle& p, const BodyVelocities& vel, const Vec3& impulse) const;
    void solve_rows(const BodyVelocities& vel, bool use_bias);
    static std::uint64_t key(const Particle& p, std::uint32_t rigid) {
        return (std::uint64_t(p.soft) << 44) | (std::uint64_t(p.index) << 20) | (rigid & 0xfffffu);
    }

    SoftSystem& soft_;
    const CouplingSettings& settings_;
    std::vector<Particle> particles_;
    std::vector<Row> rows_;
    std::vector<std::int32_t> particle_of_;  ///< scratch of build(): a soft body's particle -> particles_
    RowStep step_;
    Real h_ = 0;  ///< the step's length (the rows' prediction spans it)
    // Warm starting across steps: last step's rows by key (sorted), with their accumulated impulses.
    struct Kept {
        std::uint64_t key;
        Real n, t1, t2;
        Vec3 tangent;  ///< t1 of that row: the tangent impulse is carried as a world vector
        Vec3 t2dir;
        bool operator<(const Kept& o) const { return key < o.key; }
    };
    std::vector<Kept> kept_;
    struct Push {
        std::uint32_t rigid;
        Vec3 j, arm;
        Vec3 dv = Vec3::Zero(), dw = Vec3::Zero();  ///< the whole push as velocity changes (prepare)
    };
    std::vector<Push> pushes_;
    int push_parts_left_ = 0;   ///< sub-steps still to take a share
    bool push_pending_ = false; ///< a new sub-step began since the last share
};

}  // namespace sinew
