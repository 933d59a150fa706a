// "Soft step" (Catto, Solver2D 2024, as in Box2D v3): the step is split into sub-steps; each sub-step
// integrates velocities, warm starts, solves the contacts once with soft constraints (Catto 2011: a
// spring-damper of `contact_hertz` and `contact_damping_ratio`, implicit and so unconditionally stable)
// biased to remove penetration, integrates positions, and relaxes once without the bias so the push-out
// does not turn into kinetic energy. No slop: any penetration gets a restoring push, so a tilted box in a
// tower is levelled instead of creeping within the slop band.
//
// Contacts are detected once per step. Within the step a point's separation follows the bodies' motion to
// first order, s = s0 + n.(dp_B - dp_A) + (r_B x n).dth_B - (r_A x n).dth_A, with dp and dth the
// translation and rotation vector accumulated since the step began: the Jacobian row applied to the
// displacement, as NVIDIA's TGS solver does. It needs no rotated anchors, so a body's solver state is
// four rows (v, w, dp, dth) that a 4x4 transpose gathers.
//
// Manifolds are graph-coloured (rigid/constraint_colouring.hpp) and a colour is solved four manifolds at
// a time, one per SIMD lane (rigid/wide_float.hpp), as Box2D v3 does. Manifolds that fit no colour run
// one per batch. Measured on pyramid-40 (820 boxes, 2,380 manifolds): see the commit message.
#include <algorithm>
#include <vector>

#include "rigid/constraint_colouring.hpp"
#include "rigid/joint_set.hpp"
#include "rigid/rigid_solver.hpp"
#include "rigid/wide_float.hpp"

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

/// Point slot k of four manifolds, one per lane. Lanes whose manifold has fewer points keep zero masses
/// and impulses, so they compute nothing.
struct WidePoint {
    Vec3W ra_n, rb_n, ia_n, ib_n;  // r x n and I^-1 (r x n) for A and B
    Vec3W ra_t[2], rb_t[2], ia_t[2], ib_t[2];
    FloatW normal_mass, tangent_mass[2];
    FloatW normal_impulse, tangent_impulse[2], max_normal_impulse;
    FloatW base_separation;    // separation at detection (negative = overlap)
    FloatW relative_velocity;  // normal velocity at the start of the step (restitution)
};

/// Four manifolds solved side by side. Unused lanes point at the padding body and have zero masses.
struct WideContact {
    std::int32_t a[kWideLanes], b[kWideLanes];
    Vec3W n, t[2];
    FloatW inv_ma, inv_mb, inv_m_sum, friction, restitution;
    FloatW bias_rate, mass_scale, impulse_scale;  // soft contact (Catto 2011), per lane
    std::uint32_t manifold[kWideLanes];           // source manifold, or kNoManifold
    int count[kWideLanes];
    int max_count;
    bool any_restitution;
    WidePoint p[Manifold::kMaxPoints];
};

constexpr std::uint32_t kNoManifold = 0xFFFFFFFFu;

class SoftStepSolver final : public RigidSolver {
public:
    bool integrates_itself() const override { return true; }
    void solve_velocities(RigidSystem& sys, Real h) override;
    void correct_positions(RigidSystem& sys, Real h) override;

private:
    void colour(const RigidSystem& sys);
    void prepare(const RigidSystem& sys, Real h_sub);
    /// Prepares batch c from up to four manifolds of one colour (`lanes` of them).
    void fill_batch(WideContact& c, const std::uint32_t* manifolds, int lanes, const RigidSystem& sys,
                    const Softness& soft, const Softness& static_soft);
    void warm_start();
    void solve(Real inv_h_sub, Real push_velocity, bool use_bias);
    void restitution(Real threshold);
    void store_impulses(RigidSystem& sys) const;
    void bodies_to_state(RigidSystem::State& st) const;
    void bodies_from_state(const RigidSystem::State& st);
    // The last sub-step is finished in correct_positions(), after the pipeline's coupling hooks.
    void integrate_and_relax(RigidSystem& sys);

