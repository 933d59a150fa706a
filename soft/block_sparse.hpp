// A symmetric sparse matrix of 3x3 blocks, one block row per particle, with its pattern built once from
// the elements that couple particles (the linear or quadratic tets of an FEM body): compressed rows, both triangles stored so
// the product is one pass over the rows. Each element keeps the positions of its blocks in the value
// array, so assembling adds into fixed places and allocates nothing.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "engine/core/math.hpp"
#include "engine/core/task_system.hpp"

namespace sinew {

struct BlockSparse3 {
    std::vector<std::uint32_t> row_start;  ///< n + 1 offsets into col and the blocks
    std::vector<std::uint32_t> col;        ///< the column (particle) of each block, ascending in a row
    std::vector<Mat3> block;               ///< the values
    std::vector<std::uint32_t> diagonal;   ///< per row, the index of its diagonal block

    std::size_t rows() const { return row_start.empty() ? 0 : row_start.size() - 1; }

    /// The pattern of n rows from elements of `per` particles each (tets: 4, quadratic tets: 10), and per
    /// element its per² block indices, row-major (a, b) for a, b in 0..per-1, at element_blocks[per² e].
    void build_pattern(std::size_t n, const std::vector<std::uint32_t>& elements, int per,
                       std::vector<std::uint32_t>& element_blocks) {
        std::vector<std::vector<std::uint32_t>> adjacent(n);
        const std::size_t P = std::size_t(per), m = elements.size() / P;
        for (std::size_t e = 0; e < m; ++e)
            for (std::size_t a = 0; a < P; ++a)
                for (std::size_t b = 0; b < P; ++b) adjacent[elements[P * e + a]].push_back(elements[P * e + b]);
        row_start.assign(n + 1, 0);
        col.clear();
        diagonal.assign(n, 0);
        for (std::size_t i = 0; i < n; ++i) {
            std::vector<std::uint32_t>& r = adjacent[i];
            r.push_back(std::uint32_t(i));
            std::sort(r.begin(), r.end());
            r.erase(std::unique(r.begin(), r.end()), r.end());
            for (const std::uint32_t j : r) {
                if (j == i) diagonal[i] = std::uint32_t(col.size());
                col.push_back(j);
            }
            row_start[i + 1] = std::uint32_t(col.size());
        }
        block.assign(col.size(), Mat3::Zero());
        element_blocks.resize(m * P * P);
        for (std::size_t e = 0; e < m; ++e)
            for (std::size_t a = 0; a < P; ++a) {
                const std::uint32_t i = elements[P * e + a];
                for (std::size_t b = 0; b < P; ++b) {
                    const std::uint32_t j = elements[P * e + b];
                    const auto begin = col.begin() + row_start[i], end = col.begin() + row_start[i + 1];
                    element_blocks[(e * P + a) * P + b] = std::uint32_t(std::lower_bound(begin, end, j) - col.begin());
                }
            }
    }

    void set_zero() { std::fill(block.begin(), block.end(), Mat3::Zero()); }

    /// q += s A u, row by row (each row writes only its own q[i], so the rows split among the workers of
    /// `region` give the same sums; null: one thread).
    void add_product(const std::vector<Vec3>& u, Real s, std::vector<Vec3>& q, ParallelRegion* region = nullptr) const {
        auto rows_of = [&](int begin, int end, int) {
            for (std::size_t i = std::size_t(begin); i < std::size_t(end); ++i) {
                Vec3 sum = Vec3::Zero();
                for (std::uint32_t k = row_start[i]; k < row_start[i + 1]; ++k) sum.noalias() += block[k] * u[col[k]];
                q[i] += s * sum;
            }
        };
        if (region) region->for_each(int(rows()), 256, rows_of);
        else rows_of(0, int(rows()), 0);
    }
};

}  // namespace sinew
