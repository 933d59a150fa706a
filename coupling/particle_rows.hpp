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
// One-solver coupling (coupling/coupling_settings.hpp) puts whole soft bodies here: every particle of a
// mass-spring body with SoftBody::solved_by_rows. Its springs are swept particle by particle in every
// pass, before the contact rows (solve_springs: block Gauss-Seidel on implicit Euler's linearised system,
// re-linearised at every sub-step); its contacts with every collider, static and kinematic ones too, are
// rows; an attachment to a dynamic body puts the body's point inertia into the attached particle's block.
// The particles' positions follow the solver's sub-steps (positions_advanced), with gravity a sub-step
// at a time, and the body takes the rows' positions and velocities before its own stages go on
// (hand_to_soft_prediction).
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

/// A round body's (sphere, capsule) outward normal and surface point under a particle at `point`, if it
/// faces within about 25 degrees of `found` (the normal a contact was found with, at the particle's
/// predicted position): a contact pushes a round body through its axis, and the found normal, which
/// misses it by the step's sliding, would spin it with no friction at all (a frictionless ball on
/// ball-on-trampoline's cloth spun up to 3.5 rad/s in 20 s). False for other shapes (flat faces keep
/// their plane; at an edge the feature may change within the step), or beyond `reach` of the surface.
bool round_body_normal(const Shape& shape, const Transform& xf, const Vec3& point, const Vec3& found, Real reach,
                       Vec3& normal, Vec3& surface);

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
    /// them since the last hand-over (SoftSystem::change_predicted_velocity); a whole body's particles take
    /// the rows' velocity and their position `remaining` seconds on (what the rigid solver has still to
    /// integrate: RigidSystem::unintegrated_time()).
    void hand_to_soft_prediction(Real h, Real remaining);
    /// After the soft solve: the rows' particles take the soft system's velocities (what its own solve
    /// and contact pass did to them).
    void take_soft_velocities();
    /// One more pass over the rows on the system's velocity arrays (an exchange iteration after the soft
    /// solve), then the particles' changes handed to the soft velocities.
    void exchange_pass(RigidSystem& sys);
    bool empty() const { return rows_.empty() && particles_.empty(); }
    bool active() const override {
        return !particles_.empty() || !rows_.empty() || !pushes_.empty() || !attach_rows_.empty() || !whole_bodies_.empty();
    }
    /// At the start of a step: last step's rows and pushes dropped (their bodies may be gone), so nothing
    /// stale is handed on if the rigid solver does not prepare this step. The warm-start impulses stay.
    void reset() {
        particles_.clear();
        rows_.clear();
        spring_ends_.clear();
        attach_rows_.clear();
        whole_bodies_.clear();
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
        Vec3 x = Vec3::Zero();       ///< position, moved with the rigid solver's (sub-)steps (whole bodies' links read it)
        bool whole = false;          ///< of a body solved here (one-solver)
        Vec3 gravity_part = Vec3::Zero();  ///< whole bodies: the gravity of one sub-step, h_sub g (m/s)
        Vec3 v_ref = Vec3::Zero();   ///< whole bodies: the (sub-)step's velocity before any spring or row acted
        Vec3 gravity_shortfall = Vec3::Zero();  ///< whole bodies: the sub-step's gravity the sweep's start leaves out
        Vec3 ext = Vec3::Zero();     ///< whole bodies: impulses from contact rows and the soft contact pass since then
        std::uint32_t ends_begin = 0, ends_end = 0, ends_fill = 0;  ///< its springs in spring_ends_
        std::int32_t attach = -1;    ///< into attach_rows_, or -1
        std::int32_t share_row = -1; ///< whole bodies: the contact row with a dynamic body whose mass share it carries, or -1
        Mat3 share = Mat3::Zero();   ///< that share (kg): the body's mass along the normal, K^-1's tangential part across it
        Mat3 share_normal = Mat3::Zero();  ///< its normal part alone (outside the friction cone)
    };
    struct AttachRow {  ///< one-solver: an attached particle whose block carries its body's share
        std::uint32_t particle = 0;  ///< into particles_
        std::uint32_t rigid = 0;
        Vec3 arm = Vec3::Zero();     ///< the point - the body's centre of mass
        Mat3 share = Mat3::Zero();   ///< K^-1, K = w_B I - [arm]x I_B^-1 [arm]x (kg)
        Real inv_mb = 0;
        Mat3 inv_inertia = Mat3::Zero();
        Vec3 total = Vec3::Zero();   ///< impulse given to the particle over the step, for the report
    };
    struct SpringEnd {  ///< a spring seen from one of its particles
        std::uint32_t other = 0;     ///< into particles_
        Real rest = 1, k = 0, c = 0; ///< m, N/m, N s/m
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
    /// One-solver: every particle of soft body `slot` and its links (particle_of_ maps them).
    void add_whole_body(const RigidSystem& sys, std::uint32_t slot, const SoftBody& b, Real h);
    void solve_springs(const BodyVelocities& vel);
    void assign_contact_shares(const RigidSystem::State& st);
    void add_attachment_rows(const RigidSystem& sys, std::uint32_t slot, const SoftBody& b, std::uint32_t base);
    /// Adds dv to the soft particle's velocity (and to a whole body's position, over `moves` seconds).
    void give_soft_velocity(Particle& p, const Vec3& dv, Real moves);
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
    std::vector<SpringEnd> spring_ends_;
    std::vector<AttachRow> attach_rows_;
    struct WholeBody {
        std::uint32_t begin = 0, end = 0;  ///< its particles in particles_
        Real mass = 0;                     ///< of its free particles (kg)
        bool held = false;                 ///< some particle pinned or kinematically attached
    };
    std::vector<WholeBody> whole_bodies_;
    struct Previous {
        std::vector<Vec3> v;     ///< the body's velocities when it was last swept (before its prediction)
        std::uint64_t stamp = 0; ///< its generation and the step (prepare count) they were taken at
    };
    std::vector<Previous> previous_v_;  ///< per soft slot
    std::uint32_t step_count_ = 0;      ///< prepare() calls
    std::vector<std::uint32_t> degree_;  ///< scratch of add_whole_body
    std::vector<std::uint32_t> share_count_;  ///< scratch of assign_contact_shares: per rigid slot
    bool springs_active_ = true;         ///< a (sub-)step is still to be integrated
    std::vector<std::int32_t> particle_of_;  ///< scratch of build(): a soft body's particle -> particles_
    RowStep step_;
    Real h_ = 0;  ///< the step's length (the rows' prediction spans it)
    int substeps_done_ = 0;  ///< positions_advanced calls since prepare
    Real remaining_ = 0;  ///< at the hand-over: the time the rigid solver had still to integrate
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
