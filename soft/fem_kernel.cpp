// The element loop of tetrahedral FEM, eight elements at a time (soft/fem_elements.hpp): rotations,
// forces and the warped stiffness blocks computed lane by lane in plain arrays [quantity][lane], which
// the compiler turns into SIMD instructions (SSE2 on any x86-64: 4 floats; the rigid solver's contact
// kernels do the same by hand, rigid/wide_float.hpp). Gathering an element's nodes and scattering its
// forces and blocks stay per element. Equations: docs/theory.md#fem.
//
// The polar rotation (Müller, Bender, Chentanez & Macklin 2016) turns q by the small rotation whose
// vector is ω = Σ r_i × f_i / |Σ r_i · f_i| as the normalised first-order quaternion (1, ω/2) ⊗ q: a
// rotation by 2 atan(|ω|/2) instead of the paper's |ω|, equal to second order, shorter for large turns
// (so it never overshoots) and free of trigonometry, which keeps the lanes in SIMD registers. Elements with
// det F <= 0 take Nesme's flip by SVD, one at a time (inverted_rotation()). Quadratic tets share the
// rotation lanes (F their mean deformation gradient) and take their forces and blocks one element at a
// time (soft/fem_quadratic.cpp).
#include <Eigen/SVD>
#include <algorithm>
#include <atomic>
#include <cmath>

#include "soft/fem_elements.hpp"
#include "engine/core/task_system.hpp"

namespace sinew {

namespace {

constexpr int L = 8;  // elements per batch
// The polar iteration stops when every lane's turn is below this (rad): float's round-off in R's columns
// is ~1e-7, so a tighter bound is never met there and every element would run to the cap.
constexpr Real kPolarTolerance = sizeof(Real) == 8 ? Real(1e-9) : Real(2e-6);

struct Batch {
    int count = 0;             // real elements in the batch (the others are padding: identity, zero volume)
    std::size_t first = 0;     // index of lane 0's element
    Real F[9][L];              // deformation gradient, F(i, j) at [3 i + j]
    Real Di[9][L];             // D_m⁻¹, (i, j) at [3 i + j]: row a - 1 is g_a
    Real R[9][L];              // rotation
    Real V[L];                 // rest volume
    bool flat[L];              // det F <= 0
};

// Elements [first, min(first + L, end)) into b's lanes (end: the elements' count by default).
void gather(const FemState& s, const std::vector<Vec3>& x, std::size_t first, Batch& b, std::size_t end = ~std::size_t(0)) {
    b.first = first;
    b.count = int(std::min<std::size_t>(L, std::min(end, s.size()) - first));
    for (int l = 0; l < L; ++l) {
        Mat3 ds = Mat3::Identity(), di = Mat3::Identity();
        Real v = 0;
        bool mean = false;  // quadratic tets: F is the mean deformation gradient
        if (l < b.count) {
            const std::size_t e = first + std::size_t(l);
            di = s.dm_inv[e];
            v = s.volume[e];
            if (s.order == 2) {
                ds = quadratic_mean_gradient(s, e, x);
                mean = true;
            } else {
                const std::uint32_t* t = &s.tets[4 * e];
                ds.col(0) = x[t[1]] - x[t[0]];
                ds.col(1) = x[t[2]] - x[t[0]];
                ds.col(2) = x[t[3]] - x[t[0]];
            }
        }
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) b.Di[3 * i + j][l] = di(i, j);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                b.F[3 * i + j][l] = mean ? ds(i, j) : ds(i, 0) * di(0, j) + ds(i, 1) * di(1, j) + ds(i, 2) * di(2, j);
        b.V[l] = v;
    }
    for (int l = 0; l < L; ++l) {
        const Real det = b.F[0][l] * (b.F[4][l] * b.F[8][l] - b.F[5][l] * b.F[7][l]) -
                         b.F[1][l] * (b.F[3][l] * b.F[8][l] - b.F[5][l] * b.F[6][l]) +
                         b.F[2][l] * (b.F[3][l] * b.F[7][l] - b.F[4][l] * b.F[6][l]);
        b.flat[l] = l < b.count && !(det > 0);
    }
}

Mat3 lane_matrix(const Real (&M)[9][L], int l) {
    Mat3 m;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) m(i, j) = M[3 * i + j][l];
    return m;
}
void set_lane_matrix(Real (&M)[9][L], int l, const Mat3& m) {
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) M[3 * i + j][l] = m(i, j);
}

