// Soft bodies embedded into the rigid solver as rigid proxies (coupling/rigid_embedding.hpp).
#include "coupling/rigid_embedding.hpp"

#include "coupling/coupling_layer.hpp"  // CouplingError

#include <algorithm>
#include <cmath>

namespace sinew {

namespace {
bool anchored(const SoftBody& b) {
    for (Real im : b.p.inv_mass)
        if (im == 0) return true;
    return false;
}
}  // namespace

RigidEmbedding::RigidEmbedding(Pipeline& pipeline, RigidSystem& rigid, SoftSystem& soft)
    : pipeline_(pipeline), rigid_(rigid), soft_(soft), elements_(rigid, soft, soft_slot_of_rigid_, kNoSoft) {
    const int r = pipeline.find_system(rigid.name());
    const int s = pipeline.find_system(soft.name());
    hooks_[0] = pipeline.add_hook(r, Stage::IntegrateVelocities, HookWhen::Before,
                                  [this](const StepContext& ctx) {
                                      begin_step(ctx.h);
                                      elements_.begin_step();
                                  }, "embedding: proxies measured");
    hooks_[1] = pipeline.add_hook(s, Stage::IntegrateVelocities, HookWhen::After,
                                  [this](const StepContext& ctx) {
                                      after_soft_predict(ctx.h);
                                      elements_.after_soft_predict(ctx.h);
                                  },
                                  "embedding: proxy velocities from the prediction");
    hooks_[2] = pipeline.add_hook(r, Stage::SolveVelocities, HookWhen::After,
                                  [this](const StepContext& ctx) {
                                      after_rigid_solve(ctx.h);
                                      elements_.after_rigid_solve(ctx.h);
                                  },
                                  "embedding: rigid solve -> nodes");
    hooks_[3] = pipeline.add_hook(r, Stage::IntegratePositions, HookWhen::After,
                                  [this](const StepContext& ctx) {
                                      after_rigid_positions(ctx.h);
                                      elements_.after_rigid_positions(ctx.h);
                                  },
                                  "embedding: rigid positions -> nodes");
    hooks_[4] = pipeline.add_hook(s, Stage::IntegratePositions, HookWhen::After,
                                  [this](const StepContext&) {
                                      end_step();
                                      elements_.end_step();
                                  }, "embedding: proxies placed");
}

RigidEmbedding::~RigidEmbedding() {
    for (int h : hooks_) pipeline_.remove_hook(h);
}

std::size_t RigidEmbedding::count() const {
    std::size_t n = 0;
    for (const Proxy& px : proxies_) n += px.body.is_null() ? 0 : 1;
    return n + elements_.count();
}

const std::vector<BodyId>& RigidEmbedding::element_proxies(SoftBodyId id) const {
    static const std::vector<BodyId> none;
    if (!soft_.valid(id) || elements_.generation(id.index) != id.generation) return none;
    return elements_.proxies(id.index);
}

std::vector<std::uint32_t> RigidEmbedding::element_nodes(SoftBodyId id, std::size_t e) const {
    if (!soft_.valid(id) || elements_.generation(id.index) != id.generation) return {};
    return elements_.element_nodes(id.index, e);
}

BodyId RigidEmbedding::proxy(SoftBodyId id) const {
    if (!soft_.valid(id) || id.index >= proxies_.size()) return {};
    const Proxy& px = proxies_[id.index];
    return px.soft_generation == id.generation && rigid_.valid(px.body) ? px.body : BodyId{};
}

std::uint32_t RigidEmbedding::proxy_slot(BodyId rigid) const {
    if (rigid.is_null() || rigid.index >= soft_slot_of_rigid_.size()) return kNoSoft;
    const std::uint32_t s = soft_slot_of_rigid_[rigid.index];
    // The whole id, generation included: a stale entry (the rigid slot reused by another body) differs.
    if (s < proxies_.size() && proxies_[s].body == rigid) return s;
    return elements_.holds(s, rigid) ? s : kNoSoft;
}

bool RigidEmbedding::is_proxy(BodyId rigid) const { return proxy_slot(rigid) != kNoSoft; }

SoftBodyId RigidEmbedding::soft_of(BodyId rigid) const {
    const std::uint32_t s = proxy_slot(rigid);
    if (s == kNoSoft || !soft_.slot_alive(s)) return {};
    const std::uint32_t generation = elements_.embedded(s) ? elements_.generation(s) : proxies_[s].soft_generation;
    if (soft_.id_of_slot(s).generation != generation) return {};
    return soft_.id_of_slot(s);
}

void RigidEmbedding::update_membership(const CouplingSettings& settings) {
    const auto wanted = [&](std::uint32_t s) {
        if (s >= soft_.slot_count() || !soft_.slot_alive(s) || soft_.slot_body(s).p.size() == 0) return false;
        if (soft_.slot_body(s).meets_soft_bodies_only) return false;  // a rigid body's FEM proxy (embed-fem)
        return coupling_strategy_of(settings, soft_.id_of_slot(s), BodyId{}) == CouplingStrategy::EmbedRigid;
    };
    const bool by_elements = settings.embed_proxies == EmbedProxies::Elements;
    // Checked first, so that a body whose proxy cannot be made leaves everything as it was.
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s)
        if (wanted(s) && !all_finite(soft_.slot_body(s).p.x))
            throw CouplingError("embed-rigid: soft body " + std::to_string(s) +
                                " has a node position that is not finite: no rigid proxy can be made of it");
    settings_ = settings;
    if (proxies_.size() < soft_.slot_count()) proxies_.resize(soft_.slot_count());
    for (std::uint32_t s = 0; s < proxies_.size(); ++s) {
        Proxy& px = proxies_[s];
        const bool alive = s < soft_.slot_count() && soft_.slot_alive(s);
        const SoftBodyId id = alive ? soft_.id_of_slot(s) : SoftBodyId{};
        const bool same_body = alive && px.soft_generation == id.generation;
        const bool want = wanted(s) && !by_elements;
        const bool have = !px.body.is_null() && rigid_.valid(px.body) && same_body &&
                          px.anchored == anchored(soft_.slot_body(s));
        if (have && want) {
            // The proxy collides as its soft body does: a filter changed since follows it.
            const CollisionFilter& f = soft_.slot_body(s).def.filter;
            if (rigid_.filter(px.body) != f) rigid_.set_filter(px.body, f);
            continue;
        }
        if (!px.body.is_null() && rigid_.valid(px.body)) rigid_.destroy_body(px.body);
        if (proxy_slot(px.body) == s) soft_slot_of_rigid_[px.body.index] = kNoSoft;
        if (alive && same_body) {
            SoftBody& b = soft_.slot_body(s);
            b.meets_colliders_through_proxy = false;
            b.sleeps_with_proxy = false;
        }
        px = Proxy{};
        if (want) {
            px.soft_generation = id.generation;
            px.body = create_proxy(s);
        }
    }
    std::vector<bool> by_element(proxies_.size(), false);
    for (std::uint32_t s = 0; s < proxies_.size(); ++s) by_element[s] = by_elements && wanted(s);
    elements_.update_membership(by_element, settings.embed_proxy_mass);
    // Whichever kind of proxy a body has (or none), its own contact pass meets colliders only without one.
    // A body with element proxies never sleeps: the soft system's thresholds are set aside for it, as for
    // a dynamic whole-body proxy, and nothing puts it to sleep (coupling/element_proxies.hpp).
    for (std::uint32_t s = 0; s < proxies_.size(); ++s) {
        if (s >= soft_.slot_count() || !soft_.slot_alive(s)) continue;
        SoftBody& b = soft_.slot_body(s);
        const bool whole = !proxies_[s].body.is_null();
        b.meets_colliders_through_proxy = whole || elements_.embedded(s);
        if (elements_.embedded(s)) b.sleeps_with_proxy = true;
        else if (!whole) b.sleeps_with_proxy = false;
    }
}

