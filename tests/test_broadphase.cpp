// Dynamic AABB tree against brute force. The tree's answers are exact set computations on the stored
// fat boxes (no arithmetic beyond min/max and comparisons), so every comparison here is exact equality;
// no tolerance is involved in either precision.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "engine/core/dynamic_tree.hpp"

using namespace sinew;

namespace {

using Pair = std::pair<std::int32_t, std::int32_t>;

struct Scene {
    DynamicTree tree;
    std::vector<std::int32_t> live;  ///< proxy ids currently in the tree
    std::mt19937 rng;
    explicit Scene(unsigned seed) : rng(seed) {}

    Real uniform(Real lo, Real hi) { return std::uniform_real_distribution<Real>(lo, hi)(rng); }
    Aabb random_box(Real world, Real min_size, Real max_size) {
        Vec3 lo(uniform(0, world), uniform(0, world), uniform(0, world));
        Vec3 size(uniform(min_size, max_size), uniform(min_size, max_size), uniform(min_size, max_size));
        return {lo, lo + size};
    }
};

std::vector<Pair> brute_pairs(const DynamicTree& tree, std::vector<std::int32_t> live) {
    std::sort(live.begin(), live.end());
    std::vector<Pair> out;
    for (std::size_t i = 0; i < live.size(); ++i)
        for (std::size_t j = i + 1; j < live.size(); ++j)
            if (tree.fat_box(live[i]).overlaps(tree.fat_box(live[j]))) out.emplace_back(live[i], live[j]);
    return out;
}

std::vector<Pair> tree_pairs(const DynamicTree& tree) {
    std::vector<Pair> out;
    tree.all_pairs(out);
    for (const Pair& p : out) REQUIRE(p.first < p.second);
    std::sort(out.begin(), out.end());
    REQUIRE(std::adjacent_find(out.begin(), out.end()) == out.end());  // each pair reported once
    return out;
}

std::vector<std::int32_t> brute_query(const DynamicTree& tree, const std::vector<std::int32_t>& live, const Aabb& box) {
    std::vector<std::int32_t> out;
    for (std::int32_t id : live)
        if (tree.fat_box(id).overlaps(box)) out.push_back(id);
    std::sort(out.begin(), out.end());
    return out;
}

std::vector<std::int32_t> tree_query(const DynamicTree& tree, const Aabb& box) {
    std::vector<std::int32_t> out;
    tree.query(box, [&](std::int32_t id) {
        out.push_back(id);
        return true;
    });
    std::sort(out.begin(), out.end());
    return out;
}

/// A balanced binary tree over n leaves has height ceil(log2 n). The AVL-style rotations keep every
/// node's children within one level of each other after each update, which bounds the height by
/// ~1.44 log2 n (the AVL bound); 2 log2 n + 2 leaves room for the looser balance after removals.
int height_bound(int n) { return int(std::ceil(2 * std::log2(double(std::max(n, 2))))) + 2; }

void check_tree(Scene& s) {
    REQUIRE(s.tree.validate());
    REQUIRE(s.tree.proxy_count() == int(s.live.size()));
    CHECK(s.tree.height() <= height_bound(s.tree.proxy_count()));
    REQUIRE(tree_pairs(s.tree) == brute_pairs(s.tree, s.live));
}

}  // namespace

TEST_CASE("empty and tiny trees", "[broadphase]") {
    DynamicTree t;
    CHECK(t.validate());
    CHECK(t.height() == 0);
    CHECK(t.proxy_count() == 0);
    std::vector<Pair> pairs;
    t.all_pairs(pairs);
    CHECK(pairs.empty());
    int calls = 0;
    t.query(Aabb{Vec3::Zero(), Vec3::Ones()}, [&](std::int32_t) {
        ++calls;
        return true;
    });
    CHECK(calls == 0);

    const Real margin = Real(0.1);
    std::int32_t a = t.create(Aabb{Vec3::Zero(), Vec3::Ones()}, 42, margin);
    CHECK(t.validate());
    CHECK(t.user_data(a) == 42u);
    CHECK(t.fat_box(a).lo == Vec3::Constant(-margin));
    CHECK(t.fat_box(a).hi == Vec3::Constant(1 + margin));
    std::int32_t b = t.create(Aabb{Vec3::Constant(Real(0.5)), Vec3::Constant(2)}, 7, margin);
    CHECK(t.validate());
    CHECK(t.height() == 1);
    t.all_pairs(pairs);
    REQUIRE(pairs.size() == 1);
    CHECK(pairs[0] == Pair(std::min(a, b), std::max(a, b)));

    t.destroy(a);
    t.destroy(b);
    CHECK(t.validate());
    CHECK(t.proxy_count() == 0);
    CHECK(t.height() == 0);
    // Freed nodes are reused rather than the pool growing.
    std::int32_t c = t.create(Aabb{Vec3::Zero(), Vec3::Ones()}, 1, margin);
    CHECK(c <= 2);
    CHECK(t.validate());
}

