// C API: joints between rigid bodies (rigid/joint.hpp, RigidSystem::create_joint / destroy_joint).
//
// The C fields are checked here and named as the caller wrote them (def->lower, def->body_b); the joint
// set's own validation (at least one dynamic body, hinge limits within [-pi, pi], a distance joint's rest
// length) follows and is reported as SINEW_ERROR_INVALID_ARGUMENT with its text.
#include <cmath>

#include "engine/api/capi_internal.hpp"
#include "engine/core/format.hpp"
#include "rigid/joint_set.hpp"

using namespace sinew;
using namespace sinew::capi;

namespace {

std::string vec_text(const sinew_vec3& v) { return to_text(Vec3(Real(v.x), Real(v.y), Real(v.z))); }
bool nonneg(float x) { return std::isfinite(x) && x >= 0; }

std::string describe(const sinew_body_id& b) {
    return "{index " + std::to_string(b.index) + ", generation " + std::to_string(b.generation) + "}";
}

/// The body of a joint definition, or a null id after recording SINEW_ERROR_STALE_ID.
BodyId joint_body(const sinew_body_id& b, const char* name, sinew_world_id world, const World& w, const char* fn) {
    if (b.generation == 0) {
        fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": def->" + name + " is the null handle");
        return {};
    }
    if (b.world != pack_world(world)) {
        fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": def->" + name + " " + describe(b) + " belongs to world " +
                                       std::to_string(b.world) + ", not to world " + std::to_string(pack_world(world)));
        return {};
    }
    const BodyId id{b.index, b.generation};
    if (!w.rigid().valid(id)) {
        fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": def->" + name + " " + describe(b) + " is destroyed or was never created");
        return {};
    }
    return id;
}

std::string check_flags_and_numbers(const sinew_joint_def& d) {
    const struct {
        const char* name;
        int value;
    } flags[] = {{"collide_connected", d.collide_connected}, {"enable_limit", d.enable_limit}, {"enable_motor", d.enable_motor}};
    for (const auto& f : flags)
        if (f.value != 0 && f.value != 1) return std::string("def->") + f.name + " = " + std::to_string(f.value) + " must be 0 or 1";
    if (!finite(d.local_anchor_a)) return "def->local_anchor_a = " + vec_text(d.local_anchor_a) + " must be finite";
    if (!finite(d.local_anchor_b)) return "def->local_anchor_b = " + vec_text(d.local_anchor_b) + " must be finite";
    if (!finite(d.local_axis_a)) return "def->local_axis_a = " + vec_text(d.local_axis_a) + " must be finite";
    const int type = enum_value(d.type);
    if ((type == SINEW_JOINT_HINGE || type == SINEW_JOINT_SLIDER) && !(to_vec(d.local_axis_a).norm() > Real(1e-6)))
        return "def->local_axis_a = " + vec_text(d.local_axis_a) + " must be non-zero for a hinge or slider";
    if (!std::isfinite(d.lower)) return "def->lower = " + to_text(d.lower) + " must be finite";
    if (!std::isfinite(d.upper)) return "def->upper = " + to_text(d.upper) + " must be finite";
    if (d.lower > d.upper) return "def->lower = " + to_text(d.lower) + " is greater than def->upper = " + to_text(d.upper);
    if (!std::isfinite(d.motor_speed)) return "def->motor_speed = " + to_text(d.motor_speed) + " must be finite";
    if (!nonneg(d.max_motor_force)) return "def->max_motor_force = " + to_text(d.max_motor_force) + " must be finite and >= 0";
    if (!std::isfinite(d.length)) return "def->length = " + to_text(d.length) + " must be finite";
    if (!nonneg(d.frequency)) return "def->frequency = " + to_text(d.frequency) + " must be finite and >= 0 (Hz)";
    if (!nonneg(d.damping_ratio)) return "def->damping_ratio = " + to_text(d.damping_ratio) + " must be finite and >= 0";
    if (!nonneg(d.break_force))
        return "def->break_force = " + to_text(d.break_force) + " must be finite and >= 0 (N; 0 = unbreakable)";
    return {};
}

