// The point blocks of all joints (ball, hinge, fixed: C = p_B - p_A, 3 rows each) solved together and
// exactly, after the Gauss-Seidel sweeps of a soft-step pass (rigid/joint_set.cpp). Sweeping joint by
// joint converges slowly where masses differ: a 20-link chain of 1 kg links with a 100 kg end (issue 14)
// kept 12.8 mm of stretch after 50 sweeps at 120 Hz, and stiffer joints, which would stretch less, blew
// up at 2 sweeps (300 Hz) because the unconverged sweeps feed their error back. Solved exactly, the soft
// rows are stable at any stiffness (Catto 2011: a soft constraint is an implicit spring), so the point
// blocks can be much stiffer than the other rows.
//
// The exact solve is the fixed point of block sweeps at the point blocks' own softness: for every joint k,
//     mass_scale K_k^-1 (C-dot_k + bias_rate C_k) + impulse_scale (Lambda_k + dLambda_k) = 0
// with C-dot_k after all the dLambda are applied, i.e. with gamma = impulse_scale / mass_scale,
//     (J M^-1 J^T + gamma blockdiag(K)) dLambda = -(J v + bias_rate C) - gamma blockdiag(K) Lambda,
// where K_k, the joint's own 3x3 block of J M^-1 J^T, is (m_A + m_B) 1 - [r_A]x I_A^-1 [r_A]x - [r_B]x
// I_B^-1 [r_B]x. Joints couple through the bodies they share; a chain's matrix is block tridiagonal and
// its sparse LDL^T (Eigen's SimplicialLDLT; the pattern ordered and analysed once while the joints and
// their movable bodies stand) costs O(n). Solved in double whatever Real is: the diagonal of a 1:100
// chain spans four orders of magnitude. The matrix's values are written in place through indices found
// when the pattern is built, then copied into the ordered matrix, which is factorised where it is.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "rigid/joint_rows.hpp"

namespace sinew::joint_detail {

/// True for the joint types with a point block.
inline bool has_point_block(JointType t) { return t == JointType::Ball || t == JointType::Hinge || t == JointType::Fixed; }

class JointPointSolve {
public:
    JointPointSolve();
    ~JointPointSolve();
    JointPointSolve(const JointPointSolve&) = delete;
    JointPointSolve& operator=(const JointPointSolve&) = delete;

    /// Once per step, after the rows are prepared: the joints among the `count` slots at `active` that
    /// have a point block, their movable bodies (inverse mass > 0) and the matrix's pattern (kept from
    /// the last call while the joints and their movable bodies are the same). `body_scratch` has an
    /// entry per body slot, all zero, and is left so; only the movable bodies' entries are touched. The
    /// joints on a movable body that holds more than 32 of them are left out (its block would be
    /// dense): the sweeps alone hold those.
    void prepare(const std::vector<JointData>& joints, const std::vector<JointRows>& rows, const std::uint32_t* active,
                 std::size_t count, std::vector<std::uint32_t>& body_scratch);
    /// The joint slots in the solve, in matrix order (empty: solve() does nothing). The caller must not
    /// solve when one of them has been destroyed since prepare().
    const std::vector<std::uint32_t>& slots() const;
    /// One exact solve of every point block on the pass's velocities with the softness `bias` ({} =
    /// rigid and unbiased, the relax pass), at the current poses; adds to the joints' accumulated point
    /// impulses.
    void solve(std::vector<JointData>& joints, const std::vector<JointRows>& rows, const RigidSystem::State& st,
               RowPass& pass, const Softness& bias);

private:
    struct Impl;
    /// The bodies, ends, matrix pattern, its ordering and analysis for the joints in m.slots.
    static void build_pattern(Impl& m, const std::vector<JointRows>& rows, std::vector<std::uint32_t>& body_scratch);
    std::unique_ptr<Impl> m_;
};

}  // namespace sinew::joint_detail
