// Tetrahedral elements: rest data, rotations, forces, the warped stiffness and plasticity
// (soft/fem_elements.hpp; docs/theory.md#fem).
#include "soft/fem_elements.hpp"

#include "engine/core/format.hpp"
#include "soft/soft_body.hpp"
#include "soft/tet_mesh.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <string>

namespace sinew {

namespace {

// The deformed edge matrix D_s times D_m⁻¹.
inline Mat3 deformation_gradient(const FemState& s, std::size_t e, const std::vector<Vec3>& x) {
    const std::uint32_t* t = &s.tets[4 * e];
    Mat3 ds;
    ds.col(0) = x[t[1]] - x[t[0]];
    ds.col(1) = x[t[2]] - x[t[0]];
    ds.col(2) = x[t[3]] - x[t[0]];
    return ds * s.dm_inv[e];
}

// The symmetric part of G minus I as a Strain6.
inline Strain6 strain_of(const Mat3& G) {
    return {G(0, 0) - 1, G(1, 1) - 1, G(2, 2) - 1, Real(0.5) * (G(0, 1) + G(1, 0)), Real(0.5) * (G(0, 2) + G(2, 0)),
            Real(0.5) * (G(1, 2) + G(2, 1))};
}

inline Real norm_of(const Strain6& e) {
    // Frobenius norm of the tensor (off-diagonal components count twice).
    return std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + 2 * (e[3] * e[3] + e[4] * e[4] + e[5] * e[5]));
}

}  // namespace

std::unique_ptr<FemState> make_fem_state(const std::vector<Vec3>& rest, const std::vector<std::uint32_t>& tets,
                                         const FemMaterial& material, int order) {
    auto s = std::make_unique<FemState>();
    s->order = order == 2 ? 2 : 1;
    const std::size_t per = std::size_t(s->nodes_per_tet()), m = tets.size() / per;
    s->rest = rest;
    s->tets = tets;
    s->dm_inv.resize(m);
    s->volume.resize(m);
    for (std::size_t e = 0; e < m; ++e) {
        const std::uint32_t* t = &tets[per * e];
        Mat3 dm;
        dm.col(0) = rest[t[1]] - rest[t[0]];
        dm.col(1) = rest[t[2]] - rest[t[0]];
        dm.col(2) = rest[t[3]] - rest[t[0]];
        // In double: thin elements lose digits in single precision.
        s->dm_inv[e] = dm.cast<double>().inverse().cast<Real>();
        s->volume[e] = Real(dm.cast<double>().determinant() / 6.0);
    }
    s->lambda = material.lame_lambda();
    s->mu = material.lame_mu();
    s->rotation.assign(m, Mat3::Identity());
    s->polar.assign(m, Quat::Identity());
    s->plastic.assign(m, Strain6{});
    s->stiffness.build_pattern(rest.size(), tets, s->nodes_per_tet(), s->element_blocks);
    if (s->order == 2) s->quad_stiffness = quadratic_rest_stiffness(*s, s->lambda, s->mu);
    s->scratch.assign(rest.size(), Vec3::Zero());
    return s;
}

