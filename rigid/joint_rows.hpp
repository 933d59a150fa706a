// Internal to the joint solver (rigid/joint_*.cpp): a joint's creation-time frames and accumulated
// impulses, its rows prepared for one (sub-)step, and the row algebra shared by the joint types.
//
// Every joint type is built from four kinds of rows (Catto 2005; derivations of J from C-dot below):
//   point block   C = p_B - p_A (3 rows), K = (m_A + m_B) 1 - [r_A]x I_A^-1 [r_A]x - [r_B]x I_B^-1 [r_B]x
//   angular block C = rotation vector of the relative orientation error (3 rows), K = I_A^-1 + I_B^-1
//   pair of rows  two coupled scalar rows solved as a 2x2 block (hinge axis alignment, slider offsets)
//   axial row     one scalar row (hinge / slider motor and limits, distance)
// Each row solve is  lambda = -mass_scale K^-1 (C-dot + bias_rate C) - impulse_scale Lambda  (Catto 2011
// soft constraints in Box2D's form; Baumgarte is bias_rate = beta/h, mass_scale = 1, impulse_scale = 0;
// no bias is bias_rate = 0), and the accumulated Lambda is clamped where the row is an inequality.
// The same row code runs on the bodies' velocities (velocity passes) and on pseudo-velocities that only
// move positions (the position projection pass of rigid/joint_set.cpp), chosen by the RowPass.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "rigid/constraint_rows.hpp"
#include "rigid/joint.hpp"
#include "rigid/rigid_system.hpp"
#include "rigid/soft_constraint.hpp"

