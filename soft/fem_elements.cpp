// Tetrahedral elements: rest data, rotations, forces, the warped stiffness and plasticity
// (soft/fem_elements.hpp; docs/theory.md#fem).
#include "soft/fem_elements.hpp"

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

// σ = 2 μ ε + λ tr(ε) I as a matrix.
inline Mat3 stress_of(const Strain6& e, Real lambda, Real mu) {
    const Real tr = lambda * (e[0] + e[1] + e[2]);
    Mat3 s;
    s << 2 * mu * e[0] + tr, 2 * mu * e[3], 2 * mu * e[4],  //
        2 * mu * e[3], 2 * mu * e[1] + tr, 2 * mu * e[5],   //
        2 * mu * e[4], 2 * mu * e[5], 2 * mu * e[2] + tr;
    return s;
}

// f_a += -V R σ g_a for a = 1..3 (the columns of -V R σ D_m⁻ᵀ) and f_0 -= their sum.
inline void scatter_stress(const FemState& s, std::size_t e, const Mat3& R, const Mat3& sigma, Real scale,
                           std::vector<Vec3>& f) {
    const Mat3 H = (-scale * s.volume[e]) * (R * sigma * s.dm_inv[e].transpose());
    const std::uint32_t* t = &s.tets[4 * e];
    f[t[1]] += H.col(0);
    f[t[2]] += H.col(1);
    f[t[3]] += H.col(2);
    f[t[0]] -= H.col(0) + H.col(1) + H.col(2);
}

}  // namespace

