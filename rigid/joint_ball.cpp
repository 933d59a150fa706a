// Ball-and-socket joint: the two anchors coincide. One 3x3 point block (Catto 2005):
//   C = p_B - p_A,  C-dot = v_B + w_B x r_B - v_A - w_A x r_A,  J = [-1, [r_A]x, 1, -[r_B]x],
//   K = J M^-1 J^T = (m_A + m_B) 1 - [r_A]x I_A^-1 [r_A]x - [r_B]x I_B^-1 [r_B]x,
// solved as a block with K^-1 so the three rows do not fight each other (a point constraint solved
// row by row converges slowly when the arms are long).
#include "rigid/joint_rows.hpp"

namespace sinew::joint_detail {

void prepare_ball(const JointData& j, JointRows& r, const State& st) {
    const PairPose pose(st, j, r);
    r.point_mass = point_block_mass(r, pose.ra, pose.rb);
}

void warm_start_ball(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass) {
    const PairPose pose(st, j, r);
    PairVelocity p(pass, r);
    apply_linear(p, r, pose.ra, pose.rb, acc.point);
    p.store(pass, r);
}

void solve_ball(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass) {
    const PairPose pose(st, j, r);
    PairVelocity p(pass, r);
    solve_point_block(p, acc.point, r, pose, pass.bias);
    p.store(pass, r);
}

}  // namespace sinew::joint_detail
