// Distance joint: keeps the anchors `length` apart, rigidly or as a spring.
//   C = |d| - L with d = p_B - p_A,  n = d / |d|,  C-dot = n.(v_B + w_B x r_B - v_A - w_A x r_A)
// (the change of n is perpendicular to d, so it drops out). One bilateral row.
//
// The spring (frequency f > 0) is Catto's 2011 soft constraint with the joint's own f and damping
// ratio: implicit Euler of a damped spring on the row's effective mass, so it is unconditionally stable
// however stiff, and for a body whose anchor is its centre of mass it oscillates at exactly f (up to
// the integrator's O((2 pi f h)^2) frequency error). Being a physical force, not position correction,
// it acts in the unbiased (relax) pass too, as in Box2D v3.
#include "rigid/joint_rows.hpp"

namespace sinew::joint_detail {

namespace {

// Below this separation the direction of d is undefined and the row is skipped for the pass (the joint
// then only acts once the anchors separate); 1e-6 m is far below any useful rest length.
constexpr Real kMinSeparation = Real(1e-6);

}  // namespace

void prepare_distance(const JointData& j, JointRows& r, const State& st) {
    const PairPose pose(st, j, r);
    const Real len = pose.d.norm();
    const Vec3 n = len > kMinSeparation ? Vec3(pose.d / len) : Vec3::Zero();
    r.axial_mass = len > kMinSeparation ? linear_row_mass(r, pose.ra.cross(n), pose.rb.cross(n)) : 0;
    r.dir[0] = n;
}

void warm_start_distance(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st,
                         RowPass& pass) {
    const PairPose pose(st, j, r);
    const Real len = pose.d.norm();
    if (!(len > kMinSeparation)) return;
    PairVelocity p(pass, r);
    apply_linear(p, r, pose.ra, pose.rb, (acc.axial / len) * pose.d);
    p.store(pass, r);
}

void solve_distance(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass) {
    const bool spring = j.def.frequency > 0;
    if (spring && !pass.drive) return;  // a spring has no position to project to
    const PairPose pose(st, j, r);
    const Real len = pose.d.norm();
    if (!(len > kMinSeparation)) return;
    const Vec3 n = pose.d / len;
    PairVelocity p(pass, r);
    const Real cdot = n.dot(p.vb + p.wb.cross(pose.rb) - p.va - p.wa.cross(pose.ra));
    const Softness& s = spring ? r.spring : pass.bias;
    const Real c = s.cap(len - j.def.length);
    const Real lambda = -s.mass_scale * r.axial_mass * (cdot + s.bias_rate * c) - s.impulse_scale * acc.axial;
    acc.axial += lambda;
    apply_linear(p, r, pose.ra, pose.rb, lambda * n);
    p.store(pass, r);
}

}  // namespace sinew::joint_detail