BodyId RigidEmbedding::create_proxy(std::uint32_t slot) {
    SoftBody& b = soft_.slot_body(slot);
    Proxy& px = proxies_[slot];
    const RigidProxyState st = measure_rigid_proxy(b.p.x, b.p.v, b.p.mass, b.p.x, b.def.thickness);  // rest: as it is now
    px.rest.resize(b.p.size());
    for (std::size_t i = 0; i < b.p.size(); ++i) px.rest[i] = b.p.x[i] - st.com;
    px.anchored = anchored(b);
    BodyDef def;
    def.type = px.anchored ? BodyType::Kinematic : BodyType::Dynamic;
    def.pose = Transform{st.com, Quat::Identity()};
    def.shape = make_sphere(Real(0.01));  // replaced by the hull in write()
    def.mass = st.mass;
    def.material.friction = b.def.friction;
    def.material.restitution = b.def.restitution;
    // The proxy falls as the rigid bodies do (the soft step adds gravity a sub-step at a time: given at
    // once, a stack of five proxies kept 0.07 m/s of push-out velocity the relax passes did not remove);
    // the nodes take their gravity in their own step, so the rigid system's part is not given back.
    def.gravity_scale = b.def.gravity_scale;
    def.allow_sleep = b.def.allow_sleep;  // the proxy's island decides; the soft body follows it
    def.filter = b.def.filter;
    px.body = rigid_.create_body(def);
    if (soft_slot_of_rigid_.size() <= px.body.index) soft_slot_of_rigid_.resize(px.body.index + 1, kNoSoft);
    soft_slot_of_rigid_[px.body.index] = slot;
    b.meets_colliders_through_proxy = true;
    b.sleeps_with_proxy = !px.anchored;
    write(slot, px, b.p.x, b.p.v, true);
    return px.body;
}