// R from unit quaternions (w, x, y, z) per lane.
void rotation_from_quaternions(const Real (&q)[4][L], Real (&R)[9][L]) {
    for (int l = 0; l < L; ++l) {
        const Real w = q[0][l], x = q[1][l], y = q[2][l], z = q[3][l];
        R[0][l] = 1 - 2 * (y * y + z * z);
        R[1][l] = 2 * (x * y - w * z);
        R[2][l] = 2 * (x * z + w * y);
        R[3][l] = 2 * (x * y + w * z);
        R[4][l] = 1 - 2 * (x * x + z * z);
        R[5][l] = 2 * (y * z - w * x);
        R[6][l] = 2 * (x * z - w * y);
        R[7][l] = 2 * (y * z + w * x);
        R[8][l] = 1 - 2 * (x * x + y * y);
    }
}

void polar_lanes(FemState& s, Batch& b) {
    Real q[4][L];
    for (int l = 0; l < L; ++l) {
        const Quat p = l < b.count ? s.polar[b.first + std::size_t(l)] : Quat::Identity();
        q[0][l] = p.w();
        q[1][l] = p.x();
        q[2][l] = p.y();
        q[3][l] = p.z();
    }
    const Real tol2 = kPolarTolerance * kPolarTolerance;
    for (int iteration = 0; iteration < s.polar_iterations; ++iteration) {
        rotation_from_quaternions(q, b.R);
        Real h[3][L];
        int turning = 0;
        for (int l = 0; l < L; ++l) {
            // ω = Σ_c R.col(c) × F.col(c) / (|Σ_c R.col(c) · F.col(c)| + 1e-9), halved.
            Real nx = 0, ny = 0, nz = 0, d = 0;
            for (int c = 0; c < 3; ++c) {
                const Real rx = b.R[c][l], ry = b.R[3 + c][l], rz = b.R[6 + c][l];
                const Real fx = b.F[c][l], fy = b.F[3 + c][l], fz = b.F[6 + c][l];
                nx += ry * fz - rz * fy;
                ny += rz * fx - rx * fz;
                nz += rx * fy - ry * fx;
                d += rx * fx + ry * fy + rz * fz;
            }
            const Real k = Real(0.5) / (std::abs(d) + Real(1e-9));
            const Real wx = nx * k, wy = ny * k, wz = nz * k;
            const bool moving = 4 * (wx * wx + wy * wy + wz * wz) >= tol2 && !b.flat[l];
            turning += moving;
            h[0][l] = moving ? wx : Real(0);
            h[1][l] = moving ? wy : Real(0);
            h[2][l] = moving ? wz : Real(0);
        }
        if (turning == 0) break;
        for (int l = 0; l < L; ++l) {
            // q ← normalise((1, h) ⊗ q).
            const Real w = q[0][l], x = q[1][l], y = q[2][l], z = q[3][l];
            const Real hx = h[0][l], hy = h[1][l], hz = h[2][l];
            const Real nw = w - (hx * x + hy * y + hz * z);
            const Real nx = x + w * hx + (hy * z - hz * y);
            const Real ny = y + w * hy + (hz * x - hx * z);
            const Real nz = z + w * hz + (hx * y - hy * x);
            const Real inv = Real(1) / std::sqrt(nw * nw + nx * nx + ny * ny + nz * nz);
            q[0][l] = nw * inv;
            q[1][l] = nx * inv;
            q[2][l] = ny * inv;
            q[3][l] = nz * inv;
        }
    }
    rotation_from_quaternions(q, b.R);
    for (int l = 0; l < b.count; ++l) {
        Quat& p = s.polar[b.first + std::size_t(l)];
        if (b.flat[l]) {
            const Mat3 R = inverted_rotation(lane_matrix(b.F, l));
            set_lane_matrix(b.R, l, R);
            p = Quat(R);
            p.normalize();
        } else {
            p = Quat(q[0][l], q[1][l], q[2][l], q[3][l]);
        }
    }
}

