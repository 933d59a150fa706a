// Ray casts against placed shapes: the first point where the segment from -> to enters a shape.
//
// A ray that starts inside a solid shape (sphere, box, capsule, hull, or below a plane) reports no hit,
// as in Box2D and Jolt's default: a query from inside a body is about what lies beyond it. Triangle
// meshes are surfaces and are hit from either side.
#pragma once

#include "engine/core/shape.hpp"

namespace sinew {

struct RayHit {
    Real fraction = 1;             ///< t in [0, 1]: the hit is at from + t (to - from)
    Vec3 point = Vec3::Zero();     ///< world
    Vec3 normal = Vec3::UnitY();   ///< unit, world, facing against the ray
};

/// The first hit of the segment against `shape` placed at `xf`, with fraction <= max_fraction. Returns
/// false if there is none.
bool ray_cast(const Shape& shape, const Transform& xf, const Vec3& from, const Vec3& to, Real max_fraction,
              RayHit& hit);

}  // namespace sinew
