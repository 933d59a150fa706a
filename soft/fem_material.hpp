// The material of a tetrahedral FEM body (docs/fem.md; equations docs/theory.md#fem): isotropic linear
// elasticity (Young's modulus, Poisson's ratio), density for the lumped masses, Rayleigh damping, the
// element rotation that warps the stiffness (Müller & Gross 2004) and O'Brien 2002's plasticity rule.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "engine/core/math.hpp"

namespace sinew {

/// How each element's rotation R_e is taken from its deformation gradient F (Müller & Gross 2004's
/// stiffness warping, f_e = -R_e K_e (R_eᵀ x_e - x⁰_e)).
enum class FemRotation : std::uint8_t {
    Linear,  ///< R_e = I: plain linear FEM (Cauchy strain), which inflates under rotation (the baseline)
    Polar,   ///< the rotation of F's polar decomposition; det F <= 0: Nesme 2005's flip of the smallest axis
    QR,      ///< Gram-Schmidt of F's first two columns, the third their cross product (Nesme 2005)
    Count
};
const char* fem_rotation_name(FemRotation r);
/// Parses "linear", "polar", "qr"; returns false if unknown.
bool parse_fem_rotation(const char* text, FemRotation& out);

struct FemMaterial;
/// "" if every field is in its range, else what is wrong, each field named with `prefix` ("fem.",
/// "material->"): young > 0, poisson in (-1, 0.5), density > 0, damping and plasticity >= 0, all finite,
/// a rotation of the enum. The one check SoftSystem::create_body, set_fem_material and the C API share.
std::string fem_material_problem(const FemMaterial& m, const std::string& prefix);

/// A symmetric strain in an element's rest frame: xx, yy, zz, xy, xz, yz (tensor components).
using Strain6 = std::array<Real, 6>;

struct FemMaterial {
    Real young = Real(1e5);    ///< E (Pa), > 0
    Real poisson = Real(0.3);  ///< ν, in (-1, 0.5): 0.5 is incompressible, where linear elements lock
    Real density = 1000;       ///< ρ (kg/m³): the builders' lumped masses (soft/tet_mesh.hpp, lumped_masses)
    Real mass_damping = 0;     ///< Rayleigh α (1/s): damping force -α M v
    Real stiffness_damping = 0;  ///< Rayleigh β (s): damping force -β K' v
    // Plasticity (O'Brien et al. 2002 as Müller & Gross 2004 use it): with ε_e = ε - ε_p the elastic
    // strain, if ‖ε_e‖ > yield then ε_p += h creep ε_e; ‖ε_p‖ is capped at max_plastic. yield = 0 and
    // creep = 0: elastic.
    Real yield = 0;        ///< strain norm (Frobenius, dimensionless) above which the element creeps
    Real creep = 0;        ///< rate (1/s) at which the plastic strain takes up the elastic strain (h creep capped at 1)
    Real max_plastic = 0;  ///< cap on ‖ε_p‖ (dimensionless); 0 with creep > 0 means no plastic strain
    FemRotation rotation = FemRotation::Polar;

    bool plastic() const { return creep > 0 && max_plastic > 0; }
    /// Lamé's λ = E ν / ((1 + ν)(1 - 2ν)) and μ = E / (2 (1 + ν)).
    Real lame_lambda() const { return young * poisson / ((1 + poisson) * (1 - 2 * poisson)); }
    Real lame_mu() const { return young / (2 * (1 + poisson)); }
};

}  // namespace sinew