namespace sinew::joint_detail {

/// Coefficients of one soft (or Baumgarte, or unbiased) row solve.
struct Softness {
    Real bias_rate = 0;      ///< 1/s: multiplies the position error C
    Real mass_scale = 1;
    Real impulse_scale = 0;
    Real max_error = kRealMax;  ///< m or rad: larger errors are corrected this much per pass (projection)
    Real cap(Real c) const { return std::clamp(c, -max_error, max_error); }
    Vec3 cap(const Vec3& c) const {
        const Real n2 = c.squaredNorm();
        return n2 > max_error * max_error ? Vec3(c * (max_error / std::sqrt(n2))) : c;
    }
};

/// Catto 2011 soft constraint of natural frequency `hertz` and damping ratio `zeta` over a step h
/// (rigid/soft_constraint.hpp), with no cap on the error.
inline Softness make_soft(Real hertz, Real zeta, Real h) {
    const SoftCoefficients c = soft_coefficients(hertz, zeta, h);
    return {c.bias_rate, c.mass_scale, c.impulse_scale};
}

/// Accumulated impulses of a joint's rows over the current (sub-)step (N s, or N m s for angular rows).
struct JointImpulses {
    Vec3 point = Vec3::Zero();    ///< ball, hinge, fixed: world, on B at the anchor
    Vec3 angular = Vec3::Zero();  ///< fixed, slider: world; hinge: (x, y) = the two alignment rows
    Real pair[2] = {0, 0};        ///< slider: the two rows perpendicular to the axis
    Real axial = 0;               ///< distance row
    Real motor = 0, lower = 0, upper = 0;
    void clear() { *this = JointImpulses{}; }
};

/// A joint's fixed data (from its definition at creation) and its accumulated impulses, which persist
/// across steps for warm starting and give the reaction force.
struct JointData {
    JointDef def;          ///< as given; axis normalised and the distance resolved at creation
    Vec3 la, lb;           ///< anchors measured from each body's centre of mass, in body axes (m)
    Vec3 axis_a;           ///< hinge / slider axis in A's axes (unit)
    Vec3 perp_a[2];        ///< completes axis_a to an orthonormal basis (A's axes)
    Vec3 axis_b;           ///< the hinge axis in B's axes (coincides with axis_a in the world at creation)
    Quat rel0;             ///< q_A^-1 q_B at creation: the relative orientation angular rows keep
    JointImpulses impulses;
    // Reaction of the last step (finish()), on B.
    Vec3 reaction_force = Vec3::Zero();   ///< N
    Vec3 reaction_torque = Vec3::Zero();  ///< N m (angular rows only; not r x F)
};

/// A symmetric 2x2 matrix stored as (xx, xy, yy), for two coupled rows.
struct Sym2 {
    Real xx = 0, xy = 0, yy = 0;
    /// Inverse, or zero if singular (both rows have no mobility).
    Sym2 inverse() const {
        const Real det = xx * yy - xy * xy;
        if (!(std::abs(det) > std::numeric_limits<Real>::min())) return {};
        const Real inv = 1 / det;
        return {yy * inv, -xy * inv, xx * inv};
    }
    void mul(Real x, Real y, Real& ox, Real& oy) const {
        ox = xx * x + xy * y;
        oy = xy * x + yy * y;
    }
};

/// One joint's rows for one (sub-)step: the bodies' mass data and the effective masses, computed by
/// prepare() at the poses of that moment. Plain data in a flat array; the solve loops only read it.
struct JointRows {
    std::uint32_t a = 0, b = 0;    ///< body slots
    Real ma = 0, mb = 0;           ///< inverse masses (0 for static, kinematic and sleeping bodies)
    Mat3 ia = Mat3::Zero(), ib = Mat3::Zero();  ///< inverse world inertias
    Mat3 point_mass = Mat3::Zero();    ///< K^-1 of the point block
    Mat3 angular_mass = Mat3::Zero();  ///< (I_A^-1 + I_B^-1)^-1
    Sym2 pair_mass;                    ///< inverse of the 2x2 block (hinge alignment / slider offsets)
    Real axial_mass = 0;               ///< 1 / K of the axial row
    Real h = 0, inv_h = 0;             ///< the (sub-)step length the rows were prepared for
    Softness spring;                   ///< distance joint spring (frequency > 0)
    Real max_motor_impulse = 0;        ///< max_motor_force * h
    bool fresh_point_mass = false;     ///< recompute the point block's K at the current arms (sub-stepping)
    // World directions at prepare time, for the reaction force and torque reported after the step.
    Vec3 dir[3] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
};

/// What one pass over a joint's rows works on: the velocity arrays it reads and updates (the bodies'
/// velocities, or pseudo-velocities in a position projection pass), how bilateral rows and violated
/// limits remove position error, and whether motors and springs act.
struct RowPass {
    BodyVelocities vel;
    Softness bias;      ///< {} = no position bias (relax pass, or velocity pass before a projection)
    bool drive = true;  ///< motors and springs: velocity passes only, never in a projection pass
};

/// Velocities of a joint's two bodies: loaded from the pass's arrays at the start of a joint's rows and
/// stored back at the end, so the rows of one joint work on registers, not on the arrays.
struct PairVelocity {
    Vec3 va, wa, vb, wb;
    PairVelocity(const RowPass& pass, const JointRows& r)
        : va(pass.vel.linear(r.a)), wa(pass.vel.angular(r.a)), vb(pass.vel.linear(r.b)), wb(pass.vel.angular(r.b)) {}
    void store(RowPass& pass, const JointRows& r) const {
        // Immovable bodies keep their velocities (a kinematic body's is the game's).
        if (r.ma != 0) {
            pass.vel.set_linear(r.a, va);
            pass.vel.set_angular(r.a, wa);
        }
        if (r.mb != 0) {
            pass.vel.set_linear(r.b, vb);
            pass.vel.set_angular(r.b, wb);
        }
    }
};

/// Where the joint is now: arms from the centres of mass and the anchor separation d = p_B - p_A.
struct PairPose {
    Quat qa, qb;
    Vec3 ra, rb, d;
    PairPose(const RigidSystem::State& st, const JointData& j, const JointRows& r)
        : qa(st.q[r.a]), qb(st.q[r.b]), ra(qa * j.la), rb(qb * j.lb), d(st.x[r.b] + rb - st.x[r.a] - ra) {}
    PairPose(const RigidSystem::State& st, const JointData& j, std::uint32_t a, std::uint32_t b)
        : qa(st.q[a]), qb(st.q[b]), ra(qa * j.la), rb(qb * j.lb), d(st.x[b] + rb - st.x[a] - ra) {}
};

// ---- row algebra ---------------------------------------------------------------------------------------

/// K^-1 of the point block at arms ra, rb.
inline Mat3 point_block_mass(const JointRows& r, const Vec3& ra, const Vec3& rb) {
    const Mat3 sa = skew(ra), sb = skew(rb);
    const Mat3 k = (r.ma + r.mb) * Mat3::Identity() - sa * r.ia * sa - sb * r.ib * sb;
    return k.inverse();  // closed-form 3x3; SPD since at least one body moves (ma + mb > 0)
}

/// 1 / (I_A^-1 + I_B^-1) as a matrix, or zero when neither body can rotate.
inline Mat3 angular_block_mass(const JointRows& r) {
    const Mat3 k = r.ia + r.ib;
    return std::abs(k.determinant()) > std::numeric_limits<Real>::min() ? Mat3(k.inverse()) : Mat3::Zero();
}

inline Real inverse_or_zero(Real k) { return k > 0 ? 1 / k : 0; }

/// Effective mass of a linear row along unit n with angular arms sa (for A) and sb (for B):
/// C-dot = n.(v_B - v_A) + sb.w_B - sa.w_A.
inline Real linear_row_mass(const JointRows& r, const Vec3& sa, const Vec3& sb) {
    return inverse_or_zero(r.ma + r.mb + sa.dot(r.ia * sa) + sb.dot(r.ib * sb));
}

/// Effective mass of an angular row about unit u: C-dot = u.(w_B - w_A).
inline Real angular_row_mass(const JointRows& r, const Vec3& u) { return inverse_or_zero(u.dot((r.ia + r.ib) * u)); }

/// Impulse P on B at arm rb and -P on A at arm ra.
inline void apply_linear(PairVelocity& p, const JointRows& r, const Vec3& ra, const Vec3& rb, const Vec3& P) {
    p.va -= r.ma * P;
    p.wa -= r.ia * ra.cross(P);
    p.vb += r.mb * P;
    p.wb += r.ib * rb.cross(P);
}

/// Linear row impulse lambda along n with angular arms sa, sb (see linear_row_mass).
inline void apply_linear_row(PairVelocity& p, const JointRows& r, const Vec3& n, const Vec3& sa, const Vec3& sb,
                             Real lambda) {
    p.va -= (r.ma * lambda) * n;
    p.wa -= lambda * (r.ia * sa);
    p.vb += (r.mb * lambda) * n;
    p.wb += lambda * (r.ib * sb);
}

/// Angular impulse L on B and -L on A.
inline void apply_angular(PairVelocity& p, const JointRows& r, const Vec3& L) {
    p.wa -= r.ia * L;
    p.wb += r.ib * L;
}

/// Point block: drives C = pose.d to zero.
inline void solve_point_block(PairVelocity& p, Vec3& acc, const JointRows& r, const PairPose& pose,
                              const Softness& s) {
    const Vec3 cdot = p.vb + p.wb.cross(pose.rb) - p.va - p.wa.cross(pose.ra);
    const Mat3 mass = r.fresh_point_mass ? point_block_mass(r, pose.ra, pose.rb) : r.point_mass;
    const Vec3 impulse = -s.mass_scale * (mass * (cdot + s.bias_rate * s.cap(pose.d))) - s.impulse_scale * acc;
    acc += impulse;
    apply_linear(p, r, pose.ra, pose.rb, impulse);
}

/// Rotation vector (rad, world axes) of B's orientation error relative to "A's orientation times rel0":
/// q_err = q_B (q_A rel0)^-1, C = 2 vec(q_err) with w >= 0 (the small-angle rotation vector, whose
/// derivative is w_B - w_A).
inline Vec3 orientation_error(const Quat& qa, const Quat& qb, const Quat& rel0) {
    Quat e = qb * (qa * rel0).conjugate();
    const Real sign = e.w() < 0 ? Real(-1) : Real(1);
    return (2 * sign) * e.vec();
}

/// Angular block: keeps the relative orientation at rel0 (fixed and slider joints).
inline void solve_angular_block(PairVelocity& p, Vec3& acc, const JointRows& r, const Vec3& c, const Softness& s) {
    const Vec3 cdot = p.wb - p.wa;
    const Vec3 impulse = -s.mass_scale * (r.angular_mass * (cdot + s.bias_rate * s.cap(c))) - s.impulse_scale * acc;
    acc += impulse;
    apply_angular(p, r, impulse);
}

/// One inequality row (lambda >= 0) with effective mass `mass`, C-dot `cdot` and position `c` (>= 0 when
/// the limit holds); returns the change of the accumulated impulse `acc`. A joint short of its limit may
/// approach it by c this step (speculative, as Box2D does: the row needs no activation threshold, is
/// inactive in effect until the limit would be crossed, and a fast joint cannot jump the limit); one past
/// it is pushed back with the pass's bias `s` ({} = only stopped).
inline Real solve_limit_row(Real& acc, Real mass, Real cdot, Real c, const Softness& s, Real inv_h) {
    Real bias = 0, mass_scale = 1, impulse_scale = 0;
    if (c > 0) {
        bias = c * inv_h;  // speculative: may close the gap this step
    } else {
        bias = s.bias_rate * s.cap(c);
        mass_scale = s.mass_scale;
        impulse_scale = s.impulse_scale;
    }
    const Real impulse = -mass_scale * mass * (cdot + bias) - impulse_scale * acc;
    const Real next = std::max(acc + impulse, Real(0));
    const Real delta = next - acc;
    acc = next;
    return delta;
}

/// A motor row: drives C-dot to `speed`, the accumulated impulse bounded by +-max_impulse.
inline Real solve_motor_row(Real& acc, Real mass, Real cdot, Real speed, Real max_impulse) {
    const Real next = std::clamp(acc - mass * (cdot - speed), -max_impulse, max_impulse);
    const Real delta = next - acc;
    acc = next;
    return delta;
}

// ---- per-type rows (rigid/joint_<type>.cpp) --------------------------------------------------------------
// prepare_*: effective masses at the current poses (rows.a/b and the masses already set); also fills
// rows.dir with the world directions of its scalar rows, for the reaction force.
// warm_start_*: applies the accumulated impulses `acc`. solve_*: one pass over the joint's rows,
// accumulating into `acc`. Poses are read from the state (current, so a sub-stepping solver's joints
// see the error after its position updates); velocities come from the pass.

using State = RigidSystem::State;

void prepare_ball(const JointData& j, JointRows& r, const State& st);
void warm_start_ball(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);
void solve_ball(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);

void prepare_hinge(const JointData& j, JointRows& r, const State& st);
void warm_start_hinge(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);
void solve_hinge(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);
/// Hinge angle (rad, (-pi, pi]) of B relative to A about the axis, 0 at creation.
Real hinge_angle(const JointData& j, const Quat& qa, const Quat& qb);

void prepare_slider(const JointData& j, JointRows& r, const State& st);
void warm_start_slider(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);
void solve_slider(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);

void prepare_distance(const JointData& j, JointRows& r, const State& st);
void warm_start_distance(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);
void solve_distance(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);

void prepare_fixed(const JointData& j, JointRows& r, const State& st);
void warm_start_fixed(const JointData& j, const JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);
void solve_fixed(const JointData& j, JointImpulses& acc, const JointRows& r, const State& st, RowPass& pass);

}  // namespace sinew::joint_detail
