// Quadratic (10-node) tetrahedra for the FEM force model (soft/fem_elements.hpp; docs/fem.md#quadratic-tets).
//
// Why: a linear tet's strain is constant, so a mesh of them bends only by shearing its elements and is far
// too stiff in bending ("locking": the 480-tet cantilever reaches 0.64 of the converged deflection and
// needs about 30,000 linear tets to come within 5%). A quadratic tet's displacement is quadratic, so its
// strain varies linearly across it and a coarse mesh bends (Zienkiewicz & Taylor, The Finite Element
// Method vol. 1, ch. 8; SOFA and Abaqus offer the same element).
//
// The element (straight edges, so the geometry is the corners' affine map; barycentric L_0..L_3 with
// constant gradients g_i, the rows of D_m⁻¹ and g_0 = -(g_1 + g_2 + g_3)):
//   corner i: N_i = L_i (2 L_i - 1), ∇N_i = (4 L_i - 1) g_i;
//   edge (i, j): N_ij = 4 L_i L_j, ∇N_ij = 4 (L_i g_j + L_j g_i).
// The gradients are linear, their products quadratic: the 4-point rule (points with barycentrics
// (a, b, b, b) and its permutations, a = (5 + 3√5)/20, b = (5 - √5)/20, weights V/4) integrates
// K_ac = ∫ λ ∇N_a ∇N_cᵀ + μ ∇N_c ∇N_aᵀ + μ (∇N_a · ∇N_c) I dV exactly. The blocks are computed once in
// double and kept (55 per element: K_ca = K_acᵀ).
// Stiffness warping (Müller & Gross 2004) with one rotation per element, taken from the mean deformation
// gradient F̄ = (1/V) ∫ ∂x/∂X dV, which is exact for a rigid motion and equal to F for a linear field:
// f_e = -R K_e (Rᵀ x_e - x⁰_e), K' += R K_e Rᵀ. Plasticity is refused for these elements (a strain that
// varies inside the element needs a plastic strain per quadrature point).
#include <cmath>

#include "soft/fem_elements.hpp"
#include "soft/tet_mesh.hpp"

namespace sinew {

namespace {

// The corners (i, j) of node a when a is an edge node; a corner has i == j == a.
void node_corners(int a, int& i, int& j) {
    if (a < 4) {
        i = j = a;
    } else {
        i = kTetEdges[a - 4][0];
        j = kTetEdges[a - 4][1];
    }
}

}  // namespace

std::vector<Mat3> quadratic_rest_stiffness(const FemState& s, Real lame_lambda, Real lame_mu) {
    const std::size_t m = s.size();
    std::vector<Mat3> out(55 * m, Mat3::Zero());
    const double a = (5.0 + 3.0 * std::sqrt(5.0)) / 20.0, b = (5.0 - std::sqrt(5.0)) / 20.0;
    const double lambda = double(lame_lambda), mu = double(lame_mu);
    for (std::size_t e = 0; e < m; ++e) {
        const Eigen::Matrix3d di = s.dm_inv[e].cast<double>();
        Eigen::Vector3d g[4];
        for (int k = 1; k < 4; ++k) g[k] = di.row(k - 1).transpose();
        g[0] = -(g[1] + g[2] + g[3]);
        const double w = double(s.volume[e]) / 4;
        Eigen::Matrix3d K[55];
        for (auto& k : K) k.setZero();
        for (int q = 0; q < 4; ++q) {
            double L[4] = {b, b, b, b};
            L[q] = a;
            Eigen::Vector3d grad[10];
            for (int n = 0; n < 10; ++n) {
                int i, j;
                node_corners(n, i, j);
                grad[n] = n < 4 ? Eigen::Vector3d((4 * L[i] - 1) * g[i]) : Eigen::Vector3d(4 * (L[i] * g[j] + L[j] * g[i]));
            }
            for (int r = 0; r < 10; ++r)
                for (int c = r; c < 10; ++c)
                    K[quadratic_pair_index(r, c)] += w * (lambda * grad[r] * grad[c].transpose() + mu * grad[c] * grad[r].transpose() +
                                                mu * grad[r].dot(grad[c]) * Eigen::Matrix3d::Identity());
        }
        for (int k = 0; k < 55; ++k) out[55 * e + std::size_t(k)] = K[k].cast<Real>();
    }
    return out;
}

Mat3 quadratic_mean_gradient(const FemState& s, std::size_t e, const std::vector<Vec3>& x) {
    const std::uint32_t* t = &s.tets[10 * e];
    Vec3 g[4];
    shape_gradients(s.dm_inv[e], g);
    Mat3 F = Mat3::Zero();
    for (int k = 0; k < 6; ++k) F.noalias() += x[t[4 + k]] * (g[kTetEdges[k][0]] + g[kTetEdges[k][1]]).transpose();
    return F;
}

void quadratic_add_force(const FemState& s, std::size_t e, const Mat3& R, const std::vector<Vec3>& x,
                         const std::vector<Vec3>* v, Real beta, std::vector<Vec3>& f) {
    const std::uint32_t* t = &s.tets[10 * e];
    const Mat3* K = &s.quad_stiffness[55 * e];
    Vec3 u[10];
    for (int c = 0; c < 10; ++c) {
        const Vec3 p = beta != 0 && v ? Vec3(x[t[c]] + beta * (*v)[t[c]]) : x[t[c]];
        u[c] = R.transpose() * p - s.rest[t[c]];
    }
    Vec3 g[10];
    for (int a = 0; a < 10; ++a) g[a].setZero();
    for (int a = 0; a < 10; ++a) {
        g[a].noalias() += K[quadratic_pair_index(a, a)] * u[a];
        for (int c = a + 1; c < 10; ++c) {
            const Mat3& k = K[quadratic_pair_index(a, c)];
            g[a].noalias() += k * u[c];
            g[c].noalias() += k.transpose() * u[a];
        }
    }
    for (int a = 0; a < 10; ++a) f[t[a]] -= R * g[a];
}

void quadratic_assemble(FemState& s, std::size_t e, const Mat3& R) {
    const Mat3* K = &s.quad_stiffness[55 * e];
    const std::uint32_t* slot = &s.element_blocks[100 * e];
    Mat3* blocks = s.stiffness.block.data();
    for (int a = 0; a < 10; ++a)
        for (int c = a; c < 10; ++c) {
            const Mat3 k = R * K[quadratic_pair_index(a, c)] * R.transpose();
            blocks[slot[10 * a + c]] += k;
            if (c != a) blocks[slot[10 * c + a]] += k.transpose();
        }
}

double quadratic_energy(const FemState& s, const std::vector<Vec3>& x) {
    double energy = 0;
    for (std::size_t e = 0; e < s.size(); ++e) {
        const std::uint32_t* t = &s.tets[10 * e];
        const Mat3& R = s.rotation[e];
        const Mat3* K = &s.quad_stiffness[55 * e];
        Eigen::Vector3d u[10];
        for (int c = 0; c < 10; ++c) u[c] = (R.transpose() * x[t[c]] - s.rest[t[c]]).cast<double>();
        for (int a = 0; a < 10; ++a) {
            energy += 0.5 * u[a].dot(K[quadratic_pair_index(a, a)].cast<double>() * u[a]);
            for (int c = a + 1; c < 10; ++c) energy += u[a].dot(K[quadratic_pair_index(a, c)].cast<double>() * u[c]);
        }
    }
    return energy;
}

}  // namespace sinew
