// Broad phase: a dynamic AABB tree (Presson's / Box2D's design) over fattened boxes with incremental
// updates. A proxy is re-inserted only when its tight box leaves its fat box, so resting and slowly
// moving bodies cost nothing per step. Insertion picks the sibling by the surface-area heuristic and
// rebalances with tree rotations.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "engine/core/aabb.hpp"

namespace sinew {

class DynamicTree {
public:
    static constexpr std::int32_t kNull = -1;

    /// Inserts a proxy with tight box `box`, stored fattened by `margin`. Returns the proxy id.
    std::int32_t create(const Aabb& box, std::uint32_t user_data, Real margin);
    void destroy(std::int32_t proxy);
    /// Updates a proxy's tight box. Re-inserts (and returns true) only when the box swept by
    /// `displacement` (the predicted motion of the coming step) escaped its fat box; the new fat box is
    /// that swept box, fattened by `margin` and extended by `displacement` once more.
    bool move(std::int32_t proxy, const Aabb& box, const Vec3& displacement, Real margin);
    /// Whether move() with these arguments would re-insert the proxy (its swept box left its fat box).
    /// Only reads the tree: callers test their proxies on several threads and move the few on one.
    bool would_move(std::int32_t proxy, const Aabb& box, const Vec3& displacement) const;

    const Aabb& fat_box(std::int32_t proxy) const { return nodes_[proxy].box; }
    std::uint32_t user_data(std::int32_t proxy) const { return nodes_[proxy].user_data; }

    /// Calls f(proxy) for every proxy whose fat box overlaps `box`; f returns false to stop early.
    template <class F>
    void query(const Aabb& box, F&& f) const;

    /// Calls f(proxy, max_fraction) for every proxy whose fat box the segment from + t (to - from),
    /// t in [0, max_fraction], crosses (slab test per node). f returns the new max_fraction (clip the
    /// segment to the closest hit so far), 0 to stop, or max_fraction unchanged to go on.
    template <class F>
    void ray_query(const Vec3& from, const Vec3& to, F&& f) const;

    /// Every overlapping pair of proxies (fat boxes), each once, with a < b by proxy id. Appends to out.
    void all_pairs(std::vector<std::pair<std::int32_t, std::int32_t>>& out) const;

    int height() const;
    int proxy_count() const { return proxy_count_; }
    /// Changes whenever the set of overlapping fat boxes may have changed (a proxy was created,
    /// destroyed or re-inserted), so a caller can keep last step's pairs while it stays the same.
    std::uint64_t revision() const { return revision_; }
    /// Checks parent links, heights and box containment; for tests.
    bool validate() const;

private:
    /// `box` extended along `displacement` (the motion of the coming step).
    static Aabb swept_box(const Aabb& box, const Vec3& displacement);
    struct Node {
        Aabb box;
        std::uint32_t user_data = 0;
        std::int32_t parent = kNull;  ///< or next free node
        std::int32_t child1 = kNull;
        std::int32_t child2 = kNull;
        std::int32_t height = -1;     ///< leaf = 0, free = -1
        bool is_leaf() const { return child1 == kNull; }
    };
    std::int32_t allocate();
    void release(std::int32_t node);
    void insert_leaf(std::int32_t leaf);
    void remove_leaf(std::int32_t leaf);
    std::int32_t balance(std::int32_t node);
    void refit_upward(std::int32_t index);

    std::vector<Node> nodes_;
    std::int32_t root_ = kNull;
    std::int32_t free_list_ = kNull;
    int proxy_count_ = 0;
    std::uint64_t revision_ = 0;
    mutable std::vector<std::pair<std::int32_t, std::int32_t>> pair_stack_;  // all_pairs scratch
};

template <class F>
void DynamicTree::query(const Aabb& box, F&& f) const {
    if (root_ == kNull) return;
    std::int32_t stack_fixed[128];
    std::vector<std::int32_t> stack_big;
    int top = 0;
    stack_fixed[top++] = root_;
    while (top > 0) {
        std::int32_t id = stack_fixed[--top];
        const Node& n = nodes_[id];
        if (!n.box.overlaps(box)) continue;
        if (n.is_leaf()) {
            if (!f(id)) return;
        } else {
            // A balanced tree of a million proxies is ~40 deep; 128 slots never overflow in practice,
            // but stay correct if they would.
            if (top + 2 > 128) {
                stack_big.push_back(n.child1);
                stack_big.push_back(n.child2);
            } else {
                stack_fixed[top++] = n.child1;
                stack_fixed[top++] = n.child2;
            }
        }
        if (top == 0 && !stack_big.empty()) {
            stack_fixed[top++] = stack_big.back();
            stack_big.pop_back();
        }
    }
}

/// Does the segment from + t d, t in [0, t_max], cross the box? (slab test; inv_d may hold infinities)
inline bool segment_crosses_box(const Vec3& from, const Vec3& inv_d, Real t_max, const Aabb& box) {
    Real t0 = 0, t1 = t_max;
    for (int k = 0; k < 3; ++k) {
        Real a = (box.lo[k] - from[k]) * inv_d[k];
        Real b = (box.hi[k] - from[k]) * inv_d[k];
        if (a > b) std::swap(a, b);
        if (!(a <= b)) {  // NaN: the ray is parallel and starts on the slab's plane; inside iff within it
            if (from[k] < box.lo[k] || from[k] > box.hi[k]) return false;
            continue;
        }
        t0 = std::max(t0, a);
        t1 = std::min(t1, b);
        if (t0 > t1) return false;
    }
    return true;
}

template <class F>
void DynamicTree::ray_query(const Vec3& from, const Vec3& to, F&& f) const {
    if (root_ == kNull) return;
    const Vec3 d = to - from;
    const Vec3 inv_d(Real(1) / d.x(), Real(1) / d.y(), Real(1) / d.z());
    Real t_max = 1;
    // A fixed stack as in query(): no allocation unless the tree is deeper than any balanced one gets.
    std::int32_t stack_fixed[128];
    std::vector<std::int32_t> stack_big;
    int top = 0;
    stack_fixed[top++] = root_;
    while (top > 0 || !stack_big.empty()) {
        std::int32_t id;
        if (!stack_big.empty()) {
            id = stack_big.back();
            stack_big.pop_back();
        } else {
            id = stack_fixed[--top];
        }
        const Node& n = nodes_[id];
        if (!segment_crosses_box(from, inv_d, t_max, n.box)) continue;
        if (n.is_leaf()) {
            t_max = f(id, t_max);
            if (t_max <= 0) return;
        } else if (top + 2 <= 128) {
            stack_fixed[top++] = n.child1;
            stack_fixed[top++] = n.child2;
        } else {
            stack_big.push_back(n.child1);
            stack_big.push_back(n.child2);
        }
    }
}

}  // namespace sinew
