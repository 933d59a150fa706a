// The rigid system's body store: creating, validating and destroying bodies in slots, and reading and
// changing their state by handle.
#include "rigid/rigid_system.hpp"

#include "rigid/rigid_solver.hpp"

#include <algorithm>
#include <cmath>

#include "engine/core/format.hpp"
#include "engine/core/mass_properties.hpp"
#include "rigid/joint_set.hpp"

namespace sinew {

// ---- bodies ---------------------------------------------------------------------------------------

std::string velocity_problem(const Vec3& v, const Vec3& w) {
    if (!is_finite(v) || !is_finite(w)) return "velocities must be finite";
    // Issue 18: a finite but enormous velocity (FLT_MAX) turned the next step's positions non-finite.
    if (v.norm() > kMaxBodySpeed)
        return "linear velocity must be at most " + to_text(kMaxBodySpeed) + " m/s, got " + to_text(v.stableNorm());
    if (w.norm() > kMaxBodySpin)
        return "angular velocity must be at most " + to_text(kMaxBodySpin) + " rad/s, got " + to_text(w.stableNorm());
    return {};
}

BodyId RigidSystem::create_body(const BodyDef& def) {
    ++structure_revision_;  // a refused definition counts too: a revision is a hint to look again, never wrong
    // Validate everything before touching any array, so a bad definition changes nothing.
    auto bad = [](const std::string& why) { throw RigidError("body definition: " + why); };
    if (!is_finite(def.pose.p)) bad("position must be finite");
    if (!is_finite(def.pose.q) || def.pose.q.norm() < Real(1e-6)) bad("rotation must be a finite non-zero quaternion");
    const std::string speed_problem = velocity_problem(def.linear_velocity, def.angular_velocity);
    if (!speed_problem.empty()) bad(speed_problem);
    if (!is_finite(def.mass) || def.mass < 0) bad("mass must be finite and >= 0 (0 = from density), got " + to_text(def.mass));
    const Material& m = def.material;
    if (!is_finite(m.friction) || m.friction < 0) bad("friction must be finite and >= 0, got " + to_text(m.friction));
    if (!(m.restitution >= 0 && m.restitution <= 1)) bad("restitution must be in [0, 1], got " + to_text(m.restitution));
    if (!is_finite(def.linear_damping) || def.linear_damping < 0 || !is_finite(def.angular_damping) ||
        def.angular_damping < 0)
        bad("damping must be finite and >= 0");
    if (!is_finite(def.gravity_scale)) bad("gravity_scale must be finite");
    if (def.sensor && !def.shape.can_be_dynamic())
        bad(std::string("a sensor's shape must be a sphere, box, capsule, hull or compound, got a ") +
            shape_type_name(def.shape.type));
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
        if (mp.mass < kMinBodyMass || mp.mass > kMaxBodyMass)
            bad("mass must be in [" + to_text(kMinBodyMass) + ", " + to_text(kMaxBodyMass) + "] kg, got " +
                to_text(mp.mass) + (def.mass > 0 ? std::string() : " (density " + to_text(m.density) + " times the shape's volume)"));
    }
    Aabb box = def.shape.bounds(pose);
    if (!is_finite(box.lo) || !is_finite(box.hi)) bad("shape bounds are not finite");

