// The rest-shape factor preconditioner (soft/fem_rest_factor.hpp).
#include "soft/fem_rest_factor.hpp"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "soft/fem_elements.hpp"
#include "soft/ldlt_solve.hpp"

namespace sinew {

namespace {

// Block (a, c) of element e's rest stiffness K_e.
Eigen::Matrix3d rest_block(const FemState& s, std::size_t e, int a, int c) {
    if (s.order == 2) {
        const Mat3* K = &s.quad_stiffness[55 * e];
        return a <= c ? K[quadratic_pair_index(a, c)].cast<double>()
                      : Eigen::Matrix3d(K[quadratic_pair_index(c, a)].cast<double>().transpose());
    }
    Vec3 g[4];
    shape_gradients(s.dm_inv[e], g);
    const Eigen::Vector3d ga = g[a].cast<double>(), gc = g[c].cast<double>();
    const double V = double(s.volume[e]), lambda = double(s.lambda), mu = double(s.mu);
    return V * (lambda * ga * gc.transpose() + mu * gc * ga.transpose() + mu * ga.dot(gc) * Eigen::Matrix3d::Identity());
}

}  // namespace

struct FemRestFactor::Impl {
    bool ok = false;
    int factorisations = 0;
    // What the factor was built from.
    std::vector<double> diagonal;
    std::vector<std::uint32_t> pinned;
    double k_scale = -1, lambda = -1, mu = -1;
    // Per step.
    std::vector<Quat> node_rotation;
    std::vector<int> permutation;  ///< the factor's fill-reducing order: row i of A is row permutation[i] of P A Pᵀ
    LdltArrays factor;             ///< the factor's L and 1 / D, laid out for the solves
    std::vector<double> work;      ///< 3 n, in the factor's order
    std::vector<double> scratch;
};

FemRestFactor::FemRestFactor() : impl_(std::make_unique<Impl>()) {}
FemRestFactor::~FemRestFactor() = default;
int FemRestFactor::factorisations() const { return impl_->factorisations; }

bool FemRestFactor::prepare(const FemState& s, const std::vector<Real>& mass, Real k_scale,
                            const std::vector<std::uint32_t>& pinned) {
    Impl& f = *impl_;
    const std::size_t n = mass.size();
    bool same = f.k_scale == double(k_scale) && f.lambda == double(s.lambda) && f.mu == double(s.mu) &&
                f.diagonal.size() == n && f.pinned == pinned;
    for (std::size_t i = 0; same && i < n; ++i) same = f.diagonal[i] == double(mass[i]);
    if (!same) {
        // Nothing is kept until the factor is: a throw (out of memory) leaves no stale key behind.
        f.ok = false;
        f.diagonal.clear();
        std::vector<char> fixed(n, 0);
        for (const std::uint32_t i : pinned) fixed[i] = 1;
        const std::size_t per = std::size_t(s.nodes_per_tet());
        std::vector<Eigen::Triplet<double>> t;
        t.reserve(s.size() * per * per * 9 / 2 + 3 * n);
        for (std::size_t i = 0; i < n; ++i)
            for (int k = 0; k < 3; ++k) t.emplace_back(int(3 * i + k), int(3 * i + k), fixed[i] ? 1.0 : double(mass[i]));
        for (std::size_t e = 0; e < s.size(); ++e) {
            const std::uint32_t* nodes = &s.tets[per * e];
            for (std::size_t a = 0; a < per; ++a)
                for (std::size_t c = 0; c < per; ++c) {
                    const std::uint32_t i = nodes[a], j = nodes[c];
                    if (fixed[i] || fixed[j] || j > i) continue;  // the lower triangle (i >= j) only
                    const Eigen::Matrix3d K = double(k_scale) * rest_block(s, e, int(a), int(c));
                    for (int r = 0; r < 3; ++r)
                        for (int q = 0; q < 3; ++q)
                            if (3 * i + r >= 3 * j + q) t.emplace_back(int(3 * i + r), int(3 * j + q), K(r, q));
                }
        }
        Eigen::SparseMatrix<double> A(int(3 * n), int(3 * n));
        A.setFromTriplets(t.begin(), t.end());
        const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt(A);
        ++f.factorisations;
        const bool ok = ldlt.info() == Eigen::Success;
        if (ok) {
            const auto& perm = ldlt.permutationP().indices();
            f.permutation.assign(perm.data(), perm.data() + perm.size());
            f.factor.assign(ldlt.matrixL().nestedExpression(), ldlt.vectorD());
        }
        f.work.assign(3 * n, 0.0);
        f.node_rotation.assign(n, Quat::Identity());
        f.pinned = pinned;
        f.k_scale = double(k_scale);
        f.lambda = double(s.lambda);
        f.mu = double(s.mu);
        f.diagonal.assign(mass.begin(), mass.end());
        f.ok = ok;  // a matrix that could not be factored stays refused until its key changes
    }
    if (!f.ok) return false;
    // Each node turns with the mean of its elements' rotations (quaternions summed on one hemisphere).
    std::vector<Quat>& q = f.node_rotation;
    f.scratch.assign(4 * n, 0.0);
    const std::size_t per = std::size_t(s.nodes_per_tet());
    for (std::size_t e = 0; e < s.size(); ++e) {
        const Quat r(s.rotation[e]);
        for (std::size_t a = 0; a < per; ++a) {
            double* acc = &f.scratch[4 * s.tets[per * e + a]];
            const double sign = acc[0] * r.w() + acc[1] * r.x() + acc[2] * r.y() + acc[3] * r.z() < 0 ? -1.0 : 1.0;
            acc[0] += sign * r.w();
            acc[1] += sign * r.x();
            acc[2] += sign * r.y();
            acc[3] += sign * r.z();
        }
    }
    for (std::size_t i = 0; i < n; ++i) {
        const double* acc = &f.scratch[4 * i];
        const double len = std::sqrt(acc[0] * acc[0] + acc[1] * acc[1] + acc[2] * acc[2] + acc[3] * acc[3]);
        q[i] = len > 0 ? Quat(Real(acc[0] / len), Real(acc[1] / len), Real(acc[2] / len), Real(acc[3] / len)) : Quat::Identity();
    }
    return true;
}

void FemRestFactor::apply(const std::vector<Vec3>& r, std::vector<Vec3>& z) {
    // z = R_N Pᵀ L⁻ᵀ D⁻¹ L⁻¹ P R_Nᵀ r, on the factor's arrays (no allocation). The particles' rows only:
    // r and z may go on (implicit Euler's coupled rigid bodies).
    Impl& f = *impl_;
    const std::size_t n = f.node_rotation.size();
    double* w = f.work.data();
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3 local = f.node_rotation[i].conjugate() * r[i];
        for (int k = 0; k < 3; ++k) w[f.permutation[3 * i + std::size_t(k)]] = double(local[k]);
    }
    f.factor.solve_in_place<1>(w);
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3 local{static_cast<Real>(w[f.permutation[3 * i]]), static_cast<Real>(w[f.permutation[3 * i + 1]]),
                         static_cast<Real>(w[f.permutation[3 * i + 2]])};
        z[i] = f.node_rotation[i] * local;
    }
}

}  // namespace sinew
