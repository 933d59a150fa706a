// Solving with a sparse L D Lᵀ factor in place, allocation-free. Used by fast mass-spring / projective
// dynamics (three right-hand sides interleaved: x, y, z per row; its contact CG solves ten times a step)
// and by the FEM rest-factor preconditioner (one).
//
// Eigen's SimplicialLDLT keeps L's strictly lower part column by column. The backward solve Lᵀ x = z reads
// it well (x_j = z_j - Σ_{i>j} L_ij x_i: a gather down column j), but the forward solve L y = b by columns
// scatters (y_i -= L_ij y_j for each i of column j), a store per entry that the compiler cannot keep in
// registers. LdltArrays copies L once per factorization into both layouts, so both solves gather into
// register accumulators: on the 32 x 32 cloth's factor (1,024 rows, 19,246 entries, three right-hand
// sides) a solve took 99 µs through the column layout alone and 34 µs so. Each sum runs over the same
// entries in the same order as the scatter did (j ascending in row i), so results are bit-identical.
#pragma once

#include <Eigen/SparseCore>
#include <vector>

namespace sinew {

/// A factor L D Lᵀ in flat arrays: L's strictly lower part by rows (forward solve) and by columns
/// (backward solve), and 1 / D.
struct LdltArrays {
    std::vector<int> row_start, row_col;  ///< row i's entries: [row_start[i], row_start[i + 1])
    std::vector<double> row_value;
    std::vector<int> col_start, col_row;  ///< column j's entries: [col_start[j], col_start[j + 1])
    std::vector<double> col_value;
    std::vector<double> inv_d;

    bool empty() const { return inv_d.empty(); }
    std::size_t rows() const { return inv_d.size(); }
    void clear() { *this = LdltArrays(); }

    /// Copies a factor: `l` is the unit lower triangle without its diagonal (Eigen's
    /// SimplicialLDLT::matrixL().nestedExpression(), compressed or not), `d` its D.
    void assign(const Eigen::SparseMatrix<double, Eigen::ColMajor, int>& l, const Eigen::VectorXd& d) {
        const int n = int(l.cols());
        const int* outer = l.outerIndexPtr();
        const int* nnz = l.innerNonZeroPtr();  // null when compressed
        const int* inner = l.innerIndexPtr();
        const double* value = l.valuePtr();
        const auto end_of = [&](int j) { return nnz ? outer[j] + nnz[j] : outer[j + 1]; };
        col_start.assign(std::size_t(n) + 1, 0);
        row_start.assign(std::size_t(n) + 1, 0);
        for (int j = 0; j < n; ++j) {
            col_start[std::size_t(j) + 1] = col_start[std::size_t(j)] + (end_of(j) - outer[j]);
            for (int p = outer[j]; p < end_of(j); ++p) ++row_start[std::size_t(inner[p]) + 1];
        }
        for (int i = 0; i < n; ++i) row_start[std::size_t(i) + 1] += row_start[std::size_t(i)];
        const std::size_t total = std::size_t(col_start[std::size_t(n)]);
        col_row.resize(total);
        col_value.resize(total);
        row_col.resize(total);
        row_value.resize(total);
        std::vector<int> fill(row_start.begin(), row_start.end() - 1);
        for (int j = 0; j < n; ++j) {  // columns in order: each row's entries come out by ascending column
            int q = col_start[std::size_t(j)];
            for (int p = outer[j]; p < end_of(j); ++p, ++q) {
                col_row[std::size_t(q)] = inner[p];
                col_value[std::size_t(q)] = value[p];
                const int r = fill[std::size_t(inner[p])]++;
                row_col[std::size_t(r)] = j;
                row_value[std::size_t(r)] = value[p];
            }
        }
        inv_d.resize(std::size_t(n));
        for (int k = 0; k < n; ++k) inv_d[std::size_t(k)] = 1.0 / d[k];
    }

    /// Solves L D Lᵀ x = b in place for `Stride` (1 or 3) interleaved right-hand sides: x holds Stride
    /// values per row (row j at x[Stride j]).
    template <int Stride>
    void solve_in_place(double* x) const {
        static_assert(Stride == 1 || Stride == 3, "one or three right-hand sides");
        const int n = int(inv_d.size());
        substitute<Stride, false>(row_start.data(), row_col.data(), row_value.data(), n, x);  // L y = b
        for (int j = 0; j < n; ++j)  // D z = y
            for (int k = 0; k < Stride; ++k) x[Stride * j + k] *= inv_d[std::size_t(j)];
        substitute<Stride, true>(col_start.data(), col_row.data(), col_value.data(), n, x);  // Lᵀ x = z
    }

    /// Row i of the forward solve L y = b: y_i = b_i - Σ_{j<i} L_ij y_j (the y_j of L's row i must be done).
    template <int Stride>
    void forward_row(int i, double* x) const {
        substitute_one<Stride>(row_start.data(), row_col.data(), row_value.data(), i, x);
    }
    /// Row i of the backward solve Lᵀ x = z: x_i = z_i - Σ_{j>i} L_ji x_j (the x_j of L's column i must be
    /// done).
    template <int Stride>
    void backward_row(int i, double* x) const {
        substitute_one<Stride>(col_start.data(), col_row.data(), col_value.data(), i, x);
    }

private:
    // The sums are spelled out per right-hand side: written as loops over a local array, GCC -O2 kept the
    // accumulators in memory and the solve took 128 µs instead of 34 µs on the factor above.
    // Row i of L y = b (forward, `index` the columns of L's row i) or column i of Lᵀ x = z (backward,
    // `index` the rows of L's column i): x_i -= Σ value · x_index.
    template <int Stride>
    static void substitute_one(const int* start, const int* index, const double* value, int i, double* x) {
        double* xi = x + Stride * i;
        double a0 = xi[0], a1 = 0, a2 = 0;
        if constexpr (Stride == 3) a1 = xi[1], a2 = xi[2];
        for (int p = start[i]; p < start[i + 1]; ++p) {
            const double* xj = x + Stride * index[p];
            const double v = value[p];
            a0 -= v * xj[0];
            if constexpr (Stride == 3) a1 -= v * xj[1], a2 -= v * xj[2];
        }
        xi[0] = a0;
        if constexpr (Stride == 3) xi[1] = a1, xi[2] = a2;
    }
    // Rows ascending (forward) or descending (backward).
    template <int Stride, bool Backward>
    static void substitute(const int* start, const int* index, const double* value, int n, double* x) {
        for (int k = 0; k < n; ++k) substitute_one<Stride>(start, index, value, Backward ? n - 1 - k : k, x);
    }
};

}  // namespace sinew
