// "Soft step" (Catto, Solver2D 2024, as in Box2D v3): the step is split into sub-steps; each sub-step
// integrates velocities, warm starts, solves the contacts once with soft constraints (Catto 2011: a
// spring-damper of `contact_hertz` and `contact_damping_ratio`, implicit and so unconditionally stable)
// biased to remove penetration, integrates positions, and relaxes once without the bias so the push-out
// does not turn into kinetic energy. Contacts are detected once per step; within the step each point's
// separation is updated from the bodies' motion since the step began (anchors rotated by each body's
// rotation since then). No slop: any penetration gets a restoring push, so a tilted box in a tower is
// levelled instead of creeping within the slop band.
#include <algorithm>
#include <vector>

#include "rigid/joint_set.hpp"
#include "rigid/rigid_solver.hpp"

namespace sinew {

namespace {

struct Softness {
    Real bias_rate = 0, mass_scale = 1, impulse_scale = 0;
};

/// Catto 2011 soft constraint for frequency `hertz`, damping ratio `zeta`, step h.
Softness make_softness(Real hertz, Real zeta, Real h) {
    if (hertz <= 0) return {};
    Real omega = 2 * kPi * hertz;
    Real a1 = 2 * zeta + h * omega;
    Real a2 = h * omega * a1;
    Real a3 = 1 / (1 + a2);
    return {omega / a1, a2 * a3, a3};
}

// The contact loops work on 4-wide vectors (x, y, z, 0): Eigen maps them to one SIMD register, so a
// dot product or an impulse update is a couple of instructions instead of six scalar ones.
// Measured on pyramid-40 (soft step, 5 sub-steps): 758M -> see commit message for the after figure.
using V4 = Eigen::Matrix<Real, 4, 1>;
inline V4 v4(const Vec3& a) { return V4(a.x(), a.y(), a.z(), 0); }
inline Vec3 v3(const V4& a) { return a.head<3>(); }

// Solver-local copy of a body's hot state: what the contact loops touch, contiguous per body.
struct SoftBody {
    V4 v, w;
    Vec3 dp;   // translation of the centre of mass since the step began
    Mat3 dr;   // rotation since the step began
    Real inv_m;
};

struct SoftPoint {
    V4 ra, rb;            // anchors from the centres of mass at the start of the step (world axes)
    V4 ra_n, rb_n, ia_n, ib_n;
    V4 ra_t[2], rb_t[2], ia_t[2], ib_t[2];
    Real normal_mass, tangent_mass[2];
    Real normal_impulse, tangent_impulse[2], max_normal_impulse;
    Real adjusted_separation;  // separation at detection minus n.(rb - ra)
    Real relative_velocity;    // normal velocity at the start of the step (for restitution)
};

struct SoftContact {
    std::uint32_t a, b;
    V4 n, t[2];
    Real friction, restitution;
    Softness soft;
    int count;
    std::uint32_t manifold;
    SoftPoint p[Manifold::kMaxPoints];
};

class SoftStepSolver final : public RigidSolver {
public:
    bool integrates_itself() const override { return true; }
    void solve_velocities(RigidSystem& sys, Real h) override;
    void correct_positions(RigidSystem& sys, Real h) override;

private:
    void prepare(RigidSystem& sys, Real h_sub);
    void warm_start();
    void solve(Real inv_h_sub, Real push_velocity, bool use_bias);
    void restitution(Real threshold);