void RigidEmbedding::momenta(const Proxy& px, Vec3& p, Vec3& l) const {
    const RigidSystem::State& st = rigid_.state();
    const std::uint32_t s = px.body.index;
    p = rigid_.mass(px.body) * st.v[s];
    // The inertia as the proxy has turned since it was written: I(q) = T I0 Tᵀ, T = q q0⁻¹.
    const Mat3 t = (st.q[s] * px.q0.conjugate()).toRotationMatrix();
    l = t * (px.inertia0 * (t.transpose() * st.w[s]));
}

void RigidEmbedding::take_changes(std::uint32_t slot, Proxy& px, Into into, Real h) {
    if (px.anchored) return;  // kinematic: nothing but its nodes moves it
    Vec3 p, l;
    momenta(px, p, l);
    const Vec3 dp = p - px.p_written, dl = l - px.l_written;
    px.p_written = p;
    px.l_written = l;
    if (dp.isZero(0) && dl.isZero(0)) return;
    SoftBody& b = soft_.slot_body(slot);
    const Vec3 dv = dp / rigid_.mass(px.body);
    const Vec3 dw = px.inertia0.ldlt().solve(dl);
    // The arms are taken at x_n (p.x outside SolveVelocities), where the proxy's inertia was measured.
    for (std::uint32_t i = 0; i < b.p.size(); ++i) {
        if (b.p.inv_mass[i] == 0) continue;  // pinned or attached: its pin or target decides
        const Vec3 dvi = dv + dw.cross(b.p.x[i] - px.com0);
        if (into == Into::Predicted) soft_.change_predicted_velocity(slot, i, dvi, h);
        else b.p.v[i] += dvi;
    }
}

bool RigidEmbedding::stepping(std::uint32_t s) const {
    return !proxies_[s].body.is_null() && soft_.slot_alive(s) && soft_.slot_body(s).stepping &&
           rigid_.valid(proxies_[s].body);
}

