// Interface between the rigid system and its velocity solvers. One virtual call per step: the solvers'
// inner loops run on plain arrays they prepare themselves.
#pragma once

#include "rigid/rigid_system.hpp"

namespace sinew {

class RigidSolver {
public:
    virtual ~RigidSolver() = default;
    /// Solves contacts (and later joints) for one step of h: writes new velocities into the system's
    /// state, accumulated impulses back into its contacts, and pseudo-velocities for position correction.
    virtual void solve_velocities(RigidSystem& sys, Real h) = 0;
    /// Applies position corrections computed by solve_velocities (split impulses) after integration.
    virtual void correct_positions(RigidSystem& sys, Real h) = 0;
    /// Runs at the start of IntegrateVelocities, before forces (Guendelman's collision passes).
    virtual void before_integrate_velocities(RigidSystem&, Real) {}
    /// Whether DetectCollisions should place bodies at their candidate poses x + h v (Guendelman) rather
    /// than their current poses (Catto).
    virtual bool detects_at_candidate_poses() const { return false; }
    /// Whether the solver integrates velocities and positions itself inside SolveVelocities (sub-stepping
    /// solvers); the system then skips its own integration in the other stages.
    virtual bool integrates_itself() const { return false; }
};

std::unique_ptr<RigidSolver> make_sequential_impulse_solver();
std::unique_ptr<RigidSolver> make_newton_impulse_solver();
std::unique_ptr<RigidSolver> make_soft_step_solver();

}  // namespace sinew