void qr_lanes(const FemState& s, Batch& b) {
    bool degenerate[L];
    for (int l = 0; l < L; ++l) {
        Real a0[3] = {b.F[0][l], b.F[3][l], b.F[6][l]}, a1[3] = {b.F[1][l], b.F[4][l], b.F[7][l]};
        const Real n0 = std::sqrt(a0[0] * a0[0] + a0[1] * a0[1] + a0[2] * a0[2]);
        const Real i0 = n0 > Real(1e-12) ? Real(1) / n0 : Real(0);
        const Real r0[3] = {a0[0] * i0, a0[1] * i0, a0[2] * i0};
        const Real p = r0[0] * a1[0] + r0[1] * a1[1] + r0[2] * a1[2];
        Real r1[3] = {a1[0] - p * r0[0], a1[1] - p * r0[1], a1[2] - p * r0[2]};
        const Real n1 = std::sqrt(r1[0] * r1[0] + r1[1] * r1[1] + r1[2] * r1[2]);
        const Real i1 = n1 > Real(1e-12) ? Real(1) / n1 : Real(0);
        for (Real& c : r1) c *= i1;
        degenerate[l] = i0 == 0 || i1 == 0;
        // Columns r0, r1 and r0 × r1: right-handed even when F is inverted (Nesme 2005).
        b.R[0][l] = r0[0];
        b.R[3][l] = r0[1];
        b.R[6][l] = r0[2];
        b.R[1][l] = r1[0];
        b.R[4][l] = r1[1];
        b.R[7][l] = r1[2];
        b.R[2][l] = r0[1] * r1[2] - r0[2] * r1[1];
        b.R[5][l] = r0[2] * r1[0] - r0[0] * r1[2];
        b.R[8][l] = r0[0] * r1[1] - r0[1] * r1[0];
    }
    for (int l = 0; l < b.count; ++l)
        if (degenerate[l]) set_lane_matrix(b.R, l, s.rotation[b.first + std::size_t(l)]);  // keep the last one
}

// f += the element forces: ε = sym(Rᵀ F) - I - ε_p, σ = 2 μ ε + λ tr(ε) I (+ β times the same of the
// velocities' Rᵀ Ḟ, without the identity), H = -V R σ D_m⁻ᵀ; f_a += H's column a - 1, f_0 -= their sum.
// H of each lane, H[3 i + j][l] (the forces of nodes 1-3 are its columns).
void force_lanes(const FemState& s, const Batch& b, const std::vector<Vec3>* v, Real beta, Real (&H)[9][L]) {
    Real S[6][L];  // σ: xx yy zz xy xz yz
    const Real lambda = s.lambda, mu = s.mu;
    Real P[6][L];
    for (int l = 0; l < L; ++l) {
        const Strain6& p = l < b.count ? s.plastic[b.first + std::size_t(l)] : Strain6{};
        for (int k = 0; k < 6; ++k) P[k][l] = p[k];
    }
    for (int l = 0; l < L; ++l) {
        // G = Rᵀ F.
        Real G[9];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                G[3 * i + j] = b.R[i][l] * b.F[j][l] + b.R[3 + i][l] * b.F[3 + j][l] + b.R[6 + i][l] * b.F[6 + j][l];
        const Real e0 = G[0] - 1 - P[0][l], e1 = G[4] - 1 - P[1][l], e2 = G[8] - 1 - P[2][l];
        const Real e3 = Real(0.5) * (G[1] + G[3]) - P[3][l], e4 = Real(0.5) * (G[2] + G[6]) - P[4][l],
                   e5 = Real(0.5) * (G[5] + G[7]) - P[5][l];
        const Real tr = lambda * (e0 + e1 + e2);
        S[0][l] = 2 * mu * e0 + tr;
        S[1][l] = 2 * mu * e1 + tr;
        S[2][l] = 2 * mu * e2 + tr;
        S[3][l] = 2 * mu * e3;
        S[4][l] = 2 * mu * e4;
        S[5][l] = 2 * mu * e5;
    }
    if (beta != 0 && v) {
        Real Fv[9][L];
        for (int l = 0; l < L; ++l) {
            Mat3 dv = Mat3::Zero();
            if (l < b.count) {
                const std::uint32_t* t = &s.tets[4 * (b.first + std::size_t(l))];
                dv.col(0) = (*v)[t[1]] - (*v)[t[0]];
                dv.col(1) = (*v)[t[2]] - (*v)[t[0]];
                dv.col(2) = (*v)[t[3]] - (*v)[t[0]];
            }
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    Fv[3 * i + j][l] = dv(i, 0) * b.Di[j][l] + dv(i, 1) * b.Di[3 + j][l] + dv(i, 2) * b.Di[6 + j][l];
        }
        for (int l = 0; l < L; ++l) {
            Real G[9];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    G[3 * i + j] = b.R[i][l] * Fv[j][l] + b.R[3 + i][l] * Fv[3 + j][l] + b.R[6 + i][l] * Fv[6 + j][l];
            const Real tr = beta * lambda * (G[0] + G[4] + G[8]);
            const Real m2 = 2 * beta * mu;
            S[0][l] += m2 * G[0] + tr;
            S[1][l] += m2 * G[4] + tr;
            S[2][l] += m2 * G[8] + tr;
            S[3][l] += m2 * Real(0.5) * (G[1] + G[3]);
            S[4][l] += m2 * Real(0.5) * (G[2] + G[6]);
            S[5][l] += m2 * Real(0.5) * (G[5] + G[7]);
        }
    }
    for (int l = 0; l < L; ++l) {
        const Real sig[9] = {S[0][l], S[3][l], S[4][l], S[3][l], S[1][l], S[5][l], S[4][l], S[5][l], S[2][l]};
        Real RS[9];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                RS[3 * i + j] = b.R[3 * i][l] * sig[j] + b.R[3 * i + 1][l] * sig[3 + j] + b.R[3 * i + 2][l] * sig[6 + j];
        // H = -V RS D_m⁻ᵀ: H(i, j) = -V Σ_k RS(i, k) Di(j, k).
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                H[3 * i + j][l] = -b.V[l] * (RS[3 * i] * b.Di[3 * j][l] + RS[3 * i + 1] * b.Di[3 * j + 1][l] +
                                             RS[3 * i + 2] * b.Di[3 * j + 2][l]);
    }
}