    ConstraintColouring colouring_;
    std::vector<std::uint32_t> by_colour_[ConstraintColouring::kColours + 1];
    std::vector<WideContact> contacts_;
    std::vector<WideBody> bodies_;  // one per body slot, then the padding body (always at rest)
    std::int32_t pad_ = 0;  // index of the padding body
    bool pending_ = false, have_joints_ = false;
    Real h_sub_ = 0;
};

void SoftStepSolver::colour(const RigidSystem& sys) {
    const RigidSystem::State& st = sys.state();
    const auto& src = sys.contacts();
    colouring_.reset(st.x.size());
    for (auto& list : by_colour_) list.clear();
    for (std::size_t ci = 0; ci < src.size(); ++ci) {
        const std::uint32_t a = src[ci].body_a, b = src[ci].body_b;
        const int c = colouring_.assign(a, st.inv_mass[a] > 0, b, st.inv_mass[b] > 0);
        by_colour_[c].push_back(std::uint32_t(ci));
    }
}

void SoftStepSolver::fill_batch(WideContact& c, const std::uint32_t* manifolds, int lanes, const RigidSystem& sys,
                                const Softness& soft, const Softness& static_soft) {
    const RigidSettings& set = sys.settings();
    const RigidSystem::State& st = sys.state();
    const auto& src = sys.contacts();
    const bool warm = set.warm_starting;
    // Per-lane data is gathered into lanes; the arms, Jacobians and effective masses are then computed
    // four lanes at a time. Unused lanes point at the padding body with zero mass and inertia.
    Vec3W xa{}, xb{}, va{}, vb{}, wa{}, wb{};
    Mat3W ia{}, ib{};
    c.max_count = 0;
    c.any_restitution = false;
    for (int l = 0; l < kWideLanes; ++l) {
        Softness s{};
        if (l < lanes) {
            const ContactManifold& cm = src[manifolds[l]];
            const std::uint32_t a = cm.body_a, b = cm.body_b;
            c.a[l] = std::int32_t(a);
            c.b[l] = std::int32_t(b);
            c.manifold[l] = manifolds[l];
            c.count[l] = cm.manifold.count;
            c.max_count = std::max(c.max_count, cm.manifold.count);
            Vec3 n = cm.manifold.normal, t0, t1;
            tangent_basis(n, t0, t1);  // persistent for a persistent normal (seed 001 ch.5)
            set_lane(c.n, l, n);
            set_lane(c.t[0], l, t0);
            set_lane(c.t[1], l, t1);
            c.inv_ma.set_lane(l, st.inv_mass[a]);
            c.inv_mb.set_lane(l, st.inv_mass[b]);
            c.friction.set_lane(l, cm.friction);
            c.restitution.set_lane(l, cm.restitution);
            c.any_restitution = c.any_restitution || cm.restitution > 0;
            // Contacts against immovable bodies are twice as stiff since only one body gives way (Box2D v3).
            s = (st.inv_mass[a] == 0 || st.inv_mass[b] == 0) ? static_soft : soft;
            set_lane(xa, l, st.x[a]);
            set_lane(xb, l, st.x[b]);
            set_lane(va, l, st.v[a]);
            set_lane(vb, l, st.v[b]);
            set_lane(wa, l, st.w[a]);
            set_lane(wb, l, st.w[b]);
            set_lane(ia, l, st.inv_inertia_world[a]);
            set_lane(ib, l, st.inv_inertia_world[b]);
        } else {
            c.a[l] = c.b[l] = pad_;
            c.manifold[l] = kNoManifold;
            c.count[l] = 0;
            set_lane(c.n, l, Vec3::UnitY());
            set_lane(c.t[0], l, Vec3::UnitX());
            set_lane(c.t[1], l, Vec3::UnitZ());
            c.inv_ma.set_lane(l, 0);
            c.inv_mb.set_lane(l, 0);
            c.friction.set_lane(l, 0);
            c.restitution.set_lane(l, 0);
        }
        c.bias_rate.set_lane(l, s.bias_rate);
        c.mass_scale.set_lane(l, s.mass_scale);
        c.impulse_scale.set_lane(l, s.impulse_scale);
    }
    const FloatW zero = zero_w(), one = splat(1);
    const FloatW inv_m_sum = c.inv_m_sum = c.inv_ma + c.inv_mb;
    for (int k = 0; k < c.max_count; ++k) {
        WidePoint& p = c.p[k];
        Vec3W pos{};
        FloatW valid = zero;
        for (int l = 0; l < kWideLanes; ++l) {
            if (k < c.count[l]) {
                const ContactPoint& cp = src[c.manifold[l]].manifold.points[k];
                set_lane(pos, l, cp.position);
                valid.set_lane(l, 1);
                p.normal_impulse.set_lane(l, warm ? cp.normal_impulse : 0);
                p.tangent_impulse[0].set_lane(l, warm ? cp.tangent_impulse[0] : 0);
                p.tangent_impulse[1].set_lane(l, warm ? cp.tangent_impulse[1] : 0);
                p.base_separation.set_lane(l, -cp.depth);
            } else {
                // An empty slot: zero arms, masses and impulses, so it computes nothing.
                set_lane(pos, l, lane(xa, l));
                p.normal_impulse.set_lane(l, 0);
                p.tangent_impulse[0].set_lane(l, 0);
                p.tangent_impulse[1].set_lane(l, 0);
                p.base_separation.set_lane(l, 0);
            }
        }
        const FloatW has = greater_w(valid, zero);
        const Vec3W ra = pos - xa, rb = pos - xb;
        p.ra_n = cross(ra, c.n);
        p.rb_n = cross(rb, c.n);
        p.ia_n = ia * p.ra_n;
        p.ib_n = ib * p.rb_n;
        const FloatW kn = inv_m_sum + dot(p.ra_n, p.ia_n) + dot(p.rb_n, p.ib_n);
        p.normal_mass = select_w(and_w(has, greater_w(kn, zero)), one / max_w(kn, splat(Real(1e-30))), zero);
        for (int t = 0; t < 2; ++t) {
            p.ra_t[t] = cross(ra, c.t[t]);
            p.rb_t[t] = cross(rb, c.t[t]);
            p.ia_t[t] = ia * p.ra_t[t];
            p.ib_t[t] = ib * p.rb_t[t];
            const FloatW kt = inv_m_sum + dot(p.ra_t[t], p.ia_t[t]) + dot(p.rb_t[t], p.ib_t[t]);
            p.tangent_mass[t] = select_w(and_w(has, greater_w(kt, zero)), one / max_w(kt, splat(Real(1e-30))), zero);
        }
        p.max_normal_impulse = zero;
        p.relative_velocity = dot(c.n, vb + cross(wb, rb) - va - cross(wa, ra));
    }
}

