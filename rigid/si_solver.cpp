// Sequential impulses (Catto 2005, "Iterative Dynamics with Temporal Coherence"; Catto 2011 GDC):
// contact constraints are prepared once per step into flat arrays (arms, effective masses, biases), then
// iterated with accumulated, clamped impulses; warm starting applies last step's impulses first.
//
// Position error: Baumgarte feeds -(beta/h) max(d - slop, 0) into the velocity constraint (simple, but
// the correction becomes kinetic energy: stacks jitter and bodies pop apart), or split impulses
// (Catto's "pseudo velocities", as in Bullet's split-impulse mode) solve the same bias on separate
// velocities that move positions and are then discarded, so no energy is added.
//
// Speculative contacts: points within the contact margin with gap g > 0 let the bodies approach by
// g/h this step, so fast bodies stop at the surface instead of tunnelling deep.
#include <algorithm>
#include <cmath>
#include <vector>

#include "rigid/constraint_rows.hpp"
#include "rigid/rigid_solver.hpp"

namespace sinew {

namespace {

struct SolverBody {
    Vec3 v, w;    // velocity
    Vec3 vp, wp;  // pseudo velocity (split impulses)
    Real inv_m;
    Mat3 inv_i;
};

struct PointConstraint {
    Vec3 ra, rb;               // arms from the centres of mass
    Vec3 ra_n, rb_n;           // ra x n, rb x n
    Vec3 ia_n, ib_n;           // I_a^-1 (ra x n), I_b^-1 (rb x n)
    Vec3 ra_t[2], rb_t[2], ia_t[2], ib_t[2];
    Real normal_mass, tangent_mass[2];
    Real normal_impulse, tangent_impulse[2], pseudo_impulse;
    Real velocity_target;      // minimum normal velocity: restitution, Baumgarte or speculative
    Real pseudo_target;        // split impulses: pseudo normal velocity that removes penetration
};

struct ContactConstraint {
    std::uint32_t a, b;
    Vec3 n, t[2];
    Real friction;
    Real inv_ma, inv_mb;     // the bodies' inverse masses as this contact sees them (mass-ratio bound)
    int count;
    std::uint32_t manifold;  // index into RigidSystem::contacts()
    PointConstraint p[Manifold::kMaxPoints];
};

class SequentialImpulseSolver final : public RigidSolver {
public:
    void solve_velocities(RigidSystem& sys, Real h) override;
    void finish_step(RigidSystem& sys, Real h) override;

private:
    void prepare(RigidSystem& sys, Real h);
    void warm_start();
    void solve_iteration(bool split);
    void store_impulses(RigidSystem& sys);

