// Fixed (weld) joint: a point block keeps the anchors together and an angular block keeps B's
// orientation relative to A at its value at creation:
//   C_angular = 2 vec(q_B (q_A rel0)^-1)  (rotation vector of the error, small-angle form),
//   C-dot = w_B - w_A,  K = I_A^-1 + I_B^-1.
// Angular block first, then the point block (Box2D's weld order): the point rows, which carry the
// weight of whatever hangs on the weld, get the last word in each pass.
#include "rigid/joint_rows.hpp"

namespace sinew::joint_detail {

void prepare_fixed(const JointData& j, JointRows& r, const RigidSystem::State& st) {
    const PairPose pose(st, j, r);
    r.point_mass = point_block_mass(r, pose.ra, pose.rb);
    r.angular_mass = angular_block_mass(r);
}

void warm_start_fixed(const JointData& j, const JointRows& r, RigidSystem::State& st) {
    const PairPose pose(st, j, r);
    PairVelocity p(st, r);
    apply_linear(p, r, pose.ra, pose.rb, j.point_impulse);
    apply_angular(p, r, j.angular_impulse);
    p.store(st, r);
}

void solve_fixed(JointData& j, const JointRows& r, RigidSystem::State& st, bool use_bias) {
    const PairPose pose(st, j, r);
    PairVelocity p(st, r);
    const Softness s = use_bias ? r.soft : Softness{};
    solve_angular_block(p, j.angular_impulse, r, orientation_error(pose.qa, pose.qb, j.rel0), s);
    solve_point_block(p, j.point_impulse, r, pose, s);
    p.store(st, r);
}

}  // namespace sinew::joint_detail