void SoftStepSolver::prepare(const RigidSystem& sys, Real h_sub) {
    const RigidSettings& set = sys.settings();
    // Contact stiffness is capped at a quarter of the sub-step rate (Box2D v3).
    const Real hertz = std::min(set.contact_hertz, Real(0.25) / h_sub);
    const Softness soft = make_softness(hertz, set.contact_damping_ratio, h_sub);
    const Softness static_soft = make_softness(2 * hertz, set.contact_damping_ratio, h_sub);
    colour(sys);
    std::size_t batches = by_colour_[ConstraintColouring::kOverflow].size();
    for (int c = 0; c < ConstraintColouring::kColours; ++c)
        batches += (by_colour_[c].size() + kWideLanes - 1) / kWideLanes;
    contacts_.resize(batches);
    pad_ = std::int32_t(bodies_.size() - 1);
    std::size_t next = 0;
    for (int col = 0; col < ConstraintColouring::kColours; ++col) {
        const auto& list = by_colour_[col];
        for (std::size_t i = 0; i < list.size(); i += kWideLanes)
            fill_batch(contacts_[next++], list.data() + i, int(std::min<std::size_t>(kWideLanes, list.size() - i)), sys,
                       soft, static_soft);
    }
    // Overflow: one manifold per batch, so lanes never share a moving body.
    for (const std::uint32_t& ci : by_colour_[ConstraintColouring::kOverflow])
        fill_batch(contacts_[next++], &ci, 1, sys, soft, static_soft);
}

