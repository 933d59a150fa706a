// Joints between rigid bodies, solved in the same velocity-constraint framework as contacts
// (Catto 2005/2011): each joint is prepared once per (sub-)step into rows with effective masses and
// biases, warm started from its accumulated impulses, and iterated alongside the contacts.
//
// Conventions (all SI):
// - Anchors are points in each body's ORIGIN frame (the frame its shape is placed in), in metres; the
//   joint works at the world points pose_a(local_anchor_a) and pose_b(local_anchor_b).
// - The hinge / slider axis is given in A's origin frame; its direction in B is fixed at creation, so the
//   two bodies' relative orientation at creation is the joint's zero (hinge angle 0, slider and fixed
//   joints keep exactly that orientation).
// - Hinge angle: rotation of B relative to A about the axis (right-handed), in (-pi, pi] rad, 0 at
//   creation. Slider translation: (anchor_b - anchor_a) . axis in metres, with the axis carried by A.
// - Impulses are applied to B with a plus sign and to A with a minus sign; reaction_force() is the force
//   the joint applies to B.
//
// Interface only; the implementation lives in rigid/joint_set.cpp and rigid/joint_<type>.cpp.
#pragma once

#include <cstdint>
#include <vector>

#include "engine/core/math.hpp"
#include "rigid/rigid_body.hpp"

namespace sinew {

enum class JointType : std::uint8_t {
    Ball,      ///< ball-and-socket: anchors coincide (3 rows)
    Hinge,     ///< revolute about an axis: ball + 2 angular rows; optional limit and motor
    Slider,    ///< prismatic along an axis: 2 linear + 3 angular rows; optional limit and motor
    Distance,  ///< keeps anchor distance: rigid, or a spring (frequency in Hz, damping ratio)
    Fixed      ///< weld: 3 linear + 3 angular rows
};
/// "ball", "hinge", "slider", "distance", "fixed".
const char* joint_type_name(JointType t);

/// Generational handle, as BodyId.
struct JointId {
    std::uint32_t index = 0;
    std::uint32_t generation = 0;
    bool is_null() const { return generation == 0; }
    bool operator==(const JointId& o) const { return index == o.index && generation == o.generation; }
    bool operator!=(const JointId& o) const { return !(*this == o); }
};

struct JointDef {
    JointType type = JointType::Ball;
    BodyId body_a, body_b;             ///< distinct, at least one dynamic; body_b may be static (pin to the world)
    Vec3 local_anchor_a = Vec3::Zero();  ///< m, in A's body frame (origin frame, not centre of mass)
    Vec3 local_anchor_b = Vec3::Zero();  ///< m, in B's body frame
    Vec3 local_axis_a = Vec3::UnitZ();   ///< hinge / slider axis in A's frame (non-zero; normalised on creation)
    bool collide_connected = false;     ///< contacts between the two bodies (off by default)
    // Limits (hinge: rad within [-pi, pi], slider: m), motors (hinge: rad/s and N m, slider: m/s and N).
    // The limit is an inequality on the hinge angle / slider translation; the motor drives its rate to
    // motor_speed with a force bounded by max_motor_force.
    bool enable_limit = false;
    Real lower = 0, upper = 0;           ///< lower <= upper (checked even when the limit is off)
    bool enable_motor = false;
    Real motor_speed = 0;
    Real max_motor_force = 0;  ///< >= 0; max torque (N m) for a hinge, max force (N) for a slider
    // Distance joint: rest length (negative = the distance at creation), and softness.
    Real length = -1;          ///< m; the resolved rest length must be > 0
    Real frequency = 0;        ///< Hz, >= 0; 0 = rigid, > 0 = a spring of this natural frequency
    Real damping_ratio = 0;    ///< >= 0, of the spring (1 = critical)
    /// Break when the constraint force exceeds this (N; torque rows count as N m). 0 = unbreakable.
    Real break_force = 0;
    /// Hinge, slider, fixed: the relative orientation q_A^-1 q_B at which the joint is at its zero (hinge
    /// angle 0; the orientation slider and fixed joints keep). All zero (the default) = the bodies'
    /// relative orientation at creation. JointSet::def() returns the one in use, so a saved scene can
    /// recreate a joint whose bodies have moved since with the same zero (engine/world/scene_save.cpp).
    Quat reference_rotation = Quat(0, 0, 0, 0);
    std::uint64_t user_data = 0;
};

}  // namespace sinew
