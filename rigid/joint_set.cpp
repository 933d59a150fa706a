// The joints of a rigid system: generational slots, validation, and the per-step passes, which dispatch
// by a switch on the joint type to the row code in rigid/joint_<type>.cpp (no virtual calls, no heap
// allocation in the passes: prepared rows live in a flat array indexed by joint slot).
#include "rigid/joint_set.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Eigenvalues>

#include "rigid/joint_point_solve.hpp"
#include "rigid/joint_rows.hpp"
#include "rigid/rigid_system.hpp"
#include "engine/core/bucket_sort.hpp"
#include "engine/core/format.hpp"
#include "engine/core/task_system.hpp"

namespace sinew {

using namespace joint_detail;

const char* joint_type_name(JointType t) {
    switch (t) {
        case JointType::Ball: return "ball";
        case JointType::Hinge: return "hinge";
        case JointType::Slider: return "slider";
        case JointType::Distance: return "distance";
        case JointType::Fixed: return "fixed";
    }
    return "unknown";
}

struct JointSet::Impl {
    std::vector<JointData> joints;        // by slot
    std::vector<JointRows> rows;          // by slot: this (sub-)step's prepared rows
    Slots slots;                          // joint slots and generations (engine/core/slots.hpp)
    std::vector<std::uint32_t> active;    // slots prepared for this step, in slot order

    // This step's method (see prepare()), set by prepare() and used until finish().
    enum class Correction : std::uint8_t { Baumgarte, Soft, Projection };
    Correction correction = Correction::Baumgarte;
    Real h = 0;                           // the length given to the last prepare()
    Softness velocity_bias;               // of the rows in biased velocity passes
    Softness projection_bias;             // of the rows in the position projection pass
    std::vector<JointId> broken;          // joints broken by the last finish()
    std::vector<std::uint32_t> moving;    // bodies of the active joints that can move, each once
    std::vector<std::uint8_t> mark;       // by body slot, scratch for `moving`
    std::vector<Vec3> pv, pw;             // pseudo-velocities of the projection pass, by body slot
    // Soft step: the active joints in groups that share no movable body (connected through the bodies
    // they move), each group's joints in slot order, groups in the order of their first joint. Groups
    // are solved independently, on the workers of the rigid system's region (`region`): each group's
    // sweeps and its exact point solve touch only its own bodies, so any schedule gives the bits of the
    // one-thread loop over the groups.
    std::vector<std::uint32_t> group_start, group_joints;
    std::vector<std::unique_ptr<JointPointSolve>> group_points;  // per group: its point blocks solved together after its sweeps
    std::vector<std::uint32_t> point_generation_start;  // per group: where its joints' generations start in...
    std::vector<std::uint32_t> point_generations;       // ...the generations of the joints in the point solves, as prepared
    std::vector<std::uint32_t> group_of_body;           // by body slot, scratch of grouping (union-find parents)
    std::vector<std::uint32_t> mark_group, joint_group, group_fill;  // scratch of grouping
    std::vector<std::uint32_t> body_zero;  // by body slot, all zero between uses: JointPointSolve::prepare's scratch
    ParallelRegion* region = nullptr;
    std::size_t group_count() const { return group_start.empty() ? 0 : group_start.size() - 1; }
    Softness point_bias;                  // of the point blocks in that solve's biased passes

    // Sorted (min slot, max slot) keys of joints that filter contacts, rebuilt on the first query after
    // a joint is created or destroyed: the broad phase asks once per candidate pair.
    mutable std::vector<std::uint64_t> filter_keys;
    mutable bool filter_dirty = false;
    std::uint64_t filter_revision = 0;  // bumped whenever the filtered pairs may change

