// Solving with a sparse L D Lᵀ factor in place, allocation-free, on the factor's own arrays (Eigen's
// SimplicialLDLT keeps L's strictly lower part column by column, unit diagonal implied, and D apart).
// Used by fast mass-spring / projective dynamics (three right-hand sides interleaved: x, y, z per row) and
// by the rest-factor preconditioner (one). Eigen's own solve() allocates a mask when it permutes in place.
#pragma once

#include <Eigen/SparseCore>
#include <vector>

namespace sinew {

/// Solves L D Lᵀ x = b in place for `Stride` interleaved right-hand sides: b holds Stride values per row
/// (row j at b[Stride j]); `inv_d` is 1 / D per row; L is the factor's unit lower triangle without its
/// diagonal, compressed or not.
template <int Stride>
void ldlt_solve_in_place(const Eigen::SparseMatrix<double, Eigen::ColMajor, int>& l, const std::vector<double>& inv_d, double* x) {
    const int n = int(l.cols());
    const int* outer = l.outerIndexPtr();
    const int* nnz = l.innerNonZeroPtr();  // null when compressed
    const int* inner = l.innerIndexPtr();
    const double* value = l.valuePtr();
    for (int j = 0; j < n; ++j) {  // L y = b
        const double* xj = x + Stride * j;
        const int end = nnz ? outer[j] + nnz[j] : outer[j + 1];
        for (int p = outer[j]; p < end; ++p) {
            double* xi = x + Stride * inner[p];
            for (int k = 0; k < Stride; ++k) xi[k] -= value[p] * xj[k];
        }
    }
    for (int j = 0; j < n; ++j)  // D z = y
        for (int k = 0; k < Stride; ++k) x[Stride * j + k] *= inv_d[std::size_t(j)];
    for (int j = n - 1; j >= 0; --j) {  // Lᵀ x = z
        double* xj = x + Stride * j;
        const int end = nnz ? outer[j] + nnz[j] : outer[j + 1];
        for (int p = outer[j]; p < end; ++p) {
            const double* xi = x + Stride * inner[p];
            for (int k = 0; k < Stride; ++k) xj[k] -= value[p] * xi[k];
        }
    }
}

}  // namespace sinew