/// The joint, its world entry, or the failure recorded; also rejects mutations during a step.
struct Target {
    WorldEntry* entry = nullptr;
    JointId joint;
    sinew_status status = SINEW_OK;
};
Target target(sinew_joint_id id, const char* fn, bool mutates) {
    Target t;
    if (id.generation == 0) {
        t.status = fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": joint is the null handle");
        return t;
    }
    t.entry = find_entry({id.world & 0xFFFFu, id.world >> 16}, fn);
    if (!t.entry) {
        t.status = SINEW_ERROR_STALE_ID;
        return t;
    }
    const JointId j{id.index, id.generation};
    if (!t.entry->world->rigid().joints().valid(j)) {
        t.status = fail(SINEW_ERROR_STALE_ID, std::string(fn) + ": joint {index " + std::to_string(id.index) + ", generation " +
                                                  std::to_string(id.generation) +
                                                  "} is destroyed, broken, or was never created in world " +
                                                  std::to_string(id.world));
        return t;
    }
    if (mutates && t.entry->world->in_step()) {
        t.status = fail(SINEW_ERROR_IN_STEP, std::string(fn) + ": the world is stepping");
        return t;
    }
    t.joint = j;
    return t;
}

/// A motor or limit change applies to hinges and sliders, with a 0 or 1 flag.
sinew_status check_axis_change(const JointDef& d, const char* fn, const char* what, int enable) {
    if (d.type != JointType::Hinge && d.type != JointType::Slider)
        return invalid(fn, std::string("joint is a ") + joint_type_name(d.type) + " joint; only hinge and slider joints have " + what);
    if (enable != 0 && enable != 1) return invalid(fn, "enable = " + std::to_string(enable) + " must be 0 or 1");
    return SINEW_OK;
}

/// A changed joint wakes both its bodies (either may be gone if the joint went with it).
void wake_ends(RigidSystem& r, BodyId a, BodyId b) {
    if (r.valid(a)) r.wake(a);
    if (r.valid(b)) r.wake(b);
}

}  // namespace

extern "C" {

sinew_joint_def sinew_joint_def_default(void) {
    const JointDef j;
    sinew_joint_def d;
    d.type = SINEW_JOINT_BALL;
    d.body_a = {0, 0, 0};
    d.body_b = {0, 0, 0};
    d.local_anchor_a = to_c(j.local_anchor_a);
    d.local_anchor_b = to_c(j.local_anchor_b);
    d.local_axis_a = to_c(j.local_axis_a);
    d.collide_connected = j.collide_connected ? 1 : 0;
    d.enable_limit = j.enable_limit ? 1 : 0;
    d.lower = float(j.lower);
    d.upper = float(j.upper);
    d.enable_motor = j.enable_motor ? 1 : 0;
    d.motor_speed = float(j.motor_speed);
    d.max_motor_force = float(j.max_motor_force);
    d.length = float(j.length);
    d.frequency = float(j.frequency);
    d.damping_ratio = float(j.damping_ratio);
    d.break_force = float(j.break_force);
    d.user_data = 0;
    return d;
}

sinew_status sinew_joint_create(sinew_world_id world, const sinew_joint_def* def, sinew_joint_id* out) {
    const char* fn = "sinew_joint_create";
    return guarded(fn, [&] {
        if (!def) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": def is NULL");
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        WorldEntry* e = find_entry(world, fn);
        if (!e) return SINEW_ERROR_STALE_ID;
        World& w = *e->world;
        if (sinew_status s = check_not_stepping(&w, fn)) return s;
        const int type = enum_value(def->type);
        if (type < SINEW_JOINT_BALL || type > SINEW_JOINT_FIXED)
            return invalid(fn, "def->type = " + std::to_string(type) + " is not a sinew_joint_type");
        JointDef j;
        j.body_a = joint_body(def->body_a, "body_a", world, w, fn);
        if (j.body_a.is_null()) return SINEW_ERROR_STALE_ID;
        j.body_b = joint_body(def->body_b, "body_b", world, w, fn);
        if (j.body_b.is_null()) return SINEW_ERROR_STALE_ID;
        const std::string bad = check_flags_and_numbers(*def);
        if (!bad.empty()) return invalid(fn, bad);
        const JointType types[] = {JointType::Ball, JointType::Hinge, JointType::Slider, JointType::Distance, JointType::Fixed};
        j.type = types[type];
        j.local_anchor_a = to_vec(def->local_anchor_a);
        j.local_anchor_b = to_vec(def->local_anchor_b);
        j.local_axis_a = to_vec(def->local_axis_a);
        j.collide_connected = def->collide_connected == 1;
        j.enable_limit = def->enable_limit == 1;
        j.lower = Real(def->lower);
        j.upper = Real(def->upper);
        j.enable_motor = def->enable_motor == 1;
        j.motor_speed = Real(def->motor_speed);
        j.max_motor_force = Real(def->max_motor_force);
        j.length = Real(def->length);
        j.frequency = Real(def->frequency);
        j.damping_ratio = Real(def->damping_ratio);
        j.break_force = Real(def->break_force);
        j.user_data = def->user_data;
        const JointId id = w.rigid().create_joint(j);  // RigidError: nothing was created
        try {
            e->events.remember_joint(id, j);
        } catch (...) {
            w.rigid().destroy_joint(id);  // out of memory for the event table: undo
            throw;
        }
        *out = {pack_world(world), id.index, id.generation};
        return SINEW_OK;
    });
}

