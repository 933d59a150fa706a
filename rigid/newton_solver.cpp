// Newtonian impulses in the style of Guendelman, Bridson & Fedkiw 2003 ("Nonconvex rigid bodies with
// stacking"), after Mirtich 1994. The order is the method:
//   1. collision passes with candidate poses x + h v and the material restitution (before gravity),
//   2. integrate velocities,
//   3. contact passes at the new candidate poses with restitution rising from -1 to 0 (e_i = i/N - 1):
//      negative restitution only slows an approaching pair, so momentum propagates without bouncing,
//   4. shock propagation: contact-graph levels from the static bodies upward, each level resolved once,
//      to convergence, with the bodies of the levels below frozen (infinite mass),
//   5. integrate positions, then project penetration out (fraction p of the depth beyond the slop),
//      level by level from the ground up.
// Contacts are detected once per phase; between passes a point's depth at the candidate pose is updated
// to first order from the change of its normal velocity (d' = d - h (v_n - v_n,detected)), which is what
// re-running the narrow phase at the new candidate poses would give for small changes. A pair that is
// separating is skipped for that pass, never removed (seed 001 ch.5).
//
// Why tall stacks stand (docs/rigid-solvers.md, "Newtonian impulses: why stacks stand"): a box resting
// on a face has four contact points coupled through its rotation, so one impulse per point per level
// leaves part of the weight unresolved; that residual adds up level after level and a 20-box tower sank
// and tipped. Each level is therefore iterated until its impulses stop changing before the next level is
// frozen on top of it. Within that iteration a point's impulses are summed and the sum kept >= 0: a
// point may take back what it pushed too hard in this level's solve (pushing only, the rotation from the
// first points processed leaves the others separating, and the stack climbs and spins), but never pulls.
#include <algorithm>
#include <cmath>
#include <vector>

#include "rigid/constraint_rows.hpp"
#include "rigid/rigid_solver.hpp"

namespace sinew {

namespace {

// Shock propagation iterates a level until the largest impulse change in a sweep is below this fraction
// of the largest impulse of the level. A box on a face converges by about 0.45 per sweep and gets there
// in 12-15 sweeps; tower-20 drifts 11 mm over 10 s at 1e-4 and 1 mm at 1e-5 (docs/rigid-solvers.md).
// 1e-5 is far above float rounding (6e-8) of impulses that are sums of a few dozen terms. The rows of a
// pyramid, each box on two, are statically indeterminate: their impulses can keep shifting between the
// supports without changing any velocity, so the sweeps are capped; 24 leaves margin over 15 and costs
// pyramid-40 37 ms per step instead of 55 ms at 64, with the same drift (under 1 mm).
constexpr Real kShockTolerance = Real(1e-5);
constexpr int kShockMaxSweeps = 24;

struct NPoint {
    Vec3 ra, rb;
    // Point-mass matrices: the relative velocity change at the point per unit impulse is (Ka + Kb) P,
    // Ka = w_a 1 - [r_a]x I_a^-1 [r_a]x. Kept per body so a frozen body's part can be dropped.
    Mat3 ka, kb;
    Vec3 ka_n, kb_n;  // Ka n, Kb n: the relative velocity change per unit normal impulse
    Vec3 ia_n, ib_n;  // I^-1 (r x n): the angular velocity change per unit normal impulse
    Real depth;        // at the candidate pose used for detection
    Real vn_detected;  // normal velocity when detected
    // Impulses applied at this point during the current phase: friction is bounded by mu times the
    // normal impulse accumulated so far (seed 001 ch.5), not just the last pass's, or a resting point
    // whose passes push little could not hold any friction.
    Real jn;
    Vec3 jt;
    Real j_level;  // normal impulse applied in this point's shock-propagation level (kept >= 0)
};

struct NContact {
    std::uint32_t a, b;
    Vec3 n;
    Real friction, restitution;
    int count;
    NPoint p[Manifold::kMaxPoints];
};

class NewtonImpulseSolver final : public RigidSolver {
public:
    bool detects_at_candidate_poses() const override { return true; }
    void before_integrate_velocities(RigidSystem& sys, Real h) override;
    void solve_velocities(RigidSystem& sys, Real h) override;
    void finish_step(RigidSystem& sys, Real h) override;

private:
    void gather(RigidSystem& sys, Real h);
    Real normal_velocity(const RigidSystem::State& st, const NContact& c, const NPoint& p) const;
    /// One impulse at one point with restitution e, if the pair approaches and overlaps at the
    /// candidate pose. `frozen_a/b` treat a body as having infinite mass (shock propagation).
    /// `level_solve`: the impulse is added to p.j_level and that sum is clamped at zero instead (shock
    /// propagation's iterated level solve). Returns the largest impulse change made.
    Real resolve_point(RigidSystem::State& st, const NContact& c, NPoint& p, Real e, Real h, bool frozen_a,
                       bool frozen_b, bool level_solve);
    void compute_levels(const RigidSystem& sys);
    void propagate_shock(RigidSystem& sys, Real h);
    int level_of(std::uint32_t ci) const { return std::max(level_[contacts_[ci].a], level_[contacts_[ci].b]); }

