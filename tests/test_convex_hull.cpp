// Convex hull construction (quickhull + coplanar merging) and the triangle-mesh BVH.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "engine/core/shape.hpp"

using namespace sinew;

namespace {

// Geometric tolerance for unit-sized input: the hull is built in double and stored in Real, so results
// carry Real's rounding of unit coordinates (~1e-7 in float) times a few operations.
const Real kTol = std::max(Real(200) * kEpsilon, Real(1e-9));

/// Volume by the divergence theorem over the faces: V = 1/3 sum(offset_f * area_f).
Real hull_volume(const ConvexHullData& h) {
    Real v = 0;
    for (const auto& f : h.faces) {
        Vec3 a = Vec3::Zero();
        for (std::size_t i = 1; i + 1 < f.verts.size(); ++i)
            a += (h.vertices[f.verts[i]] - h.vertices[f.verts[0]]).cross(h.vertices[f.verts[i + 1]] - h.vertices[f.verts[0]]);
        v += f.offset * Real(0.5) * a.norm() / Real(3);
    }
    return v;
}

/// Every face is counter-clockwise seen from outside (its Newell normal agrees with the stored normal),
/// has a unit normal, and lies on its plane; every undirected edge borders exactly two faces, used once
/// in each direction.
void check_topology(const ConvexHullData& h, Real tol) {
    // Violations are counted and checked once, so a failure says how many and the pass count stays readable.
    std::map<std::pair<int, int>, int> directed;
    int small = 0, non_unit = 0, off_plane = 0, clockwise = 0;
    for (const auto& f : h.faces) {
        if (f.verts.size() < 3) ++small;
        if (std::abs(f.normal.norm() - 1) >= kTol) ++non_unit;
        Vec3 newell = Vec3::Zero();
        const Vec3& o = h.vertices[f.verts[0]];
        for (std::size_t i = 0; i < f.verts.size(); ++i) {
            newell += (h.vertices[f.verts[i]] - o).cross(h.vertices[f.verts[(i + 1) % f.verts.size()]] - o);
            if (std::abs(f.normal.dot(h.vertices[f.verts[i]]) - f.offset) >= tol) ++off_plane;
            ++directed[{f.verts[i], f.verts[(i + 1) % f.verts.size()]}];
        }
        if (newell.normalized().dot(f.normal) <= Real(0.999)) ++clockwise;
    }
    CHECK(small == 0);
    CHECK(non_unit == 0);
    CHECK(off_plane == 0);
    CHECK(clockwise == 0);
    int unpaired = 0;
    for (const auto& [e, count] : directed)
        if (count != 1 || directed.count({e.second, e.first}) != 1) ++unpaired;
    CHECK(unpaired == 0);
    CHECK(directed.size() == 2 * h.edges.size());
    int unknown_edges = 0;
    for (const auto& e : h.edges)
        if (directed.count({e.first, e.second}) != 1) ++unknown_edges;
    CHECK(unknown_edges == 0);
}

}  // namespace

