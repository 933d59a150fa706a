// The links that end at each row, for gathers that add a per-link term row by row in the order a scatter
// over the links would add it (so a row's owner can add it alone, with the one-thread bits): fast
// mass-spring's right-hand side J p and implicit Euler's springs' product, when they run on workers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "engine/core/bucket_sort.hpp"

namespace sinew {

/// Compressed rows of link ends: entry[start[r] .. start[r+1]) are the ends at row r, in ascending order of
/// end e = 2 j (link j's end a) or 2 j + 1 (its end b).
struct LinkRows {
    std::vector<std::uint32_t> start, entry;

    /// By a counting sort over the links' ends: row_of(e) gives end e's row, or a negative value for an
    /// end that has none (a pinned particle).
    template <class RowOf>
    void build(std::size_t rows, std::size_t links, RowOf&& row_of) {
        bucket_sort(2 * links, rows, row_of, start, entry, fill_);
    }
    void clear() { start.clear(), entry.clear(); }
    bool built_for(std::size_t rows) const { return start.size() == rows + 1; }

private:
    std::vector<std::uint32_t> fill_;  // the next free entry of each row while building
};

}  // namespace sinew