void SoftStepSolver::warm_start() {
    WideBody* bodies = bodies_.data();
    for (WideContact& c : contacts_) {
        BodyW A = gather_bodies(bodies, c.a), B = gather_bodies(bodies, c.b);
        // The points share n and t, so their linear impulses add up before touching the velocities.
        FloatW pn = zero_w(), p0 = zero_w(), p1 = zero_w();
        for (int k = 0; k < c.max_count; ++k) {
            const WidePoint& p = c.p[k];
            pn += p.normal_impulse;
            p0 += p.tangent_impulse[0];
            p1 += p.tangent_impulse[1];
            A.w -= p.normal_impulse * p.ia_n + p.tangent_impulse[0] * p.ia_t[0] + p.tangent_impulse[1] * p.ia_t[1];
            B.w += p.normal_impulse * p.ib_n + p.tangent_impulse[0] * p.ib_t[0] + p.tangent_impulse[1] * p.ib_t[1];
        }
        const Vec3W j = pn * c.n + p0 * c.t[0] + p1 * c.t[1];
        A.v -= c.inv_ma * j;
        B.v += c.inv_mb * j;
        scatter_velocities(bodies, c.a, A);
        scatter_velocities(bodies, c.b, B);
    }
}

void SoftStepSolver::solve(Real inv_h_sub, Real push_velocity, bool use_bias) {
    WideBody* bodies = bodies_.data();
    const FloatW zero = zero_w(), one = splat(1), inv_h = splat(inv_h_sub), min_bias = splat(-push_velocity);
    for (WideContact& c : contacts_) {
        BodyW A = gather_bodies(bodies, c.a), B = gather_bodies(bodies, c.b);
        const FloatW dpn = dot(c.n, B.dp - A.dp);
        // The linear part of each row's velocity, n.(vB - vA) and t.(vB - vA), is the same for all points
        // of a manifold, and an impulse along n changes only the n part (n, t0, t1 are orthonormal) by
        // dl (1/mA + 1/mB). Tracking the three projections and applying the summed linear impulse once
        // at the end is exact and saves a third of the arithmetic.
        const Vec3W dv = B.v - A.v;
        FloatW vn_lin = dot(c.n, dv), vt0_lin = dot(c.t[0], dv), vt1_lin = dot(c.t[1], dv);
        FloatW pn = zero, p0 = zero, p1 = zero;
        for (int k = 0; k < c.max_count; ++k) {
            WidePoint& p = c.p[k];
            const FloatW s = p.base_separation + dpn + dot(p.rb_n, B.dth) - dot(p.ra_n, A.dth);
            // A gap (s > 0) is speculative: the bodies may close it this sub-step. An overlap gets the soft
            // push in the biased pass and nothing in the relax pass.
            const FloatW gap = greater_w(s, zero);
            FloatW bias, mass_scale = one, impulse_scale = zero;
            if (use_bias) {
                bias = select_w(gap, s * inv_h, max_w(c.bias_rate * s, min_bias));
                mass_scale = select_w(gap, one, c.mass_scale);
                impulse_scale = select_w(gap, zero, c.impulse_scale);
            } else {
                bias = select_w(gap, s * inv_h, zero);
            }
            const FloatW vn = vn_lin + dot(p.rb_n, B.w) - dot(p.ra_n, A.w);
            const FloatW impulse = zero - p.normal_mass * mass_scale * (vn + bias) - impulse_scale * p.normal_impulse;
            const FloatW acc = max_w(p.normal_impulse + impulse, zero);
            const FloatW dl = acc - p.normal_impulse;
            p.normal_impulse = acc;
            p.max_normal_impulse = max_w(p.max_normal_impulse, dl);
            vn_lin += dl * c.inv_m_sum;
            pn += dl;
            A.w -= dl * p.ia_n;
            B.w += dl * p.ib_n;
        }
        // Friction after the normals (Box2D v3 order within a sub-step), bounded by each point's normal
        // impulse (seed 001 ch.5), on two persistent tangents; both rows from the same velocities, then
        // clamped together to the friction circle (a square cone is up to sqrt 2 too strong).
        for (int k = 0; k < c.max_count; ++k) {
            WidePoint& p = c.p[k];
            const FloatW max_f = c.friction * p.normal_impulse;
            const FloatW vt0 = vt0_lin + dot(p.rb_t[0], B.w) - dot(p.ra_t[0], A.w);
            const FloatW vt1 = vt1_lin + dot(p.rb_t[1], B.w) - dot(p.ra_t[1], A.w);
            FloatW l0 = p.tangent_impulse[0] - p.tangent_mass[0] * vt0;
            FloatW l1 = p.tangent_impulse[1] - p.tangent_mass[1] * vt1;
            const FloatW len2 = l0 * l0 + l1 * l1;
            const FloatW over = greater_w(len2, max_f * max_f);
            const FloatW scale = select_w(over, max_f / sqrt_w(max_w(len2, splat(Real(1e-30)))), one);
            l0 = l0 * scale;
            l1 = l1 * scale;
            const FloatW d0 = l0 - p.tangent_impulse[0], d1 = l1 - p.tangent_impulse[1];
            p.tangent_impulse[0] = l0;
            p.tangent_impulse[1] = l1;
            vt0_lin += d0 * c.inv_m_sum;
            vt1_lin += d1 * c.inv_m_sum;
            p0 += d0;
            p1 += d1;
            A.w -= d0 * p.ia_t[0] + d1 * p.ia_t[1];
            B.w += d0 * p.ib_t[0] + d1 * p.ib_t[1];
        }
        const Vec3W j = pn * c.n + p0 * c.t[0] + p1 * c.t[1];
        A.v -= c.inv_ma * j;
        B.v += c.inv_mb * j;
        scatter_velocities(bodies, c.a, A);
        scatter_velocities(bodies, c.b, B);
    }
}

