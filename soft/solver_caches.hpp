// Per-body scratch of the spring integrators, kept between steps so a step allocates nothing once the
// body's sizes are known (the vectors are sized on the first step and reused; they are resized again only
// if particles or links are added). Flat arrays indexed by particle or by link.
//
// ImplicitEulerCache doubles as the force scratch of the explicit and semi-implicit Euler steps (SoftBody
// has no third cache slot, and those steps need only its `force` array).
#pragma once

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <cstdint>
#include <memory>
#include <vector>

#include "engine/core/math.hpp"
#include "soft/block_cg.hpp"
#include "soft/fem_rest_factor.hpp"
#include "soft/ldlt_schedule.hpp"
#include "soft/ldlt_solve.hpp"
#include "soft/link_rows.hpp"

namespace sinew {

/// Baraff-Witkin implicit Euler (soft/implicit_euler.cpp): forces, the right-hand side, the CG vectors and
/// the per-link system blocks of the current step.
struct ImplicitEulerCache {
    std::vector<Vec3> force;  ///< f(x_n, v_n) + external + gravity + pressure (N)
    /// Both with one row per particle, then two per coupled rigid body (its Δv and Δω).
    std::vector<Vec3> rhs;    ///< h (f_n + h λ ∂f/∂x v_n), zero at pinned particles
    std::vector<Vec3> dv;     ///< the unknown Δv; the next step starts from it if CG converged
    /// Link j's block of the system matrix, S_j = iso I + aniso dir dirᵀ
    /// (= -h²λ² ∂f_a/∂x_a - hλ ∂f_a/∂v_a): A u += S_j (u_a - u_b) at a and -S_j (u_a - u_b) at b. The
    /// ends are copied in so the CG product streams through one compact array.
    struct LinkBlock {
        std::uint32_t a = 0, b = 0;
        Real iso = 0, aniso = 0;
        Vec3 dir = Vec3::Zero();
    };
    std::vector<LinkBlock> links;
    /// Per particle, the link ends at it, when the CG product runs on workers this step (a large body in
    /// a region with helpers): the springs' product is then gathered row by row, in the order the scatter
    /// over the links adds it. Empty otherwise.
    LinkRows link_rows;
    mutable std::vector<Vec3> link_product;  ///< scratch of the product (a const read of the cache): per link, S_j (u_a - u_b)
    std::vector<Real> mass;             ///< the system's diagonal mass m (1 + hλ drag) per particle
    std::vector<std::uint32_t> pinned;  ///< particles with inverse mass 0 this step (their rows are filtered)
    /// Particles in resting or approaching contact this step: their normal velocity change is fixed to
    /// `dv_normal` (along `normal`) and the solve runs in the plane orthogonal to it (Baraff & Witkin's S).
    struct ContactRow {
        std::uint32_t particle = 0;
        Vec3 normal = Vec3::Zero();
        Vec3 dv_normal = Vec3::Zero();
        Real rhs_normal = 0;  ///< n · rhs before the filter (for the constraint's force after the solve)
    };
    std::vector<ContactRow> contact_rows;
    /// Particles tied to a dynamic rigid body under two-way coupling (SoftBody::contact_rigid): in the
    /// directions C (n nᵀ, or I where friction holds) the particle's velocity is the body's at its arm, so
    /// the body's velocity and angular velocity are unknowns of the solve (soft/implicit_euler.cpp).
    struct CoupledRow {
        std::uint32_t particle = 0;
        std::uint32_t rigid = 0;        ///< index into SoftBody::coupled_rigids
        Mat3 tied = Mat3::Zero();       ///< C: the directions tied to the body
        Vec3 arm = Vec3::Zero();        ///< from the body's centre of mass to the point it moves with (SoftBody::contact_arm)
        Vec3 rhs = Vec3::Zero();        ///< the particle's right-hand side before the tie (for its impulse)
        Vec3 friction = Vec3::Zero();   ///< the kinetic friction impulse the body gives it (SoftBody::contact_friction)
    };
    std::vector<CoupledRow> coupled_rows;
    /// Attached particles tied to their body this step, and where the soft system had placed them (the
    /// body's predicted point), restored after the solve.
    std::vector<std::pair<std::uint32_t, Vec3>> tied_attached;
    std::vector<Vec3> expanded, expanded_product;  ///< scratch per particle: J u and A J u in the coupled product
    /// Per particle: 1 if its contact constraint pulled it towards the collider in the last solve
    /// (adhesion); the next step leaves it free, as Baraff & Witkin release such constraints.
    std::vector<std::uint8_t> contact_released;
    /// The CG scratch and its block-Jacobi preconditioner (each particle's 3x3 diagonal block, inverted;
    /// all zero for pinned particles: Baraff-Witkin's filter S).
    BlockCg cg;
    /// FEM bodies under SoftPreconditioner::RestFactor: the factored rest system, and the diagonal it was
    /// built with (mass, drag and mass damping).
    std::shared_ptr<FemRestFactor> rest_factor;
    std::vector<Real> factor_diagonal;
    std::vector<std::uint32_t> factor_fixed;  ///< its identity rows: the particles with inverse mass 0

