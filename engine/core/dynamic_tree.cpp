// Dynamic AABB tree (broad phase). The design follows Presson's bounding-volume tree as popularised by
// Box2D's b2DynamicTree: a pool of nodes with an intrusive free list, leaves holding fattened boxes,
// insertion by the surface-area heuristic and AVL-style rotations on the way back up.
//
// Sibling choice uses the branch-and-bound search of Bittner, Hapala and Havran, "Fast insertion-based
// optimization of bounding volume hierarchies" (CGF 2013): the cost of making node S the sibling of a
// new leaf L is area(S ∪ L) plus the growth area(A ∪ L) - area(A) of every ancestor A of S. A subtree
// is skipped when even its lower bound area(L) + inherited growth already exceeds the best cost found.
// This finds the SAH-optimal sibling, which the classic greedy descent only approximates.
#include "engine/core/dynamic_tree.hpp"

#include <algorithm>
#include <cassert>
#include <utility>

namespace sinew {

namespace {

// Fixed-size stacks cover every realistic tree (height ~2 log2 n); deeper trees spill into a vector so
// correctness never depends on the bound.
constexpr int kFixedStack = 256;

}  // namespace

std::int32_t DynamicTree::allocate() {
    std::int32_t id;
    if (free_list_ == kNull) {
        id = static_cast<std::int32_t>(nodes_.size());
        nodes_.emplace_back();
    } else {
        id = free_list_;
        free_list_ = nodes_[id].parent;
    }
    Node& n = nodes_[id];
    n = Node();
    n.height = 0;
    return id;
}

void DynamicTree::release(std::int32_t node) {
    Node& n = nodes_[node];
    n = Node();
    n.parent = free_list_;  // the parent slot doubles as the free-list link
    n.height = -1;
    free_list_ = node;
}

std::int32_t DynamicTree::create(const Aabb& box, std::uint32_t user_data, Real margin) {
    std::int32_t leaf = allocate();
    Node& n = nodes_[leaf];
    n.box = box.fattened(margin);
    n.user_data = user_data;
    n.height = 0;
    insert_leaf(leaf);
    ++proxy_count_;
    ++revision_;
    return leaf;
}

void DynamicTree::destroy(std::int32_t proxy) {
    assert(proxy >= 0 && proxy < static_cast<std::int32_t>(nodes_.size()));
    assert(nodes_[proxy].is_leaf() && nodes_[proxy].height == 0);
    remove_leaf(proxy);
    release(proxy);
    --proxy_count_;
    ++revision_;
}

Aabb DynamicTree::swept_box(const Aabb& box, const Vec3& displacement) {
    Aabb swept = box;
    for (int k = 0; k < 3; ++k) {
        if (displacement[k] < 0)
            swept.lo[k] += displacement[k];
        else
            swept.hi[k] += displacement[k];
    }
    return swept;
}

bool DynamicTree::would_move(std::int32_t proxy, const Aabb& box, const Vec3& displacement) const {
    return !nodes_[proxy].box.contains(swept_box(box, displacement));
}

bool DynamicTree::move(std::int32_t proxy, const Aabb& box, const Vec3& displacement, Real margin) {
    assert(proxy >= 0 && proxy < static_cast<std::int32_t>(nodes_.size()));
    assert(nodes_[proxy].is_leaf() && nodes_[proxy].height == 0);
    // The box swept over the coming step: the pair with whatever it will reach must be found now, so a
    // fast body gets its speculative contact before it penetrates (a box falling at 4.4 m/s sank 3 cm
    // into the ground when only its current box was tested against a fat box grown at a slower speed).
    const Aabb swept = swept_box(box, displacement);
    // Still inside the fat box: the tree is untouched, which is what makes resting bodies free.
    if (nodes_[proxy].box.contains(swept)) return false;

    remove_leaf(proxy);
    // Fatten by the margin, then stretch along the predicted motion once more (Box2D's displacement
    // extension): a body moving steadily stays inside its box for a step or two.
    Aabb fat = swept.fattened(margin);
    for (int k = 0; k < 3; ++k) {
        if (displacement[k] < 0)
            fat.lo[k] += displacement[k];
        else
            fat.hi[k] += displacement[k];
    }
    nodes_[proxy].box = fat;
    insert_leaf(proxy);
    ++revision_;
    return true;
}

void DynamicTree::insert_leaf(std::int32_t leaf) {
    if (root_ == kNull) {
        root_ = leaf;
        nodes_[leaf].parent = kNull;
        return;
    }

    // ---- 1. best sibling by branch and bound over the SAH cost ----
    const Aabb leaf_box = nodes_[leaf].box;
    const Real leaf_area = leaf_box.area();
    std::int32_t best = root_;
    Real best_cost = nodes_[root_].box.merged(leaf_box).area();

    struct Candidate {
        std::int32_t node;
        Real inherited;  ///< growth of all ancestors if the leaf is inserted below them
    };
    Candidate stack_fixed[kFixedStack];
    std::vector<Candidate> stack_big;
    int top = 0;
    auto push = [&](std::int32_t node, Real inherited) {
        if (top < kFixedStack)
            stack_fixed[top++] = {node, inherited};
        else
            stack_big.push_back({node, inherited});
    };
    auto pop = [&](Candidate& c) {
        if (!stack_big.empty()) {
            c = stack_big.back();
            stack_big.pop_back();
            return true;
        }
        if (top == 0) return false;
        c = stack_fixed[--top];
        return true;
    };

    // Ties (e.g. many identical boxes, where every candidate costs the same) go to the sibling of
    // smaller height: pairing the leaf with a deep, short subtree keeps the imbalance local where one
    // rotation repairs it, whereas pairing it with the root would grow the tree by a level each time.
    // A subtree whose bound only ties the best is still worth a look while the best is not a leaf.
    auto worth_descending = [&](Real lower_bound) {
        return lower_bound < best_cost || (lower_bound == best_cost && nodes_[best].height > 0);
    };
    if (!nodes_[root_].is_leaf()) {
        Real inherited = best_cost - nodes_[root_].box.area();
        if (worth_descending(leaf_area + inherited)) {
            push(nodes_[root_].child1, inherited);
            push(nodes_[root_].child2, inherited);
        }
    }
    Candidate c;
    while (pop(c)) {
        const Node& n = nodes_[c.node];
        Real direct = n.box.merged(leaf_box).area();
        Real cost = direct + c.inherited;
        if (cost < best_cost || (cost == best_cost && n.height < nodes_[best].height)) {
            best_cost = cost;
            best = c.node;
        }
        if (n.is_leaf()) continue;
        Real inherited = c.inherited + (direct - n.box.area());
        // Lower bound for anything in this subtree: the new parent has at least the leaf's area.
        if (worth_descending(leaf_area + inherited)) {
            push(n.child1, inherited);
            push(n.child2, inherited);
        }
    }

    // ---- 2. a new parent joins the sibling and the leaf ----
    const std::int32_t sibling = best;
    const std::int32_t old_parent = nodes_[sibling].parent;
    const std::int32_t new_parent = allocate();  // may reallocate nodes_: no references held across it
    {
        Node& p = nodes_[new_parent];
        p.parent = old_parent;
        p.box = leaf_box.merged(nodes_[sibling].box);
        p.height = nodes_[sibling].height + 1;
        p.child1 = sibling;
        p.child2 = leaf;
    }
    if (old_parent != kNull) {
        Node& op = nodes_[old_parent];
        if (op.child1 == sibling)
            op.child1 = new_parent;
        else
            op.child2 = new_parent;
    } else {
        root_ = new_parent;
    }
    nodes_[sibling].parent = new_parent;
    nodes_[leaf].parent = new_parent;

    // ---- 3. walk back up: rotate where unbalanced, refit boxes and heights ----
    refit_upward(nodes_[leaf].parent);
}

void DynamicTree::refit_upward(std::int32_t index) {
    // From `index` to the root: rotate where unbalanced, refit boxes and heights.
    while (index != kNull) {
        index = balance(index);
        Node& n = nodes_[index];
        const Node& a = nodes_[n.child1];
        const Node& b = nodes_[n.child2];
        n.height = 1 + std::max(a.height, b.height);
        n.box = a.box.merged(b.box);
        index = n.parent;
    }
}

void DynamicTree::remove_leaf(std::int32_t leaf) {
    if (leaf == root_) {
        root_ = kNull;
        return;
    }
    const std::int32_t parent = nodes_[leaf].parent;
    const std::int32_t grand = nodes_[parent].parent;
    const std::int32_t sibling = nodes_[parent].child1 == leaf ? nodes_[parent].child2 : nodes_[parent].child1;

    if (grand == kNull) {
        root_ = sibling;
        nodes_[sibling].parent = kNull;
        release(parent);
    } else {
        // The sibling takes the parent's place; the parent node is freed.
        Node& g = nodes_[grand];
        if (g.child1 == parent)
            g.child1 = sibling;
        else
            g.child2 = sibling;
        nodes_[sibling].parent = grand;
        release(parent);

        refit_upward(grand);
    }
    nodes_[leaf].parent = kNull;
}

// AVL-style rotation at node A (Box2D's b2DynamicTree::Balance, written from its description). If one
// child is more than one level taller, that child is lifted into A's place and A adopts the shorter of
// the lifted child's two children; the taller one stays with the lifted node. Returns the subtree's new
// root. Boxes and heights of the two rotated nodes are refitted here; the caller refits the ancestors.
std::int32_t DynamicTree::balance(std::int32_t a_id) {
    Node& a = nodes_[a_id];
    if (a.is_leaf() || a.height < 2) return a_id;

    const std::int32_t b_id = a.child1;
    const std::int32_t c_id = a.child2;
    const int skew = nodes_[c_id].height - nodes_[b_id].height;
    if (skew >= -1 && skew <= 1) return a_id;

    // Lift `up` (the taller child) over A; `stay` is A's other child.
    const bool lift_c = skew > 1;
    const std::int32_t up_id = lift_c ? c_id : b_id;
    const std::int32_t stay_id = lift_c ? b_id : c_id;
    Node& up = nodes_[up_id];
    const std::int32_t f_id = up.child1;
    const std::int32_t g_id = up.child2;

    // `up` takes A's place under A's parent.
    up.parent = a.parent;
    a.parent = up_id;
    if (up.parent != kNull) {
        Node& p = nodes_[up.parent];
        if (p.child1 == a_id)
            p.child1 = up_id;
        else
            p.child2 = up_id;
    } else {
        root_ = up_id;
    }

    // The taller grandchild stays under `up`, the shorter moves under A (in the slot `up` vacated).
    const bool f_taller = nodes_[f_id].height > nodes_[g_id].height;
    const std::int32_t keep_id = f_taller ? f_id : g_id;
    const std::int32_t give_id = f_taller ? g_id : f_id;
    up.child1 = a_id;
    up.child2 = keep_id;
    if (lift_c)
        a.child2 = give_id;
    else
        a.child1 = give_id;
    nodes_[give_id].parent = a_id;
    nodes_[keep_id].parent = up_id;

    const Node& stay = nodes_[stay_id];
    const Node& give = nodes_[give_id];
    const Node& keep = nodes_[keep_id];
    a.box = stay.box.merged(give.box);
    a.height = 1 + std::max(stay.height, give.height);
    up.box = a.box.merged(keep.box);
    up.height = 1 + std::max(a.height, keep.height);
    return up_id;
}

int DynamicTree::height() const { return root_ == kNull ? 0 : nodes_[root_].height; }

// Overlapping leaf pairs by a simultaneous self-traversal: the pairs inside a subtree are those inside
// each child plus those across the two children. Every pair is reached exactly once, so no duplicate
// removal is needed, and disjoint subtree pairs are rejected with one box test.
void DynamicTree::all_pairs(std::vector<std::pair<std::int32_t, std::int32_t>>& out) const {
    if (root_ == kNull) return;
    // Tasks (a, b): a == b means pairs within subtree a, otherwise pairs across a and b. The stack is
    // a member so a step's broad phase allocates nothing once warm.
    std::vector<std::pair<std::int32_t, std::int32_t>>& stack = pair_stack_;
    stack.clear();
    stack.push_back({root_, root_});
    while (!stack.empty()) {
        const auto [ta, tb] = stack.back();
        stack.pop_back();
        const Node& na = nodes_[ta];
        if (ta == tb) {
            if (na.is_leaf()) continue;
            stack.push_back({na.child1, na.child1});
            stack.push_back({na.child2, na.child2});
            stack.push_back({na.child1, na.child2});
            continue;
        }
        const Node& nb = nodes_[tb];
        if (!na.box.overlaps(nb.box)) continue;
        if (na.is_leaf() && nb.is_leaf()) {
            out.emplace_back(std::min(ta, tb), std::max(ta, tb));
            continue;
        }
        // Descend the larger node (by area) so both sides shrink at a similar rate.
        if (nb.is_leaf() || (!na.is_leaf() && na.box.area() >= nb.box.area())) {
            stack.push_back({na.child1, tb});
            stack.push_back({na.child2, tb});
        } else {
            stack.push_back({ta, nb.child1});
            stack.push_back({ta, nb.child2});
        }
    }
}

bool DynamicTree::validate() const {
    const std::int32_t count = static_cast<std::int32_t>(nodes_.size());
    // Free list: every entry is a free node, no cycles.
    std::int32_t free_count = 0;
    for (std::int32_t f = free_list_; f != kNull; f = nodes_[f].parent) {
        if (f < 0 || f >= count || nodes_[f].height != -1) return false;
        if (++free_count > count) return false;
    }
    if (root_ == kNull) return proxy_count_ == 0 && free_count == count;
    if (root_ < 0 || root_ >= count || nodes_[root_].parent != kNull) return false;

    std::int32_t reached = 0;
    int leaves = 0;
    std::vector<std::int32_t> stack{root_};
    while (!stack.empty()) {
        const std::int32_t id = stack.back();
        stack.pop_back();
        if (++reached > count) return false;  // a cycle
        const Node& n = nodes_[id];
        if (n.is_leaf()) {
            if (n.child2 != kNull || n.height != 0 || !n.box.valid()) return false;
            ++leaves;
            continue;
        }
        const std::int32_t c1 = n.child1, c2 = n.child2;
        if (c1 < 0 || c2 < 0 || c1 >= count || c2 >= count || c1 == c2) return false;
        const Node& a = nodes_[c1];
        const Node& b = nodes_[c2];
        if (a.parent != id || b.parent != id) return false;
        if (a.height < 0 || b.height < 0) return false;
        if (n.height != 1 + std::max(a.height, b.height)) return false;
        if (!n.box.contains(a.box) || !n.box.contains(b.box)) return false;
        stack.push_back(c1);
        stack.push_back(c2);
    }
    return leaves == proxy_count_ && reached + free_count == count;
}

}  // namespace sinew
