// Linear and stiffness-warped tetrahedral elements (Müller & Gross 2004; Nesme et al. 2005 for the
// rotations and inverted elements; O'Brien et al. 2002 for plasticity). Equations: docs/theory.md#fem.
//
// Per element with rest edge matrix D_m = [X1 - X0, X2 - X0, X3 - X0], shape-function gradients
// g_1..g_3 (the rows of D_m⁻¹) and g_0 = -(g_1 + g_2 + g_3), volume V, Lamé λ and μ:
//   K_e = V Bᵀ D B, whose 3x3 block (a, b) is V (λ g_a g_bᵀ + μ g_b g_aᵀ + μ (g_a · g_b) I);
//   deformation gradient F = D_s D_m⁻¹ with D_s the deformed edges, rotation R_e from F (fem_material.hpp);
//   f_e = -R_e K_e (R_eᵀ x_e - x⁰_e) computed through the stress: ε = sym(R_eᵀ F) - I - ε_p,
//   σ = 2 μ ε + λ tr(ε) I, f_a = -V R_e σ g_a — the same numbers as the 12x12 product (which is linear in
//   the displacement, and Σ_b x⁰_b g_bᵀ = I), in about 150 multiplications instead of 144 + 2 x 36 for
//   the product and the rotations, and without storing K_e.
//   The warped stiffness K' = Σ R_e K_e R_eᵀ, whose blocks are the same expression with the rotated
//   gradients R_e g_a, is assembled into a BlockSparse3 for implicit Euler.
// Quadratic (10-node) tets (soft/fem_quadratic.cpp) cure the locking of linear tets in bending: their
//   strain varies linearly inside the element, so K_e (30x30, by 4-point quadrature, exact for it) is
//   computed once and kept, 55 blocks per element; R_e comes from the element's mean deformation
//   gradient and f_e = -R_e K_e (R_eᵀ x_e - x⁰_e) is the product itself.
// The element data are plain arrays built once; a step allocates nothing.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "soft/block_sparse.hpp"
#include "soft/fem_material.hpp"

namespace sinew {

struct SoftBody;
class ParallelRegion;

struct FemState {
    // Rest data (from the positions at creation).
    std::vector<Vec3> rest;           ///< the rest shape, per particle
    int order = 1;                    ///< 1: linear tets; 2: quadratic tets (soft/tet_mesh.hpp)
    std::vector<std::uint32_t> tets;  ///< nodes_per_tet() per element, corners first
    std::vector<Mat3> dm_inv;         ///< D_m⁻¹ of the corners: its rows are g_1, g_2, g_3
    std::vector<Mat3> quad_stiffness;  ///< quadratic tets: the rest blocks K_ac, a <= c, 55 per element
    std::vector<Real> volume;         ///< rest volume (m³)
    Real lambda = 0, mu = 0;          ///< Lamé parameters of the material
    // Per step.
    std::vector<Mat3> rotation;       ///< R_e at the last evaluation
    std::vector<Quat> polar;          ///< the polar rotation as a quaternion: the next step starts from it
    /// Müller 2016's iterations per evaluation at most (every element of a batch of 8 runs until the last
/// of them has turned less than the tolerance). Warm-started, the rotation converges over steps
    /// (Müller et al. use a few per step): on a 20k-tet block hitting the ground, uncapped it takes 4.8 per
    /// element and step, 47% of the step; a cap of 4 leaves the run's figures within 0.1%.
    int polar_iterations = 4;
    std::vector<Strain6> plastic;     ///< ε_p per element (rest frame)
    int inverted = 0;                 ///< elements with det F <= 0 at the last evaluation
    bool rotations_current = false;   ///< the rotations are those of x_n (begin_step took them for plasticity)
    // The warped stiffness K' and the blocks of each element in it.
    BlockSparse3 stiffness;
    std::vector<std::uint32_t> element_blocks;  ///< per element its nodes_per_tet()² block indices in K'
    /// The element loop on a region's workers (soft/fem_kernel.cpp, linear tets): the nodes cut into
    /// contiguous parts, and per part the runs of elements that have a node in it. Built on first use.
    struct ElementParts {
        std::vector<std::uint32_t> node_start;  ///< parts + 1: part p owns nodes [node_start[p], node_start[p + 1])
        std::vector<std::uint32_t> run_start;   ///< parts + 1 offsets into runs
        std::vector<std::uint32_t> runs;        ///< (first, end) element ranges, ascending
        int parts() const { return node_start.empty() ? 0 : int(node_start.size()) - 1; }
    } element_parts;

    bool assembled = false;
    // Implicit Euler's product q += k_scale K' u + m_scale M u (set by the model's prepare step).
    Real k_scale = 0, m_scale = 0;
    std::vector<Vec3> scratch;  ///< n vectors

