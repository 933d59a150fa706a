// Settings of the rigid-body system: which solver, how many iterations, how positions are corrected.
#pragma once

#include "engine/core/math.hpp"

namespace sinew {

enum class RigidSolverKind : std::uint8_t {
    SequentialImpulse,  ///< Catto 2005/2011: accumulated clamped impulses, warm starting
    Newton              ///< Guendelman et al. 2003: collision / velocity / contact / position order
};

/// How the sequential-impulse solver removes penetration.
enum class PositionCorrection : std::uint8_t {
    Baumgarte,     ///< bias velocity -(beta/h) max(d - slop, 0) in the velocity solve (adds energy)
    SplitImpulse,  ///< the same bias on separate pseudo-velocities that move positions only (adds none)
};

const char* solver_kind_name(RigidSolverKind k);
const char* position_correction_name(PositionCorrection c);

struct RigidSettings {
    Vec3 gravity = Vec3(0, Real(-9.81), 0);  ///< m/s^2
    RigidSolverKind solver = RigidSolverKind::SequentialImpulse;
    int velocity_iterations = 10;
    PositionCorrection correction = PositionCorrection::SplitImpulse;
    bool warm_starting = true;
    Real baumgarte = Real(0.2);              ///< fraction of the penetration removed per step
    Real linear_slop = Real(0.005);          ///< m of penetration left alone (keeps contacts persistent)
    Real restitution_threshold = Real(1.0);  ///< m/s: slower impacts do not bounce
    Real contact_margin = Real(0.02);        ///< m: speculative contact distance and fat-AABB margin
    Real max_correction_velocity = Real(4);  ///< m/s cap on the penetration bias
    // Sleeping (seed 001 ch.2): an island sleeps when all its bodies stay below these for sleep_time.
    bool sleeping = true;
    Real sleep_linear_velocity = Real(0.05);  ///< m/s
    Real sleep_angular_velocity = Real(0.05); ///< rad/s
    Real sleep_time = Real(0.5);              ///< s
    // Newtonian-impulse solver (Guendelman 2003).
    int newton_collision_iterations = 5;
    int newton_contact_iterations = 10;
    bool newton_shock_propagation = true;
    Real newton_projection_fraction = Real(0.2);
};

}  // namespace sinew
