// Mass, centre of mass and inertia tensor of a shape at uniform density.
#pragma once

#include "engine/core/shape.hpp"

namespace sinew {

struct MassProperties {
    Real mass = 0;                  ///< kg
    Vec3 center = Vec3::Zero();     ///< centre of mass in the shape frame (m)
    Mat3 inertia = Mat3::Zero();    ///< inertia tensor about `center`, shape-frame axes (kg m^2)
    Real volume = 0;                ///< m^3
};

/// Closed forms for sphere, box and capsule; the divergence theorem over tetrahedra for convex hulls
/// (Mirtich 1996 / Eberly); compounds sum their children with the parallel-axis theorem. Planes and
/// triangle meshes are static and have no mass: throws ShapeError. Throws for density <= 0 or not finite.
MassProperties compute_mass_properties(const Shape& shape, Real density);

/// Same shape scaled to a given total mass (density = mass / volume).
MassProperties mass_properties_for_mass(const Shape& shape, Real mass);

}  // namespace sinew
