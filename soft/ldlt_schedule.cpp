// Splitting an L D Lᵀ factor's triangular solves among workers: see soft/ldlt_schedule.hpp.
#include "soft/ldlt_schedule.hpp"

#include <algorithm>
#include <numeric>
#include <queue>
#include <utility>

namespace sinew {

namespace {

// Deals subtrees (their costs) to `parts` parts, costliest first, each to the part with the least work so
// far (Graham's LPT rule: within 4/3 of the best split). Ties go to the lower index (the schedule does not
// change results, but it should not change between runs either). Writes each subtree's part; returns the
// largest part's cost.
double deal(const std::vector<int>& roots, const std::vector<double>& cost, int parts, std::vector<int>& part_of) {
    std::vector<int> order(roots.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) {
        const double ca = cost[std::size_t(roots[std::size_t(a)])], cb = cost[std::size_t(roots[std::size_t(b)])];
        return ca != cb ? ca > cb : roots[std::size_t(a)] < roots[std::size_t(b)];
    });
    std::vector<double> load(std::size_t(parts), 0.0);
    part_of.assign(roots.size(), 0);
    for (const int k : order) {
        const auto least = std::size_t(std::min_element(load.begin(), load.end()) - load.begin());
        part_of[std::size_t(k)] = int(least);
        load[least] += cost[std::size_t(roots[std::size_t(k)])];
    }
    return *std::max_element(load.begin(), load.end());
}

}  // namespace

void LdltSchedule::build(const LdltArrays& f, int part_count) {
    clear();
    const int n = int(f.rows());
    const std::size_t rows = f.rows();
    part_count = std::max(part_count, 2);
    // The elimination tree: a column's first entry below the diagonal is its parent (rows ascend within
    // a column in Eigen's up-looking factorization; the minimum is taken anyway).
    std::vector<int> parent(rows, -1);
    for (int j = 0; j < n; ++j)
        for (int p = f.col_start[std::size_t(j)]; p < f.col_start[std::size_t(j) + 1]; ++p) {
            const int i = f.col_row[std::size_t(p)];
            if (parent[std::size_t(j)] < 0 || i < parent[std::size_t(j)]) parent[std::size_t(j)] = i;
        }
    // A row's work: its entries in both solves and its diagonal; a subtree's: the sum over its rows
    // (children have lower indices than their parent, so one ascending pass adds them up).
    std::vector<double> own(rows), subtree(rows);
    for (int j = 0; j < n; ++j) {
        own[std::size_t(j)] = double(f.row_start[std::size_t(j) + 1] - f.row_start[std::size_t(j)]) +
                              double(f.col_start[std::size_t(j) + 1] - f.col_start[std::size_t(j)]) + 2.0;
        subtree[std::size_t(j)] = own[std::size_t(j)];
    }
    double total = 0;
    for (int j = 0; j < n; ++j) {
        total += own[std::size_t(j)];
        if (parent[std::size_t(j)] >= 0) subtree[std::size_t(parent[std::size_t(j)])] += subtree[std::size_t(j)];
    }
    std::vector<int> child_start(rows + 1, 0), children(rows);
    for (int j = 0; j < n; ++j)
        if (parent[std::size_t(j)] >= 0) ++child_start[std::size_t(parent[std::size_t(j)]) + 1];
    for (int j = 0; j < n; ++j) child_start[std::size_t(j) + 1] += child_start[std::size_t(j)];
    {
        std::vector<int> fill(child_start.begin(), child_start.end() - 1);
        for (int j = 0; j < n; ++j)
            if (parent[std::size_t(j)] >= 0) children[std::size_t(fill[std::size_t(parent[std::size_t(j)])]++)] = j;
    }

    // Split the costliest subtree while the top's cost plus the largest part's can still fall: any split
    // from here costs at least top + (total - top) / parts, which only grows as the top does, so once that
    // reaches the best split found, none helps (a factor without links, all roots, stops after one pass).
    const auto lighter = [&](int a, int b) {
        return subtree[std::size_t(a)] != subtree[std::size_t(b)] ? subtree[std::size_t(a)] < subtree[std::size_t(b)] : a > b;
    };
    std::priority_queue<int, std::vector<int>, decltype(lighter)> heap(lighter);
    for (int j = 0; j < n; ++j)
        if (parent[std::size_t(j)] < 0) heap.push(j);
    std::vector<int> top, best_top, roots, best_roots, part_of, best_part_of;
    double top_cost = 0, best = total + 1;
    while (!heap.empty() && top_cost + (total - top_cost) / double(part_count) < best) {
        roots.clear();
        {
            auto copy = heap;
            for (; !copy.empty(); copy.pop()) roots.push_back(copy.top());
        }
        const double makespan = top_cost + deal(roots, subtree, part_count, part_of);
        if (makespan < best) {
            best = makespan;
            best_top = top;
            best_roots = roots;
            best_part_of = part_of;
            largest_part_share = (makespan - top_cost) / total;
            top_share = top_cost / total;
        }
        const int split = heap.top();
        heap.pop();
        top.push_back(split);
        top_cost += own[std::size_t(split)];
        for (int c = child_start[std::size_t(split)]; c < child_start[std::size_t(split) + 1]; ++c)
            heap.push(children[std::size_t(c)]);
    }

    // Each part's rows: every row of its subtrees, ascending.
    std::vector<std::vector<int>> part_lists(static_cast<std::size_t>(part_count));
    std::vector<int> stack;
    for (std::size_t k = 0; k < best_roots.size(); ++k) {
        std::vector<int>& out = part_lists[std::size_t(best_part_of[k])];
        stack.assign(1, best_roots[k]);
        while (!stack.empty()) {
            const int j = stack.back();
            stack.pop_back();
            out.push_back(j);
            for (int c = child_start[std::size_t(j)]; c < child_start[std::size_t(j) + 1]; ++c)
                stack.push_back(children[std::size_t(c)]);
        }
    }
    part_start.assign(1, 0);
    for (std::vector<int>& r : part_lists) {
        std::sort(r.begin(), r.end());
        part_rows.insert(part_rows.end(), r.begin(), r.end());
        part_start.push_back(int(part_rows.size()));
    }
    top_rows = std::move(best_top);
    std::sort(top_rows.begin(), top_rows.end());
    parts = part_count;
}

}  // namespace sinew
