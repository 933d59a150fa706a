// Each soft method as the soft system's stages run it: one row of function pointers per SoftMethod, so
// the system's step has no switch on the method, and a new method is its files and its row here.
//
// The stage contract (docs/ARCHITECTURE.md, "The soft system's stages"):
//  - integrate_velocities (IntegrateVelocities): gravity, external and internal forces over h. On exit
//    p.x_prev = x_n and p.x holds the predicted end-of-step positions: the step of a force-based method
//    (explicit, semi-implicit, implicit Euler: their velocities are v_{n+1} then), the inertial
//    prediction of a position-based one (Verlet, fast mass-spring: velocities still v_n).
//  - solve_constraints (SolveVelocities): the internal constraints on the predicted positions
//    (Verlet's links with collision projection inside, Liu's local/global iterations, long-range
//    attachments), velocities read back from the positions where the method is position-based. The
//    contact pass (ParticleCollision::finish) follows it in the system.
#pragma once

#include "soft/soft_body.hpp"

namespace sinew {

class ParticleCollision;

struct SoftMethodStages {
    void (*integrate_velocities)(SoftBody& b, Real h);
    void (*solve_constraints)(SoftBody& b, Real h, ParticleCollision* collision);
    /// Friction is applied at the position level inside solve_constraints (Jakobsen: Verlet), so the
    /// contact pass handles only restitution.
    bool position_friction;
    /// A coupling layer changed particle i's velocity by dv between IntegrateVelocities and SolveVelocities
    /// (an impulse from the rigid solve): the method's prediction follows, as if the impulse had been one
    /// of its forces. Null: the predicted position moves by h dv and the velocity by dv (enough for every
    /// method whose solve starts from the predicted positions alone).
    void (*shift_prediction)(SoftBody& b, std::uint32_t i, const Vec3& dv, Real h);
};

/// The row of method m (throws SoftError for a value outside the enum).
const SoftMethodStages& soft_method_stages(SoftMethod m);
/// The stages body b runs this step: its method's, or, while a coupling layer solves it in the rigid
/// solver (SoftBody::solved_by_rows), an explicit prediction and the contact pass only.
const SoftMethodStages& soft_stages_of(const SoftBody& b);

}  // namespace sinew