bool RigidEmbedding::write(std::uint32_t slot, Proxy& px, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                           bool reshape) {
    SoftBody& b = soft_.slot_body(slot);
    if (!all_finite(x) || !all_finite(v)) return false;  // diverged: SoftSystem::all_finite() tells
    const RigidProxyState st = measure_rigid_proxy(x, v, b.p.mass, px.rest, b.def.thickness);
    const Quat q(st.rotation);
    if (reshape) {
        // The hull of the nodes in the proxy's frame (origin at the centre of mass).
        std::vector<Vec3>& local = scratch_x_;
        local.resize(x.size());
        const Mat3 rt = st.rotation.transpose();
        for (std::size_t i = 0; i < x.size(); ++i) local[i] = rt * (x[i] - st.com);
        // A flat body (a cloth) has no volume: its nodes are doubled a thickness to either side.
        const Shape hull = make_proxy_hull(local, b.def.thickness, kHullFlatness);
        Mat3 inertia = rt * st.inertia * st.rotation;
        inertia = Real(0.5) * (inertia + inertia.transpose()).eval();  // symmetric to rounding, as reshape checks
        rigid_.reshape(px.body, hull, st.mass, inertia);
    }
    rigid_.place(px.body, Transform{st.com, q}, st.v, st.w);
    px.com0 = st.com;
    px.q0 = rigid_.state().q[px.body.index];
    px.inertia0 = st.inertia;
    momenta(px, px.p_written, px.l_written);
    return true;
}

void RigidEmbedding::ignore_attachment_targets(const SoftBody& b, Proxy& px) {
    std::vector<BodyId> now;
    for (const Attachment& a : b.attachments) {
        const BodyId target = unpack_body_id(a.target);
        if (rigid_.valid(target) && target != px.body && std::find(now.begin(), now.end(), target) == now.end())
            now.push_back(target);
    }
    for (const BodyId& old : px.ignored)
        if (rigid_.valid(old) && std::find(now.begin(), now.end(), old) == now.end()) rigid_.ignore_pair(px.body, old, false);
    for (const BodyId& t : now) rigid_.ignore_pair(px.body, t, true);
    px.ignored = std::move(now);
}

void RigidEmbedding::begin_step(Real) {
    if (before_step_) before_step_();
    try {
        update_membership(settings_);  // soft bodies created, destroyed or pinned since
    } catch (const CouplingError&) {
        // A body diverged to non-finite nodes: its proxy stays as it was (SoftSystem::faults() tells; the
        // soft step contains it in IntegratePositions).
    }
    for (std::uint32_t s = 0; s < proxies_.size(); ++s) {
        Proxy& px = proxies_[s];
        px.stepped = false;
        if (px.body.is_null() || !rigid_.valid(px.body)) continue;
        SoftBody& b = soft_.slot_body(s);
        const SoftBodyId id = soft_.id_of_slot(s);
        // A dynamic proxy's rigid island decides when the body sleeps (a stack of embedded cubes sleeps as
        // a rigid stack does): asleep with it, woken with it; a body woken from outside (a force, a moved
        // node) wakes the island. An anchored body's kinematic proxy follows the soft system's own sleeping.
        if (!px.anchored) {
            if (!rigid_.awake(px.body)) {
                if (b.awake && px.put_to_sleep) {
                    rigid_.wake(px.body);
                } else {
                    soft_.put_to_sleep(id);
                    px.put_to_sleep = true;
                    continue;
                }
            }
            px.put_to_sleep = false;
            if (!b.awake) soft_.wake(id);
        } else if (!b.awake) {
            continue;
        }
        take_changes(s, px, Into::Between, 0);  // impulses given to the proxy between steps
        // The proxy does not collide with what its body hangs on (a rope's hull would always overlap
        // the crate it is tied to), as joined bodies do not by default.
        ignore_attachment_targets(b, px);
        write(s, px, b.p.x, b.p.v, true);
    }
}

