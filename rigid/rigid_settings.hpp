// Settings of the rigid-body system: which solver, how many iterations, how positions are corrected.
#pragma once

#include "engine/core/math.hpp"

namespace sinew {

/// The rigid solver. The first three are sequential impulses (Catto 2005: accumulated clamped impulses,
/// warm starting) that differ in how they remove penetration and how they step; the last is another
/// method altogether.
enum class RigidSolverKind : std::uint8_t {
    SoftStep,      ///< Box2D v3 "soft step": sub-steps, soft contacts (Catto 2011), relax pass, no slop
    SplitImpulse,  ///< penetration bias -(beta/h) max(d - slop, 0) on pseudo-velocities that move positions only
    Baumgarte,     ///< the same bias in the velocity solve itself (adds energy)
    Newton,        ///< Guendelman et al. 2003: collision / velocity / contact / position order, shock propagation
    Count
};

/// "soft_step", "split_impulse", "baumgarte", "newton" (scene files, the C API's names, the bench).
const char* rigid_solver_name(RigidSolverKind k);
/// The kind of a name from rigid_solver_name(); false if unknown.
bool parse_rigid_solver(const char* name, RigidSolverKind& out);

struct RigidSettings {
    Vec3 gravity = Vec3(0, Real(-9.81), 0);  ///< m/s^2
    /// Soft step stands best per unit of time in `sinew bench rigid` (docs/RESULTS.md), so it is the default.
    RigidSolverKind solver = RigidSolverKind::SoftStep;
    int velocity_iterations = 10;
    bool warm_starting = true;
    /// Soft step only: sub-steps per step; each does one biased solve and one relax pass, so it costs
    /// about two iterations of the other methods. 0 = velocity_iterations / 2 (at least 1), so that
    /// `velocity_iterations` means passes over the constraints for every method.
    int substeps = 0;
    int effective_substeps() const { return substeps > 0 ? substeps : (velocity_iterations / 2 > 0 ? velocity_iterations / 2 : 1); }
    /// The gyroscopic effect, -w x (I w): between velocity updates a body's angular momentum is kept while
    /// its inertia turns with it (rigid/rigid_integration.cpp), so a spinning body precesses and tumbles as
    /// it should (the intermediate-axis flip), stable at any spin. Off: w changes only by torques and
    /// contacts.
    bool gyroscopic = true;
    /// Soft step: a world of many independent islands is solved a block of islands at a time, each block
    /// through all its sub-steps while it is in cache (bit-identical to colour-major passes over the
    /// whole world; turn off only to compare).
    bool solve_in_blocks = true;
    Real contact_hertz = 60;           ///< soft step: contact stiffness (Hz), capped at a quarter of the sub-step rate
    /// Soft step: critically damped, so pushing out adds no bounce. With the graph-coloured solver a
    /// higher ratio makes the contact closer to rigid and worse conditioned: pyramid-40 vibrates at 1.5
    /// and above (kinetic energy 0.1-18 J late in the run, the top box wandering 7-200 cm) while 1 keeps
    /// it at 3e-4 J with a 4.8 cm elastic sag; 0.7 sags 5.0 cm (sweep in git log).
    Real contact_damping_ratio = 1;
    Real contact_push_velocity = 3;    ///< soft step: m/s cap on the speed that removes penetration
    /// Largest mass ratio a contact sees between a body and the one holding it up (>= 1; 0 = no bound).
    /// Gauss-Seidel moves the momentum of a heavy body through a light one by about twice their mass
    /// ratio per pass, so a 1000 kg box on 1 kg ones ploughs through them at any iteration count; where a
    /// contact holds a body more than this many times heavier, the supporting body's inverse mass and
    /// inertia are scaled in that contact alone (soft step, split impulses, Baumgarte: rigid/rigid_support.cpp,
    /// docs/rigid-solvers.md; the Newtonian solver's shock propagation freezes the lower body instead).
    /// Split impulses, Baumgarte and the Newtonian solver bound joints at this ratio too (the lighter
    /// body looks heavier in that joint; rigid/joint_set.cpp), so chains with heavy ends hold together.
    Real contact_mass_ratio = 8;
    Real baumgarte = Real(0.2);              ///< fraction of the penetration removed per step
    Real linear_slop = Real(0.005);          ///< m of penetration left alone (keeps contacts persistent)
    Real restitution_threshold = Real(1.0);  ///< m/s: slower impacts do not bounce
    /// Continuous collision against static and kinematic bodies (Box2D v3's, for every dynamic body): a
    /// body that moved more than half its smallest extent in a step and whose centre passed into one of
    /// them is put back where its shape first touched it (rigid/rigid_continuous.cpp). Speculative
    /// contacts already stop most fast bodies; this catches what they cannot see (the Newtonian solver's
    /// detection at candidate poses, a body spun into a wall).
    bool continuous = true;
    Real contact_margin = Real(0.02);        ///< m: speculative contact distance and fat-AABB margin
    /// m/s cap on the penetration bias (split impulses, Baumgarte) and on the Newtonian solver's
    /// penetration projection per step (times h): deep overlaps separate no faster.
    Real max_correction_velocity = Real(4);
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