TEST_CASE("hull of a cube's corners with interior and duplicate points has 6 quads", "[hull]") {
    std::vector<Vec3> pts;
    for (int i = 0; i < 8; ++i) pts.emplace_back(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
    std::mt19937 rng(7);
    std::uniform_real_distribution<Real> u(-0.95f, 0.95f);
    for (int i = 0; i < 200; ++i) pts.emplace_back(u(rng), u(rng), u(rng));
    for (int i = 0; i < 8; ++i) pts.push_back(pts[i]);  // exact duplicates
    pts.emplace_back(1, 0, 0);                           // on a face
    pts.emplace_back(1, 1, 0);                           // on an edge
    std::shuffle(pts.begin(), pts.end(), rng);

    Shape s = make_convex_hull(pts);
    REQUIRE(s.type == ShapeType::ConvexHull);
    const ConvexHullData& h = *s.hull;
    CHECK(h.vertices.size() == 8);
    CHECK(h.faces.size() == 6);
    CHECK(h.edges.size() == 12);
    for (const auto& f : h.faces) {
        CHECK(f.verts.size() == 4);
        CHECK(std::abs(f.normal.cwiseAbs().maxCoeff() - 1) < kTol);  // axis-aligned
        CHECK(std::abs(f.offset - 1) < kTol);
    }
    check_topology(h, kTol);
    CHECK(h.centroid.norm() < kTol);
    CHECK(hull_volume(h) == Approx(8).epsilon(1e-5));
    CHECK(h.support_index(Vec3(1, 1, 1)) >= 0);
    CHECK(h.vertices[h.support_index(Vec3(1, 2, 3))].isApprox(Vec3(1, 1, 1)));
}

TEST_CASE("hull centroid and volume of an off-centre box", "[hull]") {
    // Box [1,3] x [-1,0] x [2,2.5]: volume 2*1*0.5 = 1, centroid (2, -0.5, 2.25).
    std::vector<Vec3> pts;
    for (int i = 0; i < 8; ++i)
        pts.emplace_back(i & 1 ? 3 : 1, i & 2 ? 0 : -1, i & 4 ? Real(2.5) : Real(2));
    const Shape shape = make_convex_hull(pts);
        const ConvexHullData& h = *shape.hull;
    CHECK(h.faces.size() == 6);
    CHECK(hull_volume(h) == Approx(1).epsilon(1e-5));
    CHECK((h.centroid - Vec3(2, -0.5, 2.25)).norm() < 10 * kTol);
}

TEST_CASE("hull of random points on a sphere contains them all and satisfies Euler", "[hull]") {
    std::mt19937 rng(42);
    std::normal_distribution<Real> g(0, 1);
    const Vec3 center(1, -2, 0.5);
    const Real r = 2;
    for (int n : {4, 10, 60, 500}) {
        std::vector<Vec3> pts;
        while (static_cast<int>(pts.size()) < n) {
            Vec3 d(g(rng), g(rng), g(rng));
            if (d.norm() < Real(1e-3)) continue;
            pts.push_back(center + r * d.normalized());
        }
        // Add interior points (inside the inscribed sphere of a hull of >= 60 random sphere points) and a
        // duplicate: they must not change anything.
        if (n >= 60)
            for (int i = 0; i < n / 2; ++i) pts.push_back(center + Real(0.3) * r * Vec3(g(rng), g(rng), g(rng)).normalized());
        pts.push_back(pts[0]);
        const Shape shape = make_convex_hull(pts);
        const ConvexHullData& h = *shape.hull;
        INFO("n = " << n);
        const int V = static_cast<int>(h.vertices.size());
        const int E = static_cast<int>(h.edges.size());
        const int F = static_cast<int>(h.faces.size());
        CHECK(V - E + F == 2);
        // Points on a sphere are all extreme (up to the merge tolerance, relative 1e-5 or less).
        CHECK(V >= n - n / 50);
        CHECK(V <= n);
        // Containment: every input point is inside every face plane, within the hull tolerance (relative
        // to the cloud size 2r; 1e-4 leaves room for float rounding of the stored planes).
        const Real tol = Real(1e-4) * r;
        int outside = 0;
        for (const Vec3& p : pts)
            for (const auto& f : h.faces)
                if (f.normal.dot(p) - f.offset > tol) ++outside;
        CHECK(outside == 0);
        check_topology(h, Real(1e-4) * r);
        // The hull is inscribed in the sphere: the volume is below the sphere's and the centroid near its centre.
        CHECK(hull_volume(h) < Real(4.0 / 3.0) * kPi * r * r * r);
        if (n >= 500) {
            CHECK(hull_volume(h) > Real(0.9) * Real(4.0 / 3.0) * kPi * r * r * r);
            CHECK((h.centroid - center).norm() < Real(0.05));
        }
    }
}

TEST_CASE("hull merges nearly coplanar noisy points into the faces of a box", "[hull]") {
    // A box sampled on its faces with noise of 1e-7 of its size: still 6 faces and 8 corners.
    std::mt19937 rng(3);
    std::uniform_real_distribution<Real> u(-1, 1);
    std::uniform_real_distribution<Real> noise(Real(-1e-7), Real(1e-7));
    std::vector<Vec3> pts;
    for (int i = 0; i < 8; ++i) pts.emplace_back(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
    for (int i = 0; i < 300; ++i) {
        Vec3 p(u(rng), u(rng), u(rng));
        int axis = i % 3;
        p[axis] = (i % 2 ? 1 : -1) + noise(rng);
        pts.push_back(p);
    }
    const Shape shape = make_convex_hull(pts);
        const ConvexHullData& h = *shape.hull;
    CHECK(h.faces.size() == 6);
    CHECK(h.vertices.size() <= 12);  // corners, plus perhaps a noisy point that pokes out by more than tol
    CHECK(static_cast<int>(h.vertices.size()) - static_cast<int>(h.edges.size()) + static_cast<int>(h.faces.size()) == 2);
}

TEST_CASE("degenerate hull input throws ShapeError saying why", "[hull]") {
    using Catch::Matchers::Contains;
    std::vector<Vec3> three{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    REQUIRE_THROWS_AS(make_convex_hull(three), ShapeError);
    REQUIRE_THROWS_WITH(make_convex_hull(three), Contains("at least 4"));

    std::vector<Vec3> flat;
    for (int i = 0; i < 20; ++i) flat.emplace_back(Real(i % 5), Real(i / 5), 0);
    REQUIRE_THROWS_WITH(make_convex_hull(flat), Contains("plane"));

    std::vector<Vec3> line;
    for (int i = 0; i < 10; ++i) line.emplace_back(Real(i), Real(2 * i), Real(-i));
    REQUIRE_THROWS_WITH(make_convex_hull(line), Contains("line"));

    std::vector<Vec3> same(6, Vec3(1, 2, 3));
    REQUIRE_THROWS_WITH(make_convex_hull(same), Contains("coincide"));

    std::vector<Vec3> nan{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, std::numeric_limits<Real>::quiet_NaN()}};
    REQUIRE_THROWS_WITH(make_convex_hull(nan), Contains("point 3") && Contains("not finite"));
    std::vector<Vec3> inf{{0, 0, 0}, {1, 0, 0}, {std::numeric_limits<Real>::infinity(), 1, 0}, {0, 0, 1}};
    REQUIRE_THROWS_AS(make_convex_hull(inf), ShapeError);
}

// ------------------------------------------------------------------------------------------------------
// Triangle meshes

namespace {

Aabb tri_box(const Triangle& t) {
    Aabb b;
    b.grow(t.a);
    b.grow(t.b);
    b.grow(t.c);
    return b;
}

int bvh_depth(const TriangleMeshData& m, int node) {
    const auto& n = m.nodes[node];
    if (n.left < 0) return 1;
    return 1 + std::max(bvh_depth(m, n.left), bvh_depth(m, n.right));
}

}  // namespace

TEST_CASE("triangle mesh BVH query matches a brute-force box test", "[mesh]") {
    std::mt19937 rng(11);
    std::uniform_real_distribution<Real> u(-10, 10), s(-1, 1);
    std::vector<Vec3> verts;
    std::vector<std::uint32_t> idx;
    const int n = 3000;
    for (int t = 0; t < n; ++t) {
        Vec3 c(u(rng), u(rng), u(rng));
        for (int k = 0; k < 3; ++k) {
            idx.push_back(static_cast<std::uint32_t>(verts.size()));
            verts.push_back(c + Vec3(s(rng), s(rng), s(rng)));
        }
    }
    const Shape shape = make_triangle_mesh(verts, idx);
    const TriangleMeshData& m = *shape.mesh;
    REQUIRE(m.triangle_count() == static_cast<std::size_t>(n));

    // Structure: each triangle in exactly one leaf of at most 4, children inside parents, shallow tree.
    std::vector<int> seen(n, 0);
    int bad_leaves = 0, loose_boxes = 0;
    for (const auto& node : m.nodes) {
        if (node.left < 0) {
            if (node.count < 1 || node.count > 4) ++bad_leaves;
            for (int i = 0; i < node.count; ++i) {
                ++seen[m.tri_order[node.first + i]];
                if (!node.box.contains(tri_box(m.triangle(m.tri_order[node.first + i])))) ++loose_boxes;
            }
        } else if (!node.box.contains(m.nodes[node.left].box) || !node.box.contains(m.nodes[node.right].box)) {
            ++loose_boxes;
        }
    }
    CHECK(bad_leaves == 0);
    CHECK(loose_boxes == 0);
    CHECK(std::all_of(seen.begin(), seen.end(), [](int c) { return c == 1; }));
    // Median split: depth = ceil(log2(3000 / 4)) + 1 = 11, far below the 64-slot query stack.
    CHECK(bvh_depth(m, 0) <= 11);

    int mismatches = 0, too_many_calls = 0;
    for (int q = 0; q < 200; ++q) {
        Vec3 c(u(rng), u(rng), u(rng));
        Vec3 e = Vec3(std::abs(s(rng)), std::abs(s(rng)), std::abs(s(rng))) * Real(q % 4 == 0 ? 6 : 2);
        Aabb box{c - e, c + e};
        std::set<std::uint32_t> brute, found;
        for (std::size_t t = 0; t < m.triangle_count(); ++t)
            if (tri_box(m.triangle(t)).overlaps(box)) brute.insert(static_cast<std::uint32_t>(t));
        int calls = 0;
        // query() reports every triangle of each leaf whose box overlaps (leaves hold up to 4), so the
        // exact set is what the caller gets after its per-triangle box test; nothing may be missed.
        m.query(box, [&](std::uint32_t t) {
            ++calls;
            if (tri_box(m.triangle(t)).overlaps(box)) found.insert(t);
        });
        if (found != brute) ++mismatches;
        if (calls > static_cast<int>(brute.size()) * 4 + 4 * 8) ++too_many_calls;
    }
    CHECK(mismatches == 0);
    CHECK(too_many_calls == 0);
}

TEST_CASE("triangle mesh validation", "[mesh]") {
    using Catch::Matchers::Contains;
    std::vector<Vec3> v{{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {2, 0, 0}};
    // The degenerate triangle (0, 1, 3) is collinear and is dropped; (0, 2, 2) repeats a vertex.
    Shape s = make_triangle_mesh(v, {0, 2, 1, 0, 1, 3, 0, 2, 2});
    REQUIRE(s.mesh->triangle_count() == 1);
    CHECK(s.mesh->nodes.size() == 1);
    CHECK(!s.can_be_dynamic());

    REQUIRE_THROWS_WITH(make_triangle_mesh(v, {0, 1, 3}), Contains("degenerate"));
    REQUIRE_THROWS_WITH(make_triangle_mesh(v, {0, 1}), Contains("multiple of 3"));
    REQUIRE_THROWS_WITH(make_triangle_mesh(v, {}), Contains("no triangles"));
    REQUIRE_THROWS_WITH(make_triangle_mesh(v, {0, 1, 4}), Contains("out of range"));
    std::vector<Vec3> bad = v;
    bad[2].y() = std::numeric_limits<Real>::quiet_NaN();
    REQUIRE_THROWS_WITH(make_triangle_mesh(bad, {0, 2, 1}), Contains("vertex 2") && Contains("not finite"));
}

TEST_CASE("hull with more than 65535 vertices is refused", "[hull][long]") {
    // 90000 points on a sphere: nearly all are extreme, more than 16-bit face indices can address.
    std::mt19937 rng(5);
    std::normal_distribution<Real> g(0, 1);
    std::vector<Vec3> pts;
    while (pts.size() < 90000) {
        Vec3 d(g(rng), g(rng), g(rng));
        if (d.norm() > Real(1e-3)) pts.push_back(d.normalized());
    }
    REQUIRE_THROWS_WITH(make_convex_hull(pts), Catch::Matchers::Contains("at most 65535"));
}
