// C API: rigid bodies.
#include <cmath>

#include "engine/api/capi_internal.hpp"
#include "engine/core/format.hpp"

using namespace sinew;
using namespace sinew::capi;

namespace {

/// The body and its world, or the failure already recorded; also rejects calls during a step.
struct Target {
    World* world = nullptr;
    BodyId body;
    sinew_status status = SINEW_OK;
};
Target target(sinew_body_id id, const char* fn, bool mutates) {
    Target t;
    t.body = find_body(id, fn, &t.world);
    if (t.body.is_null()) {
        t.status = SINEW_ERROR_STALE_ID;
    } else if (mutates && t.world->in_step()) {
        t.status = fail(SINEW_ERROR_IN_STEP, std::string(fn) + ": the world is stepping");
    }
    return t;
}

}  // namespace

extern "C" {

sinew_filter sinew_filter_default(void) { return to_c(CollisionFilter{}); }

sinew_body_def sinew_body_def_default(void) {
    sinew_body_def d;
    d.type = SINEW_BODY_DYNAMIC;
    d.transform = {{0, 0, 0}, {0, 0, 0, 1}};
    d.linear_velocity = {0, 0, 0};
    d.angular_velocity = {0, 0, 0};
    d.shape = sinew_shape_def_default();
    const Material m;
    d.mass = 0;
    d.density = float(m.density);
    d.friction = float(m.friction);
    d.restitution = float(m.restitution);
    d.linear_damping = 0;
    d.angular_damping = 0;
    d.filter = to_c(CollisionFilter{});
    d.gravity_scale = 1;
    d.allow_sleep = 1;
    d.is_sensor = 0;
    d.is_bullet = 0;
    d.user_data = 0;
    return d;
}

sinew_status sinew_body_create(sinew_world_id world, const sinew_body_def* def, sinew_body_id* out) {
    const char* fn = "sinew_body_create";
    return guarded(fn, [&] {
        if (!def) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": def is NULL");
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (w->in_step()) return fail(SINEW_ERROR_IN_STEP, std::string(fn) + ": the world is stepping");
        const int type = enum_value(def->type);
        if (type < SINEW_BODY_STATIC || type > SINEW_BODY_DYNAMIC)
            return invalid(fn, "def->type = " + std::to_string(type) + " is not a sinew_body_type");
        if (!finite(def->transform.p)) return invalid(fn, "def->transform.p must be finite");
        if (!unit_quat_ok(def->transform.q)) return invalid(fn, "def->transform.q must be a finite non-zero quaternion");
        if (!std::isfinite(def->mass) || def->mass < 0)
            return invalid(fn, "def->mass = " + to_text(def->mass) + " must be finite and >= 0 (0 = from density)");
        if (def->mass == 0 && type == SINEW_BODY_DYNAMIC && !(def->density > 0 && std::isfinite(def->density)))
            return invalid(fn, "def->density = " + to_text(def->density) + " must be finite and > 0 when mass is 0");
        BodyDef b;
        b.type = type == SINEW_BODY_STATIC ? BodyType::Static
                 : type == SINEW_BODY_KINEMATIC ? BodyType::Kinematic
                                                 : BodyType::Dynamic;
        b.pose = {to_vec(def->transform.p), to_quat(def->transform.q).normalized()};
        b.linear_velocity = to_vec(def->linear_velocity);
        b.angular_velocity = to_vec(def->angular_velocity);
        b.shape = make_shape(def->shape, "def->shape");  // ShapeError names the bad field
        b.mass = Real(def->mass);
        b.material.density = Real(def->density);
        b.material.friction = Real(def->friction);
        b.material.restitution = Real(def->restitution);
        b.linear_damping = Real(def->linear_damping);
        b.angular_damping = Real(def->angular_damping);
        b.filter = to_filter(def->filter);
        if (!std::isfinite(def->gravity_scale))
            return invalid(fn, "def->gravity_scale = " + to_text(def->gravity_scale) + " must be finite");
        if (def->allow_sleep != 0 && def->allow_sleep != 1)
            return invalid(fn, "def->allow_sleep = " + std::to_string(def->allow_sleep) + " must be 0 or 1");
        if (def->is_sensor != 0 && def->is_sensor != 1)
            return invalid(fn, "def->is_sensor = " + std::to_string(def->is_sensor) + " must be 0 or 1");
        if (def->is_bullet != 0 && def->is_bullet != 1)
            return invalid(fn, "def->is_bullet = " + std::to_string(def->is_bullet) + " must be 0 or 1");
        if (def->is_bullet && def->type != SINEW_BODY_DYNAMIC)
            return invalid(fn, "def->is_bullet = 1 needs a dynamic body (def->type)");
        b.gravity_scale = Real(def->gravity_scale);
        b.allow_sleep = def->allow_sleep != 0;
        b.sensor = def->is_sensor != 0;
        b.bullet = def->is_bullet != 0;
        b.user_data = def->user_data;
        BodyId id = w->rigid().create_body(b);  // RigidError names the rest; nothing is created then
        *out = {pack_world(world), id.index, id.generation};
        return SINEW_OK;
    });
}

