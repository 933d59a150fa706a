// Fixed (weld) joint: a point block keeps the anchors together and an angular block keeps B's
// orientation relative to A at its value at creation:
//   C_angular = 2 vec(q_B (q_A rel0)^-1)  (rotation vector of the error, small-angle form),
//   C-dot = w_B - w_A,  K = I_A^-1 + I_B^-1.
// Angular block first, then the point block (Box2D's weld order): the point rows, which carry the
// weight of whatever hangs on the weld, get the last word in each pass.
#include "rigid/joint_rows.hpp"

namespace sinew::joint_detail {

void prepare_fixed(const JointData& j, JointRows& r, const State& st) {
    const PairPose pose(st, j, r);
    r.point_mass = point_block_mass(r, pose.ra, pose.rb);
    r.angular_mass = angular_block_mass(r);
}

void warm_start_fixed(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass) {
    const PairPose pose(st, j, r);
    PairVelocity p(pass, r);
    apply_linear(p, r, pose.ra, pose.rb, acc.point);
    apply_angular(p, r, acc.angular);
    p.store(pass, r);
}

void solve_fixed(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass) {
    const PairPose pose(st, j, r);
    PairVelocity p(pass, r);
    solve_angular_block(p, acc.angular, r, orientation_error(pose.qa, pose.qb, j.rel0), pass.bias);
    solve_point_block(p, acc.point, r, pose, pass.bias);
    p.store(pass, r);
}

}  // namespace sinew::joint_detail
