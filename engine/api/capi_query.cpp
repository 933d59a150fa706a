// C API: ray casts and overlap queries against a world's rigid bodies (rigid/rigid_queries.cpp), and the
// settings a game changes at run time (solver, gravity, a body's material).
#include <algorithm>
#include <cmath>
#include <vector>

#include "engine/api/capi_internal.hpp"
#include "engine/core/format.hpp"

using namespace sinew;
using namespace sinew::capi;

namespace {

// Writes up to capacity ids and the full count.
sinew_status write_ids(const char* fn, sinew_world_id world, const std::vector<BodyId>& found, sinew_body_id* ids,
                       int capacity, int* count) {
    if (capacity < 0) return invalid(fn, "capacity = " + std::to_string(capacity) + " must be >= 0");
    if (capacity > 0 && !ids) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": ids is NULL");
    const std::size_t n = std::min(found.size(), std::size_t(capacity));
    for (std::size_t k = 0; k < n; ++k) ids[k] = {pack_world(world), found[k].index, found[k].generation};
    *count = static_cast<int>(found.size());
    return SINEW_OK;
}

// One scratch list per thread: a query allocates nothing once warm.
std::vector<BodyId>& scratch() {
    thread_local std::vector<BodyId> ids;
    return ids;
}

/// A query's shape and pose from C (any shape but a plane or a mesh; ShapeError names a bad field).
sinew_status query_shape(const char* fn, const sinew_shape_def& shape, const sinew_transform& transform, Shape& s,
                         Transform& xf) {
    if (!finite(transform.p)) return invalid(fn, "transform->p must be finite");
    if (!unit_quat_ok(transform.q)) return invalid(fn, "transform->q must be a finite, non-zero quaternion");
    const int type = enum_value(shape.type);
    if (type == SINEW_SHAPE_PLANE || type == SINEW_SHAPE_MESH)
        return invalid(fn, "shape->type = " + std::to_string(type) + ": a query shape must not be a plane or a mesh");
    s = make_shape(shape, "shape->");  // ShapeError names the bad field
    xf = {to_vec(transform.p), to_quat(transform.q).normalized()};
    return SINEW_OK;
}

sinew_ray_hit ray_hit_c(sinew_world_id world, const RigidSystem::RayResult& r) {
    sinew_ray_hit h;
    h.body = {pack_world(world), r.body.index, r.body.generation};
    h.point = to_c(r.hit.point);
    h.normal = to_c(r.hit.normal);
    h.fraction = float(r.hit.fraction);
    return h;
}

sinew_status check_ray(const char* fn, sinew_vec3 from, sinew_vec3 to) {
    if (!finite(from)) return invalid(fn, "from = " + to_text(to_vec(from)) + " must be finite");
    if (!finite(to)) return invalid(fn, "to = " + to_text(to_vec(to)) + " must be finite");
    return SINEW_OK;
}

}  // namespace

extern "C" {

sinew_status sinew_world_ray_cast(sinew_world_id world, sinew_vec3 from, sinew_vec3 to, sinew_ray_hit* hit, int* found) {
    const char* fn = "sinew_world_ray_cast";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (!hit) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": hit is NULL");
        if (!found) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": found is NULL");
        if (sinew_status st = check_ray(fn, from, to)) return st;
        RigidSystem::RayResult r;
        *found = 0;
        if (w->rigid().ray_cast(to_vec(from), to_vec(to), r)) {
            *found = 1;
            *hit = ray_hit_c(world, r);
        }
        return SINEW_OK;
    });
}

sinew_status sinew_world_ray_cast_filtered(sinew_world_id world, sinew_vec3 from, sinew_vec3 to, sinew_filter filter,
                                           sinew_ray_hit* hit, int* found) {
    const char* fn = "sinew_world_ray_cast_filtered";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (!hit) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": hit is NULL");
        if (!found) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": found is NULL");
        if (sinew_status st = check_ray(fn, from, to)) return st;
        RigidSystem::RayResult r;
        *found = 0;
        if (w->rigid().ray_cast(to_vec(from), to_vec(to), to_filter(filter), r)) {
            *found = 1;
            *hit = ray_hit_c(world, r);
        }
        return SINEW_OK;
    });
}

