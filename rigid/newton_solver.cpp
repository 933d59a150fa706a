// Newtonian impulses in the style of Guendelman, Bridson & Fedkiw 2003 ("Nonconvex rigid bodies with
// stacking"), after Mirtich 1994. The order is the method:
//   1. collision passes with candidate poses x + h v and the material restitution (before gravity),
//   2. integrate velocities,
//   3. contact passes at the new candidate poses with restitution rising from -1 to 0 (e_i = i/N - 1):
//      negative restitution only slows an approaching pair, so momentum propagates without bouncing,
//   4. shock propagation: contact-graph levels from the static bodies upward, each level resolved once
//      more with the lower body frozen (infinite mass),
//   5. integrate positions, then project penetration out (fraction p of the depth beyond the slop).
// Contacts are detected once per phase; between passes a point's depth at the candidate pose is updated
// to first order from the change of its normal velocity (d' = d - h (v_n - v_n,detected)), which is what
// re-running the narrow phase at the new candidate poses would give for small changes. A pair that is
// separating is skipped for that pass, never removed (seed 001 ch.5).
#include <algorithm>
#include <vector>

#include "rigid/joint_set.hpp"
#include "rigid/rigid_solver.hpp"

namespace sinew {

namespace {

struct NPoint {
    Vec3 ra, rb;
    Real depth;        // at the candidate pose used for detection
    Real vn_detected;  // normal velocity when detected
    // Impulses applied at this point during the current phase: friction is bounded by mu times the
    // normal impulse accumulated so far (seed 001 ch.5), not just the last pass's, or a resting point
    // whose passes push little could not hold any friction.
    Real jn;
    Vec3 jt;
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
    void correct_positions(RigidSystem& sys, Real h) override;

private:
    void gather(RigidSystem& sys, Real h);
    Real normal_velocity(const RigidSystem::State& st, const NContact& c, const NPoint& p) const;
    /// One impulse at one point with restitution e, if the pair approaches and overlaps at the
    /// candidate pose. `frozen_a/b` treat a body as having infinite mass (shock propagation).
    void resolve_point(RigidSystem::State& st, const NContact& c, NPoint& p, Real e, Real h, bool frozen_a,
                       bool frozen_b);
    void compute_levels(const RigidSystem& sys);

    std::vector<NContact> contacts_;
    std::vector<int> level_;             // per body slot: contact-graph distance from the ground
    std::vector<std::uint32_t> order_;   // contact indices by level, for shock propagation
    std::vector<std::uint32_t> queue_;
    std::vector<std::uint32_t> adj_start_, adj_fill_, adj_;  // contact graph, compressed rows
};

void NewtonImpulseSolver::gather(RigidSystem& sys, Real h) {
    const RigidSystem::State& st = sys.state();
    const auto& src = sys.contacts();
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
            p.depth = cm.manifold.points[k].depth;
            p.jn = 0;
            p.jt.setZero();
            p.vn_detected = 0;
            p.vn_detected = normal_velocity(st, c, p);
        }
    }
}

Real NewtonImpulseSolver::normal_velocity(const RigidSystem::State& st, const NContact& c, const NPoint& p) const {
    return (st.v[c.b] + st.w[c.b].cross(p.rb) - st.v[c.a] - st.w[c.a].cross(p.ra)).dot(c.n);
}

void NewtonImpulseSolver::resolve_point(RigidSystem::State& st, const NContact& c, NPoint& p, Real e, Real h,
                                        bool frozen_a, bool frozen_b) {
    const std::uint32_t a = c.a, b = c.b;
    const Real wa = frozen_a ? 0 : st.inv_mass[a], wb = frozen_b ? 0 : st.inv_mass[b];
    if (wa + wb == 0) return;
    const Mat3& ia = st.inv_inertia_world[a];
    const Mat3& ib = st.inv_inertia_world[b];
    auto k_along = [&](const Vec3& d) {
        Real k = wa + wb;
        if (!frozen_a) k += d.dot((ia * p.ra.cross(d)).cross(p.ra));
        if (!frozen_b) k += d.dot((ib * p.rb.cross(d)).cross(p.rb));
        return k;
    };
    auto apply = [&](const Vec3& impulse) {
        if (!frozen_a) {
            st.v[a] -= wa * impulse;
            st.w[a] -= ia * p.ra.cross(impulse);
        }
        if (!frozen_b) {
            st.v[b] += wb * impulse;
            st.w[b] += ib * p.rb.cross(impulse);
        }
    };
    auto rel_vel = [&] { return Vec3(st.v[b] + st.w[b].cross(p.rb) - st.v[a] - st.w[a].cross(p.ra)); };
    Vec3 dv = rel_vel();
    Real vn = dv.dot(c.n);
    // Separating pairs are skipped for this pass, not removed; so are points not touching at the
    // candidate pose (depth updated to first order from the change of normal velocity).
    if (vn < 0 && p.depth - h * (vn - p.vn_detected) > 0) {
        Real kn = k_along(c.n);
        if (kn > 0) {
            // Mirtich / Guendelman: j = -(1 + e) v_n / (n . K n).
            Real j = -(1 + e) * vn / kn;
            apply(j * c.n);
            p.jn += j;
            dv = rel_vel();
        }
    }
    if (p.jn <= 0 || c.friction <= 0) return;
    // Coulomb friction: stop the sliding if the cone (about the accumulated normal impulse) allows.
    Vec3 vt = dv - dv.dot(c.n) * c.n;
    Real vt_len = vt.norm();
    if (vt_len < Real(1e-9)) return;
    Vec3 t = vt / vt_len;
    Real kt = k_along(t);
    if (kt <= 0) return;
    Vec3 jt = p.jt - (vt_len / kt) * t;
    Real limit = c.friction * p.jn;
    Real len = jt.norm();
    if (len > limit) jt *= limit / len;
    apply(jt - p.jt);
    p.jt = jt;
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
                resolve_point(st, c, c.p[k], e, h, false, false);
            }
}