sinew_status sinew_body_destroy(sinew_body_id body) {
    const char* fn = "sinew_body_destroy";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        t.world->rigid().destroy_body(t.body);
        return SINEW_OK;
    });
}

sinew_status sinew_body_get_transform(sinew_body_id body, sinew_transform* out) {
    const char* fn = "sinew_body_get_transform";
    return guarded(fn, [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        *out = to_c(t.world->rigid().transform(t.body));
        return SINEW_OK;
    });
}

sinew_status sinew_body_set_transform(sinew_body_id body, const sinew_transform* xf) {
    const char* fn = "sinew_body_set_transform";
    return guarded(fn, [&] {
        if (!xf) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": transform is NULL");
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (!finite(xf->p)) return invalid(fn, "transform->p must be finite");
        if (!unit_quat_ok(xf->q)) return invalid(fn, "transform->q must be a finite non-zero quaternion");
        t.world->rigid().set_transform(t.body, {to_vec(xf->p), to_quat(xf->q).normalized()});
        return SINEW_OK;
    });
}

sinew_status sinew_body_get_velocity(sinew_body_id body, sinew_vec3* linear, sinew_vec3* angular) {
    const char* fn = "sinew_body_get_velocity";
    return guarded(fn, [&] {
        if (!linear && !angular) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": linear and angular are NULL");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        if (linear) *linear = to_c(t.world->rigid().linear_velocity(t.body));
        if (angular) *angular = to_c(t.world->rigid().angular_velocity(t.body));
        return SINEW_OK;
    });
}

sinew_status sinew_body_set_velocity(sinew_body_id body, sinew_vec3 linear, sinew_vec3 angular) {
    const char* fn = "sinew_body_set_velocity";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        // RigidError (non-finite, too fast, non-zero on a static body) becomes INVALID_ARGUMENT in guarded.
        t.world->rigid().set_velocity(t.body, to_vec(linear), to_vec(angular));
        return SINEW_OK;
    });
}

sinew_status sinew_body_set_target_transform(sinew_body_id body, const sinew_transform* target_transform, float time_step) {
    const char* fn = "sinew_body_set_target_transform";
    return guarded(fn, [&] {
        if (!target_transform) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": target is NULL");
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (!finite(target_transform->p)) return invalid(fn, "target->p must be finite");
        if (!unit_quat_ok(target_transform->q)) return invalid(fn, "target->q must be a finite non-zero quaternion");
        if (!(time_step > 0) || !std::isfinite(time_step))
            return invalid(fn, "time_step = " + to_text(time_step) + " must be finite and > 0");
        const Transform xf{to_vec(target_transform->p), to_quat(target_transform->q)};
        t.world->rigid().set_target_transform(t.body, xf, Real(time_step));  // RigidError: static, too fast
        return SINEW_OK;
    });
}

sinew_status sinew_body_apply_force(sinew_body_id body, sinew_vec3 force, sinew_vec3 point) {
    const char* fn = "sinew_body_apply_force";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (!finite(force) || !finite(point)) return invalid(fn, "force and world_point must be finite");
        t.world->rigid().apply_force(t.body, to_vec(force), to_vec(point));
        return SINEW_OK;
    });
}

sinew_status sinew_body_apply_impulse(sinew_body_id body, sinew_vec3 impulse, sinew_vec3 point) {
    const char* fn = "sinew_body_apply_impulse";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (!finite(impulse) || !finite(point)) return invalid(fn, "impulse and world_point must be finite");
        t.world->rigid().apply_impulse(t.body, to_vec(impulse), to_vec(point));
        return SINEW_OK;
    });
}

sinew_status sinew_body_wake(sinew_body_id body) {
    const char* fn = "sinew_body_wake";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        t.world->rigid().wake(t.body);
        return SINEW_OK;
    });
}