sinew_status sinew_world_ray_cast_all(sinew_world_id world, sinew_vec3 from, sinew_vec3 to, sinew_filter filter,
                                      sinew_ray_hit* hits, int capacity, int* count) {
    const char* fn = "sinew_world_ray_cast_all";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (!count) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": count is NULL");
        if (capacity < 0) return invalid(fn, "capacity = " + std::to_string(capacity) + " must be >= 0");
        if (capacity > 0 && !hits) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": hits is NULL");
        if (sinew_status st = check_ray(fn, from, to)) return st;
        thread_local std::vector<RigidSystem::RayResult> all;
        w->rigid().ray_cast_all(to_vec(from), to_vec(to), to_filter(filter), all);
        const std::size_t n = std::min(all.size(), std::size_t(capacity));
        for (std::size_t k = 0; k < n; ++k) hits[k] = ray_hit_c(world, all[k]);
        *count = static_cast<int>(all.size());
        return SINEW_OK;
    });
}

sinew_status sinew_world_cast_shape(sinew_world_id world, const sinew_shape_def* shape, const sinew_transform* transform,
                                    sinew_vec3 translation, sinew_filter filter, sinew_shape_cast_hit* hit, int* found) {
    const char* fn = "sinew_world_cast_shape";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (!shape) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": shape is NULL");
        if (!transform) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": transform is NULL");
        if (!hit) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": hit is NULL");
        if (!found) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": found is NULL");
        if (!finite(translation)) return invalid(fn, "translation = " + to_text(to_vec(translation)) + " must be finite");
        Shape s;
        Transform xf;
        if (sinew_status st = query_shape(fn, *shape, *transform, s, xf)) return st;
        RigidSystem::ShapeCastResult r;
        *found = 0;
        if (w->rigid().shape_cast(s, xf, to_vec(translation), to_filter(filter), r)) {
            *found = 1;
            hit->body = {pack_world(world), r.body.index, r.body.generation};
            hit->point = to_c(r.hit.point);
            hit->normal = to_c(r.hit.normal);
            hit->fraction = float(r.hit.fraction);
        }
        return SINEW_OK;
    });
}

sinew_status sinew_world_closest_points(sinew_world_id world, const sinew_shape_def* shape, const sinew_transform* transform,
                                        sinew_body_id body, float max_distance, sinew_closest_points* out, int* found) {
    const char* fn = "sinew_world_closest_points";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (!shape) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": shape is NULL");
        if (!transform) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": transform is NULL");
        if (!out) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
        if (!found) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": found is NULL");
        World* bw = nullptr;
        const BodyId id = find_body(body, fn, &bw);
        if (id.is_null()) return SINEW_ERROR_STALE_ID;
        if (bw != w) return invalid(fn, "body belongs to another world");
        if (!std::isfinite(max_distance) || max_distance < 0)
            return invalid(fn, "max_distance = " + to_text(max_distance) + " must be finite and >= 0");
        Shape s;
        Transform xf;
        if (sinew_status st = query_shape(fn, *shape, *transform, s, xf)) return st;
        ClosestPoints cp;
        *found = 0;
        if (w->rigid().closest_points(s, xf, id, Real(max_distance), cp)) {
            *found = 1;
            out->distance = float(cp.distance);
            out->point_on_shape = to_c(cp.point_a);
            out->point_on_body = to_c(cp.point_b);
            out->normal = to_c(cp.normal);
        }
        return SINEW_OK;
    });
}

sinew_status sinew_world_overlap_aabb(sinew_world_id world, sinew_vec3 lo, sinew_vec3 hi, sinew_body_id* ids,
                                      int capacity, int* count) {
    const char* fn = "sinew_world_overlap_aabb";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (!count) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": count is NULL");
        if (!finite(lo) || !finite(hi)) return invalid(fn, "lo and hi must be finite");
        const Aabb box{to_vec(lo), to_vec(hi)};
        if (!box.valid()) return invalid(fn, "lo = " + to_text(box.lo) + " must be <= hi = " + to_text(box.hi) + " on every axis");
        std::vector<BodyId>& found = scratch();
        w->rigid().overlap_aabb(box, found);
        return write_ids(fn, world, found, ids, capacity, count);
    });
}

sinew_status sinew_sensor_get_overlaps(sinew_body_id sensor, sinew_sensor_event* overlaps, int capacity, int* count) {
    const char* fn = "sinew_sensor_get_overlaps";
    return guarded(fn, [&] {
        World* w = nullptr;
        const BodyId id = find_body(sensor, fn, &w);
        if (id.is_null()) return SINEW_ERROR_STALE_ID;
        if (!count) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": count is NULL");
        if (capacity < 0) return invalid(fn, "capacity = " + std::to_string(capacity) + " must be >= 0");
        if (capacity > 0 && !overlaps) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": overlaps is NULL");
        if (!w->rigid().is_sensor(id))
            return invalid(fn, "body {index " + std::to_string(id.index) + "} is not a sensor (sinew_body_def.is_sensor)");
        thread_local std::vector<SensorOverlap> found;  // reused: no allocation per call once warm
        w->sensors().overlaps(id, found);
        const std::size_t n = std::min(found.size(), std::size_t(capacity));
        for (std::size_t k = 0; k < n; ++k) overlaps[k] = sensor_event_c(sensor.world, found[k], 0);
        *count = static_cast<int>(found.size());
        return SINEW_OK;
    });
}