    // Statistics of the last step (benchmarks and tests read them).
    int cg_iterations = 0;      ///< CG iterations used
    Real cg_residual = 0;       ///< final sqrt(rᵀ P r / bᵀ P b) (P the preconditioner)
    bool cg_converged = false;  ///< reached b.def.cg_tolerance within the b.def.iterations cap

    /// Sizes the arrays for n particles, m links and `rigid_rows` extra rows (two per coupled rigid body;
    /// no-op when they already fit).
    void resize(std::size_t n, std::size_t m, std::size_t rigid_rows = 0);
};

/// Liu et al. 2013 fast mass-spring (soft/fast_mass_spring.cpp): the constant global matrix
/// M'/h² + L (M' = (1 + h drag) M) over the free particles (pinned ones eliminated), its factorization,
/// and what it was factored for. The rows are in a fill-reducing (AMD) order computed once and applied by
/// the index map `row`; the solves run on the factor's own arrays (L D Lᵀ, L unit lower), all three
/// coordinates of a row at once, without Eigen's solve (whose permutation step allocates per solve).
struct FastMassSpringCache {
    using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

    // What the factorization is valid for: refactored when any of these changes.
    double h = 0;
    Real drag = 0;
    std::vector<Real> inv_mass;   ///< per particle: the pin set (0) and the masses
    std::vector<std::uint32_t> link_ends;  ///< 2 per link
    std::vector<Real> link_stiffness;
    std::size_t tet_count = 0;    ///< projective dynamics: the elements and their Lamé parameters
    Real tet_mu = 0, tet_lambda = 0;

    std::vector<int> row;         ///< particle -> row of the system, -1 for pinned particles
    SparseMatrix matrix;          ///< M'/h² + L in row order, lower triangle
    LdltArrays factor;            ///< its factorization L D Lᵀ (empty: no free particle)
    LdltSchedule schedule;        ///< the factor's solves split among workers (built on first parallel use)
    /// Per row, the link ends at its particle, ascending, and each entry's stiffness signed by the end
    /// (+k at end a, -k at end b, read in sequence): the right-hand side's J p gathered row by row, in the
    /// order a pass over the links adds it.
    LinkRows link_rows;
    std::vector<double> row_link_k;
    std::vector<std::uint32_t> pinned_links;  ///< the links with one end free and one pinned, ascending
    bool factored = false;
    int factorizations = 0;       ///< how many times it was (re)factored (tests check the reuse)

    std::vector<double> inertia;  ///< 3 per row: M' y / h² plus the pinned neighbours' constant terms
    std::vector<double> rhs;      ///< 3 per row: inertia + J p, solved in place into the positions
    std::vector<Vec3> dir;        ///< p_j = L_j d̂_j per link (kept when a link has zero length)
    std::vector<Vec3> force;      ///< explicit forces that are not constant in time (pressure), per step

    /// The contact planes held inside the global step (soft/fast_mass_spring.cpp, "Contacts"): scratch
    /// kept between steps so the solve does not allocate once the contact count has been reached.
    /// A plane's normal row is followed, when the contact has friction, by two tangent rows (directions
    /// t1, t2 across the normal) that hold the particle where it started the step, moved with the
    /// surface, within the Coulomb cone of the normal force.
    struct ContactRow {
        std::uint32_t plane;   ///< index into the step's ParticleCollision planes, or kSoftPlane
        std::uint32_t particle;
        int row;               ///< the particle's row of the system
        Vec3 normal;           ///< the row's direction: the plane's normal, or a tangent of it
        double offset;         ///< normal: n · x >= offset, the plane lifted by the particle's thickness;
                               ///< tangent: t · x = offset, the particle's start moved with the surface
        double force;          ///< the force along `normal` (N); a normal row's < 0 pulls
        Real approach;         ///< normal: the particle's normal speed into the plane before the solve (m/s)
        Real mu = 0;           ///< normal: the friction coefficient (tangent rows follow when > 0)
        bool tangent = false;
    };
    /// A row's plane: another soft body's surface (SoftBody::soft_planes), reported by the soft contact pass.
    static constexpr std::uint32_t kSoftPlane = ~std::uint32_t(0);
    std::vector<ContactRow> contacts;
    std::vector<double> cg_r, cg_p, cg_q;  ///< per contact row: residual (m), direction, S p
    std::vector<std::uint8_t> cg_active;   ///< per contact row: in this solve's set
    std::vector<double> cg_u;              ///< 3 per row: A⁻¹ N p
    std::vector<std::uint8_t> planes_at;   ///< scratch: per particle, its planes this step (up to 3 counted)
    std::vector<std::uint8_t> soft_at;     ///< scratch: per particle, 1 if it has a row against another soft body
    std::vector<std::uint32_t> first_plane;  ///< scratch: per particle, its first plane
    std::vector<std::uint8_t> released;    ///< per particle: one of its planes pulled in the last step; all its
                                           ///< planes are left to the contact pass in this one
    int contact_iterations = 0;            ///< CG products over the contacts in the last step (for measuring)
};

}  // namespace sinew