    std::size_t size() const { return volume.size(); }
    int nodes_per_tet() const { return order == 2 ? 10 : 4; }
};

/// The shape-function gradients g_0..g_3 of a tet's corners: the rows of D_m⁻¹, g_0 = -(g_1 + g_2 + g_3).
inline void shape_gradients(const Mat3& dm_inv, Vec3 (&g)[4]) {
    for (int k = 1; k < 4; ++k) g[k] = dm_inv.row(k - 1).transpose();
    g[0] = -(g[1] + g[2] + g[3]);
}

/// Index of block (a, c), a <= c, among a quadratic element's 55 kept blocks (FemState::quad_stiffness).
constexpr int quadratic_pair_index(int a, int c) { return a * 10 - a * (a - 1) / 2 + (c - a); }

enum class SoftMethod : std::uint8_t;  // soft/soft_body.hpp
/// "" if an FEM body of `order` tets (1 or 2) with material m may be stepped by `method`, else why: tets
/// need a force-based method or fast-ms (projective dynamics, linear tets only); plasticity needs linear
/// tets and a force-based method. The one check create_body, set_fem_material and the C API share.
std::string fem_method_problem(const FemMaterial& m, SoftMethod method, int order);

/// Rest data of a body's elements of `order` from its rest positions (validated by the caller: positive
/// volumes, and straight edges for quadratic tets).
std::unique_ptr<FemState> make_fem_state(const std::vector<Vec3>& rest, const std::vector<std::uint32_t>& tets,
                                         const FemMaterial& material, int order = 1);

/// Changes an FEM body's material: Lamé parameters, damping, plasticity, rotation; a new density gives its
/// particles new lumped masses (pinned and attached ones stay kinematic); turning plasticity off clears the
/// plastic strain. Throws SoftError for a body without tets or a material out of range (nothing changed).
void set_fem_material(SoftBody& b, const FemMaterial& m);

/// R_e of every element at positions x by the material's method; counts the inverted elements.
void fem_update_rotations(FemState& s, const std::vector<Vec3>& x, FemRotation method);

/// f += the elastic and plastic forces at x with the current rotations, and the stiffness-proportional
/// damping -β R_e K_e R_eᵀ v_e when beta != 0 (v may be null when beta == 0).
void fem_add_forces(const FemState& s, const std::vector<Vec3>& x, const std::vector<Vec3>* v, Real beta,
                    std::vector<Vec3>& f);

/// Assembles K' = Σ R_e K_e R_eᵀ with the current rotations.
void fem_assemble_stiffness(FemState& s);

/// The three above in one pass over the elements (each F computed once, soft/fem_kernel.cpp): the
/// rotations at x if `rotate` (else the kept ones), f += the forces if f is not null, K' assembled if
/// `assemble`. The force-model row calls this.
/// With a region of several workers the rotations of linear tets are found first, batch by batch on the
/// workers (each batch writes only its own elements' rotations); the forces and blocks follow
/// owner-computes on the workers (each worker adds only to its own nodes and block rows, taking their
/// elements in ascending order), so the result is the same bit for bit.
void fem_kernel(FemState& s, const std::vector<Vec3>& x, const std::vector<Vec3>* v, Real beta, FemRotation method,
                bool rotate, std::vector<Vec3>* f, bool assemble, ParallelRegion* region = nullptr);

/// O'Brien's rule at x with the current rotations: ε_e = ε - ε_p; above yield ε_p += h creep ε_e;
/// ‖ε_p‖ capped at max_plastic.
void fem_update_plasticity(FemState& s, const std::vector<Vec3>& x, const FemMaterial& m, Real h);

/// The elastic energy Σ V (μ ε:ε + λ/2 tr(ε)²) at x with the current rotations (J).
double fem_elastic_energy(const FemState& s, const std::vector<Vec3>& x);

/// For det F <= 0 (an inverted or flat element): the proper rotation of F's SVD with Nesme 2005's flip of
/// the column of the smallest singular value (the rotation closest to F). The polar iteration for
/// det F > 0 runs in the batched element loop (soft/fem_kernel.cpp).
Mat3 inverted_rotation(const Mat3& F);

// Quadratic tets (soft/fem_quadratic.cpp), called by the element loop and make_fem_state.
/// The rest blocks K_ac (a <= c) of every element, 55 each, from dm_inv, volume and Lamé's λ and μ.
std::vector<Mat3> quadratic_rest_stiffness(const FemState& s, Real lambda, Real mu);
/// The mean deformation gradient (1/V) ∫ ∂x/∂X dV of element e: Σ over the edges (i, j) of x_ij (g_i + g_j)ᵀ
/// (the corners' shape functions integrate to zero gradient).
Mat3 quadratic_mean_gradient(const FemState& s, std::size_t e, const std::vector<Vec3>& x);
/// f_a -= R Σ_c K_ac (Rᵀ (x_c + β v_c) - x⁰_c) for element e with rotation R (v may be null when beta == 0).
void quadratic_add_force(const FemState& s, std::size_t e, const Mat3& R, const std::vector<Vec3>& x,
                         const std::vector<Vec3>* v, Real beta, std::vector<Vec3>& f);
/// K' += R K_e Rᵀ for element e.
void quadratic_assemble(FemState& s, std::size_t e, const Mat3& R);
/// ½ Σ_e uᵀ K_e u with u = R_eᵀ x - x⁰ and the current rotations (J).
double quadratic_energy(const FemState& s, const std::vector<Vec3>& x);

}  // namespace sinew
