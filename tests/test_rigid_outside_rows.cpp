// Rows from outside the contact manifolds (rigid/constraint_rows.hpp): a source that owns point masses
// and pushes them against a rigid box through its own contact rows, solved inside every solver's
// iterations. A perfectly inelastic impact has a closed form: with no bias and no restitution, the
// particle and the struck point leave with the same normal speed, and momentum is conserved exactly
// because each row applies equal and opposite impulses at one point.
#include <catch2/catch.hpp>

#include <vector>

#include "engine/core/pipeline.hpp"
#include "rigid/constraint_rows.hpp"
#include "rigid/rigid_solver.hpp"
#include "rigid/rigid_system.hpp"

using namespace sinew;

namespace {

/// Point masses outside the rigid system, each with a unilateral frictionless contact row against one
/// rigid body along a fixed normal n (from the body towards the particle): n.(v_p - v_body(x_p)) >= 0.
struct ParticleRows final : ConstraintRows {
    struct Particle {
        Vec3 x, v;
        Real mass;
        std::uint32_t body;
        Vec3 n;
        // prepared per step
        Real inv_mb = 0;
        Mat3 inv_ib = Mat3::Zero();
        Vec3 rn = Vec3::Zero();  // r x n, r from the body's centre of mass to the particle
        Real eff_mass = 0;
        Real lambda = 0;  // accumulated impulse over the (sub-)step
    };
    std::vector<Particle> particles;
    int prepares = 0, passes = 0, advances = 0, finishes = 0;

    void prepare(RigidSystem& sys, const RowStep& step) override {
        ++prepares;
        const RigidSystem::State& st = sys.state();
        for (Particle& p : particles) {
            p.inv_mb = st.inv_mass[p.body];
            p.inv_ib = st.inv_inertia_world[p.body];
            p.rn = (p.x - st.x[p.body]).cross(p.n);
            p.eff_mass = 1 / (1 / p.mass + p.inv_mb + p.rn.dot(p.inv_ib * p.rn));
            if (!step.warm_starting) p.lambda = 0;
        }
    }
    void apply(Particle& p, const BodyVelocities& vel, Real impulse) {
        p.v += (impulse / p.mass) * p.n;
        vel.set_linear(p.body, vel.linear(p.body) - (p.inv_mb * impulse) * p.n);
        vel.set_angular(p.body, vel.angular(p.body) - impulse * (p.inv_ib * p.rn));
    }
    void warm_start(const RigidSystem&, const BodyVelocities& vel) override {
        for (Particle& p : particles) apply(p, vel, p.lambda);
    }
    void solve(const RigidSystem&, const BodyVelocities& vel, bool) override {
        ++passes;
        for (Particle& p : particles) {
            const Real vn = p.n.dot(p.v - vel.linear(p.body)) - p.rn.dot(vel.angular(p.body));
            const Real next = std::max(Real(0), p.lambda - p.eff_mass * vn);
            apply(p, vel, next - p.lambda);
            p.lambda = next;
        }
    }
    void positions_advanced(const RigidSystem&, const BodyVelocities&, Real h) override {
        ++advances;
        for (Particle& p : particles) p.x += h * p.v;
    }
    void finish(RigidSystem&, Real) override { ++finishes; }
};

struct Setup {
    RigidSystem rigid;
    Pipeline pipeline;
    ParticleRows rows;
    BodyId box;
    explicit Setup(const RigidSettings& s) : rigid(s) {
        pipeline.add_system(&rigid);
        BodyDef d;
        d.shape = make_box(Vec3(Real(0.5), Real(0.5), Real(0.5)));  // a cube: isotropic inertia
        d.mass = 4;
        box = rigid.create_body(d);
        rigid.add_rows(&rows);
    }
    Vec3 momentum() const {
        Vec3 p = rigid.mass(box) * rigid.linear_velocity(box);
        for (const auto& q : rows.particles) p += q.mass * q.v;
        return p;
    }
    /// Angular momentum about the world origin: the cube's spin (isotropic, so I w) plus every orbit.
    Vec3 angular_momentum() const {
        const Real inertia = rigid.mass(box) * Real(1) / 6;  // cube of side 1: m a^2 / 6
        Vec3 l = inertia * rigid.angular_velocity(box) +
                 rigid.state().x[box.index].cross(rigid.mass(box) * rigid.linear_velocity(box));
        for (const auto& q : rows.particles) l += q.x.cross(q.mass * q.v);
        return l;
    }
};

RigidSettings settings_for(RigidSolverKind kind) {
    RigidSettings s;
    s.gravity = Vec3::Zero();
    s.sleeping = false;
    s.solver = kind;
    return s;
}

}  // namespace

