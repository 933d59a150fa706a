// Shape casts and closest points: a convex shape (or a compound of them) moved along a straight line
// against any shape, and the distance between two shapes.
//
// Both rest on the narrow phase's separated answers (speculative contacts): GJK's exact distance between
// the shapes' cores for convex pairs (narrow::convex_convex, van den Bergen 2003), the exact distance to a
// plane, GJK against each nearby triangle of a mesh. A compound is its children, part by part.
//
// The cast is conservative advancement (Mirtich 1996) for a translation: for each part within reach, the
// separation along its closest-point normal n shrinks at exactly translation . n per unit of fraction,
// and no part can touch before that linear bound reaches zero, so stepping by the smallest
// sep_i / (translation . n_i) over the parts never passes the first contact. For a convex pair the
// distance along a straight path is convex in the fraction, so the steps are Newton's iterations on it
// from the left and converge quadratically (one step for a face met head on). A part moving away from its
// closest points (translation . n <= 0) never touches. Translation only: the shape keeps its rotation.
#pragma once

#include "engine/core/shape.hpp"

namespace sinew {

/// Where a cast shape first touches another.
struct ShapeCastHit {
    Real fraction = 0;            ///< of the translation, in [0, max_fraction]; 0 if they overlap at the start
    Vec3 point = Vec3::Zero();    ///< world (m): where they touch at that fraction
    Vec3 normal = Vec3::UnitY();  ///< unit, world: the target's surface normal there, toward the cast shape
};

/// The closest points of two shapes.
struct ClosestPoints {
    Real distance = 0;            ///< m; negative: they overlap by that much (a penetration depth)
    Vec3 point_a = Vec3::Zero();  ///< world, on A's surface
    Vec3 point_b = Vec3::Zero();  ///< world, on B's surface
    Vec3 normal = Vec3::UnitY();  ///< unit, world, from A to B
};

/// The casts stop when the shapes are this close (m): the fraction is then within this distance over the
/// translation's length of the exact time of impact.
constexpr Real kCastTolerance = Real(1e-5);

/// Moves `a` from `xa` by fraction * `translation` for fraction in [0, max_fraction] and finds where it first
/// touches `b` at `xb`. `a` must be a sphere, box, capsule, hull or compound of them; `b` any shape.
/// False if they do not touch. Throws ShapeError for a shape `a` cannot be.
bool shape_cast(const Shape& a, const Transform& xa, const Vec3& translation, const Shape& b, const Transform& xb,
                Real max_fraction, ShapeCastHit& out);

/// The closest points of `a` (as for shape_cast) and `b` if their distance is at most `max_distance` (m,
/// >= 0); false otherwise. Overlapping shapes give a negative distance (the deepest part's depth).
bool closest_points(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real max_distance,
                    ClosestPoints& out);

}  // namespace sinew
