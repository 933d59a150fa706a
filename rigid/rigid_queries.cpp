// World queries against the rigid bodies: ray casts and overlaps, through the broad-phase tree.
#include <algorithm>
#include <cmath>

#include "engine/core/format.hpp"
#include "engine/core/narrowphase.hpp"
#include "rigid/rigid_system.hpp"

namespace sinew {

bool RigidSystem::ray_cast(const Vec3& from, const Vec3& to, RayResult& out) const {
    return ray_cast(from, to, CollisionFilter{}, out);
}

bool RigidSystem::ray_cast(const Vec3& from, const Vec3& to, const CollisionFilter& filter, RayResult& out) const {
    if (!is_finite(from) || !is_finite(to))
        throw RigidError("ray_cast: from and to must be finite, got " + to_text(from) + " and " + to_text(to));
    bool found = false;
    tree_.ray_query(from, to, [&](std::int32_t proxy, Real max_fraction) {
        const std::uint32_t slot = tree_.user_data(proxy);
        if (sensor_[slot] || !should_collide(filter, filter_[slot])) return max_fraction;
        RayHit hit;
        if (!sinew::ray_cast(shape_[slot], origin_transform(slot), from, to, max_fraction, hit)) return max_fraction;
        // Ties (the same fraction on two bodies) go to the lower slot, so the answer is deterministic.
        if (found && hit.fraction == out.hit.fraction && slot > out.body.index) return max_fraction;
        out.body = id_of_slot(slot);
        out.hit = hit;
        found = true;
        return hit.fraction;
    });
    return found;
}

void RigidSystem::ray_cast_all(const Vec3& from, const Vec3& to, const CollisionFilter& filter,
                               std::vector<RayResult>& out) const {
    if (!is_finite(from) || !is_finite(to))
        throw RigidError("ray_cast_all: from and to must be finite, got " + to_text(from) + " and " + to_text(to));
    out.clear();
    tree_.ray_query(from, to, [&](std::int32_t proxy, Real max_fraction) {
        const std::uint32_t slot = tree_.user_data(proxy);
        if (sensor_[slot] || !should_collide(filter, filter_[slot])) return max_fraction;
        RayHit hit;
        if (sinew::ray_cast(shape_[slot], origin_transform(slot), from, to, max_fraction, hit))
            out.push_back({id_of_slot(slot), hit});
        return max_fraction;  // keep the whole segment: every body counts
    });
    std::sort(out.begin(), out.end(), [](const RayResult& a, const RayResult& b) {
        return a.hit.fraction != b.hit.fraction ? a.hit.fraction < b.hit.fraction : a.body.index < b.body.index;
    });
}

namespace {
void check_query_shape(const Shape& shape, const Transform& xf, const char* fn) {
    if (!shape.can_be_dynamic())  // a plane, a mesh, or a compound holding one
        throw RigidError(std::string(fn) + ": the query shape must be convex or a compound, got a " +
                         shape_type_name(shape.type));
    if (!is_finite(xf.p) || !is_finite(xf.q) || xf.q.norm() < Real(1e-6))
        throw RigidError(std::string(fn) + ": the query transform must be finite with a non-zero rotation, got " +
                         to_text(xf.p));
}
}  // namespace

bool RigidSystem::shape_cast(const Shape& shape, const Transform& xf, const Vec3& translation,
                             const CollisionFilter& filter, ShapeCastResult& out) const {
    check_query_shape(shape, xf, "shape_cast");
    if (!is_finite(translation) || !std::isfinite(translation.norm()))
        throw RigidError("shape_cast: the translation must be finite (and its length too), got " + to_text(translation));
    const Transform start{xf.p, xf.q.normalized()};
    // The candidates are the bodies in the box the shape sweeps (a long cast meets more of them).
    const Aabb a0 = shape.bounds(start);
    const Aabb swept{a0.lo.cwiseMin(a0.lo + translation), a0.hi.cwiseMax(a0.hi + translation)};
    bool found = false;
    Real best = 1;
    tree_.query(swept, [&](std::int32_t proxy) {
        const std::uint32_t slot = tree_.user_data(proxy);
        if (sensor_[slot] || !should_collide(filter, filter_[slot])) return true;
        ShapeCastHit hit;
        if (!sinew::shape_cast(shape, start, translation, shape_[slot], origin_transform(slot), best, hit)) return true;
        if (found && (hit.fraction > best || (hit.fraction == best && slot > out.body.index))) return true;
        out.body = id_of_slot(slot);
        out.hit = hit;
        best = hit.fraction;
        found = true;
        return true;
    });
    return found;
}

bool RigidSystem::closest_points(const Shape& shape, const Transform& xf, BodyId id, Real max_distance,
                                 ClosestPoints& out) const {
    check(id, "closest_points");
    check_query_shape(shape, xf, "closest_points");
    if (!is_finite(max_distance) || max_distance < 0)
        throw RigidError("closest_points: max_distance must be finite and >= 0, got " + to_text(max_distance));
    return sinew::closest_points(shape, {xf.p, xf.q.normalized()}, shape_[id.index], origin_transform(id.index),
                                 max_distance, out);
}

void RigidSystem::overlap_aabb(const Aabb& box, std::vector<BodyId>& out) const {
    out.clear();
    tree_.query(box, [&](std::int32_t proxy) {
        const std::uint32_t slot = tree_.user_data(proxy);
        if (sensor_[slot]) return true;
        if (shape_[slot].bounds(origin_transform(slot)).overlaps(box)) out.push_back(id_of_slot(slot));
        return true;
    });
    std::sort(out.begin(), out.end(), [](const BodyId& a, const BodyId& b) { return a.index < b.index; });
}

void RigidSystem::overlap_shape(const Shape& shape, const Transform& xf, std::vector<BodyId>& out) const {
    check_query_shape(shape, xf, "overlap_shape");
    out.clear();
    thread_local ManifoldList manifolds;  // reused: a query allocates nothing once warm
    tree_.query(shape.bounds(xf), [&](std::int32_t proxy) {
        const std::uint32_t slot = tree_.user_data(proxy);
        if (sensor_[slot]) return true;
        if (shapes_touch(shape, xf, shape_[slot], origin_transform(slot), manifolds)) out.push_back(id_of_slot(slot));
        return true;
    });
    std::sort(out.begin(), out.end(), [](const BodyId& a, const BodyId& b) { return a.index < b.index; });
}

}  // namespace sinew
