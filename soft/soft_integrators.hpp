// Time integration of one soft body over one step, without contacts (the soft system projects contacts
// afterwards, soft/particle_collision.hpp). Equations: Jakobsen 2003, Baraff & Witkin 1998, Liu et al.
// 2013, Matyka & Ollila 2003; docs/theory.md (#verlet, #mass-spring-forces, #euler, #fast-mass-spring,
// #pressure).
//
// Contract shared by every step_* function:
//  - on entry p.x, p.v hold state n; p.f holds the external forces of this step (N); b.gravity is the
//    gravity acceleration (m/s^2); b.def.drag the velocity damping (1/s);
//  - on exit p.x_prev = x_n and p.x, p.v hold state n+1; particles with inverse mass 0 (pinned, attached)
//    do not move and get v = 0 (the system moves attached particles before calling);
//  - no allocation after the first step of a body (scratch lives in the body's caches).
#pragma once

#include <vector>

#include "soft/soft_body.hpp"

namespace sinew {

class ParticleCollision;

/// Adds the damped Hooke forces of every link (Baraff & Witkin 1998; docs/theory.md#mass-spring-forces) at
/// positions x, velocities v to f.
void add_spring_forces(const SoftBody& b, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                       std::vector<Vec3>& f);
/// Adds Matyka's pressure force (P_c / V) A n̂ of each surface triangle, split over its 3 vertices, at
/// positions x (nothing if b.def.pressure == 0 or the surface encloses no volume).
void add_pressure_forces(const SoftBody& b, const std::vector<Vec3>& x, std::vector<Vec3>& f);
/// Signed volume of the triangles at positions x (divergence theorem), m^3.
Real enclosed_volume(const std::vector<std::uint32_t>& triangles, const std::vector<Vec3>& x);

void step_explicit_euler(SoftBody& b, Real h);
void step_semi_implicit_euler(SoftBody& b, Real h);
/// Baraff-Witkin one Newton step, (M - h df/dv - h^2 df/dx) dv = h (f + h df/dx v), solved by CG with a
/// block-Jacobi preconditioner, matrix-free; Volino's isotropic blend and λ as in b.def.
void step_implicit_euler(SoftBody& b, Real h);
/// Liu et al. 2013: b.def.iterations local/global iterations, the global matrix M/h^2 + L factored once
/// (SimplicialLDLT) and refactored only when the pins or h change.
void step_fast_mass_spring(SoftBody& b, Real h);
/// Jakobsen 2003: Verlet integration with drag, then b.def.iterations relaxations of the links, each
/// followed by collision projection (if `collision` is not null) and long-range attachments.
void step_verlet(SoftBody& b, Real h, ParticleCollision* collision);

// The two position-based methods in two parts, for the soft system's stages (step_* = both in order):
// the prediction from forces and gravity (IntegrateVelocities) and the internal constraints solved on
// the predicted positions, velocities read back from them (SolveVelocities).
/// Verlet's inertial prediction x_n + (1 - h drag) h v_n + h^2 a_n (pressure included), x_prev = x_n.
void predict_verlet(SoftBody& b, Real h);
/// Verlet's relaxation (links, collision projection, long-range attachments) and v = (x - x_prev) / h.
void relax_verlet(SoftBody& b, Real h, ParticleCollision* collision);
/// Liu 2013's inertial term y (and its factorisation if stale) and the first iterate, x_prev = x_n.
void predict_fast_mass_spring(SoftBody& b, Real h);
/// Liu 2013's local/global iterations from the predicted positions, and v = (x - x_prev) / h. With
/// `collision`, each global step holds the particles on their collision planes (soft/fast_mass_spring.cpp).
void solve_fast_mass_spring(SoftBody& b, Real h, ParticleCollision* collision = nullptr);
/// A velocity change dv of particle i after predict_fast_mass_spring (a coupling impulse): the predicted
/// position and the inertial term y move by h dv, so the iterations do not pull the particle back.
void shift_fast_mass_spring_prediction(SoftBody& b, std::uint32_t i, const Vec3& dv, Real h);
/// Liu's inertial target y_i of particle i after predict_fast_mass_spring (gravity and external forces
/// included): the motion the step predicts, which the first iterate (x_n + h v_n, kept so a body at rest
/// starts at its solution) leaves out. Pinned particles: their position.
Vec3 fast_mass_spring_target(const SoftBody& b, std::uint32_t i, Real h);

/// Projects particles onto their long-range attachment spheres (unilateral) and removes the outward
/// velocity component of those it moved.
void apply_long_range_attachments(SoftBody& b);
/// Builds b.lra from the pinned particles: each free particle is tethered to every pin (up to 8 pins;
/// beyond that to the nearest), max_length = the shortest rest-length path along the links to it
/// (Kim et al. 2012 use geodesic distance).
void build_long_range_attachments(SoftBody& b);

}  // namespace sinew
