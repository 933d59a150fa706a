// Items grouped by an integer key with a counting sort: the compressed-rows index that the solvers build
// over links, joints or particles (links by row, links by colour, joints by group).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace sinew {

/// Items 0 .. count-1 grouped by key(i) in [0, buckets) (a negative key leaves the item out): bucket b's
/// items are order[start[b] .. start[b + 1]), ascending. `fill` is scratch.
template <class Key>
void bucket_sort(std::size_t count, std::size_t buckets, Key&& key, std::vector<std::uint32_t>& start,
                 std::vector<std::uint32_t>& order, std::vector<std::uint32_t>& fill) {
    start.assign(buckets + 1, 0);
    for (std::size_t i = 0; i < count; ++i) {
        const long k = long(key(i));
        if (k >= 0) ++start[std::size_t(k) + 1];
    }
    for (std::size_t b = 0; b < buckets; ++b) start[b + 1] += start[b];
    order.resize(start[buckets]);
    fill.assign(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < count; ++i) {
        const long k = long(key(i));
        if (k >= 0) order[fill[std::size_t(k)]++] = std::uint32_t(i);
    }
}

}  // namespace sinew
