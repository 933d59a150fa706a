// Preconditioned conjugate gradient on block-sparse symmetric systems with one 3x3 block row per
// particle (Shewchuk 1994, "An Introduction to the Conjugate Gradient Method Without the Agonizing
// Pain", B2), matrix-free: the caller supplies the product q = A d, so springs (soft/implicit_euler.cpp)
// and tetrahedral elements can each stream their own blocks. The preconditioner is block Jacobi: the
// inverse of each particle's 3x3 diagonal block, assembled by the caller. Rows the caller filters out
// (Baraff & Witkin 1998's S = 0 for pinned particles) have a zero right-hand side, a zero inverse block
// and a zero product row, so the unknown stays 0 there.
//
// Convergence is measured in the preconditioned norm: stop when sqrt(rᵀ P r / bᵀ P b) <= tolerance or
// after max_iterations. Sums over particles run in double (the long sums are what lose precision).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "engine/core/math.hpp"

namespace sinew {

/// Scratch and preconditioner of one system, kept between steps so a solve allocates nothing.
struct BlockCg {
    std::vector<Vec3> r, z, d, q;  ///< residual, preconditioned residual, search direction, A d
    /// Per row: the symmetric inverse diagonal block (xx, yy, zz, xy, xz, yz); the caller writes the
    /// block itself, then invert_blocks(). All zero for a filtered row.
    std::vector<Real> block_inv;

    struct Result {
        int iterations = 0;
        Real residual = 0;  ///< sqrt(rᵀ P r / bᵀ P b) at the end (0 for a zero right-hand side)
        bool converged = false;
    };

    void resize(std::size_t n) {
        if (r.size() == n) return;
        r.assign(n, Vec3::Zero());
        z.assign(n, Vec3::Zero());
        d.assign(n, Vec3::Zero());
        q.assign(n, Vec3::Zero());
        block_inv.assign(6 * n, Real(0));
    }
    Real* block(std::size_t i) { return &block_inv[6 * i]; }

    /// Inverts every non-zero block in place (adjugate over determinant, in double; the blocks are
    /// positive definite: mass plus positive semi-definite stiffness blocks).
    void invert_blocks() {
        for (std::size_t i = 0; i < r.size(); ++i) {
            Real* B = block(i);
            if (B[0] == 0 && B[1] == 0 && B[2] == 0) continue;  // filtered row
            const double xx = B[0], yy = B[1], zz = B[2], xy = B[3], xz = B[4], yz = B[5];
            const double c00 = yy * zz - yz * yz, c01 = xz * yz - xy * zz, c02 = xy * yz - xz * yy;
            const double s = 1.0 / (xx * c00 + xy * c01 + xz * c02);
            B[0] = Real(c00 * s);
            B[1] = Real((xx * zz - xz * xz) * s);
            B[2] = Real((xx * yy - xy * xy) * s);
            B[3] = Real(c01 * s);
            B[4] = Real(c02 * s);
            B[5] = Real((xy * xz - xx * yz) * s);
        }
    }
    /// P v for row i.
    Vec3 precondition(std::size_t i, const Vec3& v) const {
        const Real* B = &block_inv[6 * i];
        return Vec3(B[0] * v.x() + B[3] * v.y() + B[4] * v.z(), B[3] * v.x() + B[1] * v.y() + B[5] * v.z(),
                    B[4] * v.x() + B[5] * v.y() + B[2] * v.z());
    }
    static double dot(const Vec3& a, const Vec3& b) { return double(a.dot(b)); }

    /// Solves A x = b. `product(d, q)` writes q = A d (filtered rows zero). With `warm`, x holds the
    /// initial guess (zero at filtered rows), else x is set to 0 first. The preconditioner is the block
    /// Jacobi one the caller wrote into block_inv.
    template <class Product>
    Result solve(Product&& product, const std::vector<Vec3>& b, std::vector<Vec3>& x, Real tolerance,
                 int max_iterations, bool warm) {
        const auto jacobi = [this](const std::vector<Vec3>& in, std::vector<Vec3>& out) {
            for (std::size_t i = 0; i < in.size(); ++i) out[i] = precondition(i, in[i]);
        };
        return solve(product, jacobi, b, x, tolerance, max_iterations, warm);
    }

    /// The same with the preconditioner `precondition(r, z)`, which writes z = P r for the whole vector
    /// (P symmetric positive definite on the unfiltered rows, zero on the filtered ones).
    template <class Product, class Preconditioner>
    Result solve(Product&& product, Preconditioner&& precondition_all, const std::vector<Vec3>& b, std::vector<Vec3>& x,
                 Real tolerance, int max_iterations, bool warm) {
        const std::size_t n = b.size();
        Result out;
        precondition_all(b, z);
        double bpb = 0;
        for (std::size_t i = 0; i < n; ++i) bpb += dot(b[i], z[i]);
        if (!(bpb > 0)) {
            for (Vec3& v : x) v.setZero();
            out.converged = true;
            return out;
        }
        if (warm) product(x, q);  // q = A x0
        for (std::size_t i = 0; i < n; ++i) {
            if (!warm) x[i].setZero();
            d[i].setZero();
            r[i] = warm ? Vec3(b[i] - q[i]) : b[i];
        }
        precondition_all(r, z);
        double rz = 0;
        for (std::size_t i = 0; i < n; ++i) rz += dot(r[i], z[i]);
        const double tol2 = double(tolerance) * double(tolerance) * bpb;
        Real beta = 0;
        while (rz > tol2 && out.iterations < max_iterations) {
            for (std::size_t i = 0; i < n; ++i) d[i] = z[i] + beta * d[i];
            product(d, q);
            double dad = 0;  // over particles rather than the caller's elements: there are fewer
            for (std::size_t i = 0; i < n; ++i) dad += dot(d[i], q[i]);
            if (!(dad > 0)) break;  // lost definiteness: a guard for NaN input
            const Real alpha = Real(rz / dad);
            for (std::size_t i = 0; i < n; ++i) {
                x[i] += alpha * d[i];
                r[i] -= alpha * q[i];
            }
            precondition_all(r, z);
            double rz_new = 0;
            for (std::size_t i = 0; i < n; ++i) rz_new += dot(r[i], z[i]);
            beta = Real(rz_new / rz);
            rz = rz_new;
            ++out.iterations;
        }
        out.residual = Real(std::sqrt(rz / bpb));
        out.converged = out.residual <= tolerance;
        return out;
    }
};

}  // namespace sinew