sinew_status sinew_joint_destroy(sinew_joint_id joint) {
    const char* fn = "sinew_joint_destroy";
    return guarded(fn, [&] {
        Target t = target(joint, fn, true);
        if (t.status) return t.status;
        t.entry->world->rigid().destroy_joint(t.joint);
        return SINEW_OK;
    });
}

sinew_status sinew_joint_get_reaction(sinew_joint_id joint, sinew_vec3* force, sinew_vec3* torque) {
    const char* fn = "sinew_joint_get_reaction";
    return guarded(fn, [&] {
        if (!force && !torque) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": force and torque are NULL");
        Target t = target(joint, fn, false);
        if (t.status) return t.status;
        const JointSet& js = t.entry->world->rigid().joints();
        if (force) *force = to_c(js.reaction_force(t.joint));
        if (torque) *torque = to_c(js.reaction_torque(t.joint));
        return SINEW_OK;
    });
}

sinew_status sinew_joint_set_motor(sinew_joint_id joint, int enable, float speed, float max_force) {
    const char* fn = "sinew_joint_set_motor";
    return guarded(fn, [&] {
        Target t = target(joint, fn, true);
        if (t.status) return t.status;
        RigidSystem& r = t.entry->world->rigid();
        const JointDef& d = r.joints().def(t.joint);
        if (sinew_status s = check_axis_change(d, fn, "a motor", enable)) return s;
        if (!std::isfinite(speed)) return invalid(fn, "speed = " + to_text(speed) + " must be finite");
        if (!nonneg(max_force)) return invalid(fn, "max_force = " + to_text(max_force) + " must be finite and >= 0");
        const BodyId a = d.body_a, b = d.body_b;
        r.joints().set_motor(t.joint, enable == 1, Real(speed), Real(max_force));
        wake_ends(r, a, b);
        return SINEW_OK;
    });
}

sinew_status sinew_joint_set_limits(sinew_joint_id joint, int enable, float lower, float upper) {
    const char* fn = "sinew_joint_set_limits";
    return guarded(fn, [&] {
        Target t = target(joint, fn, true);
        if (t.status) return t.status;
        RigidSystem& r = t.entry->world->rigid();
        const JointDef& d = r.joints().def(t.joint);
        if (sinew_status s = check_axis_change(d, fn, "limits", enable)) return s;
        const BodyId a = d.body_a, b = d.body_b;
        r.joints().set_limits(t.joint, enable == 1, Real(lower), Real(upper));  // RigidError names a bad range
        wake_ends(r, a, b);
        return SINEW_OK;
    });
}

sinew_status sinew_joint_get_coordinate(sinew_joint_id joint, float* value, float* speed) {
    const char* fn = "sinew_joint_get_coordinate";
    return guarded(fn, [&] {
        if (!value && !speed) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": value and speed are both NULL");
        Target t = target(joint, fn, false);
        if (t.status) return t.status;
        const RigidSystem& r = t.entry->world->rigid();
        if (value) *value = float(r.joints().coordinate(t.joint, r));
        if (speed) *speed = float(r.joints().coordinate_speed(t.joint, r));
        return SINEW_OK;
    });
}

}  // extern "C"