// Node a's force from an element's H columns h0, h1, h2: f_a = h_{a-1}, f_0 = -(h0 + h1 + h2) (added as
// f -= h0 + h1 + h2, as one-thread and gathered scatters both do).
void add_node_force(Vec3& f, int a, const Vec3& h0, const Vec3& h1, const Vec3& h2) {
    if (a == 0) f -= h0 + h1 + h2;
    else f += a == 1 ? h0 : a == 2 ? h1 : h2;
}

// The forces of the batch's elements on the nodes in [lo, hi).
void scatter_forces(const FemState& s, const Batch& b, const Real (&H)[9][L], std::vector<Vec3>& f, std::uint32_t lo,
                    std::uint32_t hi) {
    for (int l = 0; l < b.count; ++l) {
        const std::uint32_t* t = &s.tets[4 * (b.first + std::size_t(l))];
        const Vec3 h0(H[0][l], H[3][l], H[6][l]), h1(H[1][l], H[4][l], H[7][l]), h2(H[2][l], H[5][l], H[8][l]);
        for (int a : {1, 2, 3, 0})
            if (t[a] >= lo && t[a] < hi) add_node_force(f[t[a]], a, h0, h1, h2);
    }
}

// The element blocks V (λ r_a r_cᵀ + μ r_c r_aᵀ + μ (r_a · r_c) I), r_a = R g_a, for a <= c (k counts the
// pairs (a, c) in that order), K[k][3 i + j][l] their (i, j) entries.
void stiffness_lanes(const FemState& s, const Batch& b, Real (&K)[10][9][L]) {
    Real r[4][3][L];
    for (int l = 0; l < L; ++l)
        for (int a = 1; a < 4; ++a)
            for (int i = 0; i < 3; ++i)
                r[a][i][l] = b.R[3 * i][l] * b.Di[3 * (a - 1)][l] + b.R[3 * i + 1][l] * b.Di[3 * (a - 1) + 1][l] +
                             b.R[3 * i + 2][l] * b.Di[3 * (a - 1) + 2][l];
    for (int l = 0; l < L; ++l)
        for (int i = 0; i < 3; ++i) r[0][i][l] = -(r[1][i][l] + r[2][i][l] + r[3][i][l]);
    const Real lambda = s.lambda, mu = s.mu;
    int k = 0;
    for (int a = 0; a < 4; ++a)
        for (int c = a; c < 4; ++c, ++k)
            for (int l = 0; l < L; ++l) {
                const Real vl = b.V[l] * lambda, vm = b.V[l] * mu;
                const Real d = vm * (r[a][0][l] * r[c][0][l] + r[a][1][l] * r[c][1][l] + r[a][2][l] * r[c][2][l]);
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j)
                        K[k][3 * i + j][l] = vl * r[a][i][l] * r[c][j][l] + vm * r[c][i][l] * r[a][j][l] + (i == j ? d : Real(0));
            }
}

