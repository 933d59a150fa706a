// Contact-graph levels: each body's breadth-first distance, over this step's contacts, from the
// immovable bodies (static, kinematic, asleep: level 0). Shock propagation (rigid/newton_solver.cpp)
// solves level by level from the ground; the sequential-impulse solvers' mass-ratio bound
// (rigid/rigid_support.cpp) asks which body of a contact holds the other up.
#pragma once

#include <cstdint>
#include <vector>

#include "engine/core/math.hpp"

namespace sinew {

class ContactLevels {
public:
    static constexpr std::int32_t kUnreached = 1 << 30;  ///< a body with no contact path to the ground

    /// `pair(i, a, b)` gives contact i's two body slots and returns whether it counts (has points). The
    /// adjacency is kept in member arrays as compressed rows, rebuilt each call without allocating once grown.
    template <class Pair>
    void compute(const std::vector<Real>& inv_mass, std::size_t contacts, Pair&& pair) {
        const std::size_t n = inv_mass.size();
        level_.assign(n, kUnreached);
        queue_.clear();
        for (std::uint32_t s = 0; s < n; ++s)
            if (inv_mass[s] == 0) {
                level_[s] = 0;
                queue_.push_back(s);
            }
        adj_start_.assign(n + 1, 0);
        std::uint32_t a = 0, b = 0;
        for (std::size_t i = 0; i < contacts; ++i)
            if (pair(i, a, b)) {
                ++adj_start_[a + 1];
                ++adj_start_[b + 1];
            }
        for (std::size_t i = 0; i < n; ++i) adj_start_[i + 1] += adj_start_[i];
        adj_.resize(adj_start_[n]);
        fill_.assign(adj_start_.begin(), adj_start_.end() - 1);
        for (std::size_t i = 0; i < contacts; ++i)
            if (pair(i, a, b)) {
                adj_[fill_[a]++] = b;
                adj_[fill_[b]++] = a;
            }
        for (std::size_t head = 0; head < queue_.size(); ++head) {
            const std::uint32_t s = queue_[head];
            for (std::uint32_t k = adj_start_[s]; k < adj_start_[s + 1]; ++k) {
                const std::uint32_t o = adj_[k];
                if (level_[o] == kUnreached) {
                    level_[o] = level_[s] + 1;
                    queue_.push_back(o);
                }
            }
        }
    }
    std::int32_t operator[](std::uint32_t slot) const { return level_[slot]; }
    bool empty() const { return level_.empty(); }
    void clear() { level_.clear(); }

private:
    std::vector<std::int32_t> level_;
    std::vector<std::uint32_t> queue_, adj_start_, fill_, adj_;
};

}  // namespace sinew
