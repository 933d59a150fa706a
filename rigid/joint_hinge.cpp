// Hinge (revolute) joint: a ball joint plus two angular rows that keep B's hinge axis a_2 aligned with
// A's a_1, an optional limit on the angle about the axis and an optional motor.
//
// Alignment rows (as Jolt's hinge): with b_1, b_2 perpendicular to a_1 (carried by A),
//   C_i = a_2 . b_i,  C-dot_i = (w_B x a_2).b_i + a_2.(w_A x b_i) = (w_B - w_A).(a_2 x b_i),
// so J_i = [0, -c_i, 0, c_i] with c_i = a_2 x b_i, solved as a 2x2 block K_ij = c_i.(I_A^-1 + I_B^-1) c_j.
// Axis rows (motor, lower and upper limit): C-dot = a_1.(w_B - w_A), K = a_1.(I_A^-1 + I_B^-1) a_1.
// Order within a pass (Box2D's revolute joint): motor, limits, alignment, point, so the rows that must
// hold exactly come last.
#include <cmath>

#include "rigid/joint_rows.hpp"

namespace sinew::joint_detail {

namespace {

/// The hinge's world axes at the given orientations.
struct HingeAxes {
    Vec3 a1, a2, b[2], c[2];
    HingeAxes(const JointData& j, const Quat& qa, const Quat& qb) {
        a1 = qa * j.axis_a;
        a2 = qb * j.axis_b;
        for (int i = 0; i < 2; ++i) {
            b[i] = qa * j.perp_a[i];
            c[i] = a2.cross(b[i]);
        }
    }
};

}  // namespace

Real hinge_angle(const JointData& j, const Quat& qa, const Quat& qb) {
    // Relative orientation r = q_A^-1 q_B; e = r rel0^-1 is the rotation since creation in A's axes, a
    // pure rotation about axis_a for a perfect hinge. Its twist about the axis (swing-twist
    // decomposition) is the angle: 2 atan2(e.vec . axis, e.w) with e.w >= 0.
    Quat e = qa.conjugate() * qb * j.rel0.conjugate();
    const Real sign = e.w() < 0 ? Real(-1) : Real(1);
    return 2 * std::atan2(sign * e.vec().dot(j.axis_a), sign * e.w());
}

void prepare_hinge(const JointData& j, JointRows& r, const State& st) {
    const PairPose pose(st, j, r);
    r.point_mass = point_block_mass(r, pose.ra, pose.rb);
    const HingeAxes ax(j, pose.qa, pose.qb);
    const Mat3 isum = r.ia + r.ib;
    Sym2 k;
    k.xx = ax.c[0].dot(isum * ax.c[0]);
    k.xy = ax.c[0].dot(isum * ax.c[1]);
    k.yy = ax.c[1].dot(isum * ax.c[1]);
    r.pair_mass = k.inverse();
    r.axial_mass = angular_row_mass(r, ax.a1);
    r.dir[0] = ax.a1;
    r.dir[1] = ax.c[0];
    r.dir[2] = ax.c[1];
}

void warm_start_hinge(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass) {
    const PairPose pose(st, j, r);
    const HingeAxes ax(j, pose.qa, pose.qb);
    PairVelocity p(pass, r);
    apply_linear(p, r, pose.ra, pose.rb, acc.point);
    const Real axial = acc.motor + acc.lower - acc.upper;
    apply_angular(p, r, acc.angular.x() * ax.c[0] + acc.angular.y() * ax.c[1] + axial * ax.a1);
    p.store(pass, r);
}

void solve_hinge(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass) {
    const PairPose pose(st, j, r);
    const HingeAxes ax(j, pose.qa, pose.qb);
    PairVelocity p(pass, r);
    const JointDef& d = j.def;
    const Softness& s = pass.bias;

    if (d.enable_motor && pass.drive) {
        const Real cdot = ax.a1.dot(p.wb - p.wa);
        const Real dl = solve_motor_row(acc.motor, r.axial_mass, cdot, d.motor_speed, r.max_motor_impulse);
        apply_angular(p, r, dl * ax.a1);
    }
    if (d.enable_limit) {
        const Real angle = hinge_angle(j, pose.qa, pose.qb);
        {  // lower: C = angle - lower >= 0
            const Real cdot = ax.a1.dot(p.wb - p.wa);
            const Real dl = solve_limit_row(acc.lower, r.axial_mass, cdot, angle - d.lower, s, r.inv_h);
            apply_angular(p, r, dl * ax.a1);
        }
        {  // upper: C = upper - angle >= 0, so J is negated
            const Real cdot = ax.a1.dot(p.wa - p.wb);
            const Real dl = solve_limit_row(acc.upper, r.axial_mass, cdot, d.upper - angle, s, r.inv_h);
            apply_angular(p, r, -dl * ax.a1);
        }
    }
    {  // axis alignment, 2x2 block: C_i = a_2 . b_i
        const Vec3 dw = p.wb - p.wa;
        const Real rhs0 = ax.c[0].dot(dw) + s.bias_rate * s.cap(ax.a2.dot(ax.b[0]));
        const Real rhs1 = ax.c[1].dot(dw) + s.bias_rate * s.cap(ax.a2.dot(ax.b[1]));
        Real m0, m1;
        r.pair_mass.mul(rhs0, rhs1, m0, m1);
        const Real l0 = -s.mass_scale * m0 - s.impulse_scale * acc.angular.x();
        const Real l1 = -s.mass_scale * m1 - s.impulse_scale * acc.angular.y();
        acc.angular.x() += l0;
        acc.angular.y() += l1;
        apply_angular(p, r, l0 * ax.c[0] + l1 * ax.c[1]);
    }
    solve_point_block(p, acc.point, r, pose, s);
    p.store(pass, r);
}

}  // namespace sinew::joint_detail
