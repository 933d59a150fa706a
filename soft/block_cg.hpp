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

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "engine/core/math.hpp"
#include "engine/core/task_system.hpp"

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
            each(in.size(), [&](std::size_t begin, std::size_t end) {
                const Vec3* from = in.data();
                Vec3* to = out.data();
                for (std::size_t i = begin; i < end; ++i) to[i] = precondition(i, from[i]);
            });
        };
        return solve_impl<true>(product, jacobi, b, x, tolerance, max_iterations, warm);
    }

    /// The same with the preconditioner `precondition(r, z)`, which writes z = P r for the whole vector
    /// (P symmetric positive definite on the unfiltered rows, zero on the filtered ones).
    template <class Product, class Preconditioner>
    Result solve(Product&& product, Preconditioner&& precondition_all, const std::vector<Vec3>& b, std::vector<Vec3>& x,
                 Real tolerance, int max_iterations, bool warm) {
        return solve_impl<false>(product, precondition_all, b, x, tolerance, max_iterations, warm);
    }

    /// Workers for the solve's loops over the rows (null, or outside the region's run: this thread).
    ParallelRegion* region = nullptr;
    /// From this many rows on, every sum over the rows is taken per block of kSumBlock rows (each block
    /// in row order) and the blocks' sums added in block order, with workers or without, so any worker
    /// count gives the same bits; below it the sums run in row order.
    static constexpr std::size_t kBlockedRows = 2048, kSumBlock = 512;

    /// fn(begin, end) over the rows [0, n), split among the region's workers for a large system.
    template <class Fn>
    void each(std::size_t n, Fn&& fn) const {
        for_ranges(on_workers(n) ? region : nullptr, n, 256, fn);
    }

    /// Σ term(i) over the rows [0, n) in double (see kBlockedRows for the order).
    template <class Term>
    double sum(std::size_t n, Term&& term) {
        return sum_rows(n, [&](std::size_t begin, std::size_t end) {
            double s = 0;
            for (std::size_t i = begin; i < end; ++i) s += term(i);
            return s;
        });
    }

    /// The same from `rows(begin, end)`, which returns the sum over rows [begin, end) in row order (and
    /// may write those rows' own outputs): called once for [0, n) below kBlockedRows, else once per block.
    template <class Rows>
    double sum_rows(std::size_t n, Rows&& rows) {
        if (n < kBlockedRows) return rows(std::size_t(0), n);
        const std::size_t blocks = (n + kSumBlock - 1) / kSumBlock;
        if (partial_.size() < blocks) partial_.resize(blocks);  // once per size
        const auto run = [&](std::size_t first, std::size_t last) {
            for (std::size_t k = first; k < last; ++k) partial_[k] = rows(k * kSumBlock, std::min(n, (k + 1) * kSumBlock));
        };
        if (on_workers(n))
            region->for_each(int(blocks), 1, [&](int first, int last, int) { run(std::size_t(first), std::size_t(last)); });
        else
            run(0, blocks);
        double total = 0;
        for (std::size_t k = 0; k < blocks; ++k) total += partial_[k];
        return total;
    }

private:
    bool on_workers(std::size_t n) const { return region && region->workers() > 1 && n >= kBlockedRows; }

    // Jacobi: precondition_all is block Jacobi (this->precondition row by row), fused into the step's pass.
    template <bool Jacobi, class Product, class Preconditioner>
    Result solve_impl(Product&& product, Preconditioner&& precondition_all, const std::vector<Vec3>& b,
                      std::vector<Vec3>& x, Real tolerance, int max_iterations, bool warm) {
        const std::size_t n = b.size();
        Result out;
        precondition_all(b, z);
        const double bpb = sum(n, [&](std::size_t i) { return dot(b[i], z[i]); });
        if (!(bpb > 0)) {
            for (Vec3& v : x) v.setZero();
            out.converged = true;
            return out;
        }
        if (warm) product(x, q);  // q = A x0
        each(n, [&](std::size_t begin, std::size_t end) {
            for (std::size_t i = begin; i < end; ++i) {
                if (!warm) x[i].setZero();
                d[i].setZero();
                r[i] = warm ? Vec3(b[i] - q[i]) : b[i];
            }
        });
        precondition_all(r, z);
        double rz = sum(n, [&](std::size_t i) { return dot(r[i], z[i]); });
        const double tol2 = double(tolerance) * double(tolerance) * bpb;
        Real beta = 0;
        while (rz > tol2 && out.iterations < max_iterations) {
            // Scalars and arrays in locals of each loop: read through the closure, a float store may alias
            // them, they are reloaded every row and the loop does not vectorise (the 64 x 64 implicit
            // cloth's step was 1.1x as slow on one thread).
            each(n, [&](std::size_t begin, std::size_t end) {
                const Real s = beta;
                Vec3* dd = d.data();
                const Vec3* zz = z.data();
                for (std::size_t i = begin; i < end; ++i) dd[i] = zz[i] + s * dd[i];
            });
            product(d, q);
            const double dad = sum(n, [&](std::size_t i) { return dot(d[i], q[i]); });  // over particles: fewer than elements
            if (!(dad > 0)) break;  // lost definiteness: a guard for NaN input
            const Real alpha = Real(rz / dad);
            double rz_new;
            if (Jacobi && n >= kBlockedRows) {
                // One pass: the step, the preconditioner and r · z (one stage on the workers, not three;
                // on one thread below kBlockedRows the three loops are faster: 1,058 against 1,302 perf
                // samples of the solve on a 189-node beam).
                rz_new = sum_rows(n, [&](std::size_t begin, std::size_t end) {
                    const Real a = alpha;
                    Vec3* xx = x.data();
                    Vec3* rr = r.data();
                    Vec3* zz = z.data();
                    const Vec3* dd = d.data();
                    const Vec3* qq = q.data();
                    double s = 0;
                    for (std::size_t i = begin; i < end; ++i) {
                        xx[i] += a * dd[i];
                        rr[i] -= a * qq[i];
                        zz[i] = precondition(i, rr[i]);
                        s += dot(rr[i], zz[i]);
                    }
                    return s;
                });
            } else {
                each(n, [&](std::size_t begin, std::size_t end) {
                    const Real a = alpha;
                    Vec3* xx = x.data();
                    Vec3* rr = r.data();
                    const Vec3* dd = d.data();
                    const Vec3* qq = q.data();
                    for (std::size_t i = begin; i < end; ++i) {
                        xx[i] += a * dd[i];
                        rr[i] -= a * qq[i];
                    }
                });
                precondition_all(r, z);
                rz_new = sum(n, [&](std::size_t i) { return dot(r[i], z[i]); });
            }
            beta = Real(rz_new / rz);
            rz = rz_new;
            ++out.iterations;
        }
        out.residual = Real(std::sqrt(rz / bpb));
        out.converged = out.residual <= tolerance;
        return out;
    }

    std::vector<double> partial_;
};

}  // namespace sinew
