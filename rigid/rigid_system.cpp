#include "rigid/rigid_system.hpp"

#include <algorithm>
#include <cstring>

#include "engine/core/mass_properties.hpp"
#include "rigid/joint_set.hpp"
#include "rigid/rigid_solver.hpp"
#include "engine/core/format.hpp"

namespace sinew {

namespace {
std::uint64_t pair_key(std::uint32_t a, std::uint32_t b) { return (std::uint64_t(a) << 32) | b; }
bool manifold_less(const ContactManifold& x, const ContactManifold& y) {
    std::uint64_t kx = pair_key(x.body_a, x.body_b), ky = pair_key(y.body_a, y.body_b);
    return kx != ky ? kx < ky : x.manifold.sub_key < y.manifold.sub_key;
}
}  // namespace

const char* body_type_name(BodyType t) {
    switch (t) {
        case BodyType::Static: return "static";
        case BodyType::Kinematic: return "kinematic";
        case BodyType::Dynamic: return "dynamic";
    }
    return "unknown";
}

const char* rigid_solver_name(RigidSolverKind k) {
    switch (k) {
        case RigidSolverKind::SoftStep: return "soft_step";
        case RigidSolverKind::SplitImpulse: return "split_impulse";
        case RigidSolverKind::Baumgarte: return "baumgarte";
        case RigidSolverKind::Newton: return "newton";
        default: return "unknown";
    }
}

bool parse_rigid_solver(const char* name, RigidSolverKind& out) {
    for (int k = 0; k < int(RigidSolverKind::Count); ++k)
        if (std::strcmp(name, rigid_solver_name(RigidSolverKind(k))) == 0) {
            out = RigidSolverKind(k);
            return true;
        }
    return false;
}

RigidSystem::RigidSystem(const RigidSettings& settings) : joints_(std::make_unique<JointSet>()) {
    row_sources_.push_back(joints_.get());
    set_settings(settings);
}

RigidSystem::~RigidSystem() = default;

void RigidSystem::set_settings(const RigidSettings& s) {
    auto bad = [](const std::string& field, const std::string& why) {
        throw RigidError("rigid settings: " + field + " " + why);
    };
    if (!is_finite(s.gravity)) bad("gravity", "must be finite");
    if (s.velocity_iterations < 1 || s.velocity_iterations > 1000)
        bad("velocity_iterations", "must be in [1, 1000], got " + std::to_string(s.velocity_iterations));
    if (!(s.baumgarte >= 0 && s.baumgarte <= 1)) bad("baumgarte", "must be in [0, 1], got " + to_text(s.baumgarte));
    if (!(s.linear_slop >= 0 && s.linear_slop < 1)) bad("linear_slop", "must be in [0, 1) m, got " + to_text(s.linear_slop));
    if (!(s.restitution_threshold >= 0) || !is_finite(s.restitution_threshold))
        bad("restitution_threshold", "must be finite and >= 0, got " + to_text(s.restitution_threshold));
    if (!(s.contact_margin > 0 && s.contact_margin < 1))
        bad("contact_margin", "must be in (0, 1) m, got " + to_text(s.contact_margin));
    if (!(s.max_correction_velocity > 0) || !is_finite(s.max_correction_velocity))
        bad("max_correction_velocity", "must be finite and > 0, got " + to_text(s.max_correction_velocity));
    if (!(s.sleep_linear_velocity >= 0) || !(s.sleep_angular_velocity >= 0) || !(s.sleep_time >= 0) ||
        !is_finite(s.sleep_time))
        bad("sleep thresholds", "must be finite and >= 0");
    if (s.newton_collision_iterations < 0 || s.newton_contact_iterations < 1)
        bad("newton iterations", "must be >= 0 (collision) and >= 1 (contact)");
    if (!(s.newton_projection_fraction >= 0 && s.newton_projection_fraction <= 1))
        bad("newton projection_fraction", "must be in [0, 1], got " + to_text(s.newton_projection_fraction));
    if (s.substeps < 0 || s.substeps > 64)
        bad("substeps", "must be in [0, 64] (0 = velocity_iterations / 2), got " + std::to_string(s.substeps));
    if (!(s.contact_hertz > 0) || !is_finite(s.contact_hertz)) bad("contact_hertz", "must be finite and > 0");
    if (!(s.contact_damping_ratio >= 0) || !is_finite(s.contact_damping_ratio))
        bad("contact_damping_ratio", "must be finite and >= 0");
    if (!(s.contact_push_velocity > 0) || !is_finite(s.contact_push_velocity))
        bad("contact_push_velocity", "must be finite and > 0");
    if (!(s.solver < RigidSolverKind::Count)) bad("solver", "is not a RigidSolverKind (" + std::to_string(int(s.solver)) + ")");
    // The solver object follows the method (split impulses and Baumgarte share one); impulses cached by one
    // are not meaningful to another.
    auto method = [](RigidSolverKind k) { return k == RigidSolverKind::Baumgarte ? RigidSolverKind::SplitImpulse : k; };
    if (!solver_ || method(s.solver) != method(settings_.solver)) {
        switch (s.solver) {
            case RigidSolverKind::Newton: solver_ = make_newton_impulse_solver(); break;
            case RigidSolverKind::SoftStep: solver_ = make_soft_step_solver(); break;
            default: solver_ = make_sequential_impulse_solver(); break;
        }
        for (ContactManifold& c : contacts_)
            for (int k = 0; k < c.manifold.count; ++k) {
                c.manifold.points[k].normal_impulse = 0;
                c.manifold.points[k].tangent_impulse[0] = c.manifold.points[k].tangent_impulse[1] = 0;
            }
    }
    settings_ = s;
}

// ---- bodies ---------------------------------------------------------------------------------------

BodyId RigidSystem::create_body(const BodyDef& def) {
    // Validate everything before touching any array, so a bad definition changes nothing.
    auto bad = [](const std::string& why) { throw RigidError("body definition: " + why); };
    if (!is_finite(def.pose.p)) bad("position must be finite");
    if (!is_finite(def.pose.q) || def.pose.q.norm() < Real(1e-6)) bad("rotation must be a finite non-zero quaternion");
    if (!is_finite(def.linear_velocity) || !is_finite(def.angular_velocity)) bad("velocities must be finite");
    if (!is_finite(def.mass) || def.mass < 0) bad("mass must be finite and >= 0 (0 = from density), got " + to_text(def.mass));
    const Material& m = def.material;
    if (!is_finite(m.friction) || m.friction < 0) bad("friction must be finite and >= 0, got " + to_text(m.friction));
    if (!(m.restitution >= 0 && m.restitution <= 1)) bad("restitution must be in [0, 1], got " + to_text(m.restitution));
    if (!is_finite(def.linear_damping) || def.linear_damping < 0 || !is_finite(def.angular_damping) ||
        def.angular_damping < 0)
        bad("damping must be finite and >= 0");
    if (!is_finite(def.gravity_scale)) bad("gravity_scale must be finite");
    if (def.type != BodyType::Static && !def.shape.can_be_dynamic())
        bad(std::string("a ") + shape_type_name(def.shape.type) + " can only belong to a static body");

    // A rotation that is unit to rounding is kept as given, so that a saved world's comes back bit for
    // bit (normalising it again may move it by an ulp).
    const bool unit = std::abs(def.pose.q.squaredNorm() - 1) <= 4 * kEpsilon;
    Transform pose{def.pose.p, unit ? def.pose.q : Quat(def.pose.q.normalized())};
    MassProperties mp;
    if (def.type == BodyType::Dynamic) {
        try {
            mp = def.mass > 0 ? mass_properties_for_mass(def.shape, def.mass)
                              : compute_mass_properties(def.shape, m.density);
        } catch (const ShapeError& e) {
            bad(e.what());
        }
        if (!(mp.mass > 0) || !is_finite(mp.mass)) bad("mass must be > 0, got " + to_text(mp.mass));
    }
    Aabb box = def.shape.bounds(pose);
    if (!is_finite(box.lo) || !is_finite(box.hi)) bad("shape bounds are not finite");

    const Slots::Acquired got = slots_.acquire();
    const std::uint32_t slot = got.index;
    if (got.fresh) {
        type_.emplace_back();
        shape_.emplace_back();
        material_.emplace_back();
        mass_.push_back(0);
        body_inv_mass_.push_back(0);
        inv_inertia_local_.emplace_back();
        local_com_.emplace_back();
        linear_damping_.push_back(0);
        angular_damping_.push_back(0);
        gravity_scale_.push_back(1);
        allow_sleep_.push_back(true);
        awake_.push_back(true);
        sleep_timer_.push_back(0);
        user_data_.push_back(0);
        proxy_.push_back(DynamicTree::kNull);
        island_.push_back(0);
        state_.x.emplace_back();
        state_.q.emplace_back();
        state_.v.emplace_back();
        state_.w.emplace_back();
        state_.inv_mass.push_back(0);
        state_.inv_inertia_world.emplace_back();
        state_.force.emplace_back();
        state_.torque.emplace_back();
    }
    const bool dynamic = def.type == BodyType::Dynamic;
    type_[slot] = def.type;
    shape_[slot] = def.shape;
    material_[slot] = def.material;
    mass_[slot] = dynamic ? mp.mass : 0;
    body_inv_mass_[slot] = dynamic ? 1 / mp.mass : 0;
    inv_inertia_local_[slot] = dynamic ? Mat3(mp.inertia.inverse()) : Mat3::Zero();
    local_com_[slot] = dynamic ? mp.center : Vec3::Zero();
    linear_damping_[slot] = def.linear_damping;
    angular_damping_[slot] = def.angular_damping;
    gravity_scale_[slot] = def.gravity_scale;
    allow_sleep_[slot] = def.allow_sleep;
    awake_[slot] = def.type != BodyType::Static;
    sleep_timer_[slot] = 0;
    user_data_[slot] = def.user_data;
    island_[slot] = slot;
    state_.q[slot] = pose.q;
    state_.x[slot] = pose.apply(local_com_[slot]);
    state_.v[slot] = def.type == BodyType::Static ? Vec3::Zero() : def.linear_velocity;
    state_.w[slot] = def.type == BodyType::Static ? Vec3::Zero() : def.angular_velocity;
    state_.inv_mass[slot] = body_inv_mass_[slot];
    Mat3 r = pose.q.toRotationMatrix();
    state_.inv_inertia_world[slot] = r * inv_inertia_local_[slot] * r.transpose();
    state_.force[slot].setZero();
    state_.torque[slot].setZero();
    proxy_[slot] = tree_.create(box, slot, settings_.contact_margin);
    return {slot, got.generation};
}

void RigidSystem::check(BodyId id, const char* where) const {
    if (id.is_null()) throw RigidError(std::string(where) + ": body id is null");
    if (!slots_.valid(id.index, id.generation))
        throw RigidError(std::string(where) + ": stale or unknown body id (index " + std::to_string(id.index) +
                         ", generation " + std::to_string(id.generation) + ")");
}

bool RigidSystem::valid(BodyId id) const { return slots_.valid(id.index, id.generation); }

void RigidSystem::destroy_body(BodyId id) {
    check(id, "destroy_body");
    std::uint32_t s = id.index;
    // Bodies that rested on this one must not be left floating asleep.
    for (const ContactManifold& c : contacts_)
        if (c.body_a == s || c.body_b == s) {
            wake_island(c.body_a);
            wake_island(c.body_b);
        }
    joints_->destroy_attached(s);
    tree_.destroy(proxy_[s]);
    proxy_[s] = DynamicTree::kNull;
    shape_[s] = Shape{};
    state_.inv_mass[s] = 0;
    state_.v[s].setZero();
    state_.w[s].setZero();
    auto gone = [s](const ContactManifold& c) { return c.body_a == s || c.body_b == s; };
    contacts_.erase(std::remove_if(contacts_.begin(), contacts_.end(), gone), contacts_.end());
    prev_contacts_.erase(std::remove_if(prev_contacts_.begin(), prev_contacts_.end(), gone), prev_contacts_.end());
    slots_.release(s);
}

std::vector<BodyId> RigidSystem::bodies() const {
    std::vector<BodyId> out;
    out.reserve(slots_.count());
    for (std::uint32_t i = 0; i < slots_.size(); ++i)
        if (slots_.alive(i)) out.push_back({i, slots_.generation(i)});
    return out;
}

Transform RigidSystem::origin_transform(std::uint32_t s) const {
    return {state_.x[s] - state_.q[s] * local_com_[s], state_.q[s]};
}

Transform RigidSystem::predicted_transform(std::uint32_t s, Real t) const {
    const Quat q = integrate_rotation(state_.q[s], state_.w[s], t);
    return {state_.x[s] + t * state_.v[s] - q * local_com_[s], q};
}

Transform RigidSystem::transform(BodyId id) const {
    check(id, "transform");
    return origin_transform(id.index);
}

void RigidSystem::set_transform(BodyId id, const Transform& xf) {
    check(id, "set_transform");
    if (!is_finite(xf.p) || !is_finite(xf.q) || xf.q.norm() < Real(1e-6))
        throw RigidError("set_transform: transform must be finite with a non-zero quaternion");
    std::uint32_t s = id.index;
    state_.q[s] = xf.q.normalized();
    state_.x[s] = xf.p + state_.q[s] * local_com_[s];
    tree_.move(proxy_[s], shape_[s].bounds(origin_transform(s)), Vec3::Zero(), settings_.contact_margin);
    wake_island(s);
}

Vec3 RigidSystem::linear_velocity(BodyId id) const {
    check(id, "linear_velocity");
    return state_.v[id.index];
}

Vec3 RigidSystem::angular_velocity(BodyId id) const {
    check(id, "angular_velocity");
    return state_.w[id.index];
}

void RigidSystem::set_velocity(BodyId id, const Vec3& v, const Vec3& w) {
    check(id, "set_velocity");
    if (!is_finite(v) || !is_finite(w)) throw RigidError("set_velocity: velocities must be finite");
    if (type_[id.index] == BodyType::Static) return;
    state_.v[id.index] = v;
    state_.w[id.index] = w;
    wake_island(id.index);
}

void RigidSystem::apply_force(BodyId id, const Vec3& f, const Vec3& p) {
    check(id, "apply_force");
    if (!is_finite(f) || !is_finite(p)) throw RigidError("apply_force: force and point must be finite");
    std::uint32_t s = id.index;
    if (type_[s] != BodyType::Dynamic) return;
    state_.force[s] += f;
    state_.torque[s] += (p - state_.x[s]).cross(f);
    wake_island(s);
}

void RigidSystem::apply_impulse(BodyId id, const Vec3& j, const Vec3& p) {
    check(id, "apply_impulse");
    if (!is_finite(j) || !is_finite(p)) throw RigidError("apply_impulse: impulse and point must be finite");
    std::uint32_t s = id.index;
    if (type_[s] != BodyType::Dynamic) return;
    wake_island(s);
    state_.v[s] += body_inv_mass_[s] * j;
    Mat3 r = state_.q[s].toRotationMatrix();
    state_.w[s] += r * inv_inertia_local_[s] * r.transpose() * (p - state_.x[s]).cross(j);
}

const std::vector<JointId>& RigidSystem::broken_joints() const { return joints_->broken(); }

void RigidSystem::add_rows(ConstraintRows* rows) {
    if (!rows) throw RigidError("add_rows: rows is null");
    if (std::find(row_sources_.begin(), row_sources_.end(), rows) != row_sources_.end())
        throw RigidError("add_rows: this source of rows was already added");
    row_sources_.push_back(rows);
}

void RigidSystem::remove_rows(ConstraintRows* rows) {
    if (rows == joints_.get()) return;  // the joints stay
    row_sources_.erase(std::remove(row_sources_.begin(), row_sources_.end(), rows), row_sources_.end());
}

JointId RigidSystem::create_joint(const JointDef& def) {
    JointId id = joints_->create(def, *this);
    if (valid(def.body_a)) wake_island(def.body_a.index);
    if (valid(def.body_b)) wake_island(def.body_b.index);
    return id;
}

void RigidSystem::destroy_joint(JointId id) {
    if (!joints_->valid(id)) throw RigidError("destroy_joint: stale or unknown joint id");
    const JointDef d = joints_->def(id);
    joints_->destroy(id);
    if (valid(d.body_a)) wake_island(d.body_a.index);
    if (valid(d.body_b)) wake_island(d.body_b.index);
}

BodyType RigidSystem::type(BodyId id) const { check(id, "type"); return type_[id.index]; }
Real RigidSystem::mass(BodyId id) const { check(id, "mass"); return mass_[id.index]; }
Real RigidSystem::linear_damping(BodyId id) const { check(id, "linear_damping"); return linear_damping_[id.index]; }
Real RigidSystem::angular_damping(BodyId id) const { check(id, "angular_damping"); return angular_damping_[id.index]; }
Real RigidSystem::gravity_scale(BodyId id) const { check(id, "gravity_scale"); return gravity_scale_[id.index]; }
bool RigidSystem::allow_sleep(BodyId id) const { check(id, "allow_sleep"); return allow_sleep_[id.index]; }
const Shape& RigidSystem::shape(BodyId id) const { check(id, "shape"); return shape_[id.index]; }
const Material& RigidSystem::material(BodyId id) const { check(id, "material"); return material_[id.index]; }
void RigidSystem::set_material(BodyId id, const Material& m) {
    check(id, "set_material");
    if (!(std::isfinite(m.friction) && m.friction >= 0))
        throw RigidError("set_material: friction must be finite and >= 0, got " + to_text(m.friction));
    if (!(m.restitution >= 0 && m.restitution <= 1))
        throw RigidError("set_material: restitution must be in [0, 1], got " + to_text(m.restitution));
    material_[id.index].friction = m.friction;
    material_[id.index].restitution = m.restitution;
}
bool RigidSystem::awake(BodyId id) const { check(id, "awake"); return awake_[id.index]; }
void RigidSystem::wake(BodyId id) { check(id, "wake"); wake_island(id.index); }
std::uint64_t RigidSystem::user_data(BodyId id) const { check(id, "user_data"); return user_data_[id.index]; }

double RigidSystem::kinetic_energy() const {
    double e = 0;
    for (std::uint32_t s = 0; s < slots_.size(); ++s) {
        if (!slots_.alive(s) || type_[s] != BodyType::Dynamic) continue;
        Mat3 r = state_.q[s].toRotationMatrix();
        Mat3 inertia = r * inv_inertia_local_[s].inverse() * r.transpose();
        e += 0.5 * mass_[s] * state_.v[s].squaredNorm() + 0.5 * state_.w[s].dot(inertia * state_.w[s]);
    }
    return e;
}

Real RigidSystem::max_penetration() const {
    Real d = 0;
    for (const ContactManifold& c : contacts_)
        for (int i = 0; i < c.manifold.count; ++i) d = std::max(d, c.manifold.points[i].depth);
    return d;
}

bool RigidSystem::all_finite() const {
    for (std::uint32_t s = 0; s < slots_.size(); ++s)
        if (slots_.alive(s) && (!is_finite(state_.x[s]) || !is_finite(state_.q[s]) || !is_finite(state_.v[s]) ||
                          !is_finite(state_.w[s])))
            return false;
    return true;
}

// ---- stages -------------------------------------------------------------------------------------

void RigidSystem::run_stage(Stage stage, const StepContext& ctx) {
    switch (stage) {
        case Stage::IntegrateVelocities:
            unintegrated_time_ = ctx.h;
            prepare_mass_state();
            solver_->before_integrate_velocities(*this, ctx.h);
            if (!solver_->integrates_itself()) integrate_velocities(ctx.h);
            break;
        case Stage::DetectCollisions: detect_collisions(ctx.h); break;
        case Stage::SolveVelocities:
            solver_->solve_velocities(*this, ctx.h);
            unintegrated_time_ = solver_->unintegrated_time_after_solve(ctx.h);
            break;
        case Stage::IntegratePositions:
            integrate_positions(ctx.h);
            unintegrated_time_ = 0;
            break;
        default: break;
    }
}

void RigidSystem::prepare_mass_state() {
    const std::size_t n = slots_.size();
    for (std::size_t s = 0; s < n; ++s) {
        if (!(slots_.alive(s) && type_[s] == BodyType::Dynamic && awake_[s])) {
            // Static, kinematic and sleeping bodies are immovable in this step's solve.
            state_.inv_mass[s] = 0;
            state_.inv_inertia_world[s].setZero();
            continue;
        }
        Mat3 r = state_.q[s].toRotationMatrix();
        state_.inv_mass[s] = body_inv_mass_[s];
        state_.inv_inertia_world[s] = r * inv_inertia_local_[s] * r.transpose();
    }
}

void RigidSystem::integrate_velocities(Real h) {
    const std::size_t n = slots_.size();
    for (std::size_t s = 0; s < n; ++s) {
        if (state_.inv_mass[s] == 0) continue;
        Vec3 v = state_.v[s] + h * (gravity_scale_[s] * settings_.gravity + body_inv_mass_[s] * state_.force[s]);
        Vec3 w = state_.w[s] + h * (state_.inv_inertia_world[s] * state_.torque[s]);
        // Implicit damping factor 1/(1 + h c): unconditionally stable, as Box2D does.
        state_.v[s] = v / (1 + h * linear_damping_[s]);
        state_.w[s] = w / (1 + h * angular_damping_[s]);
    }
}

void RigidSystem::detect_collisions(Real h) {
    const Real margin = settings_.contact_margin;
    // Broad phase: refit proxies of moving bodies; resting ones stay inside their fat boxes for free.
    for (std::uint32_t s = 0; s < slots_.size(); ++s) {
        if (!slots_.alive(s) || type_[s] == BodyType::Static || !awake_[s]) continue;
        tree_.move(proxy_[s], shape_[s].bounds(origin_transform(s)), h * state_.v[s], margin);
    }
    // Candidate pairs change only when a fat box was re-inserted (or a body or joint came or went): a
    // resting scene keeps last step's sorted list (as Box2D keeps its pair set between moves).
    if (tree_.revision() != pairs_tree_revision_ || joints_->filter_revision() != pairs_filter_revision_) {
        pairs_tree_revision_ = tree_.revision();
        pairs_filter_revision_ = joints_->filter_revision();
        candidate_pairs_.clear();
        tree_.all_pairs(candidate_pairs_);
        pair_keys_.clear();
        for (const auto& [pa, pb] : candidate_pairs_) {
            std::uint32_t a = tree_.user_data(pa), b = tree_.user_data(pb);
            if (a > b) std::swap(a, b);
            if (type_[a] != BodyType::Dynamic && type_[b] != BodyType::Dynamic) continue;
            if (joints_->filters_pair(a, b)) continue;
            pair_keys_.push_back(pair_key(a, b));
        }
        std::sort(pair_keys_.begin(), pair_keys_.end());
    }

    // Each body's detection pose once per step (a body is in several pairs), with its rotation as a
    // matrix: carrying a cached manifold's points costs two rotations per point.
    const std::size_t slots = slots_.size();
    detect_xf_.resize(slots);
    detect_rot_.resize(slots);
    for (std::uint32_t s = 0; s < slots; ++s) {
        if (!slots_.alive(s)) continue;
        detect_xf_[s] = detection_transform(s, h);
        detect_rot_[s] = detect_xf_[s].q.toRotationMatrix();
    }

    std::swap(prev_contacts_, contacts_);
    contacts_.clear();
    std::size_t prev_i = 0;
    for (std::uint64_t key : pair_keys_) {
        std::uint32_t a = std::uint32_t(key >> 32), b = std::uint32_t(key & 0xFFFFFFFFu);
        // Advance the merge-join cursor to this pair's cached manifolds (both lists sorted by key).
        while (prev_i < prev_contacts_.size() && pair_key(prev_contacts_[prev_i].body_a, prev_contacts_[prev_i].body_b) < key)
            ++prev_i;
        std::size_t prev_end = prev_i;
        while (prev_end < prev_contacts_.size() && pair_key(prev_contacts_[prev_end].body_a, prev_contacts_[prev_end].body_b) == key)
            ++prev_end;
        const bool asleep_a = type_[a] == BodyType::Static || !awake_[a];
        const bool asleep_b = type_[b] == BodyType::Static || !awake_[b];
        if (asleep_a && asleep_b) {
            // Sleeping pair (seed 001 ch.2): not tested, but its contacts are kept so the island stays
            // connected and wakes as a whole.
            for (std::size_t i = prev_i; i < prev_end; ++i) contacts_.push_back(prev_contacts_[i]);
            continue;
        }
        const Transform& xa = detect_xf_[a];
        const Transform& xb = detect_xf_[b];
        const Mat3& rot_a = detect_rot_[a];
        const Mat3& rot_b = detect_rot_[b];
        const Transform relative = xa.inverse() * xb;
        if (prev_end > prev_i && can_reuse(prev_contacts_[prev_i].relative, relative)) {
            // Body-pair cache (as Jolt does): the pair moved as one within 1 mm and 0.5 degrees since
            // its manifold was computed, so the cached points are carried with the bodies instead of
            // running the narrow phase again. Points stay attached to A and B; the depth follows the
            // bodies' relative motion along the normal. Warm-start impulses are kept as they are.
            for (std::size_t i = prev_i; i < prev_end; ++i) {
                ContactManifold c = prev_contacts_[i];
                Manifold& m = c.manifold;
                m.normal = rot_a * c.normal_local_a;
                for (int k = 0; k < m.count; ++k) {
                    ContactPoint& p = m.points[k];
                    const Vec3 pa = rot_a * p.local_a + xa.p, pb = rot_b * p.local_b + xb.p;
                    p.position = Real(0.5) * (pa + pb);
                    p.depth = c.detected_depth[k] - (pb - pa).dot(m.normal);
                    if (!settings_.warm_starting) p.normal_impulse = p.tangent_impulse[0] = p.tangent_impulse[1] = 0;
                }
                contacts_.push_back(c);
            }
        } else {
            scratch_.clear();
            // Speculative margin grown by how far the pair can close this step, so a fast body gets its
            // contact before it penetrates (the solvers let it close exactly the gap).
            const Real closing = h * (state_.v[a].norm() + state_.v[b].norm());
            collide(shape_[a], xa, shape_[b], xb, margin + closing, scratch_);
            if (scratch_.empty()) continue;
            const std::size_t first = contacts_.size();
            add_fresh_manifolds(a, b, xa, xb, relative, prev_i, prev_end);
            // Pairs come in key order; collide() may return a pair's sub_keys unordered, so only this
            // pair's few manifolds need sorting to keep the list ordered for the next merge join.
            if (contacts_.size() - first > 1)
                std::sort(contacts_.begin() + std::ptrdiff_t(first), contacts_.end(), manifold_less);
        }
        // A sleeping body touched by an awake one wakes with its whole island.
        if (asleep_a != asleep_b) wake_island(asleep_a ? a : b);
    }
}

Transform RigidSystem::detection_transform(std::uint32_t s, Real h) const {
    if (!solver_->detects_at_candidate_poses() || type_[s] == BodyType::Static || !awake_[s])
        return origin_transform(s);
    // Guendelman 2003: contacts are found where the bodies would be after a step with the current
    // velocities, so the impulses act before the penetration happens.
    Quat q = integrate_rotation(state_.q[s], state_.w[s], h);
    Vec3 x = state_.x[s] + h * state_.v[s];
    return {x - q * local_com_[s], q};
}

bool RigidSystem::can_reuse(const Transform& cached, const Transform& now) const {
    const Real max_move = Real(1e-3);         // m
    const Real min_cos_half = Real(0.9999905); // cos(0.25 degree): 0.5 degree of relative rotation
    return (now.p - cached.p).squaredNorm() < max_move * max_move && std::abs(now.q.dot(cached.q)) > min_cos_half;
}

void RigidSystem::add_fresh_manifolds(std::uint32_t a, std::uint32_t b, const Transform& xa, const Transform& xb,
                                  const Transform& relative, std::size_t prev_i, std::size_t prev_end) {
    const Real match_dist2 = (2 * settings_.contact_margin) * (2 * settings_.contact_margin);
    Real friction = std::sqrt(material_[a].friction * material_[b].friction);
    Real restitution = std::max(material_[a].restitution, material_[b].restitution);
    for (Manifold& m : scratch_) {
        for (int k = 0; k < m.count; ++k) {
            ContactPoint& p = m.points[k];
            p.local_a = xa.apply_inverse(p.position);
            p.local_b = xb.apply_inverse(p.position);
        }
        // Warm starting: carry impulses from the cached manifold with the same sub_key, matching
        // points by feature id, else by proximity in A's local frame (seed 001 ch.5).
        if (settings_.warm_starting) {
            for (std::size_t i = prev_i; i < prev_end; ++i) {
                const Manifold& old = prev_contacts_[i].manifold;
                if (old.sub_key != m.sub_key) continue;
                for (int k = 0; k < m.count; ++k) {
                    ContactPoint& p = m.points[k];
                    int best = -1;
                    Real best_d2 = match_dist2;
                    for (int j = 0; j < old.count; ++j) {
                        if (old.points[j].feature_id == p.feature_id) {
                            best = j;
                            break;
                        }
                        Real d2 = (old.points[j].local_a - p.local_a).squaredNorm();
                        if (d2 < best_d2) {
                            best_d2 = d2;
                            best = j;
                        }
                    }
                    if (best >= 0) {
                        p.normal_impulse = old.points[best].normal_impulse;
                        p.tangent_impulse[0] = old.points[best].tangent_impulse[0];
                        p.tangent_impulse[1] = old.points[best].tangent_impulse[1];
                    }
                }
                break;
            }
        }
        ContactManifold c;
        c.body_a = a;
        c.body_b = b;
        c.friction = friction;
        c.restitution = restitution;
        c.manifold = m;
        c.relative = relative;
        c.normal_local_a = xa.q.conjugate() * m.normal;
        for (int k = 0; k < m.count; ++k) c.detected_depth[k] = m.points[k].depth;
        contacts_.push_back(c);
    }
}

void RigidSystem::integrate_positions(Real h) {
    const bool integrate = !solver_->integrates_itself();
    for (std::uint32_t s = 0; s < slots_.size(); ++s) {
        if (!slots_.alive(s) || type_[s] == BodyType::Static || !awake_[s]) continue;
        if (integrate) {
            state_.x[s] += h * state_.v[s];
            state_.q[s] = integrate_rotation(state_.q[s], state_.w[s], h);
        }
        state_.force[s].setZero();
        state_.torque[s].setZero();
    }
    if (integrate) {
        // The soft step tells the sources after each of its sub-steps; the others move once per step.
        const BodyVelocities vel = BodyVelocities::of_arrays(state_.v, state_.w);
        for (ConstraintRows* rows : row_sources_) rows->positions_advanced(*this, vel, h);
    }
    solver_->correct_positions(*this, h);
    for (ConstraintRows* rows : row_sources_) rows->finish(*this, h);
    if (settings_.sleeping) update_sleep(h);
}

// ---- islands and sleeping (seed 001 ch.2) -----------------------------------------------------------

std::uint32_t RigidSystem::find_root(std::uint32_t s) {
    while (island_[s] != s) {
        island_[s] = island_[island_[s]];  // path halving
        s = island_[s];
    }
    return s;
}

void RigidSystem::wake_island(std::uint32_t s) {
    if (type_[s] != BodyType::Dynamic) return;
    if (awake_[s]) {  // an awake body's island is awake (update_sleep keeps islands uniform)
        sleep_timer_[s] = 0;
        return;
    }
    // Islands are from the last update_sleep(); waking is rare, so a linear scan is fine.
    std::uint32_t root = find_root(s);
    for (std::uint32_t i = 0; i < slots_.size(); ++i)
        if (slots_.alive(i) && type_[i] == BodyType::Dynamic && !awake_[i] && find_root(i) == root) {
            awake_[i] = true;
            sleep_timer_[i] = 0;
            // Woken mid-step: it takes part in this step's solve with its real mass.
            Mat3 r = state_.q[i].toRotationMatrix();
            state_.inv_mass[i] = body_inv_mass_[i];
            state_.inv_inertia_world[i] = r * inv_inertia_local_[i] * r.transpose();
        }
}

void RigidSystem::update_sleep(Real h) {
    const std::size_t n = slots_.size();
    // Islands: union-find over contacts between two dynamic bodies (static bodies do not join islands).
    for (std::uint32_t s = 0; s < n; ++s) island_[s] = s;
    for (const ContactManifold& c : contacts_) {
        if (c.manifold.count == 0 || type_[c.body_a] != BodyType::Dynamic || type_[c.body_b] != BodyType::Dynamic)
            continue;
        std::uint32_t ra = find_root(c.body_a), rb = find_root(c.body_b);
        if (ra != rb) island_[std::max(ra, rb)] = std::min(ra, rb);
    }
    joints_->for_each_connection([&](std::uint32_t a, std::uint32_t b) {
        if (type_[a] != BodyType::Dynamic || type_[b] != BodyType::Dynamic) return;
        std::uint32_t ra = find_root(a), rb = find_root(b);
        if (ra != rb) island_[std::max(ra, rb)] = std::min(ra, rb);
    });
    const Real lin2 = settings_.sleep_linear_velocity * settings_.sleep_linear_velocity;
    const Real ang2 = settings_.sleep_angular_velocity * settings_.sleep_angular_velocity;
    // Per body: time spent below the thresholds. Per island: the minimum over its bodies.
    island_min_timer_.assign(n, kRealMax);
    island_awake_.assign(n, 0);
    for (std::uint32_t s = 0; s < n; ++s) {
        if (!slots_.alive(s) || type_[s] != BodyType::Dynamic) continue;
        if (awake_[s]) {
            if (!allow_sleep_[s] || state_.v[s].squaredNorm() > lin2 || state_.w[s].squaredNorm() > ang2)
                sleep_timer_[s] = 0;
            else
                sleep_timer_[s] += h;
        }
        std::uint32_t r = find_root(s);
        island_min_timer_[r] = std::min(island_min_timer_[r], awake_[s] ? sleep_timer_[s] : kRealMax);
        island_awake_[r] |= awake_[s] ? 1 : 0;
    }
    for (std::uint32_t s = 0; s < n; ++s) {
        if (!slots_.alive(s) || type_[s] != BodyType::Dynamic) continue;
        std::uint32_t r = find_root(s);
        if (island_awake_[r] && island_min_timer_[r] >= settings_.sleep_time) {
            awake_[s] = false;  // the whole island falls asleep together
            state_.v[s].setZero();
            state_.w[s].setZero();
        } else if (island_awake_[r] && !awake_[s]) {
            awake_[s] = true;   // joined an awake island: nothing may stay asleep in it (no floating)
            sleep_timer_[s] = 0;
        }
    }
}

}  // namespace sinew