TEST_CASE("random scene: pairs and queries equal brute force through moves and removals", "[broadphase]") {
    const unsigned seed = GENERATE(1u, 2u, 3u);
    Scene s(seed);
    const int n = 1000;
    const Real world = 50, margin = Real(0.1);
    std::vector<Aabb> tight_by_id(2 * n);  // ids stay below 2n: the pool holds n leaves + n-1 inner nodes
    for (int i = 0; i < n; ++i) {
        Aabb box = s.random_box(world, Real(0.5), Real(5));
        std::int32_t id = s.tree.create(box, std::uint32_t(i), margin);
        REQUIRE(id >= 0);
        REQUIRE(id < 2 * n);
        REQUIRE(s.tree.user_data(id) == std::uint32_t(i));
        tight_by_id[id] = box;
        s.live.push_back(id);
    }
    check_tree(s);
    // With these sizes a pair overlaps with probability ~(5.7/50)^3, so a few hundred pairs: the
    // comparison is not vacuous.
    CHECK(tree_pairs(s.tree).size() > 100);

    auto check_queries = [&]() {
        for (int q = 0; q < 20; ++q) {
            Aabb box = s.random_box(world, Real(0), Real(15));
            REQUIRE(tree_query(s.tree, box) == brute_query(s.tree, s.live, box));
        }
    };
    check_queries();

    for (int round = 0; round < 3; ++round) {
        int reinserted = 0, small_moves = 0;
        for (std::int32_t id : s.live) {
            const Aabb before = s.tree.fat_box(id);
            Vec3 d;
            if (s.uniform(0, 1) < Real(0.5)) {
                // Small: under the margin per axis, so the tight box stays inside its fat box.
                d = Vec3(s.uniform(-1, 1), s.uniform(-1, 1), s.uniform(-1, 1)) * (Real(0.5) * margin);
                ++small_moves;
            } else {
                d = Vec3(s.uniform(-8, 8), s.uniform(-8, 8), s.uniform(-8, 8));
            }
            Aabb moved{tight_by_id[id].lo + d, tight_by_id[id].hi + d};
            // The tree tests the box swept by the predicted displacement (here d again).
            Aabb swept = moved;
            for (int k = 0; k < 3; ++k) (d[k] < 0 ? swept.lo[k] : swept.hi[k]) += d[k];
            const bool escaped = !before.contains(swept);
            const bool reinsert = s.tree.move(id, moved, d, margin);
            REQUIRE(reinsert == escaped);
            if (reinsert) {
                ++reinserted;
                // New fat box: the swept box, margin on every side, plus the displacement once more on the
                // side it points to.
                Aabb want = swept.fattened(margin);
                for (int k = 0; k < 3; ++k) (d[k] < 0 ? want.lo[k] : want.hi[k]) += d[k];
                REQUIRE(s.tree.fat_box(id).lo == want.lo);
                REQUIRE(s.tree.fat_box(id).hi == want.hi);
            } else {
                REQUIRE(s.tree.fat_box(id).lo == before.lo);
                REQUIRE(s.tree.fat_box(id).hi == before.hi);
            }
            tight_by_id[id] = moved;
        }
        // The exact check is `reinsert == escaped` above; these only make sure both paths ran. (Small
        // steps can accumulate over rounds and escape; a large step along the previous displacement
        // can stay inside the stretched fat box.)
        CHECK(reinserted > n / 4);
        CHECK(n - reinserted > small_moves / 2);
        check_tree(s);
        check_queries();
    }

    // Remove a random third.
    std::shuffle(s.live.begin(), s.live.end(), s.rng);
    for (int i = 0; i < n / 3; ++i) {
        s.tree.destroy(s.live.back());
        s.live.pop_back();
    }
    check_tree(s);
    check_queries();

    // Refill: freed nodes are reused, so ids stay within the original pool.
    for (int i = 0; i < n / 3; ++i) {
        Aabb box = s.random_box(world, Real(0.5), Real(5));
        std::int32_t id = s.tree.create(box, std::uint32_t(n + i), margin);
        REQUIRE(id < 2 * n);
        tight_by_id[id] = box;
        s.live.push_back(id);
    }
    check_tree(s);
    check_queries();
}

TEST_CASE("query stops when the callback returns false", "[broadphase]") {
    DynamicTree t;
    for (int i = 0; i < 100; ++i) t.create(Aabb{Vec3::Zero(), Vec3::Ones()}, std::uint32_t(i), 0);
    int calls = 0;
    t.query(Aabb{Vec3::Zero(), Vec3::Ones()}, [&](std::int32_t) { return ++calls < 5; });
    CHECK(calls == 5);
}

TEST_CASE("sorted insertion stays balanced", "[broadphase]") {
    // Boxes inserted in order along a line are the classic worst case for a tree without rotations
    // (it degenerates towards a list of height ~n).
    DynamicTree t;
    const int n = 1024;
    std::vector<std::int32_t> ids;
    for (int i = 0; i < n; ++i) {
        Vec3 lo(Real(i), 0, 0);
        ids.push_back(t.create(Aabb{lo, lo + Vec3(Real(0.5), 1, 1)}, std::uint32_t(i), Real(0.1)));
    }
    REQUIRE(t.validate());
    CHECK(t.height() <= height_bound(n));
    std::vector<Pair> pairs;
    t.all_pairs(pairs);
    CHECK(pairs.empty());  // gaps of 0.5 exceed twice the margin

    // Many identical boxes: every pair overlaps, and SAH costs all tie.
    DynamicTree same;
    const int m = 200;
    for (int i = 0; i < m; ++i) same.create(Aabb{Vec3::Zero(), Vec3::Ones()}, std::uint32_t(i), 0);
    REQUIRE(same.validate());
    CHECK(same.height() <= height_bound(m));
    pairs.clear();
    same.all_pairs(pairs);
    std::sort(pairs.begin(), pairs.end());
    CHECK(std::adjacent_find(pairs.begin(), pairs.end()) == pairs.end());
    CHECK(pairs.size() == std::size_t(m * (m - 1) / 2));
}