void SoftStepSolver::restitution(Real threshold) {
    WideBody* bodies = bodies_.data();
    const FloatW zero = zero_w(), min_speed = splat(-threshold);
    for (WideContact& c : contacts_) {
        if (!c.any_restitution) continue;
        BodyW A = gather_bodies(bodies, c.a), B = gather_bodies(bodies, c.b);
        for (int k = 0; k < c.max_count; ++k) {
            WidePoint& p = c.p[k];
            // Only impacts faster than the threshold that actually pushed (Box2D v3).
            const FloatW bounce = and_w(and_w(less_w(p.relative_velocity, min_speed), greater_w(p.max_normal_impulse, zero)),
                                        greater_w(c.restitution, zero));
            const FloatW vn = dot(c.n, B.v - A.v) + dot(p.rb_n, B.w) - dot(p.ra_n, A.w);
            const FloatW impulse = zero - p.normal_mass * (vn + c.restitution * p.relative_velocity);
            const FloatW acc = max_w(p.normal_impulse + impulse, zero);
            const FloatW dl = select_w(bounce, acc - p.normal_impulse, zero);
            p.normal_impulse += dl;
            A.v -= (dl * c.inv_ma) * c.n;
            B.v += (dl * c.inv_mb) * c.n;
            A.w -= dl * p.ia_n;
            B.w += dl * p.ib_n;
        }
        scatter_velocities(bodies, c.a, A);
        scatter_velocities(bodies, c.b, B);
    }
}

void SoftStepSolver::store_impulses(RigidSystem& sys) const {
    std::vector<ContactManifold>& dst = sys.mutable_contacts();
    for (const WideContact& c : contacts_) {
        for (int l = 0; l < kWideLanes; ++l) {
            if (c.manifold[l] == kNoManifold) continue;
            Manifold& m = dst[c.manifold[l]].manifold;
            for (int k = 0; k < c.count[l]; ++k) {
                m.points[k].normal_impulse = c.p[k].normal_impulse.lane(l);
                m.points[k].tangent_impulse[0] = c.p[k].tangent_impulse[0].lane(l);
                m.points[k].tangent_impulse[1] = c.p[k].tangent_impulse[1].lane(l);
            }
        }
    }
}

void SoftStepSolver::bodies_to_state(RigidSystem::State& st) const {
    for (std::size_t s = 0; s < st.v.size(); ++s) {
        const WideBody& b = bodies_[s];
        st.v[s] = Vec3(b.v[0], b.v[1], b.v[2]);
        st.w[s] = Vec3(b.w[0], b.w[1], b.w[2]);
    }
}