sinew_status sinew_world_overlap_shape(sinew_world_id world, const sinew_shape_def* shape, const sinew_transform* transform,
                                       sinew_body_id* ids, int capacity, int* count) {
    const char* fn = "sinew_world_overlap_shape";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (!shape) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": shape is NULL");
        if (!transform) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": transform is NULL");
        if (!count) return fail(SINEW_ERROR_NULL_ARGUMENT, std::string(fn) + ": count is NULL");
        Shape s;
        Transform xf;
        if (sinew_status st = query_shape(fn, *shape, *transform, s, xf)) return st;
        std::vector<BodyId>& found = scratch();
        w->rigid().overlap_shape(s, xf, found);
        return write_ids(fn, world, found, ids, capacity, count);
    });
}

sinew_status sinew_world_set_solver(sinew_world_id world, sinew_solver solver, int velocity_iterations) {
    const char* fn = "sinew_world_set_solver";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        RigidSettings r = w->rigid().settings();
        switch (enum_value(solver)) {
            case SINEW_SOLVER_SOFT_STEP: r.solver = RigidSolverKind::SoftStep; break;
            case SINEW_SOLVER_SPLIT_IMPULSE: r.solver = RigidSolverKind::SplitImpulse; break;
            case SINEW_SOLVER_BAUMGARTE: r.solver = RigidSolverKind::Baumgarte; break;
            case SINEW_SOLVER_NEWTON: r.solver = RigidSolverKind::Newton; break;
            default: return invalid(fn, "solver = " + std::to_string(enum_value(solver)) + " is not a sinew_solver");
        }
        r.velocity_iterations = velocity_iterations;
        w->rigid().set_settings(r);  // RigidError names a bad iteration count; nothing changes then
        return SINEW_OK;
    });
}

sinew_status sinew_world_set_gravity(sinew_world_id world, sinew_vec3 gravity) {
    const char* fn = "sinew_world_set_gravity";
    return guarded(fn, [&] {
        World* w = find_world(world, fn);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        if (!finite(gravity)) return invalid(fn, "gravity = " + to_text(to_vec(gravity)) + " must be finite");
        w->set_gravity(to_vec(gravity));
        return SINEW_OK;
    });
}

sinew_status sinew_world_set_presolve(sinew_world_id world, sinew_presolve_fn* fn, void* context) {
    const char* name = "sinew_world_set_presolve";
    return guarded(name, [&] {
        World* w = find_world(world, name);
        if (!w) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, name)) return s;
        if (!fn) {
            w->rigid().set_pre_solve({});
            return SINEW_OK;
        }
        const std::uint32_t packed = pack_world(world);
        w->rigid().set_pre_solve([fn, context, packed](PreSolveContact& p) {
            sinew_presolve_contact c{};
            c.body_a = {packed, p.body_a.index, p.body_a.generation};
            c.body_b = {packed, p.body_b.index, p.body_b.generation};
            c.normal = to_c(p.normal);
            c.point_count = p.point_count;
            for (int k = 0; k < p.point_count; ++k) {
                c.points[k] = to_c(p.points[k]);
                c.depths[k] = float(p.depths[k]);
            }
            c.friction = float(p.friction);
            c.restitution = float(p.restitution);
            const int keep = fn(context, &c);
            p.friction = Real(c.friction);
            p.restitution = Real(c.restitution);
            return keep != 0;
        });
        return SINEW_OK;
    });
}

sinew_status sinew_body_set_material(sinew_body_id body, float friction, float restitution) {
    const char* fn = "sinew_body_set_material";
    return guarded(fn, [&] {
        World* w = nullptr;
        const BodyId id = find_body(body, fn, &w);
        if (id.is_null()) return SINEW_ERROR_STALE_ID;
        if (sinew_status s = check_not_stepping(w, fn)) return s;
        Material m = w->rigid().material(id);
        m.friction = Real(friction);
        m.restitution = Real(restitution);
        w->rigid().set_material(id, m);  // RigidError names the bad value; nothing changes then
        return SINEW_OK;
    });
}

}  // extern "C"