    std::vector<SoftContact> contacts_;
    std::vector<SoftBody> bodies_;
    std::vector<Quat> q0_;  // orientation at the start of the step
    // The last sub-step is finished in correct_positions(), after the pipeline's coupling hooks.
    void integrate_and_relax(RigidSystem& sys);
    bool pending_ = false, have_joints_ = false;
    int n_sub_ = 1;
    Real h_sub_ = 0;
};

void SoftStepSolver::prepare(RigidSystem& sys, Real h_sub) {
    const RigidSettings& set = sys.settings();
    const RigidSystem::State& st = sys.state();
    const auto& src = sys.contacts();
    // Contact stiffness is capped at a quarter of the sub-step rate (Box2D v3), and contacts against
    // immovable bodies are twice as stiff since only one body gives way.
    const Real hertz = std::min(set.contact_hertz, Real(0.25) / h_sub);
    const Softness soft = make_softness(hertz, set.contact_damping_ratio, h_sub);
    const Softness static_soft = make_softness(2 * hertz, set.contact_damping_ratio, h_sub);
    contacts_.resize(src.size());
    for (std::size_t ci = 0; ci < src.size(); ++ci) {
        const ContactManifold& cm = src[ci];
        SoftContact& c = contacts_[ci];
        c.a = cm.body_a;
        c.b = cm.body_b;
        Vec3 n = cm.manifold.normal, t1, t2;
        tangent_basis(n, t1, t2);
        c.n = v4(n);
        c.t[0] = v4(t1);
        c.t[1] = v4(t2);
        c.friction = cm.friction;
        c.restitution = cm.restitution;
        c.count = cm.manifold.count;
        c.manifold = std::uint32_t(ci);
        const Real wa = st.inv_mass[c.a], wb = st.inv_mass[c.b];
        c.soft = (wa == 0 || wb == 0) ? static_soft : soft;
        const Mat3& ia = st.inv_inertia_world[c.a];
        const Mat3& ib = st.inv_inertia_world[c.b];
        for (int k = 0; k < c.count; ++k) {
            const ContactPoint& cp = cm.manifold.points[k];
            SoftPoint& p = c.p[k];
            const Vec3 ra = cp.position - st.x[c.a], rb = cp.position - st.x[c.b];
            const Vec3 ra_n = ra.cross(n), rb_n = rb.cross(n);
            const Vec3 ia_n = ia * ra_n, ib_n = ib * rb_n;
            p.ra = v4(ra);
            p.rb = v4(rb);
            p.ra_n = v4(ra_n);
            p.rb_n = v4(rb_n);
            p.ia_n = v4(ia_n);
            p.ib_n = v4(ib_n);
            Real kn = wa + wb + ra_n.dot(ia_n) + rb_n.dot(ib_n);
            p.normal_mass = kn > 0 ? 1 / kn : 0;
            const Vec3 ts[2] = {t1, t2};
            for (int t = 0; t < 2; ++t) {
                const Vec3 ra_t = ra.cross(ts[t]), rb_t = rb.cross(ts[t]);
                const Vec3 ia_t = ia * ra_t, ib_t = ib * rb_t;
                p.ra_t[t] = v4(ra_t);
                p.rb_t[t] = v4(rb_t);
                p.ia_t[t] = v4(ia_t);
                p.ib_t[t] = v4(ib_t);
                Real kt = wa + wb + ra_t.dot(ia_t) + rb_t.dot(ib_t);
                p.tangent_mass[t] = kt > 0 ? 1 / kt : 0;
            }
            const bool warm = set.warm_starting;
            p.normal_impulse = warm ? cp.normal_impulse : 0;
            p.tangent_impulse[0] = warm ? cp.tangent_impulse[0] : 0;
            p.tangent_impulse[1] = warm ? cp.tangent_impulse[1] : 0;
            p.max_normal_impulse = 0;
            p.adjusted_separation = -cp.depth - n.dot(rb - ra);
            p.relative_velocity = n.dot(st.v[c.b] + st.w[c.b].cross(rb) - st.v[c.a] - st.w[c.a].cross(ra));
        }
    }
}

void SoftStepSolver::warm_start() {
    for (SoftContact& c : contacts_) {
        SoftBody& A = bodies_[c.a];
        SoftBody& B = bodies_[c.b];
        V4 va = A.v, vb = B.v, oa = A.w, ob = B.w;  // locals: no aliasing reloads in the loop
        for (int k = 0; k < c.count; ++k) {
            const SoftPoint& p = c.p[k];
            V4 j = p.normal_impulse * c.n + p.tangent_impulse[0] * c.t[0] + p.tangent_impulse[1] * c.t[1];
            va -= A.inv_m * j;
            vb += B.inv_m * j;
            oa -= p.normal_impulse * p.ia_n + p.tangent_impulse[0] * p.ia_t[0] + p.tangent_impulse[1] * p.ia_t[1];
            ob += p.normal_impulse * p.ib_n + p.tangent_impulse[0] * p.ib_t[0] + p.tangent_impulse[1] * p.ib_t[1];
        }
        A.v = va;
        A.w = oa;
        B.v = vb;
        B.w = ob;
    }
}

void SoftStepSolver::solve(Real inv_h_sub, Real push_velocity, bool use_bias) {
    for (SoftContact& c : contacts_) {
        SoftBody& A = bodies_[c.a];
        SoftBody& B = bodies_[c.b];
        const Real wa = A.inv_m, wb = B.inv_m;
        V4 va = A.v, vb = B.v, oa = A.w, ob = B.w;  // locals: no aliasing reloads in the loop
        // Current separation from the motion since the step began (Box2D v3's anchor update):
        // s = n.(dp_B - dp_A) + (dR_B^T n).r_B - (dR_A^T n).r_A + adjusted separation.
        const Vec3 n3 = v3(c.n);
        const Real dpn = n3.dot(B.dp - A.dp);
        const V4 na = v4(A.dr.transpose() * n3), nb = v4(B.dr.transpose() * n3);
        for (int k = 0; k < c.count; ++k) {
            SoftPoint& p = c.p[k];
            // One SIMD product and one horizontal sum per row, not three dot products.
            Real s = dpn + (nb.cwiseProduct(p.rb) - na.cwiseProduct(p.ra)).sum() + p.adjusted_separation;
            Real bias = 0, mass_scale = 1, impulse_scale = 0;
            if (s > 0) {
                bias = s * inv_h_sub;  // speculative: may close the gap this sub-step
            } else if (use_bias) {
                bias = std::max(c.soft.bias_rate * s, -push_velocity);
                mass_scale = c.soft.mass_scale;
                impulse_scale = c.soft.impulse_scale;
            }
            Real vn = (c.n.cwiseProduct(vb - va) + p.rb_n.cwiseProduct(ob) - p.ra_n.cwiseProduct(oa)).sum();
            Real impulse = -p.normal_mass * mass_scale * (vn + bias) - impulse_scale * p.normal_impulse;
            Real acc = std::max(p.normal_impulse + impulse, Real(0));
            Real dl = acc - p.normal_impulse;
            p.normal_impulse = acc;
            p.max_normal_impulse = std::max(p.max_normal_impulse, dl);
            va -= (dl * wa) * c.n;
            vb += (dl * wb) * c.n;
            oa -= dl * p.ia_n;
            ob += dl * p.ib_n;
        }
        // Friction after the normals (Box2D v3 order within a sub-step), bounded by each point's normal
        // impulse (seed 001 ch.5), on two persistent tangents.
        for (int k = 0; k < c.count; ++k) {
            SoftPoint& p = c.p[k];
            const Real max_f = c.friction * p.normal_impulse;
            // Both tangent rows from the same velocities, then clamped together to the friction circle.
            const V4 dv = vb - va;
            Real vt0 = (c.t[0].cwiseProduct(dv) + p.rb_t[0].cwiseProduct(ob) - p.ra_t[0].cwiseProduct(oa)).sum();
            Real vt1 = (c.t[1].cwiseProduct(dv) + p.rb_t[1].cwiseProduct(ob) - p.ra_t[1].cwiseProduct(oa)).sum();
            Real l0 = p.tangent_impulse[0] - p.tangent_mass[0] * vt0;
            Real l1 = p.tangent_impulse[1] - p.tangent_mass[1] * vt1;
            clamp_to_friction_circle(l0, l1, max_f);
            Real d0 = l0 - p.tangent_impulse[0], d1 = l1 - p.tangent_impulse[1];
            p.tangent_impulse[0] = l0;
            p.tangent_impulse[1] = l1;
            V4 j = d0 * c.t[0] + d1 * c.t[1];
            va -= wa * j;
            vb += wb * j;
            oa -= d0 * p.ia_t[0] + d1 * p.ia_t[1];
            ob += d0 * p.ib_t[0] + d1 * p.ib_t[1];
        }
        A.v = va;
        A.w = oa;
        B.v = vb;
        B.w = ob;
    }
}

void SoftStepSolver::restitution(Real threshold) {
    for (SoftContact& c : contacts_) {
        if (c.restitution == 0) continue;
        SoftBody& A = bodies_[c.a];
        SoftBody& B = bodies_[c.b];
        for (int k = 0; k < c.count; ++k) {
            SoftPoint& p = c.p[k];
            // Only impacts faster than the threshold that actually pushed (Box2D v3).
            if (p.relative_velocity > -threshold || p.max_normal_impulse == 0) continue;
            Real vn = c.n.dot(B.v - A.v) + p.rb_n.dot(B.w) - p.ra_n.dot(A.w);
            Real impulse = -p.normal_mass * (vn + c.restitution * p.relative_velocity);
            Real acc = std::max(p.normal_impulse + impulse, Real(0));
            Real dl = acc - p.normal_impulse;
            p.normal_impulse = acc;
            A.v -= (dl * A.inv_m) * c.n;
            B.v += (dl * B.inv_m) * c.n;
            A.w -= dl * p.ia_n;
            B.w += dl * p.ib_n;
        }
    }
}

void SoftStepSolver::solve_velocities(RigidSystem& sys, Real h) {
    const RigidSettings& set = sys.settings();
    const int n_sub = set.effective_substeps();
    const Real h_sub = h / Real(n_sub), inv_h_sub = Real(n_sub) / h;
    RigidSystem::State& st = sys.state();
    prepare(sys, h_sub);
    const std::size_t nb = st.x.size();
    bodies_.resize(nb);
    q0_.assign(st.q.begin(), st.q.end());
    for (std::size_t s = 0; s < nb; ++s) {
        SoftBody& b = bodies_[s];
        b.v = v4(st.v[s]);
        b.w = v4(st.w[s]);
        b.dp.setZero();
        b.dr.setIdentity();
        b.inv_m = st.inv_mass[s];
    }
    // Joints are soft too (Box2D v3: twice the contact stiffness, damping ratio 2); they work on the
    // system's arrays, synced with the solver's copies around each joint pass when joints exist.
    JointSet& joints = sys.joints();
    const bool have_joints = joints.count() > 0;
    auto to_state = [&] {
        for (std::size_t s = 0; s < nb; ++s) {
            st.v[s] = v3(bodies_[s].v);
            st.w[s] = v3(bodies_[s].w);
        }
    };
    auto from_state = [&] {
        for (std::size_t s = 0; s < nb; ++s) {
            bodies_[s].v = v4(st.v[s]);
            bodies_[s].w = v4(st.w[s]);
        }
    };
    if (have_joints)
        joints.prepare(sys, h_sub, JointSoftness{true, set.baumgarte, 2 * set.contact_hertz, 2}, set.warm_starting);
    have_joints_ = have_joints;
    n_sub_ = n_sub;
    h_sub_ = h_sub;
    for (int i = 0; i < n_sub; ++i) {
        // Velocities of moving bodies: gravity and forces, through the system (it owns the body data).
        to_state();
        sys.integrate_velocities(h_sub);
        from_state();
        if (have_joints) {
            to_state();
            if (set.warm_starting) joints.warm_start(sys);
            joints.solve(sys, true);
            from_state();
        }
        if (set.warm_starting) warm_start();
        solve(inv_h_sub, set.contact_push_velocity, true);
        if (i + 1 == n_sub) break;  // the last sub-step's positions wait for IntegratePositions
        integrate_and_relax(sys);
    }
    // Hand the velocities to the pipeline: a coupling hook between SolveVelocities and
    // IntegratePositions (seed 001 Figure 9) still changes the last sub-step's positions.
    to_state();
    pending_ = true;
}

void SoftStepSolver::integrate_and_relax(RigidSystem& sys) {
    const RigidSettings& set = sys.settings();
    RigidSystem::State& st = sys.state();
    const std::size_t nb = bodies_.size();
    // Positions (kinematic bodies move with their velocity; static and sleeping ones have none).
    for (std::size_t s = 0; s < nb; ++s) {
        SoftBody& b = bodies_[s];
        if (b.inv_m == 0 && b.v.isZero() && b.w.isZero()) continue;
        const Vec3 v = v3(b.v), w = v3(b.w);
        st.x[s] += h_sub_ * v;
        b.dp += h_sub_ * v;
        st.q[s] = integrate_rotation(st.q[s], w, h_sub_);
        b.dr = (st.q[s] * q0_[s].conjugate()).toRotationMatrix();
    }
    if (have_joints_) {
        for (std::size_t s = 0; s < nb; ++s) {
            st.v[s] = v3(bodies_[s].v);
            st.w[s] = v3(bodies_[s].w);
        }
        sys.joints().solve(sys, false);
        for (std::size_t s = 0; s < nb; ++s) {
            bodies_[s].v = v4(st.v[s]);
            bodies_[s].w = v4(st.w[s]);
        }
    }
    solve(Real(1) / h_sub_, set.contact_push_velocity, false);  // relax: remove the bias velocity
}

void SoftStepSolver::correct_positions(RigidSystem& sys, Real) {
    if (!pending_) return;
    pending_ = false;
    RigidSystem::State& st = sys.state();
    const std::size_t nb = bodies_.size();
    for (std::size_t s = 0; s < nb; ++s) {  // coupling layers may have changed them
        bodies_[s].v = v4(st.v[s]);
        bodies_[s].w = v4(st.w[s]);
    }
    integrate_and_relax(sys);
    restitution(sys.settings().restitution_threshold);
    for (std::size_t s = 0; s < nb; ++s) {
        if (st.inv_mass[s] == 0) continue;
        st.v[s] = v3(bodies_[s].v);
        st.w[s] = v3(bodies_[s].w);
    }
    store_contact_impulses(contacts_, sys.mutable_contacts());
}

}  // namespace

std::unique_ptr<RigidSolver> make_soft_step_solver() { return std::make_unique<SoftStepSolver>(); }

}  // namespace sinew