void SoftStepSolver::bodies_from_state(const RigidSystem::State& st) {
    for (std::size_t s = 0; s < st.v.size(); ++s) {
        WideBody& b = bodies_[s];
        for (int i = 0; i < 3; ++i) {
            b.v[i] = st.v[s][i];
            b.w[i] = st.w[s][i];
        }
    }
}

void SoftStepSolver::solve_velocities(RigidSystem& sys, Real h) {
    const RigidSettings& set = sys.settings();
    const int n_sub = set.effective_substeps();
    const Real h_sub = h / Real(n_sub), inv_h_sub = Real(n_sub) / h;
    RigidSystem::State& st = sys.state();
    const std::size_t nb = st.x.size();
    bodies_.assign(nb + 1, WideBody{});  // zero motion since the step began; the padding body at rest
    prepare(sys, h_sub);
    // Joints are soft too (Box2D v3: twice the contact stiffness, damping ratio 2); they work on the
    // system's arrays, synced with the solver's copies around each joint pass when joints exist.
    JointSet& joints = sys.joints();
    const bool have_joints = joints.count() > 0;
    if (have_joints)
        joints.prepare(sys, h_sub, JointSoftness{true, set.baumgarte, 2 * set.contact_hertz, 2}, set.warm_starting);
    have_joints_ = have_joints;
    h_sub_ = h_sub;
    for (int i = 0; i < n_sub; ++i) {
        // Velocities of moving bodies: gravity and forces, through the system (it owns the body data).
        if (i > 0) bodies_to_state(st);
        sys.integrate_velocities(h_sub);
        if (have_joints) {
            if (set.warm_starting) joints.warm_start(sys);
            joints.solve(sys, true);
        }
        bodies_from_state(st);
        if (set.warm_starting) warm_start();
        solve(inv_h_sub, set.contact_push_velocity, true);
        if (i + 1 == n_sub) break;  // the last sub-step's positions wait for IntegratePositions
        integrate_and_relax(sys);
    }
    // Hand the velocities to the pipeline: a coupling hook between SolveVelocities and
    // IntegratePositions (seed 001 Figure 9) still changes the last sub-step's positions.
    bodies_to_state(st);
    pending_ = true;
}

void SoftStepSolver::integrate_and_relax(RigidSystem& sys) {
    RigidSystem::State& st = sys.state();
    const std::size_t nb = st.x.size();
    // Positions (kinematic bodies move with their velocity; static and sleeping ones have none).
    for (std::size_t s = 0; s < nb; ++s) {
        WideBody& b = bodies_[s];
        const Vec3 v(b.v[0], b.v[1], b.v[2]), w(b.w[0], b.w[1], b.w[2]);
        if (st.inv_mass[s] == 0 && v.isZero() && w.isZero()) continue;
        st.x[s] += h_sub_ * v;
        st.q[s] = integrate_rotation(st.q[s], w, h_sub_);
        for (int i = 0; i < 3; ++i) {
            b.dp[i] += h_sub_ * v[i];
            b.dth[i] += h_sub_ * w[i];
        }
    }
    if (have_joints_) {
        bodies_to_state(st);
        sys.joints().solve(sys, false);
        bodies_from_state(st);
    }
    solve(Real(1) / h_sub_, sys.settings().contact_push_velocity, false);  // relax: remove the bias velocity
}

void SoftStepSolver::correct_positions(RigidSystem& sys, Real) {
    if (!pending_) return;
    pending_ = false;
    RigidSystem::State& st = sys.state();
    bodies_from_state(st);  // coupling layers may have changed them
    integrate_and_relax(sys);
    restitution(sys.settings().restitution_threshold);
    for (std::size_t s = 0; s < st.v.size(); ++s) {
        if (st.inv_mass[s] == 0) continue;
        const WideBody& b = bodies_[s];
        st.v[s] = Vec3(b.v[0], b.v[1], b.v[2]);
        st.w[s] = Vec3(b.w[0], b.w[1], b.w[2]);
    }
    store_impulses(sys);
}

}  // namespace

std::unique_ptr<RigidSolver> make_soft_step_solver() { return std::make_unique<SoftStepSolver>(); }

}  // namespace sinew
