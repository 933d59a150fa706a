// Rigid-body definitions and handles.
#pragma once

#include <cstdint>

#include "engine/core/collision_filter.hpp"
#include "engine/core/math.hpp"
#include "engine/core/shape.hpp"

namespace sinew {

enum class BodyType : std::uint8_t {
    Static,     ///< never moves, infinite mass
    Kinematic,  ///< moved by the game through its velocity, infinite mass, pushes dynamic bodies
    Dynamic     ///< moved by forces and contacts
};
const char* body_type_name(BodyType t);

/// Generational handle: index into the body arrays plus the generation of that slot. Zero generation is
/// never issued, so a value-initialised BodyId is null and a stale id (slot reused) is detected.
struct BodyId {
    std::uint32_t index = 0;
    std::uint32_t generation = 0;
    bool is_null() const { return generation == 0; }
    bool operator==(const BodyId& o) const { return index == o.index && generation == o.generation; }
    bool operator!=(const BodyId& o) const { return !(*this == o); }
};

/// A BodyId in 64 bits, for layers that keep rigid bodies as opaque numbers (a soft body's attachment
/// targets, the C API's handles).
inline std::uint64_t pack_body_id(BodyId id) { return (std::uint64_t(id.generation) << 32) | id.index; }
inline BodyId unpack_body_id(std::uint64_t v) {
    return {static_cast<std::uint32_t>(v & 0xffffffffu), static_cast<std::uint32_t>(v >> 32)};
}

struct Material {
    Real friction = Real(0.6);     ///< Coulomb coefficient (dimensionless), >= 0
    Real restitution = 0;          ///< [0, 1]
    Real density = 1000;           ///< kg/m^3; used when BodyDef::mass is 0
};

struct BodyDef {
    BodyType type = BodyType::Dynamic;
    Transform pose;                  ///< body origin in the world (m); the shape is placed in this frame
    Vec3 linear_velocity = Vec3::Zero();   ///< m/s, of the centre of mass
    Vec3 angular_velocity = Vec3::Zero();  ///< rad/s
    Shape shape;
    Material material;
    Real mass = 0;                   ///< kg; if > 0 overrides material.density (density = mass / volume)
    Real linear_damping = 0;         ///< 1/s, v *= 1 / (1 + h c)
    Real angular_damping = 0;        ///< 1/s
    Real gravity_scale = 1;
    bool allow_sleep = true;
    CollisionFilter filter;          ///< which bodies this one may touch (engine/core/collision_filter.hpp)
    /// A sensor (trigger volume) detects the bodies that overlap it and never touches them: no contacts, no
    /// soft-body collisions, not found by ray casts or overlap queries. Its shape must be a sphere, box,
    /// capsule, hull or compound. Fixed at creation. What it detects: World::sensor_events().
    bool sensor = false;
    /// A bullet (Box2D's isBullet): continuous collision against dynamic bodies too, not only static and
    /// kinematic ones (RigidSettings::continuous, rigid/rigid_continuous.cpp). For small fast bodies such as
    /// projectiles; dynamic bodies only.
    bool bullet = false;
    std::uint64_t user_data = 0;
};

}  // namespace sinew