void NewtonImpulseSolver::compute_levels(const RigidSystem& sys) {
    const RigidSystem::State& st = sys.state();
    const std::size_t n = st.x.size();
    const int kUnreached = 1 << 30;
    level_.assign(n, kUnreached);
    queue_.clear();
    for (std::uint32_t s = 0; s < n; ++s)
        if (st.inv_mass[s] == 0) {
            level_[s] = 0;  // static, kinematic and sleeping bodies are the ground
            queue_.push_back(s);
        }
    // Breadth-first over the contact graph: level = contacts between the body and the ground. The
    // adjacency is a compressed row list in member arrays, rebuilt each step without allocating.
    adj_start_.assign(n + 1, 0);
    for (const NContact& c : contacts_)
        if (c.count > 0) {
            ++adj_start_[c.a + 1];
            ++adj_start_[c.b + 1];
        }
    for (std::size_t i = 0; i < n; ++i) adj_start_[i + 1] += adj_start_[i];
    adj_.resize(adj_start_[n]);
    adj_fill_.assign(adj_start_.begin(), adj_start_.end() - 1);
    for (const NContact& c : contacts_)
        if (c.count > 0) {
            adj_[adj_fill_[c.a]++] = c.b;
            adj_[adj_fill_[c.b]++] = c.a;
        }
    for (std::size_t head = 0; head < queue_.size(); ++head) {
        std::uint32_t s = queue_[head];
        for (std::uint32_t k = adj_start_[s]; k < adj_start_[s + 1]; ++k) {
            std::uint32_t o = adj_[k];
            if (level_[o] == kUnreached) {
                level_[o] = level_[s] + 1;
                queue_.push_back(o);
            }
        }
    }
    order_.resize(contacts_.size());
    for (std::uint32_t i = 0; i < order_.size(); ++i) order_[i] = i;
    auto key = [&](std::uint32_t i) { return std::max(level_[contacts_[i].a], level_[contacts_[i].b]); };
    std::stable_sort(order_.begin(), order_.end(), [&](std::uint32_t x, std::uint32_t y) { return key(x) < key(y); });
}

void NewtonImpulseSolver::solve_velocities(RigidSystem& sys, Real h) {
    const RigidSettings& set = sys.settings();
    gather(sys, h);
    RigidSystem::State& st = sys.state();
    const int iters = set.newton_contact_iterations;
    // Joints: velocity constraints with a Baumgarte bias, one pass before each contact pass.
    JointSet& joints = sys.joints();
    const bool have_joints = joints.count() > 0;
    if (have_joints) joints.prepare(sys, h, JointSoftness{false, set.baumgarte, 0, 0}, false);
    for (int i = 1; i <= iters; ++i) {
        if (have_joints) joints.solve(sys, true);
        const Real e = Real(i) / Real(iters) - 1;  // rises from -1 + 1/N to 0
        for (NContact& c : contacts_)
            for (int k = 0; k < c.count; ++k) resolve_point(st, c, c.p[k], e, h, false, false);
    }
    if (!set.newton_shock_propagation) return;
    // Shock propagation: one more e = 0 sweep in level order, the lower body of a pair frozen, so the
    // weight of a stack never pushes down into the bodies below it.
    compute_levels(sys);
    for (std::uint32_t ci : order_) {
        NContact& c = contacts_[ci];
        int la = level_[c.a], lb = level_[c.b];
        for (int k = 0; k < c.count; ++k) resolve_point(st, c, c.p[k], 0, h, la < lb, lb < la);
    }
}

void NewtonImpulseSolver::correct_positions(RigidSystem& sys, Real h) {
    // Penetration projection (Guendelman 2003): after integration, move bodies apart by a fraction of
    // the depth beyond the slop, along the normal, split by inverse mass; with shock propagation the
    // lower body is frozen so projection never pushes a stack into the ground.
    const RigidSettings& set = sys.settings();
    RigidSystem::State& st = sys.state();
    const bool shock = set.newton_shock_propagation;
    if (shock && order_.size() != contacts_.size()) compute_levels(sys);
    const std::size_t m = contacts_.size();
    for (std::size_t oi = 0; oi < m; ++oi) {
        const NContact& c = contacts_[shock ? order_[oi] : oi];
        Real wa = st.inv_mass[c.a], wb = st.inv_mass[c.b];
        if (shock) {
            if (level_[c.a] < level_[c.b]) wa = 0;
            if (level_[c.b] < level_[c.a]) wb = 0;
        }
        if (wa + wb <= 0) continue;
        Real depth = 0;
        for (int k = 0; k < c.count; ++k) {
            const NPoint& p = c.p[k];
            Real vn = normal_velocity(st, c, p);
            depth = std::max(depth, p.depth - h * (vn - p.vn_detected));
        }
        Real corr = std::max(depth - set.linear_slop, Real(0)) * set.newton_projection_fraction;
        if (corr <= 0) continue;
        st.x[c.a] -= (corr * wa / (wa + wb)) * c.n;
        st.x[c.b] += (corr * wb / (wa + wb)) * c.n;
    }
    order_.clear();
}

}  // namespace

std::unique_ptr<RigidSolver> make_newton_impulse_solver() { return std::make_unique<NewtonImpulseSolver>(); }

}  // namespace sinew
