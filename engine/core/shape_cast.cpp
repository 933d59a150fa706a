// Shape casts and closest points (see shape_cast.hpp for the method and why it is safe).
#include "engine/core/shape_cast.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "engine/core/narrowphase.hpp"

namespace sinew {

namespace {

/// One part's answer: separation along its normal (A to B) and the point midway between the surfaces.
struct Part {
    Real separation;
    Vec3 normal;
    Vec3 point;
};

struct PartScratch {
    ManifoldList manifolds;
    std::vector<Part> parts;
};

void add_deepest(const Manifold& m, std::vector<Part>& out) {
    if (m.count == 0) return;
    int k = 0;
    for (int i = 1; i < m.count; ++i)
        if (m.points[i].depth > m.points[k].depth) k = i;
    out.push_back({-m.points[k].depth, m.normal, m.points[k].position});
}

/// Every part of a against b closer than `margin`: compounds split into their children, convex pairs by
/// GJK (exact distance; the specialised pair routines may answer separated pairs with an axis's lower
/// bound), planes and meshes by the narrow phase.
void parts_of(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, PartScratch& s) {
    if (a.type == ShapeType::Compound) {
        for (const CompoundChild& c : *a.children) parts_of(*c.shape, xa * c.local, b, xb, margin, s);
        return;
    }
    if (b.type == ShapeType::Compound) {
        for (const CompoundChild& c : *b.children) parts_of(a, xa, *c.shape, xb * c.local, margin, s);
        return;
    }
    if (b.type == ShapeType::Plane || b.type == ShapeType::TriangleMesh) {
        s.manifolds.clear();
        collide(a, xa, b, xb, margin, s.manifolds);
        for (const Manifold& m : s.manifolds) add_deepest(m, s.parts);
        return;
    }
    Manifold m;
    if (narrow::convex_convex(a, xa, b, xb, margin, m)) add_deepest(m, s.parts);
}

void check_cast_shape(const Shape& a, const char* fn) {
    if (!a.can_be_dynamic())  // a plane, a mesh, or a compound holding one
        throw ShapeError(std::string(fn) + ": the moving shape must be a sphere, box, capsule, hull or compound of them, got a " +
                         shape_type_name(a.type));
}

PartScratch& scratch() {
    thread_local PartScratch s;  // reused: a query allocates nothing once warm
    return s;
}

}  // namespace

bool shape_cast(const Shape& a, const Transform& xa, const Vec3& translation, const Shape& b, const Transform& xb,
                Real max_fraction, ShapeCastHit& out) {
    check_cast_shape(a, "shape_cast");
    PartScratch& s = scratch();
    const Real length = translation.norm();
    Real t = 0;
    for (int iter = 0; iter < 64; ++iter) {
        const Transform at{xa.p + t * translation, xa.q};
        s.parts.clear();
        // Nothing further than the rest of the path can be reached.
        parts_of(a, at, b, xb, std::max(Real(0), max_fraction - t) * length + 2 * kCastTolerance, s);
        if (s.parts.empty()) return false;
        Real step = std::numeric_limits<Real>::infinity();
        const Part* touching = nullptr;
        for (const Part& p : s.parts) {
            if (p.separation <= kCastTolerance) {
                if (!touching || p.separation < touching->separation) touching = &p;
                continue;
            }
            const Real approach = translation.dot(p.normal);
            if (approach > 0) step = std::min(step, (p.separation - Real(0.5) * kCastTolerance) / approach);
        }
        if (touching) {
            out.fraction = t;
            out.point = touching->point;
            out.normal = -touching->normal;
            return true;
        }
        if (!(step < std::numeric_limits<Real>::infinity())) return false;  // every part moving away
        if (iter == 63) {
            // Not converged (a path grazing a curved surface closes in linearly): the fraction reached is
            // still before the contact and the closest part is where it will be.
            const Part* closest = &*std::min_element(s.parts.begin(), s.parts.end(), [](const Part& x, const Part& y) {
                return x.separation < y.separation;
            });
            out.fraction = t;
            out.point = closest->point;
            out.normal = -closest->normal;
            return true;
        }
        t += step;
        if (t > max_fraction) return false;
    }
    return false;
}

bool closest_points(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real max_distance,
                    ClosestPoints& out) {
    check_cast_shape(a, "closest_points");
    if (!(max_distance >= 0) || !std::isfinite(max_distance))
        throw ShapeError("closest_points: max_distance must be finite and >= 0, got " + std::to_string(max_distance));
    PartScratch& s = scratch();
    s.parts.clear();
    parts_of(a, xa, b, xb, max_distance, s);
    const Part* best = nullptr;
    for (const Part& p : s.parts)
        if (p.separation <= max_distance && (!best || p.separation < best->separation)) best = &p;
    if (!best) return false;
    out.distance = best->separation;
    out.normal = best->normal;
    out.point_a = best->point - Real(0.5) * best->separation * best->normal;
    out.point_b = best->point + Real(0.5) * best->separation * best->normal;
    return true;
}

}  // namespace sinew
