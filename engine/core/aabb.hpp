// Axis-aligned bounding boxes.
#pragma once

#include "engine/core/math.hpp"

namespace sinew {

struct Aabb {
    Vec3 lo = Vec3::Constant(kRealMax);
    Vec3 hi = Vec3::Constant(-kRealMax);

    bool overlaps(const Aabb& b) const {
        return lo.x() <= b.hi.x() && b.lo.x() <= hi.x() && lo.y() <= b.hi.y() && b.lo.y() <= hi.y() &&
               lo.z() <= b.hi.z() && b.lo.z() <= hi.z();
    }
    bool contains(const Aabb& b) const {
        return lo.x() <= b.lo.x() && lo.y() <= b.lo.y() && lo.z() <= b.lo.z() && b.hi.x() <= hi.x() &&
               b.hi.y() <= hi.y() && b.hi.z() <= hi.z();
    }
    bool contains(const Vec3& x) const {
        return lo.x() <= x.x() && x.x() <= hi.x() && lo.y() <= x.y() && x.y() <= hi.y() && lo.z() <= x.z() &&
               x.z() <= hi.z();
    }
    Aabb merged(const Aabb& b) const { return {lo.cwiseMin(b.lo), hi.cwiseMax(b.hi)}; }
    Aabb fattened(Real margin) const { return {lo.array() - margin, hi.array() + margin}; }
    void grow(const Vec3& x) {
        lo = lo.cwiseMin(x);
        hi = hi.cwiseMax(x);
    }
    Vec3 center() const { return Real(0.5) * (lo + hi); }
    Vec3 extent() const { return hi - lo; }
    /// Surface area, the cost the dynamic tree minimises (surface-area heuristic).
    Real area() const {
        Vec3 e = hi - lo;
        return Real(2) * (e.x() * e.y() + e.y() * e.z() + e.z() * e.x());
    }
    bool valid() const { return lo.x() <= hi.x() && lo.y() <= hi.y() && lo.z() <= hi.z(); }
};

}  // namespace sinew
