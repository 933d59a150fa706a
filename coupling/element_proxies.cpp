// Soft bodies embedded into the rigid solver one element at a time (coupling/element_proxies.hpp).
#include "coupling/element_proxies.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "coupling/rigid_proxy.hpp"  // make_proxy_hull
#include "soft/fem_elements.hpp"
#include "soft/soft_integrators.hpp"

namespace sinew {

namespace {
constexpr Real kHullFlatness = kProxyHullFlatness;
/// An element's hull is made anew once a node has moved this share of the body's thickness in the
/// element's frame since the last one (a contact then errs by at most that much).
constexpr Real kHullRefresh = Real(0.1);

/// The collision group of a soft body's element proxies: negative, so they never meet each other, and
/// far below the groups a game hands out by hand.
std::int32_t element_group(std::uint32_t soft_slot) {
    return -std::int32_t(0x40000000u + (soft_slot & 0x3FFFFFFFu));
}

/// The elements of a body: its tets (all nodes of a quadratic one), else its surface triangles, else its
/// structural links (all links if none is structural), else one element of every node.
void collect_elements(const SoftBody& b, std::vector<std::uint32_t>& start, std::vector<std::uint32_t>& node) {
    start.assign(1, 0);
    node.clear();
    const auto close = [&] { start.push_back(std::uint32_t(node.size())); };
    if (b.fem && b.fem->size() > 0) {
        const std::size_t n = std::size_t(b.fem->nodes_per_tet());
        for (std::size_t e = 0; e < b.fem->size(); ++e) {
            node.insert(node.end(), b.fem->tets.begin() + std::ptrdiff_t(n * e), b.fem->tets.begin() + std::ptrdiff_t(n * (e + 1)));
            close();
        }
    } else if (!b.triangles.empty()) {
        for (std::size_t t = 0; t + 2 < b.triangles.size(); t += 3) {
            node.insert(node.end(), b.triangles.begin() + std::ptrdiff_t(t), b.triangles.begin() + std::ptrdiff_t(t + 3));
            close();
        }
    } else if (!b.links.empty()) {
        const bool any_structural = std::any_of(b.links.begin(), b.links.end(),
                                                [](const Link& l) { return l.kind == LinkKind::Structural; });
        for (const Link& l : b.links) {
            if (any_structural && l.kind != LinkKind::Structural) continue;
            node.push_back(l.a);
            node.push_back(l.b);
            close();
        }
    } else {
        for (std::uint32_t i = 0; i < b.p.size(); ++i) node.push_back(i);
        close();
    }
}

/// The hull of an element's nodes in its proxy's frame (`local`, used as scratch). A triangle becomes the
/// prism of its nodes moved the thickness to either side along its normal (no failed hull first: a
/// flat set throws, which costs more than the hull); anything else goes through make_proxy_hull.
Shape element_hull(std::vector<Vec3>& local, Real thickness) {
    if (local.size() == 3) {
        const Vec3 n = (local[1] - local[0]).cross(local[2] - local[0]);
        const Real diagonal = std::max({(local[1] - local[0]).norm(), (local[2] - local[0]).norm(), (local[2] - local[1]).norm()});
        const Real pad = std::max(thickness, kHullFlatness * diagonal);
        if (n.norm() > kHullFlatness * diagonal * diagonal && pad > 0) {
            const Vec3 d = n * (pad / n.norm());
            for (int k = 0; k < 3; ++k) local.push_back(local[std::size_t(k)] - d);
            for (int k = 0; k < 3; ++k) local[std::size_t(k)] += d;
            return make_convex_hull(local);
        }
    }
    return make_proxy_hull(local, thickness, kHullFlatness);
}

}  // namespace

Vec3 predicted_node_velocity(const SoftBody& b, std::uint32_t i, Real h) {
    // Fast mass-spring's first iterate leaves gravity out (a body at rest starts at its solution); its
    // inertial target y holds the step's predicted motion.
    const Vec3 to = b.def.method == SoftMethod::FastMassSpring ? fast_mass_spring_target(b, i, h) : b.p.x_next[i];
    return (to - b.p.x[i]) / h;
}

ElementProxies::ElementProxies(RigidSystem& rigid, SoftSystem& soft, std::vector<std::uint32_t>& soft_slot_of_rigid,
                               std::uint32_t no_soft)
    : rigid_(rigid), soft_(soft), soft_slot_of_rigid_(soft_slot_of_rigid), no_soft_(no_soft) {
    rigid_.add_rows(this);
}

ElementProxies::~ElementProxies() { rigid_.remove_rows(this); }

std::size_t ElementProxies::count() const {
    std::size_t n = 0;
    for (const Set& set : sets_) n += set.body.empty() ? 0 : 1;
    return n;
}

bool ElementProxies::embedded(std::uint32_t s) const { return s < sets_.size() && !sets_[s].body.empty(); }

bool ElementProxies::current(std::uint32_t s) const {
    // The body the proxies were made of, still there: a slot destroyed and reused since the last update
    // (which a diverged body can skip) has another body of other nodes.
    return embedded(s) && soft_.slot_alive(s) && soft_.id_of_slot(s).generation == sets_[s].soft_generation &&
           soft_.slot_body(s).p.size() == sets_[s].node_v.size();
}

std::uint32_t ElementProxies::generation(std::uint32_t s) const { return embedded(s) ? sets_[s].soft_generation : 0; }

bool ElementProxies::holds(std::uint32_t s, BodyId rigid) const {
    if (!embedded(s) || rigid.is_null() || rigid.index >= element_of_rigid_.size()) return false;
    const std::uint32_t e = element_of_rigid_[rigid.index];
    return e < sets_[s].body.size() && sets_[s].body[e] == rigid;
}

const std::vector<BodyId>& ElementProxies::proxies(std::uint32_t s) const {
    static const std::vector<BodyId> none;
    return embedded(s) ? sets_[s].body : none;
}

std::vector<std::uint32_t> ElementProxies::element_nodes(std::uint32_t s, std::size_t e) const {
    if (!embedded(s) || e + 1 >= sets_[s].start.size()) return {};
    const Set& set = sets_[s];
    return {set.node.begin() + set.start[e], set.node.begin() + set.start[e + 1]};
}

void ElementProxies::destroy(std::uint32_t s) {
    Set& set = sets_[s];
    for (const BodyId& id : set.body) {
        if (!rigid_.valid(id)) continue;  // destroyed from outside: its slot may hold another proxy now
        rigid_.destroy_body(id);
        if (id.index < soft_slot_of_rigid_.size() && soft_slot_of_rigid_[id.index] == s) soft_slot_of_rigid_[id.index] = no_soft_;
    }
    set = Set{};  // the embedding sets the soft body's flags after every update
}

void ElementProxies::update_membership(const std::vector<bool>& wanted, EmbedProxyMass mass) {
    if (sets_.size() < wanted.size()) sets_.resize(wanted.size());
    for (std::uint32_t s = 0; s < sets_.size(); ++s) {
        const bool want = s < wanted.size() && wanted[s];
        Set& set = sets_[s];
        if (!set.body.empty()) {
            bool keep = want && set.mass == mass && soft_.id_of_slot(s).generation == set.soft_generation;
            // Pinned or freed nodes since: the kinematic elements are others.
            const SoftBody* b = keep ? &soft_.slot_body(s) : nullptr;
            for (std::size_t e = 0; keep && e < set.body.size(); ++e) {
                bool pinned = false;
                for (std::uint32_t k = set.start[e]; k < set.start[e + 1]; ++k) pinned = pinned || b->p.inv_mass[set.node[k]] == 0;
                keep = rigid_.valid(set.body[e]) && pinned == (set.kinematic[e] != 0);
            }
            if (keep) {
                CollisionFilter f = b->def.filter;
                f.group = element_group(s);
                for (const BodyId& id : set.body)
                    if (rigid_.filter(id) != f) rigid_.set_filter(id, f);
                continue;
            }
            destroy(s);
        }
        if (want) create(s, mass);
    }
}

void ElementProxies::create(std::uint32_t s, EmbedProxyMass mass) {
    SoftBody& b = soft_.slot_body(s);
    Set& set = sets_[s];
    set.soft_generation = soft_.id_of_slot(s).generation;
    set.mass = mass;
    collect_elements(b, set.start, set.node);
    const std::size_t ne = set.start.size() - 1, n = b.p.size();
    Real body_mass = 0;
    for (Real m : b.p.mass) body_mass += m;
    set.weight.resize(set.node.size());
    set.rest.resize(set.node.size());
    set.body.assign(ne, BodyId{});
    set.kinematic.assign(ne, 0);
    // Which elements hold a pinned or attached node (kinematic), then how many dynamic elements hold each
    // node: its mass is split between them (Tonge, Benevolenski & Voroshilov 2012, mass splitting).
    for (std::size_t e = 0; e < ne; ++e)
        for (std::uint32_t k = set.start[e]; k < set.start[e + 1]; ++k)
            if (b.p.inv_mass[set.node[k]] == 0) set.kinematic[e] = 1;
    std::vector<int> valence(n, 0);
    for (std::size_t e = 0; e < ne; ++e)
        if (!set.kinematic[e])
            for (std::uint32_t k = set.start[e]; k < set.start[e + 1]; ++k) ++valence[set.node[k]];
    set.inv_valence.resize(n);
    for (std::size_t i = 0; i < n; ++i) set.inv_valence[i] = valence[i] ? Real(1) / Real(valence[i]) : Real(0);
    for (std::size_t e = 0; e < ne; ++e) {
        const std::uint32_t k0 = set.start[e], k1 = set.start[e + 1];
        Vec3 c = Vec3::Zero();
        Real wsum = 0;
        for (std::uint32_t k = k0; k < k1; ++k) {
            const std::uint32_t i = set.node[k];
            set.weight[k] = mass == EmbedProxyMass::Physical ? b.p.mass[i] / Real(std::max(valence[i], 1))
                                                             : body_mass / Real(k1 - k0);
            c += set.weight[k] * b.p.x[i];
            wsum += set.weight[k];
        }
        c /= wsum;
        for (std::uint32_t k = k0; k < k1; ++k) set.rest[k] = b.p.x[set.node[k]] - c;
    }
    set.hull_at.resize(set.node.size());
    set.hulled.assign(ne, 0);
    set.com.resize(ne);
    set.inv_inertia.resize(ne);
    set.q0.resize(ne);
    set.v_sync.assign(ne, Vec3::Zero());
    set.w_sync.assign(ne, Vec3::Zero());
    set.node_v.assign(n, Vec3::Zero());
    set.node_v0.assign(n, Vec3::Zero());
    CollisionFilter filter = b.def.filter;
    filter.group = element_group(s);
    // A body or hull that cannot be made (it should not happen: the nodes were checked finite) leaves
    // nothing behind: the bodies made so far go, and the set is empty.
    try {
        create_bodies(s, b, set, filter);
        if (!write(s, set, b.p.v, Write::Reshape)) {
            // Checked before (RigidEmbedding::update_membership): only a velocity can be non-finite here.
            std::vector<Vec3> still(n, Vec3::Zero());
            write(s, set, still, Write::Reshape);
        }
    } catch (...) {
        destroy(s);
        throw;
    }
}

void ElementProxies::create_bodies(std::uint32_t s, const SoftBody& b, Set& set, const CollisionFilter& filter) {
    for (std::size_t e = 0; e + 1 < set.start.size(); ++e) {
        BodyDef def;
        def.type = set.kinematic[e] ? BodyType::Kinematic : BodyType::Dynamic;
        def.shape = make_sphere(Real(0.01));  // replaced by the hull in write()
        def.mass = 1;
        def.material.friction = b.def.friction;
        def.material.restitution = b.def.restitution;
        // The proxies fall under the rigid solver's gravity as the whole-body proxy does (the soft step adds
        // it a sub-step at a time; given at once with the nodes' prediction, a resting cube kept 9 mm/s of
        // push-out velocity that the relax passes did not remove); what it adds is not given back to the
        // nodes, which have it from their own step (after_soft_predict).
        def.gravity_scale = b.def.gravity_scale;
        def.allow_sleep = false;  // neither the proxies nor their soft body sleep (element_proxies.hpp)
        def.filter = filter;
        const BodyId id = rigid_.create_body(def);
        set.body[e] = id;
        if (soft_slot_of_rigid_.size() <= id.index) soft_slot_of_rigid_.resize(id.index + 1, no_soft_);
        soft_slot_of_rigid_[id.index] = s;
        if (element_of_rigid_.size() <= id.index) element_of_rigid_.resize(id.index + 1, ~std::uint32_t(0));
        element_of_rigid_[id.index] = std::uint32_t(e);
    }
    ignore_attachment_targets(b, set);
}

void ElementProxies::ignore_attachment_targets(const SoftBody& b, Set& set) {
    // The proxies do not collide with what the body hangs on (a rope's links would always overlap the
    // crate it is tied to), as joined bodies do not; checked every step, since attachments change.
    std::vector<BodyId> now;
    for (const Attachment& a : b.attachments) {
        const BodyId t = unpack_body_id(a.target);
        if (rigid_.valid(t) && !holds_any(set, t) && std::find(now.begin(), now.end(), t) == now.end()) now.push_back(t);
    }
    if (now == set.ignored) return;
    for (const BodyId& old : set.ignored)
        if (rigid_.valid(old) && std::find(now.begin(), now.end(), old) == now.end())
            for (const BodyId& id : set.body)
                if (rigid_.valid(id)) rigid_.ignore_pair(id, old, false);
    for (const BodyId& t : now)
        if (std::find(set.ignored.begin(), set.ignored.end(), t) == set.ignored.end())
            for (const BodyId& id : set.body)
                if (rigid_.valid(id)) rigid_.ignore_pair(id, t, true);
    set.ignored = std::move(now);
}

bool ElementProxies::holds_any(const Set& set, BodyId rigid) const {
    return std::find(set.body.begin(), set.body.end(), rigid) != set.body.end();
}

namespace {
/// The rotation of the polar decomposition of `a`, by Müller, Bender, Chentanez & Macklin 2016 ("A robust
/// method to extract the rotational part of deformations"): `q` turned by the small rotation that aligns
/// its columns with a's, until the turn is below 1e-6 rad. Warm-started from the element's orientation of
/// the step before, one or two iterations; a rank-deficient a (a triangle, a link) keeps the turn about
/// its missing directions, where the SVD's would be arbitrary.
Quat polar_iterated(const Mat3& a, Quat q) {
    for (int iteration = 0; iteration < 16; ++iteration) {
        const Mat3 r = q.toRotationMatrix();
        const Vec3 torque = r.col(0).cross(a.col(0)) + r.col(1).cross(a.col(1)) + r.col(2).cross(a.col(2));
        const Real align = std::abs(r.col(0).dot(a.col(0)) + r.col(1).dot(a.col(1)) + r.col(2).dot(a.col(2)));
        const Vec3 omega = torque / (align + std::numeric_limits<Real>::min());
        const Real angle = omega.norm();
        if (!(angle > Real(1e-6))) break;  // converged (or a NaN: keep the last orientation)
        q = (Quat(Eigen::AngleAxis<Real>(angle, omega / angle)) * q).normalized();
    }
    return q;
}
}  // namespace

bool ElementProxies::write(std::uint32_t s, Set& set, const std::vector<Vec3>& v, Write what) {
    const SoftBody& b = soft_.slot_body(s);
    if (!all_finite(b.p.x) || !all_finite(v)) return false;
    const RigidSystem::State& st = rigid_.state();
    for (std::size_t e = 0; e + 1 < set.start.size(); ++e) {
        const std::uint32_t k0 = set.start[e], k1 = set.start[e + 1];
        const BodyId id = set.body[e];
        Real m = 0;
        Vec3 p = Vec3::Zero();
        Transform xf = rigid_.transform(id);
        if (what != Write::Velocity) {
            // The element's centre, inertia (Steiner's sum, each node a ball of the body's thickness: its
            // own I_0, which keeps a link's inertia invertible) and rotation against its rest shape.
            Vec3 c = Vec3::Zero();
            for (std::uint32_t k = k0; k < k1; ++k) {
                c += set.weight[k] * b.p.x[set.node[k]];
                m += set.weight[k];
            }
            c /= m;
            Mat3 inertia = Mat3::Zero(), a = Mat3::Zero();
            Real size = 0;
            for (std::uint32_t k = k0; k < k1; ++k) {
                const Vec3 r = b.p.x[set.node[k]] - c;
                inertia += set.weight[k] * (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
                a += set.weight[k] * r * set.rest[k].transpose();
                size = std::max(size, r.norm());
            }
            const Real ball = std::max(b.def.thickness, Real(1e-3) * size);
            inertia += Real(0.4) * m * ball * ball * Mat3::Identity();
            const Quat q = polar_iterated(a, set.hulled[e] ? st.q[id.index] : Quat::Identity());
            set.com[e] = c;
            set.inv_inertia[e] = inertia.inverse();
            if (what == Write::Reshape) {
                // The hull follows the element's shape in its own frame, made anew only once a node has moved
                // more than kHullRefresh of the body's thickness (or 1% of the element's size) from where it
                // was when the hull was last made: a hull costs more than the rest of a step's work on the
                // element. The mass stays (the weights are fixed); the solver keeps the inertia of the last
                // hull while the exchange uses the measured one (an error of that order in a contact's turn).
                const Mat3 rt = q.toRotationMatrix().transpose();
                sx_.clear();
                Real moved = set.hulled[e] ? Real(0) : std::numeric_limits<Real>::infinity();
                for (std::uint32_t k = k0; k < k1; ++k) {
                    sx_.push_back(rt * (b.p.x[set.node[k]] - c));
                    if (set.hulled[e]) moved = std::max(moved, (sx_.back() - set.hull_at[k]).norm());
                }
                if (moved > std::max(kHullRefresh * b.def.thickness, Real(0.01) * size)) {
                    for (std::uint32_t k = k0; k < k1; ++k) set.hull_at[k] = sx_[k - k0];
                    const Shape hull = element_hull(sx_, b.def.thickness);
                    Mat3 local = rt * inertia * rt.transpose();
                    local = Real(0.5) * (local + local.transpose()).eval();
                    rigid_.reshape(id, hull, m, local);
                    set.hulled[e] = 1;
                }
            }
            xf = Transform{c, q};
        } else {
            for (std::uint32_t k = k0; k < k1; ++k) m += set.weight[k];
        }
        // Its velocity from the nodes' momentum and angular momentum about the centre.
        Vec3 l = Vec3::Zero();
        for (std::uint32_t k = k0; k < k1; ++k) {
            const std::uint32_t i = set.node[k];
            const Vec3 pi = set.weight[k] * v[i];
            p += pi;
            l += (b.p.x[i] - set.com[e]).cross(pi);
        }
        set.v_sync[e] = p / m - (set.kinematic[e] ? Vec3::Zero() : set.pending);
        set.w_sync[e] = set.inv_inertia[e] * l;
        rigid_.place(id, xf, set.v_sync[e], set.w_sync[e]);
        set.q0[e] = st.q[id.index];
    }
    return true;
}

bool ElementProxies::scatter(const SoftBody& b, Set& set, const BodyVelocities& vel) {
    bool any = false;
    for (std::size_t e = 0; e + 1 < set.start.size(); ++e) {
        if (set.kinematic[e]) continue;
        const std::uint32_t r = set.body[e].index;
        const Vec3 dv = vel.linear(r) - set.v_sync[e], dw = vel.angular(r) - set.w_sync[e];
        if (dv == Vec3::Zero() && dw == Vec3::Zero()) continue;
        any = true;
        set.v_sync[e] += dv;
        set.w_sync[e] += dw;
        // The rigid field of the change over the element's nodes (arms at x_n, where it was measured), each
        // node taking the mean of its elements' changes: mass splitting's averaging, so that elements
        // solved at once in one pass do not each stop a shared node (their sum would overshoot it).
        for (std::uint32_t k = set.start[e]; k < set.start[e + 1]; ++k) {
            const std::uint32_t i = set.node[k];
            set.node_v[i] += set.inv_valence[i] * (dv + dw.cross(b.p.x[i] - set.com[e]));
        }
    }
    return any;
}

void ElementProxies::gather(const SoftBody& b, Set& set, const BodyVelocities& vel) {
    for (std::size_t e = 0; e + 1 < set.start.size(); ++e) {
        if (set.kinematic[e]) continue;
        Vec3 p = Vec3::Zero(), l = Vec3::Zero();
        Real m = 0;
        for (std::uint32_t k = set.start[e]; k < set.start[e + 1]; ++k) {
            const std::uint32_t i = set.node[k];
            const Vec3 pi = set.weight[k] * set.node_v[i];
            p += pi;
            l += (b.p.x[i] - set.com[e]).cross(pi);
            m += set.weight[k];
        }
        const std::uint32_t r = set.body[e].index;
        set.v_sync[e] = p / m - set.pending;
        set.w_sync[e] = set.inv_inertia[e] * l;
        vel.set_linear(r, set.v_sync[e]);
        vel.set_angular(r, set.w_sync[e]);
    }
}

void ElementProxies::give(std::uint32_t s, Set& set, bool predicted, Real h) {
    SoftBody& b = soft_.slot_body(s);
    for (std::uint32_t i = 0; i < b.p.size(); ++i) {
        const Vec3 d = set.node_v[i] - set.node_v0[i];
        set.node_v0[i] = set.node_v[i];
        if (b.p.inv_mass[i] == 0 || d == Vec3::Zero()) continue;
        if (predicted) soft_.change_predicted_velocity(s, i, d, h);
        else b.p.v[i] += d;
    }
}

BodyVelocities ElementProxies::state_view() {
    RigidSystem::State& st = rigid_.state();
    return BodyVelocities::of_arrays(st.v, st.w);
}

bool ElementProxies::stepping(std::uint32_t s) const {
    return current(s) && sets_[s].stepped && soft_.slot_body(s).stepping;
}

void ElementProxies::begin_step() {
    any_stepping_ = false;
    const BodyVelocities vel = state_view();
    for (std::uint32_t s = 0; s < sets_.size(); ++s) {
        if (!current(s)) continue;
        Set& set = sets_[s];
        set.stepped = false;
        set.pending = Vec3::Zero();
        set.pending_substeps = 0;
        SoftBody& b = soft_.slot_body(s);
        ignore_attachment_targets(b, set);
        // The body does not sleep (its proxies would fall asleep island by island, each a static obstacle
        // to the rest while the body moves): one asleep when it was embedded wakes.
        if (!b.awake) soft_.wake(soft_.id_of_slot(s));
        // Impulses given to the proxies between steps (a game's) go to the nodes.
        std::fill(set.node_v.begin(), set.node_v.end(), Vec3::Zero());
        std::fill(set.node_v0.begin(), set.node_v0.end(), Vec3::Zero());
        if (scatter(b, set, vel)) give(s, set, false, 0);
        write(s, set, b.p.v, Write::Reshape);
    }
}

void ElementProxies::after_soft_predict(Real h) {
    const BodyVelocities vel = state_view();
    const bool fall_in_solve = rigid_.gravity_in_solve();
    for (std::uint32_t s = 0; s < sets_.size(); ++s) {
        if (!current(s) || !soft_.slot_body(s).stepping) continue;
        Set& set = sets_[s];
        SoftBody& b = soft_.slot_body(s);
        const Vec3 fall = h * b.def.gravity_scale * rigid_.settings().gravity;
        // Solvers that integrate in IntegrateVelocities have given the proxies their gravity there: not a
        // change to give the nodes, which have it from their own step. What else happened there (the
        // Newtonian solver's collision passes) goes into the nodes' prediction.
        if (!fall_in_solve)
            for (std::size_t e = 0; e < set.body.size(); ++e)
                if (!set.kinematic[e]) set.v_sync[e] += fall;
        std::fill(set.node_v.begin(), set.node_v.end(), Vec3::Zero());
        std::fill(set.node_v0.begin(), set.node_v0.end(), Vec3::Zero());
        if (scatter(b, set, vel)) give(s, set, true, h);
        // The velocity the rigid solve starts from: the nodes' predicted motion over the step (gravity,
        // internal forces; fast mass-spring's from Liu's inertial target). Under the soft step the proxies
        // start without the step's gravity, which its sub-steps give them a sub-step at a time (`pending`
        // until then); the nodes have it already, so it is never a change to give them.
        for (std::uint32_t i = 0; i < b.p.size(); ++i) set.node_v[i] = predicted_node_velocity(b, i, h);
        set.node_v0 = set.node_v;
        set.pending = fall_in_solve ? fall : Vec3::Zero();
        set.pending_substeps = 0;  // prepare() knows how many sub-steps the solver takes
        if (!write(s, set, set.node_v, Write::Velocity)) {  // diverged: the soft step's faults tell
            set.pending = Vec3::Zero();
            continue;
        }
        set.stepped = true;
        any_stepping_ = true;
    }
}

void ElementProxies::prepare(RigidSystem&, const RowStep& step) {
    for (Set& set : sets_) {
        if (set.pending == Vec3::Zero()) continue;
        set.pending_substeps = std::max(step.substeps, 1);
        set.fall_per_substep = set.pending / Real(set.pending_substeps);
    }
}

void ElementProxies::solve(const RigidSystem&, const BodyVelocities& vel, bool use_bias) {
    for (std::uint32_t s = 0; s < sets_.size(); ++s) {
        if (!stepping(s)) continue;
        Set& set = sets_[s];
        const SoftBody& b = soft_.slot_body(s);
        if (use_bias && set.pending_substeps > 0) {
            // The soft step gave every dynamic proxy a sub-step's gravity before this pass (its biased
            // pass comes once per sub-step, after the velocities): the nodes have it already.
            --set.pending_substeps;
            set.pending = set.fall_per_substep * Real(set.pending_substeps);
            for (std::size_t e = 0; e < set.body.size(); ++e)
                if (!set.kinematic[e]) set.v_sync[e] += set.fall_per_substep;
        }
        if (scatter(b, set, vel)) gather(b, set, vel);
    }
}

void ElementProxies::after_rigid_solve(Real h) {
    const BodyVelocities vel = state_view();
    for (std::uint32_t s = 0; s < sets_.size(); ++s) {
        if (!stepping(s)) continue;
        Set& set = sets_[s];
        const SoftBody& b = soft_.slot_body(s);
        if (scatter(b, set, vel)) gather(b, set, vel);
        give(s, set, true, h);
    }
}

void ElementProxies::after_rigid_positions(Real h) {
    const BodyVelocities vel = state_view();
    const RigidSystem::State& st = rigid_.state();
    for (std::uint32_t s = 0; s < sets_.size(); ++s) {
        if (!stepping(s)) continue;
        Set& set = sets_[s];
        SoftBody& b = soft_.slot_body(s);
        if (scatter(b, set, vel)) gather(b, set, vel);
        give(s, set, false, h);  // the soft step's relax and restitution, layers' reactions
        // The rigid solve's position work: where each element's proxy went against where its final velocity
        // alone takes it, as a rigid displacement of the element's nodes about their end-of-step centre;
        // each node moves by the mean over the dynamic elements holding it.
        Particles& p = b.p;
        std::vector<Vec3>& y = sx_;  // the nodes' end-of-step positions (SoftSystem::integrate_positions)
        y.resize(p.size());
        for (std::size_t i = 0; i < p.size(); ++i) y[i] = end_of_step_position(p, i, h);
        std::vector<Vec3>& corr = sv_;
        corr.assign(p.size(), Vec3::Zero());
        for (std::size_t e = 0; e < set.body.size(); ++e) {
            if (set.kinematic[e]) continue;
            const std::uint32_t r = set.body[e].index;
            const Vec3 shift = st.x[r] - (set.com[e] + h * st.v[r]);
            const Quat free_q = integrate_rotation(set.q0[e], st.w[r], h);
            const Mat3 turn = (st.q[r] * free_q.conjugate()).normalized().toRotationMatrix();
            Vec3 c = Vec3::Zero();
            Real m = 0;
            for (std::uint32_t k = set.start[e]; k < set.start[e + 1]; ++k) {
                c += set.weight[k] * y[set.node[k]];
                m += set.weight[k];
            }
            c /= m;
            for (std::uint32_t k = set.start[e]; k < set.start[e + 1]; ++k) {
                const std::uint32_t i = set.node[k];
                corr[i] += set.inv_valence[i] * (c + turn * (y[i] - c) + shift - y[i]);
            }
        }
        for (std::size_t i = 0; i < p.size(); ++i)
            if (p.inv_mass[i] != 0) p.x_next[i] += corr[i];
    }
}

void ElementProxies::end_step() {
    // Where the nodes ended, for queries between steps.
    for (std::uint32_t s = 0; s < sets_.size(); ++s)
        if (current(s) && sets_[s].stepped) write(s, sets_[s], soft_.slot_body(s).p.v, Write::Pose);
}

}  // namespace sinew
