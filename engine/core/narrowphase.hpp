// Narrow phase: exact contact generation between two placed shapes.
//
// collide() dispatches on the pair of shape types through a table (no virtual calls per pair) and writes
// zero or more manifolds. Every manifold's normal points from A to B, has at most 4 points, and every
// point has a depth (> 0 = penetrating) and a feature id stable under small motion. Points are reported
// when the shapes are closer than `margin` (speculative contacts with negative depth), so a resting
// contact does not flicker between touching and not touching.
#pragma once

#include <vector>

#include "engine/core/manifold.hpp"
#include "engine/core/shape.hpp"

namespace sinew {

using ManifoldList = std::vector<Manifold>;

/// Appends the manifolds of A against B to `out`. Returns the number appended.
int collide(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin,
            ManifoldList& out);

/// Do the shapes overlap or touch (a point of depth >= 0 at margin 0)? `scratch` is the narrow phase's
/// output, reused by the caller so that a query allocates nothing once warm.
bool shapes_touch(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, ManifoldList& scratch);

/// Is there a collision routine for this pair of types (in either order)?
bool can_collide(ShapeType a, ShapeType b);

// Pair routines. Each writes at most one manifold into `m` (normal from A to B) and returns whether it
// has points. They are called with the first argument's type as named.
namespace narrow {
bool sphere_sphere(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m);
bool sphere_capsule(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m);
bool sphere_box(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m);
bool capsule_capsule(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m);
bool capsule_box(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m);
bool box_box(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m);
/// Any convex pair not covered above (hulls with anything convex): libccd GJK/EPA (or MPR) for the
/// normal and depth, then reference-face clipping for a multi-point manifold.
bool convex_convex(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m);
/// Convex shape A against a static plane B.
bool convex_plane(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin, Manifold& m);
/// Convex shape A against one triangle (world coordinates), normal from A to the triangle.
bool convex_triangle(const Shape& a, const Transform& xa, const Triangle& tri, Real margin, Manifold& m);
}  // namespace narrow

}  // namespace sinew
