// World queries against the rigid bodies: ray casts and overlaps, through the broad-phase tree.
#include <algorithm>

#include "engine/core/format.hpp"
#include "engine/core/narrowphase.hpp"
#include "rigid/rigid_system.hpp"

namespace sinew {

bool RigidSystem::ray_cast(const Vec3& from, const Vec3& to, RayResult& out) const {
    if (!is_finite(from) || !is_finite(to))
        throw RigidError("ray_cast: from and to must be finite, got " + to_text(from) + " and " + to_text(to));
    bool found = false;
    tree_.ray_query(from, to, [&](std::int32_t proxy, Real max_fraction) {
        const std::uint32_t slot = tree_.user_data(proxy);
        if (sensor_[slot]) return max_fraction;
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
    if (shape.type == ShapeType::Plane || shape.type == ShapeType::TriangleMesh)
        throw RigidError(std::string("overlap_shape: the query shape must be convex or a compound, got a ") +
                         shape_type_name(shape.type));
    if (!is_finite(xf.p) || !is_finite(xf.q))
        throw RigidError("overlap_shape: the query transform must be finite, got " + to_text(xf.p));
    out.clear();
    thread_local ManifoldList manifolds;  // reused: a query allocates nothing once warm
    tree_.query(shape.bounds(xf), [&](std::int32_t proxy) {
        const std::uint32_t slot = tree_.user_data(proxy);
        if (sensor_[slot]) return true;
        manifolds.clear();
        collide(shape, xf, shape_[slot], origin_transform(slot), 0, manifolds);
        bool touching = false;
        for (const Manifold& m : manifolds)
            for (int k = 0; k < m.count && !touching; ++k) touching = m.points[k].depth >= 0;
        if (touching) out.push_back(id_of_slot(slot));
        return true;
    });
    std::sort(out.begin(), out.end(), [](const BodyId& a, const BodyId& b) { return a.index < b.index; });
}

}  // namespace sinew
