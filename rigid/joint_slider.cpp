// Slider (prismatic) joint: B translates along an axis carried by A and keeps its orientation relative
// to A. Two linear rows keep the anchor separation d = p_B - p_A perpendicular to the axis, a 3x3
// angular block locks the relative rotation, and an optional limit and motor act along the axis.
//
// Linear row along a direction n carried by A (n = axis or one of its perpendiculars):
//   C = d.n,  C-dot = n.(v_B + w_B x r_B - v_A - w_A x r_A) + d.(w_A x n)
//         = n.(v_B - v_A) + (r_B x n).w_B - ((r_A + d) x n).w_A,
// so A's angular arm is r_A + d (the point of B's anchor, seen from A) and B's is r_B.
// Order within a pass (Box2D's prismatic joint): motor, limits, angular block, perpendicular rows.
#include "rigid/joint_rows.hpp"

namespace sinew::joint_detail {

namespace {

/// The slider's world directions and row arms at the current poses.
struct SliderRows {
    Vec3 n[3];          // axis, perpendicular 1, perpendicular 2
    Vec3 sa[3], sb[3];  // angular arms of each row
    SliderRows(const JointData& j, const PairPose& pose) {
        n[0] = pose.qa * j.axis_a;
        n[1] = pose.qa * j.perp_a[0];
        n[2] = pose.qa * j.perp_a[1];
        const Vec3 arm_a = pose.ra + pose.d;
        for (int i = 0; i < 3; ++i) {
            sa[i] = arm_a.cross(n[i]);
            sb[i] = pose.rb.cross(n[i]);
        }
    }
    Real cdot(int i, const PairVelocity& p) const { return n[i].dot(p.vb - p.va) + sb[i].dot(p.wb) - sa[i].dot(p.wa); }
};

}  // namespace

void prepare_slider(const JointData& j, JointRows& r, const State& st) {
    const PairPose pose(st, j, r);
    const SliderRows rows(j, pose);
    Sym2 k;
    k.xx = r.ma + r.mb + rows.sa[1].dot(r.ia * rows.sa[1]) + rows.sb[1].dot(r.ib * rows.sb[1]);
    k.xy = rows.sa[1].dot(r.ia * rows.sa[2]) + rows.sb[1].dot(r.ib * rows.sb[2]);  // n1.n2 = 0
    k.yy = r.ma + r.mb + rows.sa[2].dot(r.ia * rows.sa[2]) + rows.sb[2].dot(r.ib * rows.sb[2]);
    r.pair_mass = k.inverse();
    r.angular_mass = angular_block_mass(r);
    r.axial_mass = linear_row_mass(r, rows.sa[0], rows.sb[0]);
    for (int i = 0; i < 3; ++i) r.dir[i] = rows.n[i];
}

void warm_start_slider(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass) {
    const PairPose pose(st, j, r);
    const SliderRows rows(j, pose);
    PairVelocity p(pass, r);
    const Real axial = acc.motor + acc.lower - acc.upper;
    apply_linear_row(p, r, rows.n[0], rows.sa[0], rows.sb[0], axial);
    apply_linear_row(p, r, rows.n[1], rows.sa[1], rows.sb[1], acc.pair[0]);
    apply_linear_row(p, r, rows.n[2], rows.sa[2], rows.sb[2], acc.pair[1]);
    apply_angular(p, r, acc.angular);
    p.store(pass, r);
}

void solve_slider(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass) {
    const PairPose pose(st, j, r);
    const SliderRows rows(j, pose);
    PairVelocity p(pass, r);
    const JointDef& d = j.def;
    const Softness& s = pass.bias;

    if (d.enable_motor && pass.drive) {
        const Real dl = solve_motor_row(acc.motor, r.axial_mass, rows.cdot(0, p), d.motor_speed, r.max_motor_impulse);
        apply_linear_row(p, r, rows.n[0], rows.sa[0], rows.sb[0], dl);
    }
    if (d.enable_limit) {
        const Real translation = pose.d.dot(rows.n[0]);
        {  // lower: C = translation - lower >= 0
            const Real dl = solve_limit_row(acc.lower, r.axial_mass, rows.cdot(0, p), translation - d.lower, s, r.inv_h);
            apply_linear_row(p, r, rows.n[0], rows.sa[0], rows.sb[0], dl);
        }
        {  // upper: C = upper - translation >= 0, J negated
            const Real dl = solve_limit_row(acc.upper, r.axial_mass, -rows.cdot(0, p), d.upper - translation, s, r.inv_h);
            apply_linear_row(p, r, rows.n[0], rows.sa[0], rows.sb[0], -dl);
        }
    }
    solve_angular_block(p, acc.angular, r, orientation_error(pose.qa, pose.qb, j.rel0), s);
    {  // perpendicular rows, 2x2 block: C_i = d.n_i
        const Real rhs0 = rows.cdot(1, p) + s.bias_rate * s.cap(pose.d.dot(rows.n[1]));
        const Real rhs1 = rows.cdot(2, p) + s.bias_rate * s.cap(pose.d.dot(rows.n[2]));
        Real m0, m1;
        r.pair_mass.mul(rhs0, rhs1, m0, m1);
        const Real l0 = -s.mass_scale * m0 - s.impulse_scale * acc.pair[0];
        const Real l1 = -s.mass_scale * m1 - s.impulse_scale * acc.pair[1];
        acc.pair[0] += l0;
        acc.pair[1] += l1;
        apply_linear_row(p, r, rows.n[1], rows.sa[1], rows.sb[1], l0);
        apply_linear_row(p, r, rows.n[2], rows.sa[2], rows.sb[2], l1);
    }
    p.store(pass, r);
}

}  // namespace sinew::joint_detail