// The batch's element blocks into K' (Owned: only the block rows of the nodes in [lo, hi); block (a, c) is
// in node a's row).
template <bool Owned>
void scatter_blocks(FemState& s, const Batch& b, const Real (&K)[10][9][L], std::uint32_t lo = 0, std::uint32_t hi = 0) {
    Mat3* blocks = s.stiffness.block.data();
    for (int l = 0; l < b.count; ++l) {
        const std::uint32_t* t = &s.tets[4 * (b.first + std::size_t(l))];
        const std::uint32_t* slot = &s.element_blocks[16 * (b.first + std::size_t(l))];
        const auto owned = [&](int a) { return !Owned || (t[a] >= lo && t[a] < hi); };
        int k = 0;
        for (int a = 0; a < 4; ++a)
            for (int c = a; c < 4; ++c, ++k) {
                if (owned(a)) {
                    Real* A = blocks[slot[4 * a + c]].data();  // column-major: A(i, j) = A[3 j + i]
                    for (int i = 0; i < 3; ++i)
                        for (int j = 0; j < 3; ++j) A[3 * j + i] += K[k][3 * i + j][l];
                }
                if (c != a && owned(c)) {
                    Real* B = blocks[slot[4 * c + a]].data();  // the transpose
                    for (int i = 0; i < 3; ++i)
                        for (int j = 0; j < 3; ++j) B[3 * i + j] += K[k][3 * i + j][l];
                }
            }
    }
}


/// The rotations of batch `first`'s elements at x (b gathered), kept in the state and left in b.R.
void rotate_batch(FemState& s, FemRotation method, std::size_t first, Batch& b) {
    switch (method) {
        case FemRotation::Polar: polar_lanes(s, b); break;
        case FemRotation::QR: qr_lanes(s, b); break;
        default:
            for (int l = 0; l < L; ++l) set_lane_matrix(b.R, l, Mat3::Identity());
            break;
    }
    for (int l = 0; l < b.count; ++l) s.rotation[first + std::size_t(l)] = lane_matrix(b.R, l);
}


void build_parts(FemState& s, int parts) {
    FemState::ElementParts& g = s.element_parts;
    const std::size_t n = s.rest.size();
    // Cuts where the elements' corners (each one a force and four block rows to add) are shared about
    // equally; a part's element runs follow from its nodes.
    std::vector<std::size_t> corners(n + 1, 0);
    for (const std::uint32_t i : s.tets) ++corners[i + 1];
    for (std::size_t i = 0; i < n; ++i) corners[i + 1] += corners[i];
    g.node_start.assign(std::size_t(parts) + 1, std::uint32_t(n));
    g.node_start[0] = 0;
    for (int p = 1; p < parts; ++p) {
        const std::size_t target = corners[n] * std::size_t(p) / std::size_t(parts);
        g.node_start[std::size_t(p)] = std::uint32_t(std::lower_bound(corners.begin(), corners.end(), target) - corners.begin());
    }
    g.run_start.assign(1, 0);
    g.runs.clear();
    for (int p = 0; p < parts; ++p) {
        const std::uint32_t lo = g.node_start[std::size_t(p)], hi = g.node_start[std::size_t(p) + 1];
        bool open = false;
        for (std::size_t e = 0; e < s.size(); ++e) {
            bool touches = false;
            for (int a = 0; a < 4; ++a) touches = touches || (s.tets[4 * e + std::size_t(a)] >= lo && s.tets[4 * e + std::size_t(a)] < hi);
            if (touches && !open) g.runs.push_back(std::uint32_t(e)), open = true;
            if (!touches && open) g.runs.push_back(std::uint32_t(e)), open = false;
        }
        if (open) g.runs.push_back(std::uint32_t(s.size()));
        g.run_start.push_back(std::uint32_t(g.runs.size() / 2));
    }
}

// The element loop of linear tets on the region's workers, the rotations already kept, owner-computes:
// the nodes are cut into one contiguous part per worker, and a part's task runs every element with a
// node in it (an element across a cut runs in both parts: about one layer of elements per cut) and adds
// its forces and blocks to the part's own nodes and block rows only. Each node's and block's sum then
// takes its elements in ascending order, as the one-thread loop does: bit for bit the same.
void element_loop_on_workers(FemState& s, const std::vector<Vec3>& x, const std::vector<Vec3>* v, Real beta,
                             std::vector<Vec3>* f, bool assemble, ParallelRegion& region) {
    FemState::ElementParts& g = s.element_parts;
    if (g.parts() != region.workers() || g.node_start.back() != s.rest.size()) build_parts(s, region.workers());
    region.for_each(g.parts(), 1, [&](int begin, int end, int) {
        Batch b;
        for (int p = begin; p < end; ++p) {
            const std::uint32_t lo = g.node_start[std::size_t(p)], hi = g.node_start[std::size_t(p) + 1];
            for (std::uint32_t r = g.run_start[std::size_t(p)]; r < g.run_start[std::size_t(p) + 1]; ++r) {
                const std::size_t run_end = g.runs[2 * r + 1];
                for (std::size_t first = g.runs[2 * r]; first < run_end; first += L) {
                    gather(s, x, first, b, run_end);
                    for (int l = 0; l < L; ++l)
                        set_lane_matrix(b.R, l, l < b.count ? s.rotation[b.first + std::size_t(l)] : Mat3::Identity());
                    if (f) {
                        Real H[9][L];
                        force_lanes(s, b, v, beta, H);
                        scatter_forces(s, b, H, *f, lo, hi);
                    }
                    if (assemble) {
                        Real K[10][9][L];
                        stiffness_lanes(s, b, K);
                        scatter_blocks<true>(s, b, K, lo, hi);
                    }
                }
            }
        }
    });
}

}  // namespace