    bool valid(JointId id) const { return slots.valid(id.index, id.generation); }
    void check(JointId id, const char* where) const {
        if (!valid(id))
            throw RigidError(std::string(where) + ": stale or unknown joint id (index " + std::to_string(id.index) +
                             ", generation " + std::to_string(id.generation) + ")");
    }
    JointData& at(JointId id, const char* where) {
        check(id, where);
        return joints[id.index];
    }
    const JointData& at(JointId id, const char* where) const {
        check(id, where);
        return joints[id.index];
    }
    void remove(std::uint32_t slot) {
        slots.release(slot);
        filter_dirty = true;
        ++filter_revision;
    }
    static std::uint64_t pair_key(std::uint32_t a, std::uint32_t b) {
        if (a > b) std::swap(a, b);
        return (std::uint64_t(a) << 32) | b;
    }
};

namespace {

// Largest error one projection sweep removes (m for linear rows, rad for angular ones), as Box2D v2's
// b2_maxLinearCorrection: a joint created with its anchors far apart closes over several steps instead
// of teleporting its bodies through whatever lies between.
constexpr Real kMaxProjection = Real(0.2);

// The soft step's point blocks, solved exactly, at this fraction of the sub-step rate (Hz x s): the cap the
// other joint rows have.
constexpr Real kPointHertzPerRate = Real(0.5);
// Position projection sweeps per step (Box2D v2 uses 3 position iterations, Jolt 2).
constexpr int kProjectionSweeps = 2;

// Gauss-Seidel sweeps over the joints per solve() call of a sub-stepping (soft) solver, which calls
// once per pass. With one sweep, a 20-link chain's 120 Hz joints at 5 sub-steps (omega h = 2.5) never
// come to rest (~0.4 J of wobble, joint errors up to 1.3 mm, damping 1/s); two sweeps settle it at the
// predicted sag (0.65 mm). Joint rows are few next to contacts, so the second sweep is cheap.
constexpr int kSoftSweeps = 2;

[[noreturn]] void bad(const JointDef& d, const std::string& why) {
    throw RigidError(std::string("joint definition (") + joint_type_name(d.type) + "): " + why);
}

void check_motor(const JointDef& d, Real speed, Real max_force) {
    if (!is_finite(speed)) bad(d, "motor_speed must be finite, got " + to_text(speed));
    if (!is_finite(max_force) || max_force < 0)
        bad(d, "max_motor_force must be finite and >= 0, got " + to_text(max_force));
}

/// The limit's checks (at creation and when set_limits changes it).
void check_limits(const JointDef& d) {
    if (!is_finite(d.lower) || !is_finite(d.upper))
        bad(d, "limits must be finite, got lower " + to_text(d.lower) + ", upper " + to_text(d.upper));
    if (d.lower > d.upper) bad(d, "lower limit " + to_text(d.lower) + " is greater than upper limit " + to_text(d.upper));
    // The hinge angle is measured in (-pi, pi]; a limit outside that range could never be reached.
    if (d.type == JointType::Hinge && d.enable_limit && (d.lower < -kPi || d.upper > kPi))
        bad(d, "hinge limits must lie within [-pi, pi] rad, got [" + to_text(d.lower) + ", " + to_text(d.upper) + "]");
}

/// Every check that does not need the bodies' poses.
void validate(const JointDef& d, const RigidSystem& sys) {
    switch (d.type) {
        case JointType::Ball: case JointType::Hinge: case JointType::Slider: case JointType::Distance:
        case JointType::Fixed: break;
        default: throw RigidError("joint definition: unknown joint type " + std::to_string(int(d.type)));
    }
    for (int k = 0; k < 2; ++k) {
        const BodyId id = k == 0 ? d.body_a : d.body_b;
        const char* name = k == 0 ? "body_a" : "body_b";
        if (id.is_null()) bad(d, std::string(name) + " is null");
        if (!sys.valid(id))
            bad(d, std::string(name) + " is a stale or unknown body id (index " + std::to_string(id.index) +
                       ", generation " + std::to_string(id.generation) + ")");
    }
    if (d.body_a == d.body_b) bad(d, "body_a and body_b are the same body (index " + std::to_string(d.body_a.index) + ")");
    if (sys.type(d.body_a) != BodyType::Dynamic && sys.type(d.body_b) != BodyType::Dynamic)
        bad(d, std::string("at least one body must be dynamic (body_a is ") + body_type_name(sys.type(d.body_a)) +
                   ", body_b is " + body_type_name(sys.type(d.body_b)) + ")");
    if (!is_finite(d.local_anchor_a)) bad(d, "local_anchor_a must be finite, got " + to_text(d.local_anchor_a));
    if (!is_finite(d.local_anchor_b)) bad(d, "local_anchor_b must be finite, got " + to_text(d.local_anchor_b));
    if (!is_finite(d.local_axis_a)) bad(d, "local_axis_a must be finite, got " + to_text(d.local_axis_a));
    const bool has_axis = d.type == JointType::Hinge || d.type == JointType::Slider;
    if (has_axis && !(d.local_axis_a.norm() > Real(1e-6)))
        bad(d, "local_axis_a must be non-zero, got " + to_text(d.local_axis_a));
    check_limits(d);
    check_motor(d, d.motor_speed, d.max_motor_force);
    if (!is_finite(d.length)) bad(d, "length must be finite, got " + to_text(d.length));
    if (!is_finite(d.frequency) || d.frequency < 0) bad(d, "frequency must be finite and >= 0 Hz, got " + to_text(d.frequency));
    if (!is_finite(d.damping_ratio) || d.damping_ratio < 0)
        bad(d, "damping_ratio must be finite and >= 0, got " + to_text(d.damping_ratio));
    if (!is_finite(d.break_force) || d.break_force < 0)
        bad(d, "break_force must be finite and >= 0 (0 = unbreakable), got " + to_text(d.break_force));
    if (!is_finite(d.reference_rotation))
        bad(d, "reference_rotation must be finite (all zero = the orientation at creation)");
    const Real n2 = d.reference_rotation.squaredNorm();
    if (n2 != 0 && !(n2 > Real(1e-12)))
        bad(d, "reference_rotation must be a unit quaternion, or all zero for the orientation at creation");
}

/// The reference rotation as a unit quaternion. One that is unit to rounding is kept as it is, so a
/// rotation read back from a saved scene is the one that was saved, bit for bit.
Quat unit_rotation(const Quat& q) {
    return std::abs(q.squaredNorm() - 1) <= 4 * kEpsilon ? q : q.normalized();
}

/// Centre of mass in the body's own axes, from the origin transform and the state.
Vec3 local_com(const RigidSystem& sys, BodyId id) {
    const Transform origin = sys.transform(id);
    return origin.rotate_inverse(sys.state().x[id.index] - origin.p);
}

// A lever arm far beyond the body's size makes the anchor point's effective mass matrix,
// 1/m + [r]x^T I^-1 [r]x, ill-conditioned by (r/k)^2 (k the smallest radius of gyration): past about
// 1/epsilon of float it is not representable and the first step ends as NaN (a ball joint anchored 40 km
// from a 0.5 m box, issue 18; 10 km still stepped by luck). 1000 radii keeps the condition number below
// 1e6 (float's epsilon is 1.2e-7): a 0.5 m box may be held from 204 m away.
constexpr Real kMaxArmInRadiiOfGyration = 1000;

void check_lever_arm(const JointDef& d, const RigidSystem& sys, BodyId id, const Vec3& anchor_value,
                     const Vec3& arm, const char* anchor, const char* body) {
    if (sys.type(id) != BodyType::Dynamic) return;  // static and kinematic bodies have no effective mass to lose
    const Mat3& inv_i = sys.inverse_inertia_local(id);
    const Real largest = inv_i.selfadjointView<Eigen::Lower>().eigenvalues().maxCoeff();  // 1 / I_min
    const Real k = std::sqrt(1 / (sys.mass(id) * largest));  // smallest radius of gyration (m)
    const Real r = arm.norm();
    if (!(r <= kMaxArmInRadiiOfGyration * k))
        bad(d, std::string(anchor) + " " + to_text(anchor_value) + " lies " + to_text(r) + " m from " + body +
                   "'s centre of mass, more than " + to_text(kMaxArmInRadiiOfGyration) +
                   " times its smallest radius of gyration (" + to_text(k) +
                   " m): the joint's effective mass would not be representable; put the anchor nearer the body");
}

}  // namespace

JointSet::JointSet() : impl_(std::make_unique<Impl>()) {}
JointSet::~JointSet() = default;

JointId JointSet::create(const JointDef& def, const RigidSystem& sys) {
    validate(def, sys);  // throws before anything changes
    JointData j;
    j.def = def;
    const RigidSystem::State& st = sys.state();
    const Transform xa = sys.transform(def.body_a), xb = sys.transform(def.body_b);
    const Quat qa = st.q[def.body_a.index], qb = st.q[def.body_b.index];
    j.la = def.local_anchor_a - local_com(sys, def.body_a);
    j.lb = def.local_anchor_b - local_com(sys, def.body_b);
    check_lever_arm(def, sys, def.body_a, def.local_anchor_a, j.la, "local_anchor_a", "body_a");
    check_lever_arm(def, sys, def.body_b, def.local_anchor_b, j.lb, "local_anchor_b", "body_b");
    const bool has_axis = def.type == JointType::Hinge || def.type == JointType::Slider;
    j.axis_a = has_axis ? Vec3(def.local_axis_a.normalized()) : Vec3::UnitZ();
    if (has_axis) j.def.local_axis_a = j.axis_a;
    tangent_basis(j.axis_a, j.perp_a[0], j.perp_a[1]);
    j.rel0 = def.reference_rotation.squaredNorm() > 0 ? unit_rotation(def.reference_rotation)
                                                      : Quat((qa.conjugate() * qb).normalized());
    j.def.reference_rotation = j.rel0;
    j.axis_b = j.rel0.conjugate() * j.axis_a;
    if (def.type == JointType::Distance) {
        const Real now = (xb.apply(def.local_anchor_b) - xa.apply(def.local_anchor_a)).norm();
        const Real length = def.length < 0 ? now : def.length;
        // A zero rest length has no direction to push along; that is a ball joint.
        if (!(length > Real(1e-4)))
            bad(def, "rest length must be > 1e-4 m, got " + to_text(length) +
                         (def.length < 0 ? " (the anchors' distance at creation)" : "") + "; use a ball joint");
        j.def.length = length;
    }

    Impl& m = *impl_;
    if (m.slots.count() == m.slots.size()) {  // no free slot: room for a new one first (may throw)
        m.joints.emplace_back();
        m.rows.emplace_back();
    }
    const Slots::Acquired got = m.slots.acquire();
    m.joints[got.index] = j;
    m.rows[got.index] = JointRows{};
    m.filter_dirty = true;
    ++m.filter_revision;
    return {got.index, got.generation};
}

void JointSet::destroy(JointId id) {
    impl_->at(id, "destroy_joint");
    impl_->remove(id.index);
}

bool JointSet::valid(JointId id) const { return impl_->valid(id); }
std::size_t JointSet::count() const { return impl_->slots.count(); }

std::vector<JointId> JointSet::ids() const {
    const Impl& m = *impl_;
    std::vector<JointId> out;
    out.reserve(m.slots.count());
    for (std::uint32_t s = 0; s < m.joints.size(); ++s)
        if (m.slots.alive(s)) out.push_back({s, m.slots.generation(s)});
    return out;
}

void JointSet::destroy_attached(std::uint32_t slot) {
    Impl& m = *impl_;
    for (std::uint32_t s = 0; s < m.joints.size(); ++s)
        if (m.slots.alive(s) && (m.joints[s].def.body_a.index == slot || m.joints[s].def.body_b.index == slot)) m.remove(s);
}

void JointSet::forget_impulses(std::uint32_t slot) {
    Impl& m = *impl_;
    for (std::uint32_t s = 0; s < m.joints.size(); ++s) {
        JointData& j = m.joints[s];
        if (!m.slots.alive(s) || (j.def.body_a.index != slot && j.def.body_b.index != slot)) continue;
        j.impulses.clear();
        j.reaction_force.setZero();
        j.reaction_torque.setZero();
    }
}

std::uint64_t JointSet::filter_revision() const { return impl_->filter_revision; }

bool JointSet::filters_pair(std::uint32_t a, std::uint32_t b) const {
    const Impl& m = *impl_;
    if (m.slots.count() == 0) return false;
    if (m.filter_dirty) {
        m.filter_keys.clear();
        for (std::uint32_t s = 0; s < m.joints.size(); ++s)
            if (m.slots.alive(s) && !m.joints[s].def.collide_connected)
                m.filter_keys.push_back(Impl::pair_key(m.joints[s].def.body_a.index, m.joints[s].def.body_b.index));
        std::sort(m.filter_keys.begin(), m.filter_keys.end());
        m.filter_dirty = false;
    }
    return std::binary_search(m.filter_keys.begin(), m.filter_keys.end(), Impl::pair_key(a, b));
}

void JointSet::for_each_connection(const std::function<void(std::uint32_t, std::uint32_t)>& f) const {
    const Impl& m = *impl_;
    for (std::uint32_t s = 0; s < m.joints.size(); ++s)
        if (m.slots.alive(s)) f(m.joints[s].def.body_a.index, m.joints[s].def.body_b.index);
}

const JointDef& JointSet::def(JointId id) const { return impl_->at(id, "joint def").def; }
Vec3 JointSet::reaction_force(JointId id) const { return impl_->at(id, "reaction_force").reaction_force; }
Vec3 JointSet::reaction_torque(JointId id) const { return impl_->at(id, "reaction_torque").reaction_torque; }

Real JointSet::position_error(JointId id, const RigidSystem& sys) const {
    const JointData& j = impl_->at(id, "position_error");
    const PairPose pose(sys.state(), j, j.def.body_a.index, j.def.body_b.index);
    switch (j.def.type) {
        case JointType::Slider: {
            const Vec3 axis = pose.qa * j.axis_a;
            return (pose.d - pose.d.dot(axis) * axis).norm();
        }
        case JointType::Distance: return std::abs(pose.d.norm() - j.def.length);
        default: return pose.d.norm();
    }
}

Real JointSet::angular_error(JointId id, const RigidSystem& sys) const {
    const JointData& j = impl_->at(id, "angular_error");
    const Quat qa = sys.state().q[j.def.body_a.index], qb = sys.state().q[j.def.body_b.index];
    switch (j.def.type) {
        case JointType::Hinge: {
            const Vec3 a1 = qa * j.axis_a, a2 = qb * j.axis_b;
            return std::atan2(a1.cross(a2).norm(), a1.dot(a2));
        }
        case JointType::Slider:
        case JointType::Fixed: {
            const Quat e = qb * (qa * j.rel0).conjugate();
            return 2 * std::atan2(e.vec().norm(), std::abs(e.w()));
        }
        default: return 0;
    }
}

Real JointSet::coordinate(JointId id, const RigidSystem& sys) const {
    const JointData& j = impl_->at(id, "coordinate");
    const PairPose pose(sys.state(), j, j.def.body_a.index, j.def.body_b.index);
    switch (j.def.type) {
        case JointType::Hinge: return hinge_angle(j, pose.qa, pose.qb);
        case JointType::Slider: return pose.d.dot(pose.qa * j.axis_a);
        case JointType::Distance: return pose.d.norm();
        default: return 0;
    }
}

Real JointSet::coordinate_speed(JointId id, const RigidSystem& sys) const {
    const JointData& j = impl_->at(id, "coordinate_speed");
    const RigidSystem::State& st = sys.state();
    const std::uint32_t a = j.def.body_a.index, b = j.def.body_b.index;
    const PairPose pose(st, j, a, b);
    const Vec3 axis = pose.qa * j.axis_a;
    // d = x_b + r_b - x_a - r_a moves at the anchors' relative velocity.
    const Vec3 dd = st.v[b] + st.w[b].cross(pose.rb) - st.v[a] - st.w[a].cross(pose.ra);
    switch (j.def.type) {
        case JointType::Hinge: return (st.w[b] - st.w[a]).dot(axis);
        case JointType::Slider: return dd.dot(axis) + pose.d.dot(st.w[a].cross(axis));  // the axis turns with A
        case JointType::Distance: {
            const Real len = pose.d.norm();
            return len > 0 ? dd.dot(pose.d) / len : 0;
        }
        default: return 0;
    }
}

void JointSet::set_limits(JointId id, bool enable, Real lower, Real upper) {
    JointData& j = impl_->at(id, "set_limits");
    JointDef d = j.def;
    d.enable_limit = enable;
    d.lower = lower;
    d.upper = upper;
    check_limits(d);
    if (!enable) j.impulses.lower = j.impulses.upper = 0;
    j.def.enable_limit = enable;
    j.def.lower = lower;
    j.def.upper = upper;
}

void JointSet::set_motor(JointId id, bool enable, Real speed, Real max_force) {
    JointData& j = impl_->at(id, "set_motor");
    check_motor(j.def, speed, max_force);
    if (!enable) j.impulses.motor = 0;
    j.def.enable_motor = enable;
    j.def.motor_speed = speed;
    j.def.max_motor_force = max_force;
}

bool JointSet::active() const { return !impl_->active.empty(); }
std::size_t JointSet::active_count() const { return impl_->active.size(); }

namespace {

// Without the soft step's sub-steps, Gauss-Seidel cannot hold a 100 kg body on a 1 kg link: a 20-link
// chain with a 100:1 end mass came apart under split impulses, Baumgarte and the Newtonian solver (joint
// errors of metres), hanging at rest under the last two. These solvers bound the mass ratio a joint sees
// as their contacts do (rigid/rigid_support.cpp): the lighter body's inverse mass and inertia are scaled
// in this joint alone so the ratio is the bound. The chains then hold together (split impulses 4 cm,
// Newton 16 cm; Baumgarte 13 cm in float, apart in double, at its stability's edge), at the price of
// the motion: the chain above feels the end as if it were bound times its link's mass (docs/rigid-solvers.md).
// The soft step keeps true masses: its chain stays within 15 mm and on the converged path.
void bound_mass_ratio(JointRows& r, Real bound) {
    if (!(bound > 0) || r.ma <= 0 || r.mb <= 0) return;
    if (r.ma > bound * r.mb) {
        const Real k = bound * r.mb / r.ma;
        r.ma *= k;
        r.ia *= k;
    } else if (r.mb > bound * r.ma) {
        const Real k = bound * r.ma / r.mb;
        r.mb *= k;
        r.ib *= k;
    }
}

}  // namespace

// The active joints grouped by the movable bodies they connect (union-find over body slots), for the soft
// step's solve (Impl::group_start); each group's exact point solve prepared.
void JointSet::group_joints(Impl& m, std::size_t body_slots) {
    std::vector<std::uint32_t>& parent = m.group_of_body;
    if (parent.size() < body_slots) parent.resize(body_slots);
    for (std::uint32_t b : m.moving) parent[b] = b;
    const auto find = [&](std::uint32_t b) {
        while (parent[b] != b) b = parent[b] = parent[parent[b]];
        return b;
    };
    for (std::uint32_t s : m.active) {
        const JointRows& r = m.rows[s];
        if (r.ma != 0 && r.mb != 0) {
            const std::uint32_t ra = find(r.a), rb = find(r.b);
            if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
        }
    }
    // Groups numbered in the order of their first joint; the joints sorted into them by a counting sort.
    constexpr std::uint32_t kNone = ~0u;
    std::vector<std::uint32_t>& group_of_root = m.mark_group;
    if (group_of_root.size() < body_slots) group_of_root.assign(body_slots, kNone);
    struct Unset {  // the scratch back to unset however this ends (a throw included)
        std::vector<std::uint32_t>& of_root;
        const std::vector<std::uint32_t>& roots;
        ~Unset() {
            for (std::uint32_t b : roots) of_root[b] = ~0u;
        }
    } unset{group_of_root, m.moving};
    std::vector<std::uint32_t>& group = m.joint_group;  // per active joint
    group.clear();
    std::uint32_t groups_found = 0;
    for (std::uint32_t s : m.active) {
        const JointRows& r = m.rows[s];
        const std::uint32_t root = find(r.ma != 0 ? r.a : r.b);
        if (group_of_root[root] == kNone) group_of_root[root] = groups_found++;
        group.push_back(group_of_root[root]);
    }
    std::vector<std::uint32_t>& count = m.group_start;
    bucket_sort(m.active.size(), groups_found, [&](std::size_t k) { return group[k]; }, count, m.group_joints, m.group_fill);
    for (std::uint32_t& k : m.group_joints) k = m.active[k];  // the joints' slots
    const std::size_t groups = groups_found;
    while (m.group_points.size() < groups) m.group_points.push_back(std::make_unique<JointPointSolve>());
    if (m.body_zero.size() < body_slots) m.body_zero.resize(body_slots, 0);
    // Each group's point solve, on the workers (they share no movable body, the scratch's only entries
    // a prepare touches).
    for_ranges(groups > 1 ? m.region : nullptr, groups, 1, [&](std::size_t first, std::size_t last) {
        for (std::size_t g = first; g < last; ++g)
            m.group_points[g]->prepare(m.joints, m.rows, m.group_joints.data() + count[g], count[g + 1] - count[g], m.body_zero);
    });
    m.point_generation_start.assign(1, 0);
    m.point_generations.clear();
    for (std::size_t g = 0; g < groups; ++g) {
        for (std::uint32_t s : m.group_points[g]->slots()) m.point_generations.push_back(m.slots.generation(s));
        m.point_generation_start.push_back(std::uint32_t(m.point_generations.size()));
    }
}

void JointSet::prepare(RigidSystem& sys, const RowStep& step) {
    Impl& m = *impl_;
    const RigidSystem::State& st = sys.state();
    const Real h = step.h;
    const RowSoftness& softness = step.softness;
    const bool warm = step.warm_starting;
    m.h = h;
    m.active.clear();
    m.moving.clear();
    m.group_start.clear();
    m.group_joints.clear();
    m.region = nullptr;
    if (m.slots.count() == 0) return;  // nothing to prepare (and no per-body scratch to clear)
    // How position error is removed this step:
    // - Soft (a sub-stepping solver asked for soft joints): Catto 2011 soft rows in its biased passes.
    // - Projection (sequential impulses with split impulses and warm starting, the default): the velocity
    //   passes carry no position bias, and finish() projects the positions afterwards (non-linear
    //   Gauss-Seidel on pseudo-velocities, as Box2D v2 and Jolt correct joints; the joints' analogue of
    //   split impulses). A Baumgarte bias inside warm-started, unconverged velocity iterations turns
    //   position error into velocity that the warm start feeds back: a 20-link chain at 10 iterations
    //   never comes to rest with beta = 0.2 (it keeps ~2 J of jitter), while the projection adds no
    //   energy. The projection corrects the whole error (capped at kMaxProjection per sweep, as Box2D
    //   v2 caps its position correction): it moves no velocity, so there is nothing to under-relax, and
    //   a fraction beta = 0.2 leaves the slow stretch mode of a long chain at millimetres for seconds.
    // - Baumgarte (RigidSolverKind::Baumgarte, warm starting off, and the Newton solver, which does
    //   not warm start): the bias -(beta/h) C in the biased velocity passes. Without warm starting the
    //   velocity iterations cannot carry a long chain's load, and only the bias holds it up.
    if (softness.soft)
        m.correction = Impl::Correction::Soft;
    else if (softness.projection)
        m.correction = Impl::Correction::Projection;
    else
        m.correction = Impl::Correction::Baumgarte;
    // Soft joints are capped at half the (sub-)step rate: Box2D v3 makes them twice its contact
    // stiffness, which it caps at a quarter of the sub-step rate. Stiffer springs than the step can
    // resolve only wobble (a 20-link chain at 2 sub-steps and 120 Hz never rests; at 60 Hz it does).
    const Real joint_hertz = std::min(softness.hertz, Real(0.5) / h);
    m.velocity_bias = m.correction == Impl::Correction::Soft ? make_soft(joint_hertz, softness.damping_ratio, h)
                      : m.correction == Impl::Correction::Baumgarte ? Softness{softness.baumgarte / h, 1, 0}
                                                                     : Softness{};
    m.projection_bias = Softness{1 / h, 1, 0, kMaxProjection};
    // Solved exactly, the point blocks are stable at any stiffness (rigid/joint_point_solve.hpp); they
    // take the joints' cap, half the sub-step rate, where the sweeps needed Box2D v3's twice the contact
    // stiffness (a 20-link chain with a 100:1 end: 14.5 mm of stretch at 120 Hz swept, 3.4 mm at 150 Hz
    // solved exactly; 1.3 mm at 300 Hz, 0.9 mm at 600 Hz).
    m.point_bias = make_soft(kPointHertzPerRate / h, softness.damping_ratio, h);
    m.mark.assign(st.x.size(), 0);
    for (std::uint32_t s = 0; s < m.joints.size(); ++s) {
        if (!m.slots.alive(s)) continue;
        JointData& j = m.joints[s];
        JointRows& r = m.rows[s];
        r = JointRows{};
        r.a = j.def.body_a.index;
        r.b = j.def.body_b.index;
        r.ma = st.inv_mass[r.a];
        r.mb = st.inv_mass[r.b];
        // A joint of a disabled body is out with it (RigidSystem::set_enabled).
        if (!sys.slot_enabled(r.a) || !sys.slot_enabled(r.b)) continue;
        // Both ends immovable this step (static, kinematic or asleep): nothing to solve; the impulses are
        // kept for when the bodies wake.
        if (r.ma == 0 && r.mb == 0) continue;
        r.ia = st.inv_inertia_world[r.a];
        r.ib = st.inv_inertia_world[r.b];
        if (!softness.soft) bound_mass_ratio(r, sys.settings().contact_mass_ratio);
        r.h = h;
        r.inv_h = 1 / h;
        r.spring = make_soft(j.def.frequency, j.def.damping_ratio, h);
        r.max_motor_impulse = j.def.max_motor_force * h;
        // A sub-stepping solver moves the bodies between passes: refresh the point block's mass then
        // (Catto, Solver2D: a stale pivot mass adds jitter to ragdolls).
        r.fresh_point_mass = softness.soft;
        JointImpulses& acc = j.impulses;
        if (!warm) acc.clear();
        if (!j.def.enable_motor) acc.motor = 0;
        if (!j.def.enable_limit) acc.lower = acc.upper = 0;
        switch (j.def.type) {
            case JointType::Ball: prepare_ball(j, r, st); break;
            case JointType::Hinge: prepare_hinge(j, r, st); break;
            case JointType::Slider: prepare_slider(j, r, st); break;
            case JointType::Distance: prepare_distance(j, r, st); break;
            case JointType::Fixed: prepare_fixed(j, r, st); break;
        }
        m.active.push_back(s);
        for (std::uint32_t b : {r.a, r.b})
            if (st.inv_mass[b] != 0 && !m.mark[b]) {
                m.mark[b] = 1;
                m.moving.push_back(b);
            }
    }
    // The soft step solves the point blocks exactly after its sweeps, group by group. The other solvers
    // keep their sweeps alone (not tried with the exact solve): their rows see bounded mass ratios
    // (bound_mass_ratio), which the exact solve would take as the bodies' masses.
    if (m.correction == Impl::Correction::Soft) {
        m.region = &sys.region();
        group_joints(m, st.x.size());
    }
    if (m.correction == Impl::Correction::Projection) {
        m.pv.assign(st.x.size(), Vec3::Zero());
        m.pw.assign(st.x.size(), Vec3::Zero());
    }
}

namespace {

void warm_start_joint(const JointData& j, const JointRows& r, const RigidSystem::State& st, RowPass& pass) {
    switch (j.def.type) {
        case JointType::Ball: warm_start_ball(j, j.impulses, r, st, pass); break;
        case JointType::Hinge: warm_start_hinge(j, j.impulses, r, st, pass); break;
        case JointType::Slider: warm_start_slider(j, j.impulses, r, st, pass); break;
        case JointType::Distance: warm_start_distance(j, j.impulses, r, st, pass); break;
        case JointType::Fixed: warm_start_fixed(j, j.impulses, r, st, pass); break;
    }
}

void solve_joint(const JointData& j, JointImpulses& acc, const JointRows& r, const RigidSystem::State& st,
                 RowPass& pass) {
    switch (j.def.type) {
        case JointType::Ball: solve_ball(j, acc, r, st, pass); break;
        case JointType::Hinge: solve_hinge(j, acc, r, st, pass); break;
        case JointType::Slider: solve_slider(j, acc, r, st, pass); break;
        case JointType::Distance: solve_distance(j, acc, r, st, pass); break;
        case JointType::Fixed: solve_fixed(j, acc, r, st, pass); break;
    }
}

}  // namespace

void JointSet::warm_start(const RigidSystem& sys, const BodyVelocities& vel) {
    Impl& m = *impl_;
    const RigidSystem::State& st = sys.state();
    const RowPass pass{vel, Softness{}, true};
    const auto warm_start_joints = [&](const std::uint32_t* joints, std::size_t count) {
        RowPass p = pass;
        for (std::size_t i = 0; i < count; ++i)
            if (m.slots.alive(joints[i])) warm_start_joint(m.joints[joints[i]], m.rows[joints[i]], st, p);  // skip joints destroyed since prepare()
    };
    const std::size_t groups = m.group_count();
    if (groups < 2) {
        warm_start_joints(m.active.data(), m.active.size());
        return;
    }
    // The soft step's groups share no movable body: each on its own, in slot order.
    for_ranges(m.region, groups, 1, [&](std::size_t first, std::size_t last) {
        warm_start_joints(m.group_joints.data() + m.group_start[first], m.group_start[last] - m.group_start[first]);
    });
}

void JointSet::positions_advanced(const RigidSystem& sys, const BodyVelocities&, Real) {
    // The soft step turned the bodies between its passes (RigidSystem::follow_turn): the rows' inverse
    // inertia turns with them, as their arms do (PairPose reads the orientation now). The other solvers
    // keep their prepared (mass-ratio bounded) values: they move bodies once, after their last pass.
    Impl& m = *impl_;
    if (m.correction != Impl::Correction::Soft) return;
    const RigidSystem::State& st = sys.state();
    const std::size_t groups = m.group_count();
    for_ranges(groups > 1 ? m.region : nullptr, m.active.size(), 256, [&](std::size_t first, std::size_t last) {
        for (std::size_t k = first; k < last; ++k) {
            JointRows& r = m.rows[m.active[k]];
            r.ia = st.inv_inertia_world[r.a];
            r.ib = st.inv_inertia_world[r.b];
        }
    });
}

void JointSet::solve(const RigidSystem& sys, const BodyVelocities& vel, bool use_bias) {
    Impl& m = *impl_;
    const RigidSystem::State& st = sys.state();
    const RowPass pass{vel, use_bias ? m.velocity_bias : Softness{}, true};
    if (m.correction != Impl::Correction::Soft) {
        RowPass p = pass;
        for (std::uint32_t s : m.active)
            if (m.slots.alive(s)) solve_joint(m.joints[s], m.joints[s].impulses, m.rows[s], st, p);
        return;
    }
    const Softness point_bias = use_bias ? m.point_bias : Softness{};
    const auto solve_groups = [&](std::size_t first, std::size_t last) {
        RowPass p = pass;
        for (std::size_t g = first; g < last; ++g) {
            const std::uint32_t* joints = m.group_joints.data() + m.group_start[g];
            const std::uint32_t count = m.group_start[g + 1] - m.group_start[g];
            for (int k = 0; k < kSoftSweeps; ++k)
                for (std::uint32_t i = 0; i < count; ++i)
                    if (m.slots.alive(joints[i])) solve_joint(m.joints[joints[i]], m.joints[joints[i]].impulses, m.rows[joints[i]], st, p);
            JointPointSolve& points = *m.group_points[g];
            const std::vector<std::uint32_t>& exact = points.slots();
            bool current = !exact.empty();
            const std::uint32_t* generation = m.point_generations.data() + m.point_generation_start[g];
            for (std::size_t k = 0; k < exact.size() && current; ++k)  // a joint destroyed (or its slot reused)
                current = m.slots.alive(exact[k]) && m.slots.generation(exact[k]) == generation[k];  // within the step: sweeps alone
            if (current) points.solve(m.joints, m.rows, st, p, point_bias);
        }
    };
    const std::size_t groups = m.group_count();
    for_ranges(groups > 1 ? m.region : nullptr, groups, 1, solve_groups);
}

void JointSet::project_positions(RigidSystem& sys) {
    // Non-linear Gauss-Seidel on positions (Box2D v2, Jolt): each sweep solves every joint once on
    // pseudo-velocities that start at zero, with the Baumgarte fraction of the CURRENT error as target,
    // then moves the bodies by h times them, so the next sweep sees the corrected error. Velocities are
    // untouched: no energy is added.
    Impl& m = *impl_;
    RigidSystem::State& st = sys.state();
    const Real h = m.h;
    for (int sweep = 0; sweep < kProjectionSweeps; ++sweep) {
        for (std::uint32_t b : m.moving) {
            m.pv[b].setZero();
            m.pw[b].setZero();
        }
        RowPass pass{BodyVelocities::of_arrays(m.pv, m.pw), m.projection_bias, false};
        for (std::uint32_t s : m.active) {
            if (!m.slots.alive(s)) continue;
            JointImpulses acc;  // pseudo-impulses live for one sweep
            solve_joint(m.joints[s], acc, m.rows[s], st, pass);
        }
        for (std::uint32_t b : m.moving) {
            st.x[b] += h * m.pv[b];
            st.q[b] = integrate_rotation(st.q[b], m.pw[b], h);
        }
    }
}

const std::vector<JointId>& JointSet::broken() const { return impl_->broken; }

void JointSet::finish(RigidSystem& sys, Real /*h*/) {
    Impl& m = *impl_;
    m.broken.clear();
    if (!(m.h > 0) || m.active.empty()) return;  // nothing prepared
    if (m.correction == Impl::Correction::Projection) project_positions(sys);
    // Impulses are per prepared (sub-)step, so the force is impulse / that step's length.
    const Real inv_h = 1 / m.h;
    for (std::uint32_t s : m.active) {
        if (!m.slots.alive(s)) continue;
        JointData& j = m.joints[s];
        const JointRows& r = m.rows[s];
        const JointImpulses& acc = j.impulses;
        const Real axial = acc.motor + acc.lower - acc.upper;
        Vec3 f = Vec3::Zero(), t = Vec3::Zero();
        switch (j.def.type) {
            case JointType::Ball: f = acc.point; break;
            case JointType::Hinge:
                f = acc.point;
                t = acc.angular.x() * r.dir[1] + acc.angular.y() * r.dir[2] + axial * r.dir[0];
                break;
            case JointType::Slider:
                f = axial * r.dir[0] + acc.pair[0] * r.dir[1] + acc.pair[1] * r.dir[2];
                t = acc.angular;
                break;
            case JointType::Distance: f = acc.axial * r.dir[0]; break;
            case JointType::Fixed:
                f = acc.point;
                t = acc.angular;
                break;
        }
        j.reaction_force = inv_h * f;
        j.reaction_torque = inv_h * t;
        const Real limit = j.def.break_force;
        if (limit > 0 && (j.reaction_force.norm() > limit || j.reaction_torque.norm() > limit)) {
            m.broken.push_back({s, m.slots.generation(s)});
            m.remove(s);
        }
    }
    m.active.clear();  // finished: a second finish() without a prepare() does nothing
}

}  // namespace sinew