    std::vector<NContact> contacts_;
    Real slop_ = 0;                      // RigidSettings::linear_slop, for resolve_point
    ContactLevels level_;                // per body slot: contact-graph distance from the ground
    std::vector<std::uint32_t> order_;   // contact indices by level, for shock propagation
    std::vector<Vec3> pushed_;           // per body slot: displacement by this step's projection
};

Mat3 point_matrix(Real inv_mass, const Mat3& inv_inertia, const Vec3& r) {
    const Mat3 rx = skew(r);
    return inv_mass * Mat3::Identity() - rx * inv_inertia * rx;
}

void NewtonImpulseSolver::gather(RigidSystem& sys, Real h) {
    const RigidSystem::State& st = sys.state();
    const auto& src = sys.contacts();
    slop_ = sys.settings().linear_slop;
    contacts_.resize(src.size());
    for (std::size_t i = 0; i < src.size(); ++i) {
        const ContactManifold& cm = src[i];
        NContact& c = contacts_[i];
        c.a = cm.body_a;
        c.b = cm.body_b;
        c.n = cm.manifold.normal;
        c.friction = cm.friction;
        c.restitution = cm.restitution;
        c.count = cm.manifold.count;
        // Arms from the candidate centres of mass, where the contact was found.
        Vec3 xa = st.x[c.a] + (st.inv_mass[c.a] > 0 ? Vec3(h * st.v[c.a]) : Vec3::Zero());
        Vec3 xb = st.x[c.b] + (st.inv_mass[c.b] > 0 ? Vec3(h * st.v[c.b]) : Vec3::Zero());
        for (int k = 0; k < c.count; ++k) {
            NPoint& p = c.p[k];
            p.ra = cm.manifold.points[k].position - xa;
            p.rb = cm.manifold.points[k].position - xb;
            p.ka = point_matrix(st.inv_mass[c.a], st.inv_inertia_world[c.a], p.ra);
            p.kb = point_matrix(st.inv_mass[c.b], st.inv_inertia_world[c.b], p.rb);
            p.ka_n = p.ka * c.n;
            p.kb_n = p.kb * c.n;
            p.ia_n = st.inv_inertia_world[c.a] * p.ra.cross(c.n);
            p.ib_n = st.inv_inertia_world[c.b] * p.rb.cross(c.n);
            p.depth = cm.manifold.points[k].depth;
            p.jn = 0;
            p.jt.setZero();
            p.j_level = 0;
            p.vn_detected = 0;
            p.vn_detected = normal_velocity(st, c, p);
        }
    }
}

Real NewtonImpulseSolver::normal_velocity(const RigidSystem::State& st, const NContact& c, const NPoint& p) const {
    return (st.v[c.b] + st.w[c.b].cross(p.rb) - st.v[c.a] - st.w[c.a].cross(p.ra)).dot(c.n);
}

Real NewtonImpulseSolver::resolve_point(RigidSystem::State& st, const NContact& c, NPoint& p, Real e, Real h,
                                        bool frozen_a, bool frozen_b, bool level_solve) {
    const std::uint32_t a = c.a, b = c.b;
    const Real wa = frozen_a ? 0 : st.inv_mass[a], wb = frozen_b ? 0 : st.inv_mass[b];
    if (wa + wb == 0) return 0;
    Vec3 dv = st.v[b] + st.w[b].cross(p.rb) - st.v[a] - st.w[a].cross(p.ra);
    const Real vn = dv.dot(c.n);
    // Overlap at the candidate pose, its depth updated to first order from the change of normal velocity.
    const bool touching = p.depth - h * (vn - p.vn_detected) > 0;
    // The gap at the current pose (depth at the candidate pose less the approach it assumed): a pair that
    // does not bounce may close it this step, as a speculative contact lets it (Catto). Stopping the whole
    // approach instead froze a 100 m/s sphere in mid-air 1.7 m short of a wall, and a 300 m/s one where it
    // started.
    // Gaps within the slop count as touching: a resting pyramid's speculative points closing theirs let
    // pyramid-40 drift 16 mm instead of 0.4 mm.
    const Real gap = -(p.depth + h * p.vn_detected);
    const Real gap_speed = gap > slop_ ? gap / h : 0;
    Real j = 0;
    if (level_solve ? (touching || p.j_level > 0) : (vn < 0 && touching)) {
        const Vec3 k_n = (frozen_a ? Vec3::Zero() : p.ka_n) + (frozen_b ? Vec3::Zero() : p.kb_n);
        const Real kn = k_n.dot(c.n);
        if (kn > 0) {
            if (level_solve) {
                // A point that pushed in this level's solve may take that push back (sum clamped at
                // zero); one apart at the candidate pose may only let go.
                Real sum = std::max(p.j_level - (vn + gap_speed) / kn, Real(0));
                if (!touching) sum = std::min(sum, p.j_level);
                j = sum - p.j_level;
                p.j_level = sum;
            } else {
                // Separating pairs are skipped for this pass, not removed; so are points not touching
                // at the candidate pose. Mirtich / Guendelman: j = -(1 + e) v_n / (n . K n).
                // A pair still apart that does not bounce closes its gap (speculatively); a bouncing one
                // reflects now, at most one step's travel from the surface, as before.
                j = gap_speed > 0 && e <= 0 ? -(1 + e) * (vn + gap_speed) / kn : -(1 + e) * vn / kn;
            }
            if (j != 0) {
                if (!frozen_a) {
                    st.v[a] -= (wa * j) * c.n;
                    st.w[a] -= j * p.ia_n;
                }
                if (!frozen_b) {
                    st.v[b] += (wb * j) * c.n;
                    st.w[b] += j * p.ib_n;
                }
                p.jn += j;
                dv += j * k_n;
            }
        }
    }
    Real changed = std::abs(j);
    auto apply = [&](const Vec3& impulse) {
        if (!frozen_a) {
            st.v[a] -= wa * impulse;
            st.w[a] -= st.inv_inertia_world[a] * p.ra.cross(impulse);
        }
        if (!frozen_b) {
            st.v[b] += wb * impulse;
            st.w[b] += st.inv_inertia_world[b] * p.rb.cross(impulse);
        }
    };
    if (p.jn <= 0 || c.friction <= 0) {
        if (p.jt.squaredNorm() > 0) {  // the normal impulse was taken back: so is the friction it held
            apply(-p.jt);
            changed = std::max(changed, Real(p.jt.norm()));
            p.jt.setZero();
        }
        return changed;
    }
    // Coulomb friction: stop the sliding if the cone (about the accumulated normal impulse) allows.
    const Vec3 vt = dv - dv.dot(c.n) * c.n;
    const Real vt_len = vt.norm();
    Vec3 jt = p.jt;
    if (vt_len > Real(1e-9)) {
        const Vec3 t = vt / vt_len;
        Real kt = 0;
        if (!frozen_a) kt += t.dot(p.ka * t);
        if (!frozen_b) kt += t.dot(p.kb * t);
        if (kt > 0) jt -= (vt_len / kt) * t;
    }
    const Real limit = c.friction * p.jn;
    const Real len2 = jt.squaredNorm();
    if (len2 > limit * limit) jt *= limit / std::sqrt(len2);
    const Vec3 djt = jt - p.jt;
    const Real dlen2 = djt.squaredNorm();
    if (dlen2 == 0) return changed;
    apply(djt);
    p.jt = jt;
    return std::max(changed, std::sqrt(dlen2));
}

void NewtonImpulseSolver::before_integrate_velocities(RigidSystem& sys, Real h) {
    const RigidSettings& set = sys.settings();
    if (set.newton_collision_iterations == 0) return;
    sys.detect_contacts_now(h);  // at candidate poses with the velocities of the last step
    gather(sys, h);
    RigidSystem::State& st = sys.state();
    for (int it = 0; it < set.newton_collision_iterations; ++it)
        for (NContact& c : contacts_)
            for (int k = 0; k < c.count; ++k) {
                Real vn = normal_velocity(st, c, c.p[k]);
                // Elastic collision; impacts slower than the threshold do not bounce.
                Real e = vn < -set.restitution_threshold ? c.restitution : 0;
                resolve_point(st, c, c.p[k], e, h, false, false, false);
            }
}

void NewtonImpulseSolver::compute_levels(const RigidSystem& sys) {
    // Bodies side by side (a pyramid's row) get the same level and are solved together, both free.
    level_.compute(sys.state().inv_mass, contacts_.size(), [&](std::size_t i, std::uint32_t& a, std::uint32_t& b) {
        a = contacts_[i].a;
        b = contacts_[i].b;
        return contacts_[i].count > 0;
    });
    // A contact belongs to the level of its higher body: level L's contacts are those that hold the
    // bodies of level L on level L - 1 and those between bodies of level L.
    order_.resize(contacts_.size());
    for (std::uint32_t i = 0; i < order_.size(); ++i) order_[i] = i;
    std::stable_sort(order_.begin(), order_.end(),
                     [&](std::uint32_t x, std::uint32_t y) { return level_of(x) < level_of(y); });
}

void NewtonImpulseSolver::solve_velocities(RigidSystem& sys, Real h) {
    const RigidSettings& set = sys.settings();
    gather(sys, h);
    RigidSystem::State& st = sys.state();
    const int iters = set.newton_contact_iterations;
    // Joints and other outside rows: velocity constraints with a Baumgarte bias, one pass before each
    // contact pass, on the system's own arrays (this solver has no copy of the bodies).
    const RowStep step{h, 1, false, RowSoftness{false, false, set.baumgarte, 0, 0}};
    const std::vector<ConstraintRows*>& sources = sys.row_sources();
    for (ConstraintRows* rows : sources) rows->prepare(sys, step);
    const BodyVelocities vel = BodyVelocities::of_arrays(st.v, st.w);
    for (int i = 1; i <= iters; ++i) {
        for (ConstraintRows* rows : sources) rows->solve(sys, vel, true);
        const Real e = Real(i) / Real(iters) - 1;  // rises from -1 + 1/N to 0
        for (NContact& c : contacts_)
            for (int k = 0; k < c.count; ++k) resolve_point(st, c, c.p[k], e, h, false, false, false);
    }
    if (set.newton_shock_propagation) propagate_shock(sys, h);
    // The impulses of this step's contact and shock-propagation passes, for events and coupling layers
    // (the collision passes before gravity ran on manifolds of their own and are not included).
    std::vector<ContactManifold>& dst = sys.mutable_contacts();
    for (std::size_t i = 0; i < contacts_.size() && i < dst.size(); ++i)
        for (int k = 0; k < contacts_[i].count; ++k) dst[i].manifold.points[k].total_normal_impulse = contacts_[i].p[k].jn;
}

void NewtonImpulseSolver::propagate_shock(RigidSystem& sys, Real h) {
    RigidSystem::State& st = sys.state();
    // Shock propagation: level by level from the ground up, each level once, with e = 0 and the lower
    // body of a pair frozen, so the weight of a stack never pushes down into the bodies below it. A level
    // is swept until its impulses settle (see the top of the file), then it is frozen for the levels
    // above.
    compute_levels(sys);
    for (std::size_t begin = 0; begin < order_.size();) {
        const int level = level_of(order_[begin]);
        std::size_t end = begin;
        while (end < order_.size() && level_of(order_[end]) == level) ++end;
        for (int sweep = 0; sweep < kShockMaxSweeps; ++sweep) {
            Real changed = 0, largest = 0;
            for (std::size_t oi = begin; oi < end; ++oi) {
                NContact& c = contacts_[order_[oi]];
                const bool frozen_a = level_[c.a] < level_[c.b], frozen_b = level_[c.b] < level_[c.a];
                for (int k = 0; k < c.count; ++k) {
                    changed = std::max(changed, resolve_point(st, c, c.p[k], 0, h, frozen_a, frozen_b, true));
                    largest = std::max(largest, std::max(c.p[k].j_level, Real(c.p[k].jt.norm())));
                }
            }
            if (changed <= kShockTolerance * largest) break;
        }
        begin = end;
    }
}

void NewtonImpulseSolver::finish_step(RigidSystem& sys, Real h) {
    // Penetration projection (Guendelman 2003): after integration, move bodies apart by a fraction of
    // the depth beyond the slop, along the normal, split by inverse mass. With shock propagation the
    // lower body is frozen so projection never pushes a stack into the ground, and the contacts go from
    // the ground up, each seeing how far this projection already moved its bodies: a box lifted out of
    // the one below lifts the box above it in the same step instead of being pushed into it.
    const RigidSettings& set = sys.settings();
    RigidSystem::State& st = sys.state();
    const bool shock = set.newton_shock_propagation;
    if (shock && order_.size() != contacts_.size()) compute_levels(sys);
    pushed_.assign(st.x.size(), Vec3::Zero());
    const std::size_t m = contacts_.size();
    for (std::size_t oi = 0; oi < m; ++oi) {
        const NContact& c = contacts_[shock ? order_[oi] : oi];
        Real wa = st.inv_mass[c.a], wb = st.inv_mass[c.b];
        if (shock) {
            if (level_[c.a] < level_[c.b]) wa = 0;
            if (level_[c.b] < level_[c.a]) wb = 0;
        }
        if (wa + wb <= 0 || c.count == 0) continue;
        Real depth = -kRealMax;
        for (int k = 0; k < c.count; ++k) {
            const NPoint& p = c.p[k];
            Real vn = normal_velocity(st, c, p);
            depth = std::max(depth, p.depth - h * (vn - p.vn_detected));
        }
        depth += (pushed_[c.a] - pushed_[c.b]).dot(c.n);
        // At most max_correction_velocity * h a step: a deep overlap separates at a bounded speed
        // (0.8 m of overlap between two unit boxes had moved them 8 cm a step, 4.8 m/s).
        Real corr = std::min(std::max(depth - set.linear_slop, Real(0)) * set.newton_projection_fraction,
                             h * set.max_correction_velocity);
        if (corr <= 0) continue;
        const Vec3 da = (corr * wa / (wa + wb)) * c.n, db = (corr * wb / (wa + wb)) * c.n;
        st.x[c.a] -= da;
        st.x[c.b] += db;
        pushed_[c.a] -= da;
        pushed_[c.b] += db;
    }
    order_.clear();
}

}  // namespace

std::unique_ptr<RigidSolver> make_newton_impulse_solver() { return std::make_unique<NewtonImpulseSolver>(); }

}  // namespace sinew