void RigidEmbedding::after_soft_predict(Real h) {
    // The velocity the rigid solve starts from: the nodes' predicted motion over the step (gravity and
    // internal forces; Verlet's and Liu's inertial prediction), (x_next - x_n) / h.
    for (std::uint32_t s = 0; s < proxies_.size(); ++s) {
        if (!stepping(s)) continue;
        Proxy& px = proxies_[s];
        SoftBody& b = soft_.slot_body(s);
        px.stepped = true;
        // Solvers that integrate in IntegrateVelocities have given the proxy its gravity there (before
        // this): the nodes have it from their own step.
        const Vec3 fall = h * b.def.gravity_scale * rigid_.settings().gravity * rigid_.mass(px.body);
        const bool fall_in_solve = rigid_.gravity_in_solve();
        if (!px.anchored && !fall_in_solve) px.p_written += fall;
        take_changes(s, px, Into::Predicted, h);  // Newtonian impulses' collision passes
        std::vector<Vec3>& v = scratch_v_;
        v.resize(b.p.size());
        // Fast mass-spring's first iterate leaves gravity out (a body at rest starts at its solution);
        // its inertial target y holds the step's predicted motion.
        for (std::uint32_t i = 0; i < v.size(); ++i) v[i] = predicted_node_velocity(b, i, h);
        if (!px.anchored && fall_in_solve) {
            // The solver adds the step's gravity a sub-step at a time (the soft step): the proxy starts
            // without it, and what the solve adds is not a change to give the nodes.
            const Vec3 dv = fall / rigid_.mass(px.body);
            for (Vec3& vi : v) vi -= dv;
        }
        if (!write(s, px, b.p.x, v, false)) {  // diverged: the rigid solve's changes are not given back
            px.stepped = false;
            continue;
        }
        if (!px.anchored && fall_in_solve) px.p_written += fall;
    }
}

void RigidEmbedding::after_rigid_solve(Real h) {
    for (std::uint32_t s = 0; s < proxies_.size(); ++s)
        if (stepping(s) && proxies_[s].stepped) take_changes(s, proxies_[s], Into::Predicted, h);
}

void RigidEmbedding::after_rigid_positions(Real h) {
    const RigidSystem::State& st = rigid_.state();
    for (std::uint32_t s = 0; s < proxies_.size(); ++s) {
        if (!stepping(s) || !proxies_[s].stepped) continue;
        Proxy& px = proxies_[s];
        take_changes(s, px, Into::Solved, h);  // the soft step's relax and restitution, layers' reactions
        if (px.anchored) continue;
        // Where the proxy went against where its final velocity alone takes it from where it was written:
        // the rigid solve's position work (the soft step's biased sub-steps, split impulses' pseudo-
        // velocities, joint projection). The nodes' end-of-step positions take the same rigid displacement
        // about their centre of mass, so the soft body ends where its proxy did.
        const std::uint32_t r = px.body.index;
        const Vec3 shift = st.x[r] - (px.com0 + h * st.v[r]);
        const Quat free_q = integrate_rotation(px.q0, st.w[r], h);
        const Mat3 turn = (st.q[r] * free_q.conjugate()).normalized().toRotationMatrix();
        SoftBody& b = soft_.slot_body(s);
        Particles& p = b.p;
        // The nodes' end-of-step positions: x_next + h (v - v_solved) (SoftSystem::integrate_positions).
        std::vector<Vec3>& y = scratch_x_;
        y.resize(p.size());
        double m_total = 0;
        Eigen::Vector3d cm = Eigen::Vector3d::Zero();
        for (std::size_t i = 0; i < p.size(); ++i) {
            y[i] = end_of_step_position(p, i, h);
            m_total += p.mass[i];
            cm += double(p.mass[i]) * y[i].cast<double>();
        }
        const Vec3 c = (cm / m_total).cast<Real>();
        for (std::size_t i = 0; i < p.size(); ++i)
            if (p.inv_mass[i] != 0) p.x_next[i] += c + turn * (y[i] - c) + shift - y[i];
    }
}

void RigidEmbedding::end_step() {
    for (std::uint32_t s = 0; s < proxies_.size(); ++s) {
        Proxy& px = proxies_[s];
        if (px.body.is_null() || !soft_.slot_alive(s) || !rigid_.valid(px.body)) continue;
        if (!px.stepped) {
            // Its soft body did not step, but an awake body may have woken the proxy inside the rigid step
            // and pushed it: the soft body wakes, and the next step gives the nodes that change.
            if (!px.anchored && rigid_.awake(px.body)) soft_.wake(soft_.id_of_slot(s));
            continue;
        }
        SoftBody& b = soft_.slot_body(s);
        write(s, px, b.p.x, b.p.v, false);
    }
}

}  // namespace sinew
