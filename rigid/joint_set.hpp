// The joints of a rigid system and their solver rows. Solvers call, per step or sub-step:
//   prepare()   once, with the step (or sub-step) length: anchors, axes, effective masses, biases
//   warm_start() once per (sub-)step, before iterating, if warm starting is on
//   solve()     in each iteration, interleaved with the contacts (joints first, as Box2D does)
//   finish()    once per step, after integration: position projection (split-impulse mode), reaction
//               forces, and breakable joints whose constraint force exceeded the threshold break
// Velocities are read and written in the RigidSystem::State arrays; poses are read from it, so a
// sub-stepping solver that integrated positions sees the current error. The row math is in
// rigid/joint_rows.hpp and rigid/joint_<type>.cpp.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "rigid/joint.hpp"

namespace sinew {

class RigidSystem;

/// How joint position error is removed.
struct JointSoftness {
    /// false: Baumgarte's fraction beta of the error per step, as a velocity bias -(beta/h) C, or, with
    /// sequential impulses and split impulses, as a position projection after the step (finish());
    /// true: Catto 2011 soft constraint of `hertz` and `damping_ratio` in the biased passes.
    bool soft = false;
    Real baumgarte = Real(0.2);
    Real hertz = 60;          ///< soft: stiffness (Hz), capped at half the (sub-)step rate
    Real damping_ratio = 2;   ///< soft
};

class JointSet {
public:
    JointSet();
    ~JointSet();
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
    /// Changes a hinge / slider motor (validated as in create; throws RigidError). Does not wake the
    /// bodies: call RigidSystem::wake if they may be asleep.
    void set_motor(JointId id, bool enable, Real speed, Real max_force);

    void prepare(RigidSystem& sys, Real h, const JointSoftness& softness, bool warm);
    void warm_start(RigidSystem& sys);
    void solve(RigidSystem& sys, bool use_bias);
    /// Once per step, after positions are integrated: projects the joints' position error out when
    /// prepare() chose projection (sequential impulses with split impulses: the system given to prepare()
    /// is updated), records each joint's reaction force, and breaks joints over their break_force,
    /// appending their ids to `broken`. `h` is the full step; the impulses are divided by the length
    /// given to prepare() (the sub-step for a sub-stepping solver), which is what they accumulated over.
    void finish(Real h, std::vector<JointId>& broken);

private:
    void project_positions();  ///< finish()'s position projection (see joint_set.cpp)
    struct Impl;  // joints and their prepared rows, defined in joint_set.cpp
    std::unique_ptr<Impl> impl_;
};

}  // namespace sinew