std::unique_ptr<FemState> make_fem_state(const std::vector<Vec3>& rest, const std::vector<std::uint32_t>& tets,
                                         const FemMaterial& material) {
    auto s = std::make_unique<FemState>();
    const std::size_t m = tets.size() / 4;
    s->rest = rest;
    s->tets = tets;
    s->dm_inv.resize(m);
    s->volume.resize(m);
    for (std::size_t e = 0; e < m; ++e) {
        const std::uint32_t* t = &tets[4 * e];
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
    s->stiffness.build_pattern(rest.size(), tets, s->element_blocks);
    s->scratch.assign(rest.size(), Vec3::Zero());
    return s;
}

namespace {
// Müller 2016's iteration stops when the turn is below this (rad): float's round-off in R's columns is
// ~1e-7, so a tighter bound is never met there and every element would run to the cap.
constexpr Real kPolarTolerance = sizeof(Real) == 8 ? Real(1e-9) : Real(2e-6);
}  // namespace

Mat3 polar_rotation(const Mat3& F, Quat& q, int max_iterations) {
    if (!(F.determinant() > 0)) {
        // Inverted or flat (Nesme et al. 2005): F = U Σ Vᵀ with Σ descending; the proper rotation closest to
        // F flips U's column of the smallest singular value, so the element is pushed back through itself.
        const Eigen::Matrix3d Fd = F.cast<double>();
        Eigen::JacobiSVD<Eigen::Matrix3d> svd(Fd, Eigen::ComputeFullU | Eigen::ComputeFullV);
        Eigen::Matrix3d U = svd.matrixU();
        const Eigen::Matrix3d V = svd.matrixV();
        if ((U * V.transpose()).determinant() < 0) U.col(2) = -U.col(2);
        const Mat3 R = (U * V.transpose()).cast<Real>();
        q = Quat(R);
        q.normalize();
        return R;
    }
    // Müller, Bender, Chentanez & Macklin 2016, "A robust method to extract the rotational part of
    // deformations": turn R about ω = Σ r_i × f_i / |Σ r_i · f_i| until the columns of R and F are parallel
    // in the sense of maximising tr(Rᵀ F), which for det F > 0 is F's polar rotation. The convergence is
    // linear; from the previous step's rotation a resting element needs none, and an element in an impact a
    // few per step (20k tets hitting the ground: 4.8 on average with no cap).
    for (int iteration = 0; iteration < max_iterations; ++iteration) {
        const Mat3 R = q.toRotationMatrix();
        const Vec3 num = R.col(0).cross(F.col(0)) + R.col(1).cross(F.col(1)) + R.col(2).cross(F.col(2));
        const Real den = std::abs(R.col(0).dot(F.col(0)) + R.col(1).dot(F.col(1)) + R.col(2).dot(F.col(2))) + Real(1e-9);
        const Vec3 omega = num / den;
        const Real w2 = omega.squaredNorm();
        if (w2 < kPolarTolerance * kPolarTolerance) break;
        // The turn by |ω| about ω: exact half-angle form, with the first-order form below 1e-3 rad where the
        // two differ by under 1e-10 (as integrate_rotation does).
        const Real w = std::sqrt(w2);
        const Real half = Real(0.5) * w;
        const Real s = half < Real(1e-3) ? Real(0.5) : std::sin(half) / w;
        const Real c = half < Real(1e-3) ? Real(1) - Real(0.5) * half * half : std::cos(half);
        q = Quat(c, s * omega.x(), s * omega.y(), s * omega.z()) * q;
        q.normalize();
    }
    return q.toRotationMatrix();
}

Mat3 qr_rotation(const Mat3& F, const Mat3& previous) {
    const Vec3 a0 = F.col(0), a1 = F.col(1);
    const Real n0 = a0.norm();
    if (!(n0 > Real(1e-12))) return previous;
    const Vec3 r0 = a0 / n0;
    Vec3 r1 = a1 - r0.dot(a1) * r0;
    const Real n1 = r1.norm();
    if (!(n1 > Real(1e-12))) return previous;
    r1 /= n1;
    Mat3 R;
    R.col(0) = r0;
    R.col(1) = r1;
    R.col(2) = r0.cross(r1);  // right-handed even when F is inverted (Nesme 2005)
    return R;
}

void set_fem_material(SoftBody& b, const FemMaterial& m) {
    FemState& s = *b.fem;
    const Real old_density = b.def.fem.density;
    b.def.fem = m;
    s.lambda = m.lame_lambda();
    s.mu = m.lame_mu();
    if (m.density != old_density) {
        const std::vector<Real> mass = lumped_masses(s.rest, s.tets, m.density);
        for (std::size_t i = 0; i < b.p.size(); ++i) {
            b.p.mass[i] = mass[i];
            if (b.p.inv_mass[i] != 0) b.p.inv_mass[i] = 1 / mass[i];
        }
    }
}

void fem_update_rotations(FemState& s, const std::vector<Vec3>& x, FemRotation method) {
    const std::size_t m = s.size();
    int inverted = 0;
    for (std::size_t e = 0; e < m; ++e) {
        const Mat3 F = deformation_gradient(s, e, x);
        if (!(F.determinant() > 0)) ++inverted;
        switch (method) {
            case FemRotation::Linear: s.rotation[e].setIdentity(); break;
            case FemRotation::Polar: s.rotation[e] = polar_rotation(F, s.polar[e], s.polar_iterations); break;
            case FemRotation::QR: s.rotation[e] = qr_rotation(F, s.rotation[e]); break;
            case FemRotation::Count: break;
        }
    }
    s.inverted = inverted;
}

void fem_add_forces(const FemState& s, const std::vector<Vec3>& x, const std::vector<Vec3>* v, Real beta,
                    std::vector<Vec3>& f) {
    const std::size_t m = s.size();
    for (std::size_t e = 0; e < m; ++e) {
        const Mat3& R = s.rotation[e];
        const Mat3 G = R.transpose() * deformation_gradient(s, e, x);
        Strain6 eps = strain_of(G);
        for (int k = 0; k < 6; ++k) eps[k] -= s.plastic[e][k];
        Mat3 sigma = stress_of(eps, s.lambda, s.mu);
        if (beta != 0 && v) {
            // -β R K_e Rᵀ v_e: the same expression on the velocities' "strain rate" (no identity to remove).
            Strain6 rate = strain_of(R.transpose() * deformation_gradient(s, e, *v));
            rate[0] += 1;
            rate[1] += 1;
            rate[2] += 1;
            sigma += beta * stress_of(rate, s.lambda, s.mu);
        }
        scatter_stress(s, e, R, sigma, 1, f);
    }
}

void fem_assemble_stiffness(FemState& s) {
    s.stiffness.set_zero();
    const std::size_t m = s.size();
    const Real lambda = s.lambda, mu = s.mu;
    for (std::size_t e = 0; e < m; ++e) {
        const Mat3& R = s.rotation[e];
        const Mat3& Di = s.dm_inv[e];
        // Rotated gradients r_a = R g_a.
        Vec3 r[4];
        r[1] = R * Di.row(0).transpose();
        r[2] = R * Di.row(1).transpose();
        r[3] = R * Di.row(2).transpose();
        r[0] = -(r[1] + r[2] + r[3]);
        const Real V = s.volume[e];
        const std::array<std::uint32_t, 16>& slot = s.element_blocks[e];
        Vec3 rl[4], rm[4];  // V λ r_a and V μ r_a
        for (int a = 0; a < 4; ++a) {
            rl[a] = (V * lambda) * r[a];
            rm[a] = (V * mu) * r[a];
        }
        Mat3* blocks = s.stiffness.block.data();
        for (int a = 0; a < 4; ++a)
            for (int b = a; b < 4; ++b) {
                // V (λ r_a r_bᵀ + μ r_b r_aᵀ + μ (r_a · r_b) I); block (b, a) is its transpose.
                const Real d = rm[a].dot(r[b]);
                Real k[3][3];
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j) k[i][j] = rl[a][i] * r[b][j] + r[b][i] * rm[a][j] + (i == j ? d : Real(0));
                Real* A = blocks[slot[4 * a + b]].data();  // column-major: A(i, j) = A[3 j + i]
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j) A[3 * j + i] += k[i][j];
                if (b != a) {
                    Real* B = blocks[slot[4 * b + a]].data();
                    for (int i = 0; i < 3; ++i)
                        for (int j = 0; j < 3; ++j) B[3 * i + j] += k[i][j];
                }
            }
    }
    s.assembled = true;
}

void fem_update_plasticity(FemState& s, const std::vector<Vec3>& x, const FemMaterial& mat, Real h) {
    if (!mat.plastic()) return;
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

bool parse_fem_rotation(const char* text, FemRotation& out) {
    for (int i = 0; i < static_cast<int>(FemRotation::Count); ++i)
        if (std::string(text) == kRotationNames[i]) {
            out = static_cast<FemRotation>(i);
            return true;
        }
    return false;
}

}  // namespace sinew
