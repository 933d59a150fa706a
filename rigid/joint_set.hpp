// The joints of a rigid system and their solver rows: the first source of outside rows
// (rigid/constraint_rows.hpp), called by every solver like any other source:
//   prepare()    once per step, with the (sub-)step length: anchors, axes, effective masses, biases
//   warm_start() once per (sub-)step, before iterating, if warm starting is on
//   solve()      in each iteration, before the contacts (Box2D's order)
//   finish()     once per step, after integration: position projection (split-impulse mode), reaction
//                forces, and breakable joints whose constraint force exceeded the threshold break
// Velocities are read and written through the solver's BodyVelocities view; poses are read from the
// system's state, so a sub-stepping solver that integrated positions shows the rows the current error.
// The row math is in rigid/joint_rows.hpp and rigid/joint_<type>.cpp.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "rigid/constraint_rows.hpp"
#include "rigid/joint.hpp"

namespace sinew {

class RigidSystem;

class JointSet final : public ConstraintRows {
public:
    JointSet();
    ~JointSet() override;
    JointSet(const JointSet&) = delete;
    JointSet& operator=(const JointSet&) = delete;

    /// Validates (both bodies valid and distinct, at least one dynamic, finite anchors and axis,
    /// lower <= upper, non-negative force limits, ...) and adds. Throws RigidError naming the problem.
    JointId create(const JointDef& def, const RigidSystem& sys);
    void destroy(JointId id);
    bool valid(JointId id) const;
    std::size_t count() const;
    /// Ids of all live joints in slot order.
    std::vector<JointId> ids() const;
    /// Removes every joint attached to body slot `slot` (when the body is destroyed).
    void destroy_attached(std::uint32_t slot);
    /// Clears the accumulated impulses (warm start, reactions) of every joint attached to body slot `slot`:
    /// the body's state was not finite and has been put back (engine/core/step_fault.hpp).
    void forget_impulses(std::uint32_t slot);
    /// Does a live joint connect the two slots with collide_connected == false? (contact filtering)
    bool filters_pair(std::uint32_t a, std::uint32_t b) const;
    /// Changes whenever a joint is created or removed, i.e. whenever filters_pair() may answer differently.
    std::uint64_t filter_revision() const;
    /// Body slots of every live joint (both ends), for islands: calls f(slot_a, slot_b).
    void for_each_connection(const std::function<void(std::uint32_t, std::uint32_t)>& f) const;

    const JointDef& def(JointId id) const;
    /// Force (N) and torque (N m, angular rows only) the joint applied to B in the last step, from the
    /// accumulated impulses / h; A received the opposite.
    Vec3 reaction_force(JointId id) const;
    Vec3 reaction_torque(JointId id) const;
    /// Position error of the joint's linear constraint at the current poses (m): anchor separation for
    /// ball, hinge and fixed joints, offset from the axis for a slider, |distance - length| for a
    /// distance joint (the spring's stretch when it is soft).
    Real position_error(JointId id, const RigidSystem& sys) const;
    /// Angular error at the current poses (rad): hinge axis misalignment; rotation away from the creation
    /// orientation for slider and fixed joints; 0 for ball and distance joints.
    Real angular_error(JointId id, const RigidSystem& sys) const;
    /// The joint's free coordinate at the current poses: hinge angle (rad, 0 at creation), slider
    /// translation (m), distance (m) for a distance joint; 0 for ball and fixed joints.
    Real coordinate(JointId id, const RigidSystem& sys) const;
    /// The rate of coordinate() at the current velocities: hinge rad/s, slider and distance m/s; 0 for
    /// ball and fixed joints.
    Real coordinate_speed(JointId id, const RigidSystem& sys) const;
    /// Changes a hinge / slider motor (validated as in create; throws RigidError). Does not wake the
    /// bodies: call RigidSystem::wake if they may be asleep.
    void set_motor(JointId id, bool enable, Real speed, Real max_force);
    /// Changes a hinge / slider limit (validated as in create: finite, lower <= upper, a hinge's within
    /// [-pi, pi]; throws RigidError). Does not wake the bodies.
    void set_limits(JointId id, bool enable, Real lower, Real upper);

    // ---- ConstraintRows -----------------------------------------------------------------------------
    void prepare(RigidSystem& sys, const RowStep& step) override;
    void warm_start(const RigidSystem& sys, const BodyVelocities& vel) override;
    void solve(const RigidSystem& sys, const BodyVelocities& vel, bool use_bias) override;
    void positions_advanced(const RigidSystem& sys, const BodyVelocities& vel, Real h) override;
    /// Once per step, after positions are integrated: projects the joints' position error out when
    /// prepare() chose projection (sequential impulses with split impulses), records each joint's reaction
    /// force, and breaks joints over their break_force (broken() lists them until the next finish()).
    /// The impulses are divided by the length given to prepare() (the sub-step for a sub-stepping
    /// solver), which is what they accumulated over.
    void finish(RigidSystem& sys, Real h) override;
    /// Whether prepare() found a joint with a moving body.
    bool active() const override;
    /// How many joints the last prepare() found with a moving body (not asleep, disabled or static).
    std::size_t active_count() const;
    /// Joints that broke in the last finish().
    const std::vector<JointId>& broken() const;

private:
    void project_positions(RigidSystem& sys);  ///< finish()'s position projection (see joint_set.cpp)
    struct Impl;  // joints and their prepared rows, defined in joint_set.cpp
    /// prepare()'s groups of the soft step (see Impl::group_start) and their point solves.
    static void group_joints(Impl& m, std::size_t body_slots);
    std::unique_ptr<Impl> impl_;
};

}  // namespace sinew