TEST_CASE("an outside row stops a particle on a rigid box in every solver, conserving momentum", "[rigid][rows]") {
    for (RigidSolverKind kind : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Baumgarte,
                                 RigidSolverKind::Newton}) {
        SECTION(rigid_solver_name(kind)) {
            Setup s(settings_for(kind));
            const Real m = 1, M = 4, u = 3;
            // Central impact: the particle touches the +x face at its centre, moving in -x.
            s.rows.particles.push_back({Vec3(Real(0.5), 0, 0), Vec3(-u, 0, 0), m, s.box.index, Vec3::UnitX()});
            const Vec3 p0 = s.momentum();
            const Real h = Real(1) / 60;
            s.pipeline.step(h);
            // Inelastic: both leave at m u / (m + M) (a single row converges in one Gauss-Seidel pass, so
            // only rounding remains: 1e-5 relative is float's epsilon times the handful of operations).
            const Real v_after = -m * u / (m + M);
            CHECK(s.rigid.linear_velocity(s.box).x() == Approx(v_after).epsilon(1e-5));
            CHECK(s.rows.particles[0].v.x() == Approx(v_after).epsilon(1e-5));
            CHECK((s.momentum() - p0).norm() <= Real(1e-5) * p0.norm());
            CHECK(s.rigid.angular_velocity(s.box).norm() < Real(1e-6));  // central: no spin
            // The source was called at the solver's points: one prepare and one finish per step, a pass
            // per iteration at least, and its particles moved with the bodies (every sub-step for the
            // soft step, once per step for the others).
            CHECK(s.rows.prepares == 1);
            CHECK(s.rows.finishes == 1);
            CHECK(s.rows.passes >= s.rigid.settings().velocity_iterations);
            const int moves = kind == RigidSolverKind::SoftStep ? s.rigid.settings().effective_substeps() : 1;
            CHECK(s.rows.advances == moves);
            CHECK(s.rows.particles[0].x.x() == Approx(Real(0.5) + h * v_after).epsilon(1e-4));
        }
    }
}

TEST_CASE("outside rows off-centre: linear and angular momentum are conserved, the contact point stops", "[rigid][rows]") {
    for (RigidSolverKind c : {RigidSolverKind::SoftStep, RigidSolverKind::SplitImpulse, RigidSolverKind::Baumgarte}) {
        Setup s(settings_for(c));
        // Two particles strike off-centre, one the top face from above, one the +x face.
        s.rows.particles.push_back({Vec3(Real(0.3), Real(0.5), Real(0.1)), Vec3(Real(0.5), -2, 0), Real(0.5),
                                    s.box.index, Vec3::UnitY()});
        s.rows.particles.push_back({Vec3(Real(0.5), Real(-0.2), Real(0.4)), Vec3(-1, 0, Real(0.3)), Real(0.25),
                                    s.box.index, Vec3::UnitX()});
        const Vec3 p0 = s.momentum(), l0 = s.angular_momentum();
        s.pipeline.step(Real(1) / 60);
        CHECK((s.momentum() - p0).norm() <= Real(1e-5) * p0.norm());
        if (c != RigidSolverKind::SoftStep) {
            // One solve before any motion: each impulse pair acts at one point, so the angular momentum
            // about a fixed point is conserved to rounding. (The soft step keeps the arms of the step's
            // start through its sub-steps while the bodies move, first order as its contacts do, so it
            // conserves angular momentum only to O(h |v_rel|): not asserted here.)
            CHECK((s.angular_momentum() - l0).norm() <= Real(1e-5) * l0.norm());
        }
        // Inelastic and frictionless: each particle's normal velocity matches its contact point's (the
        // two rows share the box, so Gauss-Seidel leaves a residual that 10 passes bring under 1 cm/s).
        for (const auto& q : s.rows.particles) {
            const Vec3 r = q.x - s.rigid.state().x[s.box.index];
            const Vec3 vp = s.rigid.linear_velocity(s.box) + s.rigid.angular_velocity(s.box).cross(r);
            CHECK(q.n.dot(q.v - vp) == Approx(0).margin(0.01));
        }
    }
}

TEST_CASE("a removed source of rows is no longer solved", "[rigid][rows]") {
    Setup s(settings_for(RigidSolverKind::SoftStep));
    s.rows.particles.push_back({Vec3(Real(0.5), 0, 0), Vec3(-3, 0, 0), 1, s.box.index, Vec3::UnitX()});
    CHECK_THROWS_AS(s.rigid.add_rows(&s.rows), RigidError);  // twice
    CHECK_THROWS_AS(s.rigid.add_rows(nullptr), RigidError);
    s.rigid.remove_rows(&s.rows);
    s.pipeline.step(Real(1) / 60);
    CHECK(s.rows.passes == 0);
    CHECK(s.rigid.linear_velocity(s.box).norm() == 0);
    CHECK(s.rows.particles[0].v.x() == Real(-3));
}