Mat3 inverted_rotation(const Mat3& F) {
    // Inverted or flat (Nesme et al. 2005): F = U Σ Vᵀ with Σ descending; the proper rotation closest to F
    // flips U's column of the smallest singular value, so the element is pushed back through itself.
    const Eigen::Matrix3d Fd = F.cast<double>();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(Fd, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d U = svd.matrixU();
    const Eigen::Matrix3d V = svd.matrixV();
    if ((U * V.transpose()).determinant() < 0) U.col(2) = -U.col(2);
    return (U * V.transpose()).cast<Real>();
}

std::string fem_method_problem(const FemMaterial& m, SoftMethod method, int order) {
    if (order != 1 && order != 2) return "tet_order = " + std::to_string(order) + " must be 1 (linear tets) or 2 (quadratic tets)";
    if (!accepts_tets(method))
        return std::string("tets need a force-based method (explicit, semi-implicit or implicit) or fast-ms (projective "
                           "dynamics), got ") + soft_method_name(method);
    if (method == SoftMethod::FastMassSpring && order != 1) return "fast-ms (projective dynamics) needs linear tets (tet_order 1)";
    if (m.plastic() && order != 1)
        return "plasticity (creep and max_plastic > 0) needs linear tets: these are quadratic, and a quadratic tet's strain "
               "varies inside it";
    if (m.plastic() && !is_force_based(method))
        return std::string("plasticity needs a force-based method (explicit, semi-implicit or implicit), not ") + soft_method_name(method);
    return {};
}

void set_fem_material(SoftBody& b, const FemMaterial& m) {
    if (!b.fem) throw SoftError("set_fem_material: the soft body has no tets (it is not an FEM solid)");
    const std::string bad = fem_material_problem(m, "set_fem_material: material.");
    if (!bad.empty()) throw SoftError(bad);
    FemState& s = *b.fem;
    const std::string unfit = fem_method_problem(m, b.def.method, s.order);
    if (!unfit.empty()) throw SoftError("set_fem_material: " + unfit);
    // What allocates (and may throw) runs before anything changes: the masses, a quadratic body's blocks.
    std::vector<Real> mass;
    if (m.density != b.def.fem.density) mass = lumped_masses(s.rest, s.tets, m.density, s.order);
    std::vector<Mat3> blocks;
    if (s.order == 2) blocks = quadratic_rest_stiffness(s, m.lame_lambda(), m.lame_mu());
    b.def.fem = m;
    s.lambda = m.lame_lambda();
    s.mu = m.lame_mu();
    if (s.order == 2) s.quad_stiffness = std::move(blocks);
    // Without plasticity no plastic strain: an earlier set is forgotten (fem_material.hpp).
    if (!m.plastic()) std::fill(s.plastic.begin(), s.plastic.end(), Strain6{});
    for (std::size_t i = 0; i < mass.size(); ++i) {
        b.p.mass[i] = mass[i];
        if (b.p.inv_mass[i] != 0) b.p.inv_mass[i] = 1 / mass[i];
    }
}

void fem_update_plasticity(FemState& s, const std::vector<Vec3>& x, const FemMaterial& mat, Real h) {
    if (!mat.plastic() || s.order != 1) return;  // quadratic tets refuse plasticity (soft_body_validate.cpp)
    const Real rate = std::min(Real(1), h * mat.creep);
    const std::size_t m = s.size();
    for (std::size_t e = 0; e < m; ++e) {
        const Strain6 total = strain_of(s.rotation[e].transpose() * deformation_gradient(s, e, x));
        Strain6& p = s.plastic[e];
        Strain6 elastic;
        for (int k = 0; k < 6; ++k) elastic[k] = total[k] - p[k];
        if (norm_of(elastic) > mat.yield)
            for (int k = 0; k < 6; ++k) p[k] += rate * elastic[k];
        const Real n = norm_of(p);
        if (n > mat.max_plastic)
            for (int k = 0; k < 6; ++k) p[k] *= mat.max_plastic / n;
    }
}

double fem_elastic_energy(const FemState& s, const std::vector<Vec3>& x) {
    if (s.order == 2) return quadratic_energy(s, x);
    double energy = 0;
    for (std::size_t e = 0; e < s.size(); ++e) {
        Strain6 eps = strain_of(s.rotation[e].transpose() * deformation_gradient(s, e, x));
        for (int k = 0; k < 6; ++k) eps[k] -= s.plastic[e][k];
        const double tr = eps[0] + eps[1] + eps[2];
        const double ee = double(eps[0]) * eps[0] + double(eps[1]) * eps[1] + double(eps[2]) * eps[2] +
                          2.0 * (double(eps[3]) * eps[3] + double(eps[4]) * eps[4] + double(eps[5]) * eps[5]);
        energy += double(s.volume[e]) * (double(s.mu) * ee + 0.5 * double(s.lambda) * tr * tr);
    }
    return energy;
}

}  // namespace sinew

namespace sinew {

namespace {
constexpr const char* kRotationNames[] = {"linear", "polar", "qr"};
static_assert(sizeof(kRotationNames) / sizeof(kRotationNames[0]) == static_cast<int>(FemRotation::Count), "");
}  // namespace

const char* fem_rotation_name(FemRotation r) {
    const int i = static_cast<int>(r);
    return i >= 0 && i < static_cast<int>(FemRotation::Count) ? kRotationNames[i] : "unknown";
}

std::string fem_material_problem(const FemMaterial& m, const std::string& prefix) {
    const auto text = [](Real x) { return to_text(x); };
    if (!(m.young > 0 && std::isfinite(m.young))) return prefix + "young = " + text(m.young) + " must be finite and > 0 (Pa)";
    if (!(m.poisson > -1 && m.poisson < Real(0.5)))
        return prefix + "poisson = " + text(m.poisson) + " must be in (-1, 0.5) (0.5 is incompressible, where linear tets lock)";
    if (!(m.density > 0 && std::isfinite(m.density))) return prefix + "density = " + text(m.density) + " must be finite and > 0 (kg/m^3)";
    const struct {
        const char* name;
        Real value;
    } nonneg[] = {{"mass_damping", m.mass_damping}, {"stiffness_damping", m.stiffness_damping}, {"yield", m.yield},
                  {"creep", m.creep}, {"max_plastic", m.max_plastic}};
    for (const auto& f : nonneg)
        if (!(f.value >= 0 && std::isfinite(f.value))) return prefix + f.name + " = " + text(f.value) + " must be finite and >= 0";
    const int r = static_cast<int>(m.rotation);
    if (r < 0 || r >= static_cast<int>(FemRotation::Count)) return prefix + "rotation = " + std::to_string(r) + " is not a rotation method";
    return {};
}

bool parse_fem_rotation(const char* text, FemRotation& out) {
    for (int i = 0; i < static_cast<int>(FemRotation::Count); ++i)
        if (std::string(text) == kRotationNames[i]) {
            out = static_cast<FemRotation>(i);
            return true;
        }
    return false;
}

}  // namespace sinew