    std::vector<SolverBody> bodies_;
    std::vector<ContactConstraint> constraints_;
    bool have_pseudo_ = false;
};

void SequentialImpulseSolver::prepare(RigidSystem& sys, Real h) {
    const RigidSettings& set = sys.settings();
    const RigidSystem::State& st = sys.state();
    const std::size_t n = st.x.size();
    bodies_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        SolverBody& b = bodies_[i];
        b.v = st.v[i];
        b.w = st.w[i];
        b.vp.setZero();
        b.wp.setZero();
        b.inv_m = st.inv_mass[i];
        b.inv_i = st.inv_inertia_world[i];
    }
    const auto& contacts = sys.contacts();
    constraints_.resize(contacts.size());
    const bool split = set.solver == RigidSolverKind::SplitImpulse;
    const Real inv_h = 1 / h;
    for (std::size_t ci = 0; ci < contacts.size(); ++ci) {
        const ContactManifold& cm = contacts[ci];
        ContactConstraint& c = constraints_[ci];
        c.a = cm.body_a;
        c.b = cm.body_b;
        c.n = cm.manifold.normal;
        tangent_basis(c.n, c.t[0], c.t[1]);  // persistent for a persistent normal (seed 001 ch.5)
        c.friction = cm.friction;
        c.count = cm.manifold.count;
        c.manifold = static_cast<std::uint32_t>(ci);
        const SolverBody& A = bodies_[c.a];
        const SolverBody& B = bodies_[c.b];
        // A body holding up one far heavier looks heavier to this contact alone (rigid/rigid_support.cpp).
        Real sa, sb;
        sys.contact_mass_scales(c.a, c.b, sa, sb);
        c.inv_ma = sa * A.inv_m;
        c.inv_mb = sb * B.inv_m;
        const Mat3 inv_ia = sa * A.inv_i, inv_ib = sb * B.inv_i;
        for (int k = 0; k < c.count; ++k) {
            const ContactPoint& cp = cm.manifold.points[k];
            PointConstraint& p = c.p[k];
            p.ra = cp.position - st.x[c.a];
            p.rb = cp.position - st.x[c.b];
            p.ra_n = p.ra.cross(c.n);
            p.rb_n = p.rb.cross(c.n);
            p.ia_n = inv_ia * p.ra_n;
            p.ib_n = inv_ib * p.rb_n;
            Real kn = c.inv_ma + c.inv_mb + p.ra_n.dot(p.ia_n) + p.rb_n.dot(p.ib_n);
            p.normal_mass = kn > 0 ? 1 / kn : 0;
            for (int t = 0; t < 2; ++t) {
                p.ra_t[t] = p.ra.cross(c.t[t]);
                p.rb_t[t] = p.rb.cross(c.t[t]);
                p.ia_t[t] = inv_ia * p.ra_t[t];
                p.ib_t[t] = inv_ib * p.rb_t[t];
                Real kt = c.inv_ma + c.inv_mb + p.ra_t[t].dot(p.ia_t[t]) + p.rb_t[t].dot(p.ib_t[t]);
                p.tangent_mass[t] = kt > 0 ? 1 / kt : 0;
            }
            const bool warm = set.warm_starting;
            p.normal_impulse = warm ? cp.normal_impulse : 0;
            p.tangent_impulse[0] = warm ? cp.tangent_impulse[0] : 0;
            p.tangent_impulse[1] = warm ? cp.tangent_impulse[1] : 0;
            p.pseudo_impulse = 0;

            // Relative normal velocity before the solve (B relative to A, along n from A to B).
            Real vn = (B.v + B.w.cross(p.rb) - A.v - A.w.cross(p.ra)).dot(c.n);
            Real d = cp.depth;
            Real target;
            if (d < 0) {
                target = d * inv_h;  // speculative: may approach by the gap this step
            } else if (split) {
                target = 0;
            } else {
                target = std::min(set.baumgarte * inv_h * std::max(d - set.linear_slop, Real(0)),
                                  set.max_correction_velocity);
            }
            // Restitution only above the threshold (resting contacts must not bounce) and only for a
            // point the bodies reach within this step.
            if (cm.restitution > 0 && vn < -set.restitution_threshold && d > vn * h)
                target = std::max(target, -cm.restitution * vn);
            p.velocity_target = target;
            p.pseudo_target = split ? std::min(set.baumgarte * inv_h * std::max(d - set.linear_slop, Real(0)),
                                               set.max_correction_velocity)
                                    : 0;
        }
    }
    have_pseudo_ = split;
}

void SequentialImpulseSolver::warm_start() {
    for (ContactConstraint& c : constraints_) {
        SolverBody& A = bodies_[c.a];
        SolverBody& B = bodies_[c.b];
        for (int k = 0; k < c.count; ++k) {
            const PointConstraint& p = c.p[k];
            Vec3 j = p.normal_impulse * c.n + p.tangent_impulse[0] * c.t[0] + p.tangent_impulse[1] * c.t[1];
            A.v -= c.inv_ma * j;
            B.v += c.inv_mb * j;
            A.w -= p.normal_impulse * p.ia_n + p.tangent_impulse[0] * p.ia_t[0] + p.tangent_impulse[1] * p.ia_t[1];
            B.w += p.normal_impulse * p.ib_n + p.tangent_impulse[0] * p.ib_t[0] + p.tangent_impulse[1] * p.ib_t[1];
        }
    }
}

void SequentialImpulseSolver::solve_iteration(bool split) {
    for (ContactConstraint& c : constraints_) {
        SolverBody& A = bodies_[c.a];
        SolverBody& B = bodies_[c.b];
        // Friction first, bounded by the point's current normal impulse (seed 001 ch.5); the normal
        // constraint last, because non-penetration matters most.
        for (int k = 0; k < c.count; ++k) {
            PointConstraint& p = c.p[k];
            const Real max_f = c.friction * p.normal_impulse;
            // Both tangent rows from the same velocities, then clamped together to the friction circle.
            const Vec3 dv = B.v - A.v;
            Real vt0 = c.t[0].dot(dv) + p.rb_t[0].dot(B.w) - p.ra_t[0].dot(A.w);
            Real vt1 = c.t[1].dot(dv) + p.rb_t[1].dot(B.w) - p.ra_t[1].dot(A.w);
            Real l0 = p.tangent_impulse[0] - p.tangent_mass[0] * vt0;
            Real l1 = p.tangent_impulse[1] - p.tangent_mass[1] * vt1;
            clamp_to_friction_circle(l0, l1, max_f);
            Real d0 = l0 - p.tangent_impulse[0], d1 = l1 - p.tangent_impulse[1];
            p.tangent_impulse[0] = l0;
            p.tangent_impulse[1] = l1;
            Vec3 j = d0 * c.t[0] + d1 * c.t[1];
            A.v -= c.inv_ma * j;
            B.v += c.inv_mb * j;
            A.w -= d0 * p.ia_t[0] + d1 * p.ia_t[1];
            B.w += d0 * p.ib_t[0] + d1 * p.ib_t[1];
        }
        for (int k = 0; k < c.count; ++k) {
            PointConstraint& p = c.p[k];
            Real vn = c.n.dot(B.v - A.v) + p.rb_n.dot(B.w) - p.ra_n.dot(A.w);
            Real old = p.normal_impulse;
            Real acc = std::max(old - p.normal_mass * (vn - p.velocity_target), Real(0));
            Real dl = acc - old;
            p.normal_impulse = acc;
            A.v -= (dl * c.inv_ma) * c.n;
            B.v += (dl * c.inv_mb) * c.n;
            A.w -= dl * p.ia_n;
            B.w += dl * p.ib_n;
        }
        if (!split) continue;
        for (int k = 0; k < c.count; ++k) {
            PointConstraint& p = c.p[k];
            if (p.pseudo_target <= 0 && p.pseudo_impulse <= 0) continue;
            Real vn = c.n.dot(B.vp - A.vp) + p.rb_n.dot(B.wp) - p.ra_n.dot(A.wp);
            Real old = p.pseudo_impulse;
            Real acc = std::max(old - p.normal_mass * (vn - p.pseudo_target), Real(0));
            Real dl = acc - old;
            p.pseudo_impulse = acc;
            A.vp -= (dl * c.inv_ma) * c.n;
            B.vp += (dl * c.inv_mb) * c.n;
            A.wp -= dl * p.ia_n;
            B.wp += dl * p.ib_n;
        }
    }
}

void SequentialImpulseSolver::store_impulses(RigidSystem& sys) {
    RigidSystem::State& st = sys.state();
    for (std::size_t i = 0; i < bodies_.size(); ++i) {
        if (st.inv_mass[i] == 0) continue;  // static, kinematic, sleeping: velocities are the game's
        st.v[i] = bodies_[i].v;
        st.w[i] = bodies_[i].w;
    }
    store_contact_impulses(constraints_, sys.mutable_contacts());
}

void SequentialImpulseSolver::solve_velocities(RigidSystem& sys, Real h) {
    const RigidSettings& set = sys.settings();
    prepare(sys, h);
    // Joints and other outside rows (rigid/constraint_rows.hpp) work on the solver's own bodies.
    const bool split = set.solver == RigidSolverKind::SplitImpulse;
    // With split impulses and warm starting the joints project their error after the step (no bias here).
    const RowStep step{h, 1, set.warm_starting, RowSoftness{false, split && set.warm_starting, set.baumgarte, 0, 0}};
    const std::vector<ConstraintRows*>& sources = sys.row_sources();
    for (ConstraintRows* rows : sources) rows->prepare(sys, step);
    const BodyVelocities vel = BodyVelocities::of(bodies_, &SolverBody::v, &SolverBody::w);
    if (set.warm_starting) {
        warm_start();
        for (ConstraintRows* rows : sources) rows->warm_start(sys, vel);
    }
    for (int it = 0; it < set.velocity_iterations; ++it) {
        for (ConstraintRows* rows : sources) rows->solve(sys, vel, true);  // outside rows first (Box2D's order)
        solve_iteration(split);
    }
    store_impulses(sys);
}

void SequentialImpulseSolver::finish_step(RigidSystem& sys, Real h) {
    if (!have_pseudo_) return;
    RigidSystem::State& st = sys.state();
    for (std::size_t i = 0; i < bodies_.size() && i < st.x.size(); ++i) {
        if (st.inv_mass[i] == 0) continue;
        const SolverBody& b = bodies_[i];
        st.x[i] += h * b.vp;
        st.q[i] = integrate_rotation(st.q[i], b.wp, h);
    }
    have_pseudo_ = false;
}

}  // namespace

std::unique_ptr<RigidSolver> make_sequential_impulse_solver() { return std::make_unique<SequentialImpulseSolver>(); }

}  // namespace sinew
