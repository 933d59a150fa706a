// What the soft system collides its particles with: rigid shapes placed in the world for this step.
//
// The soft layer does not know the rigid system (dependencies point core <- rigid, soft <- coupling): a
// coupling layer (coupling/one_way_coupling.hpp) or a test fills SoftSystem::colliders() before the soft
// system's IntegratePositions stage. The contacts the soft system finds are kept as ParticleContact records,
// with the impulse each particle received, so two-way layers can apply the reaction to the rigid body.
#pragma once

#include <cstdint>

#include "engine/core/aabb.hpp"
#include "engine/core/collision_filter.hpp"
#include "engine/core/shape.hpp"

namespace sinew {

constexpr std::uint32_t kNoOwner = 0xffffffffu;

struct Collider {
    const Shape* shape = nullptr;  ///< not owned; must outlive the step
    Transform xf;                  ///< shape frame in the world, at the end of the step
    Vec3 com = Vec3::Zero();       ///< centre of mass (world), for the velocity of a surface point
    Vec3 v = Vec3::Zero();         ///< linear velocity of the centre of mass (m/s)
    Vec3 w = Vec3::Zero();         ///< angular velocity (rad/s)
    Aabb box;                      ///< world bounds of the shape
    Real friction = Real(0.5);     ///< already combined with nothing: the soft body's own is mixed in
    Real restitution = 0;
    std::uint32_t owner = kNoOwner;  ///< rigid body slot (for coupling layers), or kNoOwner
    std::uint8_t dynamic = 0;        ///< 1 if the owner is a dynamic rigid body (two-way layers push it)
    CollisionFilter filter;          ///< the owner's: a soft body whose filter excludes it ignores this collider

    Vec3 point_velocity(const Vec3& p) const { return v + w.cross(p - com); }
};

/// One particle touching one collider during the last step.
struct ParticleContact {
    std::uint32_t body = 0;      ///< soft body slot
    std::uint32_t particle = 0;  ///< index in that body
    std::uint32_t collider = 0;  ///< index into that step's colliders
    Vec3 normal = Vec3::UnitY(); ///< unit, from the collider towards the particle
    Vec3 point = Vec3::Zero();   ///< on the collider's surface (world)
    Real depth = 0;              ///< penetration found before projection (m, >= 0)
    Vec3 impulse = Vec3::Zero(); ///< impulse the particle received (N s); the collider takes -impulse at point
};

}  // namespace sinew
