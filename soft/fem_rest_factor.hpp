// A preconditioner for implicit Euler on stiff FEM bodies: the system matrix of the rest shape,
// A₀ = M' + k K₀ (K₀ the unrotated stiffness, M' the diagonal mass terms), factored once by sparse
// Cholesky (LDLᵀ, AMD ordering) and turned with each node's rotation, P = R_N A₀⁻¹ R_Nᵀ.
//
// Why: the system (M + hC + h²K') of a stiff body (a steel-like cantilever at E = 1e8 Pa, h = 1/60) is so
// ill-conditioned that block-Jacobi CG runs to its cap every step; refactoring K' every step costs more
// than the step may (25 ms for a 1,025-node beam of quadratic tets). K' = Σ R_e K_e R_eᵀ differs from
// K₀ only by the element rotations, so A₀⁻¹ is nearly A⁻¹ wherever the elements turn with their nodes;
// taking each node's rotation as the mean of its elements' keeps it close under large bends. It is the
// rest-factor idea of Hecht, Lee, Shewchuk & O'Brien 2012 ("Updated sparse Cholesky factors for
// corotational elastodynamics", ACM TOG 31(5)) without their updates: used as a preconditioner, CG
// repairs what the frozen factor misses. Pinned rows are identity in A₀ (their unknown is fixed).
//
// The factor is rebuilt when the mass terms, the stiffness scale (h, θ, damping), the material or the set
// of particles with inverse mass 0 change; otherwise a step allocates nothing here. An attached particle
// that a two-way coupling layer lets into the solve (it carries a rigid body's share) stays an identity
// row of A₀: CG solves for it, less well preconditioned, rather than the factor being rebuilt each step.
#pragma once

#include <memory>
#include <vector>

#include "engine/core/math.hpp"

namespace sinew {

struct FemState;

class FemRestFactor {
public:
    FemRestFactor();
    ~FemRestFactor();
    FemRestFactor(const FemRestFactor&) = delete;
    FemRestFactor& operator=(const FemRestFactor&) = delete;

    /// Makes sure the factor is that of diag(mass) + k_scale K₀ (K₀ from the body's current λ and μ) with
    /// `pinned` rows as identity, and takes each node's rotation from the elements' current ones. Returns
    /// false if the matrix could not be factored (the caller falls back to block Jacobi).
    bool prepare(const FemState& s, const std::vector<Real>& mass, Real k_scale, const std::vector<std::uint32_t>& pinned);

    /// z = R_N A₀⁻¹ R_Nᵀ r (pinned rows of z are r's).
    void apply(const std::vector<Vec3>& r, std::vector<Vec3>& z);

    /// How many times the rest system was factored (a test reads it).
    int factorisations() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace sinew