void fem_kernel(FemState& s, const std::vector<Vec3>& x, const std::vector<Vec3>* v, Real beta, FemRotation method,
                bool rotate, std::vector<Vec3>* f, bool assemble, ParallelRegion* region) {
    if (assemble) s.stiffness.set_zero();
    const bool rotated = rotate;
    const bool on_workers = region && region->workers() > 1 && s.order == 1 && s.size() >= std::size_t(4 * L);
    std::atomic<int> inverted_on_workers{0};
    if (rotate && on_workers) {
        // The polar iterations are most of the loop and touch only their own element: on the workers.
        // The loop below then reads the rotations as kept ones.
        const int batches = int((s.size() + L - 1) / L);
        region->for_each(batches, 8, [&](int begin, int end, int) {
            Batch rb;
            int flat = 0;
            for (int k = begin; k < end; ++k) {
                gather(s, x, std::size_t(k) * L, rb);
                for (int l = 0; l < rb.count; ++l) flat += rb.flat[l];
                rotate_batch(s, method, std::size_t(k) * L, rb);
            }
            inverted_on_workers.fetch_add(flat, std::memory_order_relaxed);  // a count: the same in any order
        });
        rotate = false;
    }
    if (on_workers && (f || assemble)) {
        element_loop_on_workers(s, x, v, beta, f, assemble, *region);
        if (rotated) s.inverted = inverted_on_workers.load(std::memory_order_relaxed);
        if (assemble) s.assembled = true;
        return;
    }
    int inverted = 0;
    Batch b;
    for (std::size_t first = 0; first < s.size(); first += L) {
        gather(s, x, first, b);
        for (int l = 0; l < b.count; ++l) inverted += b.flat[l];
        if (!rotate) {
            for (int l = 0; l < L; ++l)
                set_lane_matrix(b.R, l, l < b.count ? s.rotation[first + std::size_t(l)] : Mat3::Identity());
        } else {
            rotate_batch(s, method, first, b);
        }
        if (s.order == 2) {
            for (int l = 0; l < b.count; ++l) {
                const std::size_t e = first + std::size_t(l);
                const Mat3 R = lane_matrix(b.R, l);
                if (f) quadratic_add_force(s, e, R, x, v, beta, *f);
                if (assemble) quadratic_assemble(s, e, R);
            }
            continue;
        }
        if (f) {
            Real H[9][L];
            force_lanes(s, b, v, beta, H);
            scatter_forces(s, b, H, *f, 0, std::uint32_t(s.rest.size()));
        }
        if (assemble) {
            Real K[10][9][L];
            stiffness_lanes(s, b, K);
            scatter_blocks<false>(s, b, K);
        }
    }
    if (rotated) s.inverted = inverted;
    if (assemble) s.assembled = true;
}

void fem_update_rotations(FemState& s, const std::vector<Vec3>& x, FemRotation method) {
    fem_kernel(s, x, nullptr, 0, method, true, nullptr, false);
}

void fem_add_forces(const FemState& s, const std::vector<Vec3>& x, const std::vector<Vec3>* v, Real beta, std::vector<Vec3>& f) {
    // Without rotating or assembling the kernel only reads the state.
    fem_kernel(const_cast<FemState&>(s), x, v, beta, FemRotation::Linear, false, &f, false);
}

void fem_assemble_stiffness(FemState& s) {
    // The positions only feed F, which neither the kept rotations nor the blocks read.
    fem_kernel(s, s.rest, nullptr, 0, FemRotation::Linear, false, nullptr, true);
}

}  // namespace sinew
