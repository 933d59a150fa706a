// The force models of a soft body, as the force-based integrators see them (explicit, semi-implicit and
// implicit Euler: soft/euler_explicit.cpp, soft/implicit_euler.cpp). A model is one row of function
// pointers: whether a body has it, its forces at a state, and for implicit Euler its linearisation
// (forces, its share of the right-hand side and of the diagonal blocks, and its part of the matrix-free
// product). The integrators loop over the models a body has and know none of them, so a new force model
// is its own files and one row in soft/force_models.cpp.
//
// Models today: springs (the body's links read as damped Hooke springs; Baraff & Witkin 1998),
// Matyka's pressure (explicit in every integrator: it adds forces and no blocks) and tetrahedral FEM
// (Müller & Gross 2004's warped stiffness, assembled block-sparse; soft/fem_forces.cpp). The position-based
// integrators read the links their own way (Verlet: Jakobsen's constraints; fast mass-spring: Liu's
// local/global springs) and are not force-based.
#pragma once

#include <vector>

#include "soft/soft_body.hpp"

namespace sinew {

struct ImplicitEulerCache;

/// One implicit Euler step's linear system, (M' - hλ ∂f/∂v - h²λ² ∂f/∂x) Δv = h (f_n + hλ ∂f/∂x v_n)
/// (docs/theory.md#euler), as the models fill it in.
struct ImplicitTerms {
    Real h = 0;
    Real lambda = 1;  ///< Volino's blend: 1 backward Euler, 1/2 the implicit midpoint rule
    /// Forces of state n (N): external, gravity and drag are in already; each model adds its own.
    std::vector<Vec3>* force = nullptr;
    /// ∂f/∂x v_n (N/s), pinned particles' velocities taken as 0; each model adds its share.
    std::vector<Vec3>* dfdx_v = nullptr;
    /// The integrator's cache: its diagonal blocks (cg.block(i), symmetric xx, yy, zz, xy, xz, yz, the
    /// mass part in already; each model adds its -hλ ∂f_i/∂v_i - h²λ² ∂f_i/∂x_i) and the models' scratch.
    ImplicitEulerCache* cache = nullptr;
};

struct ForceModel {
    const char* name;
    bool (*present)(const SoftBody& b);
    /// Adds the forces at positions x and velocities v to f.
    void (*add_forces)(const SoftBody& b, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                       std::vector<Vec3>& f);
    /// Implicit Euler: adds the model's forces, its ∂f/∂x v_n and its diagonal blocks at state n, and
    /// prepares its product. nullptr: the model is explicit even there (add_forces at state n).
    void (*prepare_implicit)(const SoftBody& b, ImplicitTerms& t);
    /// Implicit Euler: q += (the model's part of the system matrix) u, after prepare_implicit.
    void (*add_implicit_product)(const SoftBody& b, const ImplicitEulerCache& c, const std::vector<Vec3>& u,
                                 std::vector<Vec3>& q);
    /// Once per step before any force is evaluated, with the step h (FEM's plasticity); nullptr: none.
    void (*begin_step)(SoftBody& b, Real h) = nullptr;
};

/// Every force model, in the order the integrators apply them.
const std::vector<const ForceModel*>& force_models();

/// The spring model's rows (soft/spring_forces.cpp).
extern const ForceModel kSpringForces;
/// Matyka's pressure (soft/pressure.cpp).
extern const ForceModel kPressureForces;
/// Tetrahedral FEM, linear or stiffness-warped (soft/fem_forces.cpp).
extern const ForceModel kFemForces;

}  // namespace sinew