sinew_status sinew_body_get_type(sinew_body_id body, sinew_body_type* out) {
    const char* fn = "sinew_body_get_type";
    return guarded(fn, [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        const BodyType type = t.world->rigid().type(t.body);
        *out = type == BodyType::Static ? SINEW_BODY_STATIC : type == BodyType::Kinematic ? SINEW_BODY_KINEMATIC : SINEW_BODY_DYNAMIC;
        return SINEW_OK;
    });
}

sinew_status sinew_body_set_type(sinew_body_id body, sinew_body_type type) {
    const char* fn = "sinew_body_set_type";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        const int v = enum_value(type);
        if (v < SINEW_BODY_STATIC || v > SINEW_BODY_DYNAMIC)
            return invalid(fn, "type = " + std::to_string(v) + " is not a sinew_body_type");
        t.world->rigid().set_type(t.body, v == SINEW_BODY_STATIC ? BodyType::Static
                                          : v == SINEW_BODY_KINEMATIC ? BodyType::Kinematic
                                                                      : BodyType::Dynamic);  // RigidError: plane, mesh
        return SINEW_OK;
    });
}

sinew_status sinew_body_set_enabled(sinew_body_id body, int enabled) {
    const char* fn = "sinew_body_set_enabled";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        if (enabled != 0 && enabled != 1) return invalid(fn, "enabled = " + std::to_string(enabled) + " must be 0 or 1");
        t.world->rigid().set_enabled(t.body, enabled == 1);
        return SINEW_OK;
    });
}

sinew_status sinew_body_is_enabled(sinew_body_id body, int* out) {
    const char* fn = "sinew_body_is_enabled";
    return guarded(fn, [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        *out = t.world->rigid().enabled(t.body) ? 1 : 0;
        return SINEW_OK;
    });
}

sinew_status sinew_body_sleep(sinew_body_id body) {
    const char* fn = "sinew_body_sleep";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        t.world->rigid().sleep(t.body);  // RigidError: not dynamic
        return SINEW_OK;
    });
}

sinew_status sinew_body_get_mass_data(sinew_body_id body, sinew_mass_data* out) {
    const char* fn = "sinew_body_get_mass_data";
    return guarded(fn, [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        const RigidSystem& r = t.world->rigid();
        out->mass = float(r.mass(t.body));
        out->local_center = to_c(r.local_center(t.body));
        const Mat3& i = r.inertia_local(t.body);
        for (int row = 0; row < 3; ++row)
            for (int col = 0; col < 3; ++col) out->inertia[3 * row + col] = float(i(row, col));
        return SINEW_OK;
    });
}

sinew_status sinew_body_is_awake(sinew_body_id body, int* out) {
    const char* fn = "sinew_body_is_awake";
    return guarded(fn, [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        const RigidSystem& r = t.world->rigid();
        *out = r.type(t.body) != BodyType::Static && r.awake(t.body) ? 1 : 0;
        return SINEW_OK;
    });
}

sinew_status sinew_body_get_mass(sinew_body_id body, float* out) {
    const char* fn = "sinew_body_get_mass";
    return guarded(fn, [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        *out = float(t.world->rigid().mass(t.body));
        return SINEW_OK;
    });
}

sinew_status sinew_body_set_gravity_scale(sinew_body_id body, float scale) {
    const char* fn = "sinew_body_set_gravity_scale";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        t.world->rigid().set_gravity_scale(t.body, Real(scale));  // RigidError: not finite
        return SINEW_OK;
    });
}

sinew_status sinew_body_set_damping(sinew_body_id body, float linear, float angular) {
    const char* fn = "sinew_body_set_damping";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        t.world->rigid().set_damping(t.body, Real(linear), Real(angular));  // RigidError: negative, not finite
        return SINEW_OK;
    });
}

sinew_status sinew_body_set_filter(sinew_body_id body, sinew_filter filter) {
    const char* fn = "sinew_body_set_filter";
    return guarded(fn, [&] {
        Target t = target(body, fn, true);
        if (t.status) return t.status;
        t.world->rigid().set_filter(t.body, to_filter(filter));
        return SINEW_OK;
    });
}

sinew_status sinew_body_get_filter(sinew_body_id body, sinew_filter* out) {
    const char* fn = "sinew_body_get_filter";
    return guarded(fn, [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        *out = to_c(t.world->rigid().filter(t.body));
        return SINEW_OK;
    });
}

sinew_status sinew_body_user_data(sinew_body_id body, uint64_t* out) {
    const char* fn = "sinew_body_user_data";
    return guarded(fn, [&] {
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        Target t = target(body, fn, false);
        if (t.status) return t.status;
        *out = t.world->rigid().user_data(t.body);
        return SINEW_OK;
    });
}

}  // extern "C"
