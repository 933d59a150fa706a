// The triangular solves of a sparse L D Lᵀ factor (soft/ldlt_solve.hpp) split among workers by the
// factor's elimination tree (Liu 1990, "The role of elimination trees in sparse factorization"; level and
// subtree scheduling of triangular solves as in Anderson & Saad 1989). Column j of L has its first
// off-diagonal entry in row parent(j) > j, and row i of L only has entries in columns that are i's
// descendants in that tree. So the forward solve of a subtree's rows needs no row outside the subtree,
// and the backward solve of a subtree's rows needs only the subtree and its ancestors. A schedule picks
// disjoint subtrees and deals them to the workers in parts of about equal cost; the rows above them
// (the top of the tree: the last separators of the fill-reducing order) run on the calling thread:
//     forward:  every part in parallel (rows ascending), then the top rows ascending;
//     diagonal: the top rows, then (in the backward stage) each part's;
//     backward: the top rows descending, then every part in parallel (rows descending).
// Each row's sum runs over the same entries in the same order as in the one-thread solve, so the result
// is bit-identical whatever the worker count and whichever worker runs which part.
#pragma once

#include <vector>

#include "engine/core/task_system.hpp"
#include "soft/ldlt_solve.hpp"

namespace sinew {

struct LdltSchedule {
    int parts = 0;                 ///< what it was built for: 0 = not built
    std::vector<int> part_start;   ///< parts + 1 offsets into part_rows
    std::vector<int> part_rows;    ///< each part's rows, ascending
    std::vector<int> top_rows;     ///< the rows above every part, ascending
    double top_share = 0;          ///< the top rows' share of the solve's work (for measuring)
    double largest_part_share = 0;  ///< the largest part's share of the solve's work

    void clear() { *this = LdltSchedule(); }

    /// Splits `factor`'s rows into `parts` parts (>= 2) and the top rows: from the roots of the
    /// elimination tree, the costliest subtree is split (its root moved to the top) while that lowers
    /// the top's cost plus the largest part's, the subtrees dealt to the parts largest first (each to the
    /// part with the least work so far). Allocates; run once per factorization and part count.
    void build(const LdltArrays& factor, int parts);
};

/// Solves L D Lᵀ x = b in place (Stride right-hand sides interleaved, as LdltArrays::solve_in_place) with
/// the workers of `region` (its run() in progress); `schedule` built for `factor` with any part count.
/// Bit-identical to factor.solve_in_place<Stride>(x).
template <int Stride>
void solve_in_place_parallel(const LdltArrays& factor, const LdltSchedule& schedule, ParallelRegion& region, double* x) {
    const int* start = schedule.part_start.data();
    const int* rows = schedule.part_rows.data();
    region.for_each(schedule.parts, 1, [&](int begin, int end, int) {
        for (int q = begin; q < end; ++q)
            for (int k = start[q]; k < start[q + 1]; ++k) factor.forward_row<Stride>(rows[k], x);
    });
    const auto scale = [&](int i) {
        const double d = factor.inv_d[std::size_t(i)];
        for (int c = 0; c < Stride; ++c) x[Stride * i + c] *= d;
    };
    for (const int i : schedule.top_rows) factor.forward_row<Stride>(i, x);
    for (const int i : schedule.top_rows) scale(i);
    for (auto it = schedule.top_rows.rbegin(); it != schedule.top_rows.rend(); ++it) factor.backward_row<Stride>(*it, x);
    region.for_each(schedule.parts, 1, [&](int begin, int end, int) {
        for (int q = begin; q < end; ++q) {
            for (int k = start[q]; k < start[q + 1]; ++k) scale(rows[k]);
            for (int k = start[q + 1] - 1; k >= start[q]; --k) factor.backward_row<Stride>(rows[k], x);
        }
    });
}

}  // namespace sinew