    const Slots::Acquired got = slots_.acquire();
    const std::uint32_t slot = got.index;
    if (got.fresh) {
        type_.emplace_back();
        shape_.emplace_back();
        material_.emplace_back();
        filter_.emplace_back();
        sensor_.push_back(0);
        bullet_.push_back(0);
        enabled_.push_back(1);
        def_mass_.push_back(0);
        mass_.push_back(0);
        body_inv_mass_.push_back(0);
        inv_inertia_local_.emplace_back();
        inertia_local_.emplace_back();
        w_frame_.emplace_back();
        spherical_inertia_.push_back(0);
        local_com_.emplace_back();
        reshaped_.push_back(0);
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
    filter_[slot] = def.filter;
    sensor_[slot] = def.sensor ? 1 : 0;
    bullet_[slot] = def.bullet && def.type == BodyType::Dynamic ? 1 : 0;
    enabled_[slot] = 1;
    def_mass_[slot] = def.mass;
    if (def.sensor) sensor_slots_.insert(std::lower_bound(sensor_slots_.begin(), sensor_slots_.end(), slot), slot);
    ignored_changed_ = true;  // the pair list is rebuilt with this body's filter
    mass_[slot] = dynamic ? mp.mass : 0;
    body_inv_mass_[slot] = dynamic ? 1 / mp.mass : 0;
    widen_inv_mass_range(body_inv_mass_[slot]);
    inv_inertia_local_[slot] = dynamic ? Mat3(mp.inertia.inverse()) : Mat3::Zero();
    inertia_local_[slot] = dynamic ? mp.inertia : Mat3::Zero();
    {
        // Isotropic to 1e-6: the gyroscopic effect is below float's resolution of the spin.
        const Mat3& in = inertia_local_[slot];
        const Real k = in.trace() / 3;
        spherical_inertia_[slot] = (in - k * Mat3::Identity()).cwiseAbs().maxCoeff() <= Real(1e-6) * std::abs(k) ? 1 : 0;
    }
    local_com_[slot] = dynamic ? mp.center : Vec3::Zero();
    reshaped_[slot] = 0;
    linear_damping_[slot] = def.linear_damping;
    angular_damping_[slot] = def.angular_damping;
    gravity_scale_[slot] = def.gravity_scale;
    allow_sleep_[slot] = def.allow_sleep;
    awake_[slot] = def.type != BodyType::Static;
    sleep_timer_[slot] = 0;
    user_data_[slot] = def.user_data;
    island_[slot] = slot;
    state_.q[slot] = pose.q;
    w_frame_[slot] = pose.q;
    state_.x[slot] = pose.apply(local_com_[slot]);
    state_.v[slot] = def.type == BodyType::Static ? Vec3::Zero() : def.linear_velocity;
    state_.w[slot] = def.type == BodyType::Static ? Vec3::Zero() : def.angular_velocity;
    state_.inv_mass[slot] = body_inv_mass_[slot];
    Mat3 r = pose.q.toRotationMatrix();
    state_.inv_inertia_world[slot] = r * inv_inertia_local_[slot] * r.transpose();
    state_.force[slot].setZero();
    state_.torque[slot].setZero();
    // Where contain_non_finite puts it back should it blow up in the step it was created in (a reused
    // slot must not keep its former body's start pose).
    if (start_x_.size() <= slot) {
        start_x_.resize(std::size_t(slot) + 1, Vec3::Zero());
        start_q_.resize(std::size_t(slot) + 1, Quat::Identity());
    }
    start_x_[slot] = state_.x[slot];
    start_q_[slot] = state_.q[slot];
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
    ++structure_revision_;
    std::uint32_t s = id.index;
    wake_touching(s);  // bodies that rested on this one must not be left floating asleep
    joints_->destroy_attached(s);
    const auto names_s = [s](std::uint64_t key) { return std::uint32_t(key >> 32) == s || std::uint32_t(key) == s; };
    const auto kept = std::remove_if(ignored_pairs_.begin(), ignored_pairs_.end(), names_s);
    if (kept != ignored_pairs_.end()) {
        ignored_pairs_.erase(kept, ignored_pairs_.end());
        ignored_changed_ = true;
    }
    if (proxy_[s] != DynamicTree::kNull) tree_.destroy(proxy_[s]);  // a disabled body has none
    proxy_[s] = DynamicTree::kNull;
    bullet_[s] = 0;
    if (sensor_[s]) {
        sensor_[s] = 0;
        sensor_slots_.erase(std::lower_bound(sensor_slots_.begin(), sensor_slots_.end(), s));
    }
    shape_[s] = Shape{};
    state_.inv_mass[s] = 0;
    state_.v[s].setZero();
    state_.w[s].setZero();
    drop_contacts_of(s);
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
    w_frame_[s] = state_.q[s];  // the angular velocity is kept, not the angular momentum
    if (proxy_[s] != DynamicTree::kNull)
        tree_.move(proxy_[s], shape_[s].bounds(origin_transform(s)), Vec3::Zero(), settings_.contact_margin);
    wake_island(s);
}

void RigidSystem::reshape(BodyId id, const Shape& shape, Real mass, const Mat3& inertia) {
    check(id, "reshape");
    const std::uint32_t s = id.index;
    auto bad = [](const std::string& why) { throw RigidError("reshape: " + why); };
    if (type_[s] == BodyType::Static) bad("a static body cannot be reshaped");
    const bool dynamic = type_[s] == BodyType::Dynamic;
    if (!shape.can_be_dynamic()) bad(std::string("a ") + shape_type_name(shape.type) + " can only belong to a static body");
    if (!is_finite(mass) || !(mass > 0)) bad("mass must be finite and > 0, got " + to_text(mass));
    if (!inertia.allFinite() || (inertia - inertia.transpose()).cwiseAbs().maxCoeff() > Real(1e-6) * inertia.cwiseAbs().maxCoeff())
        bad("inertia must be finite and symmetric");
    const Eigen::LLT<Mat3> llt(inertia);
    if (llt.info() != Eigen::Success) bad("inertia must be positive definite");
    const Transform origin{state_.x[s], state_.q[s]};
    const Aabb box = shape.bounds(origin);
    if (!is_finite(box.lo) || !is_finite(box.hi)) bad("shape bounds are not finite");

    shape_[s] = shape;
    local_com_[s] = Vec3::Zero();
    reshaped_[s] = 1;
    if (!dynamic) {  // a kinematic body's mass plays no part
        if (proxy_[s] != DynamicTree::kNull) tree_.move(proxy_[s], box, Vec3::Zero(), settings_.contact_margin);
        return;
    }
    mass_[s] = mass;
    body_inv_mass_[s] = 1 / mass;
    widen_inv_mass_range(body_inv_mass_[s]);
    inertia_local_[s] = inertia;
    inv_inertia_local_[s] = inertia.inverse();
    const Real k = inertia.trace() / 3;
    spherical_inertia_[s] = (inertia - k * Mat3::Identity()).cwiseAbs().maxCoeff() <= Real(1e-6) * std::abs(k) ? 1 : 0;
    if (!awake_[s]) wake_island(s);  // its cached contacts are stale: the island is detected afresh
    if (state_.inv_mass[s] != 0) {  // moving in this step's solve: the new mass acts now
        const Mat3 r = state_.q[s].toRotationMatrix();
        state_.inv_mass[s] = body_inv_mass_[s];
        state_.inv_inertia_world[s] = r * inv_inertia_local_[s] * r.transpose();
    }
    if (proxy_[s] != DynamicTree::kNull) tree_.move(proxy_[s], box, Vec3::Zero(), settings_.contact_margin);
}

void RigidSystem::place(BodyId id, const Transform& xf, const Vec3& v, const Vec3& w) {
    check(id, "place");
    const std::uint32_t s = id.index;
    if (type_[s] == BodyType::Static) return;
    state_.q[s] = xf.q.normalized();
    state_.x[s] = xf.p + state_.q[s] * local_com_[s];
    state_.v[s] = v;
    state_.w[s] = w;
    w_frame_[s] = state_.q[s];
    if (state_.inv_mass[s] != 0) state_.inv_inertia_world[s] = state_.q[s].toRotationMatrix() * inv_inertia_local_[s] *
                                                                state_.q[s].toRotationMatrix().transpose();
    if (proxy_[s] != DynamicTree::kNull)
        tree_.move(proxy_[s], shape_[s].bounds(origin_transform(s)), Vec3::Zero(), settings_.contact_margin);
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
    if (!enabled_[id.index]) throw RigidError("set_velocity: body {index " + std::to_string(id.index) + "} is disabled (set_enabled)");
    const std::string speed_problem = velocity_problem(v, w);
    if (!speed_problem.empty()) throw RigidError("set_velocity: " + speed_problem);
    if (type_[id.index] == BodyType::Static) {
        // A static body never moves (the scene loader refuses a velocity on one too): a non-zero velocity
        // is a mistake to report, not to drop in silence.
        if (!(v.isZero() && w.isZero()))
            throw RigidError("set_velocity: body " + std::to_string(id.index) +
                             " is static: it takes no velocity (make it kinematic to move it)");
        return;
    }
    state_.v[id.index] = v;
    state_.w[id.index] = w;
    w_frame_[id.index] = state_.q[id.index];
    wake_island(id.index);
}

void RigidSystem::set_target_transform(BodyId id, const Transform& target, Real h) {
    check(id, "set_target_transform");
    if (!enabled_[id.index]) throw RigidError("set_target_transform: body {index " + std::to_string(id.index) + "} is disabled (set_enabled)");
    const std::uint32_t s = id.index;
    if (type_[s] == BodyType::Static)
        throw RigidError("set_target_transform: body " + std::to_string(s) + " is static (make it kinematic to move it)");
    if (!(h > 0) || !std::isfinite(h)) throw RigidError("set_target_transform: the step must be finite and > 0, got " + to_text(h));
    if (!is_finite(target.p) || !std::isfinite(target.q.norm()) || target.q.norm() < Real(1e-6))
        throw RigidError("set_target_transform: the target must be finite with a non-zero quaternion");
    const Quat q_target = target.q.normalized();
    // The centre of mass moves in a straight line to where the target puts it; the rotation is the
    // exact update's (rigid_integration.cpp: q' = exp(w h / 2) q), so w = axis * angle / h.
    const Vec3 v = (target.apply(local_com_[s]) - state_.x[s]) / h;
    Quat dq = q_target * state_.q[s].conjugate();
    if (dq.w() < 0) dq.coeffs() = -dq.coeffs();  // the shorter way round
    const Real sin_half = dq.vec().norm();
    const Real angle = 2 * std::atan2(sin_half, dq.w());
    const Vec3 w = sin_half > Real(1e-12) ? Vec3(dq.vec() * (angle / (sin_half * h))) : Vec3(2 * dq.vec() / h);
    set_velocity(id, v, w);  // checks the speed limits; wakes the body's island
}

void RigidSystem::apply_force(BodyId id, const Vec3& f, const Vec3& p) {
    check(id, "apply_force");
    if (!enabled_[id.index]) throw RigidError("apply_force: body {index " + std::to_string(id.index) + "} is disabled (set_enabled)");
    if (!is_finite(f) || !is_finite(p)) throw RigidError("apply_force: force and point must be finite");
    std::uint32_t s = id.index;
    if (type_[s] != BodyType::Dynamic) return;
    state_.force[s] += f;
    state_.torque[s] += (p - state_.x[s]).cross(f);
    wake_island(s);
}

void RigidSystem::apply_impulse(BodyId id, const Vec3& j, const Vec3& p) {
    check(id, "apply_impulse");
    if (!enabled_[id.index]) throw RigidError("apply_impulse: body {index " + std::to_string(id.index) + "} is disabled (set_enabled)");
    if (!is_finite(j) || !is_finite(p)) throw RigidError("apply_impulse: impulse and point must be finite");
    std::uint32_t s = id.index;
    if (type_[s] != BodyType::Dynamic) return;
    wake_island(s);
    state_.v[s] += body_inv_mass_[s] * j;
    Mat3 r = state_.q[s].toRotationMatrix();
    state_.w[s] += r * inv_inertia_local_[s] * r.transpose() * (p - state_.x[s]).cross(j);
}

BodyType RigidSystem::type(BodyId id) const { check(id, "type"); return type_[id.index]; }
Real RigidSystem::mass(BodyId id) const { check(id, "mass"); return mass_[id.index]; }
const Mat3& RigidSystem::inverse_inertia_local(BodyId id) const {
    check(id, "inverse_inertia_local");
    return inv_inertia_local_[id.index];
}
Real RigidSystem::linear_damping(BodyId id) const { check(id, "linear_damping"); return linear_damping_[id.index]; }
Real RigidSystem::angular_damping(BodyId id) const { check(id, "angular_damping"); return angular_damping_[id.index]; }
Real RigidSystem::gravity_scale(BodyId id) const { check(id, "gravity_scale"); return gravity_scale_[id.index]; }
void RigidSystem::set_gravity_scale(BodyId id, Real scale) {
    check(id, "set_gravity_scale");
    if (!std::isfinite(scale)) throw RigidError("set_gravity_scale: the scale must be finite, got " + to_text(scale));
    gravity_scale_[id.index] = scale;
    wake_island(id.index);
}
void RigidSystem::set_damping(BodyId id, Real linear, Real angular) {
    check(id, "set_damping");
    if (!(linear >= 0 && std::isfinite(linear)) || !(angular >= 0 && std::isfinite(angular)))
        throw RigidError("set_damping: damping must be finite and >= 0, got " + to_text(linear) + " and " + to_text(angular));
    linear_damping_[id.index] = linear;
    angular_damping_[id.index] = angular;
    wake_island(id.index);
}
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
Vec3 RigidSystem::local_center(BodyId id) const { check(id, "local_center"); return local_com_[id.index]; }
const Mat3& RigidSystem::inertia_local(BodyId id) const { check(id, "inertia_local"); return inertia_local_[id.index]; }
bool RigidSystem::is_sensor(BodyId id) const { check(id, "is_sensor"); return sensor_[id.index] != 0; }
bool RigidSystem::is_bullet(BodyId id) const {
    // A bullet turned static or kinematic by set_type is not one (a saved scene must not say it is); the
    // flag is kept for when it turns dynamic again, as Box2D keeps isBullet.
    check(id, "is_bullet");
    return bullet_[id.index] != 0 && type_[id.index] == BodyType::Dynamic;
}
void RigidSystem::set_bullet(BodyId id, bool bullet) {
    check(id, "set_bullet");
    bullet_[id.index] = bullet && type_[id.index] == BodyType::Dynamic ? 1 : 0;
}
bool RigidSystem::awake(BodyId id) const { check(id, "awake"); return awake_[id.index]; }
const CollisionFilter& RigidSystem::filter(BodyId id) const { check(id, "filter"); return filter_[id.index]; }
void RigidSystem::set_filter(BodyId id, const CollisionFilter& f) {
    check(id, "set_filter");
    if (filter_[id.index] == f) return;
    filter_[id.index] = f;
    ignored_changed_ = true;  // the broad phase rebuilds its pair list, so excluded pairs drop their contacts
    if (type_[id.index] != BodyType::Static) wake(id);
}
int RigidSystem::last_solve_blocks() const { return solver_ ? solver_->last_solve_blocks() : 0; }

std::size_t RigidSystem::awake_count() const {
    std::size_t n = 0;
    for (std::uint32_t s = 0; s < slots_.size(); ++s)
        if (slots_.alive(s) && type_[s] == BodyType::Dynamic && awake_[s]) ++n;
    return n;
}
void RigidSystem::wake(BodyId id) { check(id, "wake"); wake_island(id.index); }
std::uint64_t RigidSystem::user_data(BodyId id) const { check(id, "user_data"); return user_data_[id.index]; }

double RigidSystem::kinetic_energy() const {
    double e = 0;
    for (std::uint32_t s = 0; s < slots_.size(); ++s) {
        if (!slots_.alive(s) || type_[s] != BodyType::Dynamic) continue;
        Mat3 r = state_.q[s].toRotationMatrix();
        Mat3 inertia = r * inertia_local_[s] * r.transpose();
        e += 0.5 * mass_[s] * state_.v[s].squaredNorm() + 0.5 * state_.w[s].dot(inertia * state_.w[s]);
    }
    return e;
}

bool RigidSystem::all_finite() const {
    for (std::uint32_t s = 0; s < slots_.size(); ++s)
        if (slots_.alive(s) && (!is_finite(state_.x[s]) || !is_finite(state_.q[s]) || !is_finite(state_.v[s]) ||
                          !is_finite(state_.w[s])))
            return false;
    return true;
}

}  // namespace sinew
