// Mesh builders (soft/build_mesh.cpp): the geodesic sphere of a pressure body and links by graph distance
// for any triangle mesh. Outcomes are checked against closed forms: Euler's counts of a subdivided
// icosahedron, the inscribed icosahedron's volume and the h^2 convergence of the polyhedron's volume to
// the ball's, and graph distances on a triangulated cube counted by hand.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "soft/soft_builders.hpp"
#include "soft/soft_integrators.hpp"

using namespace sinew;

namespace {

// Float keeps ~7 digits; positions of order 1 built in double and rounded once carry a relative error
// of a few 1e-7, so geometric identities are checked to 1e-5 relative (1e-9 in double builds would do,
// but one tolerance that holds in both precisions is what the suite uses).
const double kGeomTol = 1e-5;

// What a SoftError says when `f` throws it (empty if nothing is thrown).
template <class F>
std::string soft_error_of(F&& f) {
    try {
        f();
    } catch (const SoftError& e) {
        return e.what();
    }
    return {};
}

// The unit cube [0,1]^3, vertex index = x + 2y + 4z, each face split along the diagonal that does NOT
// touch vertex 0 (000) or vertex 7 (111), all triangles counter-clockwise seen from outside.
//   face x=0: diagonal 2-4   face y=0: diagonal 1-4   face z=0: diagonal 1-2
//   face x=1: diagonal 3-5   face y=1: diagonal 3-6   face z=1: diagonal 5-6
std::vector<Vec3> cube_vertices(Real side) {
    std::vector<Vec3> v;
    for (int i = 0; i < 8; ++i) v.emplace_back(side * Real(i & 1), side * Real((i >> 1) & 1), side * Real((i >> 2) & 1));
    return v;
}
const std::vector<std::uint32_t> kCubeTriangles = {
    0, 4, 2, 2, 4, 6,  // x = 0, outward -x
    1, 3, 5, 3, 7, 5,  // x = 1, outward +x
    0, 1, 4, 1, 5, 4,  // y = 0, outward -y
    2, 6, 3, 3, 6, 7,  // y = 1, outward +y
    0, 2, 1, 1, 2, 3,  // z = 0, outward -z
    4, 5, 6, 5, 7, 6,  // z = 1, outward +z
};
}  // namespace

TEST_CASE("icosphere: Euler's counts, every vertex on the sphere, outward faces, edge links", "[soft][mesh]") {
    const Vec3 centre(Real(0.3), Real(2), Real(-1));
    const Real r = Real(0.75);
    const Real total_mass = Real(2.5);
    LinkMaterial mat;
    mat.stretch = 1234;
    mat.damping = Real(0.5);
    for (int s = 0; s <= 4; ++s) {
        CAPTURE(s);
        const SoftBodyDef d = make_icosphere(centre, r, s, total_mass, mat);
        const std::size_t p4 = std::size_t(1) << (2 * s);  // 4^s
        // Each 1-to-4 split adds one vertex per edge and turns each face into 4 and each edge into 2
        // plus 3 per face: V = 10·4^s + 2, F = 20·4^s, E = 30·4^s, and V − E + F = 2 (a sphere).
        REQUIRE(d.positions.size() == 10 * p4 + 2);
        REQUIRE(d.triangles.size() == 3 * 20 * p4);
        REQUIRE(d.links.size() == 30 * p4);
        REQUIRE(d.masses.size() == d.positions.size());

        double mass = 0;
        for (Real m : d.masses) mass += m;
        CHECK(mass == Approx(total_mass).epsilon(1e-5));
        CHECK(*std::min_element(d.masses.begin(), d.masses.end()) == *std::max_element(d.masses.begin(), d.masses.end()));

        for (const Vec3& x : d.positions) CHECK((x - centre).norm() == Approx(r).epsilon(kGeomTol));

        // Outward, counter-clockwise: the normal of every face points away from the centre (the mesh
        // is star-shaped about it), and the enclosed volume is positive.
        for (std::size_t t = 0; t < d.triangles.size(); t += 3) {
            const Vec3& a = d.positions[d.triangles[t]];
            const Vec3& b = d.positions[d.triangles[t + 1]];
            const Vec3& c = d.positions[d.triangles[t + 2]];
            REQUIRE((b - a).cross(c - a).dot((a + b + c) / Real(3) - centre) > 0);
        }
        CHECK(enclosed_volume(d.triangles, d.positions) > 0);

        // Links: exactly the unique mesh edges, structural, unstressed, with the material's constants.
        std::set<std::pair<std::uint32_t, std::uint32_t>> edges, links;
        for (std::size_t t = 0; t < d.triangles.size(); t += 3)
            for (int k = 0; k < 3; ++k) {
                std::uint32_t a = d.triangles[t + k], b = d.triangles[t + (k + 1) % 3];
                edges.insert({std::min(a, b), std::max(a, b)});
            }
        for (const Link& l : d.links) {
            links.insert({std::min(l.a, l.b), std::max(l.a, l.b)});
            CHECK(l.kind == LinkKind::Structural);
            CHECK(l.rest == Approx((d.positions[l.a] - d.positions[l.b]).norm()).epsilon(1e-6));
            CHECK(l.stiffness == mat.stretch);
            CHECK(l.damping == mat.damping);
        }
        CHECK(links.size() == d.links.size());  // no duplicates
        CHECK(links == edges);
        // Every edge is shared by exactly two faces: a closed 2-manifold (3F = 2E).
        CHECK(2 * d.links.size() == d.triangles.size());
    }
    // Subdivision 3 is the 642-vertex ball of the pressure-ball benchmark scene.
    const SoftBodyDef d3 = make_icosphere(Vec3::Zero(), 1, 3, 1, mat);
    CHECK(d3.positions.size() == 642);
    CHECK(d3.triangles.size() / 3 == 1280);
}

TEST_CASE("icosphere: volume is the inscribed icosahedron's, then converges to 4/3 pi r^3 as h^2", "[soft][mesh]") {
    const double r = 1.5;
    const double ball = 4.0 / 3.0 * 3.14159265358979323846 * r * r * r;
    // Subdivision 0 is the regular icosahedron inscribed in the sphere: edge a = 4 r / sqrt(10 + 2 sqrt 5),
    // volume (5/12)(3 + sqrt 5) a^3.
    const double a = 4 * r / std::sqrt(10 + 2 * std::sqrt(5.0));
    const double icosahedron = 5.0 / 12.0 * (3 + std::sqrt(5.0)) * a * a * a;
    LinkMaterial mat;
    std::vector<double> err;
    double previous = 0;
    for (int s = 0; s <= 5; ++s) {
        const SoftBodyDef d = make_icosphere(Vec3(1, -2, 3), Real(r), s, 1, mat);
        const double v = enclosed_volume(d.triangles, d.positions);
        INFO("s = " << s << ": volume " << v << " (ball " << ball << "), relative error " << 1 - v / ball);
        if (s == 0) CHECK(v == Approx(icosahedron).epsilon(kGeomTol));
        // Vertices on the sphere, faces inside it: every level is inscribed, so its volume is below the
        // ball's, and each level contains the previous one's volume plus the caps it adds.
        CHECK(v < ball);
        CHECK(v > previous);
        previous = v;
        err.push_back(1 - v / ball);
    }
    // The volume lost to the flat faces is the sum of cap volumes, ~ h^2 of the ball for edges h, and
    // each subdivision halves h: the error falls by a factor tending to 4 per level (measured 3.12,
    // 3.74, 3.93, 3.98, 3.996 from s = 0: the first splits still change the shape of the faces).
    for (int s = 0; s + 2 < int(err.size()); ++s) CHECK(err[s + 1] / err[s + 2] > err[s] / err[s + 1]);
    for (int s = 2; s + 1 < int(err.size()); ++s) {
        CAPTURE(s, err[s], err[s + 1]);
        CHECK(err[s] / err[s + 1] == Approx(4).epsilon(0.02));
    }
    // Richardson extrapolation of the last two levels, (4 V_5 - V_4) / 3, removes the h^2 term and lands
    // on 4/3 pi r^3 (measured 3e-6 relative; 5e-5 leaves room for float's rounding of the positions).
    const double v4 = ball * (1 - err[4]), v5 = ball * (1 - err[5]);
    CHECK((4 * v5 - v4) / 3 == Approx(ball).epsilon(5e-5));
    CHECK(err.back() < 2e-3);  // s = 5: within 0.2% of the ball
}

TEST_CASE("icosphere: bad arguments throw SoftError naming the argument", "[soft][mesh]") {
    const LinkMaterial mat;
    const Real nan = std::numeric_limits<Real>::quiet_NaN();
    CHECK_THAT(soft_error_of([&] { make_icosphere(Vec3::Zero(), 0, 2, 1, mat); }), Catch::Contains("radius"));
    CHECK_THAT(soft_error_of([&] { make_icosphere(Vec3::Zero(), -1, 2, 1, mat); }), Catch::Contains("radius"));
    CHECK_THAT(soft_error_of([&] { make_icosphere(Vec3::Zero(), nan, 2, 1, mat); }), Catch::Contains("radius"));
    CHECK_THAT(soft_error_of([&] { make_icosphere(Vec3(0, nan, 0), 1, 2, 1, mat); }), Catch::Contains("centre"));
    CHECK_THAT(soft_error_of([&] { make_icosphere(Vec3::Zero(), 1, -1, 1, mat); }), Catch::Contains("subdivisions"));
    CHECK_THAT(soft_error_of([&] { make_icosphere(Vec3::Zero(), 1, 7, 1, mat); }), Catch::Contains("subdivisions"));
    CHECK_THAT(soft_error_of([&] { make_icosphere(Vec3::Zero(), 1, 2, 0, mat); }), Catch::Contains("total_mass"));
    LinkMaterial bad;
    bad.stretch = -1;
    CHECK_THAT(soft_error_of([&] { make_icosphere(Vec3::Zero(), 1, 2, 1, bad); }), Catch::Contains("material.stretch"));
    CHECK(soft_error_of([&] { make_icosphere(Vec3::Zero(), 1, 6, 1, mat); }).empty());
}

TEST_CASE("icosphere keeps the settings of base and replaces its geometry", "[soft][mesh]") {
    SoftBodyDef base;
    base.method = SoftMethod::ImplicitEuler;
    base.pressure = 42;
    base.positions = {Vec3::Zero()};
    base.masses = {1};
    const SoftBodyDef d = make_icosphere(Vec3::Zero(), 1, 1, 1, LinkMaterial{}, base);
    CHECK(d.method == SoftMethod::ImplicitEuler);
    CHECK(d.pressure == 42);
    CHECK(d.positions.size() == 42);
    CHECK(d.masses.size() == 42);
}

TEST_CASE("mesh body on a triangulated cube: links by graph distance counted by hand", "[soft][mesh]") {
    // Hand count for kCubeTriangles (8 vertices, 28 pairs):
    //  distance 1: the 12 edges and the 6 face diagonals 2-4, 3-5, 1-4, 3-6, 1-2, 5-6 = 18 links, all
    //    structural. Vertices 0 and 7 keep only their 3 cube edges; 1, 2, 4 (one bit set) are joined to
    //    each other by diagonals, as are 3, 5, 6 (two bits set).
    //  distance 2: the 10 pairs left are the 4 body diagonals 0-7, 1-6, 2-5, 4-3 and the 6 unused face
    //    diagonals 0-3, 0-5, 0-6, 7-1, 7-2, 7-4. Each unused one is two cube edges apart (0-1-3, ...);
    //    1-6 goes through 2 (1-2 diagonal, 2-6 edge), and likewise 2-5 via 1, 4-3 via 1. But 0's
    //    neighbours {1, 2, 4} and 7's {3, 5, 6} are disjoint: 0-7 is 3 apart (0-1-3-7).
    //    So distance <= 2 adds 9 bend links (27 in all) and distance <= 3 adds 0-7 (28, every pair).
    const Real side = 2;
    const std::vector<Vec3> v = cube_vertices(side);
    LinkMaterial mat;
    mat.stretch = 500;
    mat.bend = 50;
    mat.damping = Real(0.25);
    const std::vector<std::pair<int, std::size_t>> expected = {{1, 18}, {2, 27}, {3, 28}};
    for (const auto& e : expected) {
        CAPTURE(e.first);
        const SoftBodyDef d = make_mesh_body(v, kCubeTriangles, e.first, 4, mat);
        REQUIRE(d.links.size() == e.second);
        CHECK(d.triangles == kCubeTriangles);
        CHECK(d.positions == v);
        for (Real m : d.masses) CHECK(m == Approx(0.5));
        std::set<std::pair<std::uint32_t, std::uint32_t>> pairs;
        double rest_sum = 0;
        int bends = 0;
        for (const Link& l : d.links) {
            pairs.insert({std::min(l.a, l.b), std::max(l.a, l.b)});
            CHECK(l.rest == Approx((v[l.a] - v[l.b]).norm()).epsilon(1e-6));
            CHECK(l.damping == mat.damping);
            if (l.kind == LinkKind::Bend) {
                ++bends;
                CHECK(l.stiffness == mat.bend);
            } else {
                CHECK(l.kind == LinkKind::Structural);
                CHECK(l.stiffness == mat.stretch);
            }
            rest_sum += l.rest;
        }
        CHECK(pairs.size() == e.second);  // no pair twice
        CHECK(bends == int(e.second) - 18);
        // Rest lengths: 12 edges of length side, 6 face diagonals side·√2; then the 6 unused face
        // diagonals (√2) and 3 body diagonals (√3); then 0-7 (√3).
        double expected_sum = side * (12 + 6 * std::sqrt(2.0));
        if (e.first >= 2) expected_sum += side * (6 * std::sqrt(2.0) + 3 * std::sqrt(3.0));
        if (e.first >= 3) expected_sum += side * std::sqrt(3.0);
        CHECK(rest_sum == Approx(expected_sum).epsilon(1e-5));
        const bool has_07 = pairs.count({0, 7}) > 0;
        CHECK(has_07 == (e.first >= 3));
    }
    // The triangulation is closed and outward: the divergence theorem gives the cube's volume.
    CHECK(enclosed_volume(kCubeTriangles, v) == Approx(side * side * side).epsilon(kGeomTol));
}

TEST_CASE("mesh body: an icosphere's own mesh gives back its edge links", "[soft][mesh]") {
    const LinkMaterial mat;
    const SoftBodyDef ball = make_icosphere(Vec3::Zero(), 1, 2, 1, mat);
    const SoftBodyDef d = make_mesh_body(ball.positions, ball.triangles, 1, 1, mat);
    REQUIRE(d.links.size() == ball.links.size());
    std::set<std::pair<std::uint32_t, std::uint32_t>> a, b;
    for (const Link& l : ball.links) a.insert({std::min(l.a, l.b), std::max(l.a, l.b)});
    for (const Link& l : d.links) b.insert({std::min(l.a, l.b), std::max(l.a, l.b)});
    CHECK(a == b);
    // Distance <= 2 against an independent count: all-pairs graph distances by Floyd-Warshall over
    // the edges (162 vertices), pairs at distance 1 or 2. On a flat triangular lattice a vertex has 12
    // vertices two apart; the 12 valence-5 vertices of the icosphere have fewer, so the count is just
    // under 3 E.
    const std::size_t n = ball.positions.size();
    const int far = 1000;
    std::vector<int> dist(n * n, far);
    for (std::size_t i = 0; i < n; ++i) dist[i * n + i] = 0;
    for (const Link& l : ball.links) dist[l.a * n + l.b] = dist[l.b * n + l.a] = 1;
    for (std::size_t k = 0; k < n; ++k)
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t j = 0; j < n; ++j)
                dist[i * n + j] = std::min(dist[i * n + j], dist[i * n + k] + dist[k * n + j]);
    std::size_t within2 = 0;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i + 1; j < n; ++j) within2 += dist[i * n + j] <= 2;
    const SoftBodyDef d2 = make_mesh_body(ball.positions, ball.triangles, 2, 1, mat);
    INFO("icosphere s=2: " << ball.links.size() << " edges, " << within2 << " pairs within distance 2");
    CHECK(d2.links.size() == within2);
    CHECK(within2 < 3 * ball.links.size());
    CHECK(within2 > 3 * ball.links.size() - 60);  // each of the 12 defects removes a few far pairs
}

TEST_CASE("mesh body: bad meshes throw SoftError naming the triangle, unreferenced vertices are fine", "[soft][mesh]") {
    const LinkMaterial mat;
    std::vector<Vec3> v = cube_vertices(1);
    std::vector<std::uint32_t> tris = kCubeTriangles;
    tris[3 * 5 + 1] = 8;  // triangle 5 points past the 8 vertices
    const std::string out_of_range = soft_error_of([&] { make_mesh_body(v, tris, 1, 1, mat); });
    CHECK_THAT(out_of_range, Catch::Contains("triangle 5") && Catch::Contains("out of range"));

    tris = kCubeTriangles;
    tris[3 * 7 + 2] = tris[3 * 7];  // triangle 7 repeats a vertex
    CHECK_THAT(soft_error_of([&] { make_mesh_body(v, tris, 1, 1, mat); }),
               Catch::Contains("triangle 7") && Catch::Contains("degenerate"));

    std::vector<Vec3> collinear = {Vec3(0, 0, 0), Vec3(1, 1, 1), Vec3(2, 2, 2)};
    CHECK_THAT(soft_error_of([&] { make_mesh_body(collinear, {0, 1, 2}, 1, 1, mat); }),
               Catch::Contains("triangle 0") && Catch::Contains("degenerate"));

    CHECK_THAT(soft_error_of([&] { make_mesh_body(v, {0, 1, 2, 3}, 1, 1, mat); }), Catch::Contains("multiple of 3"));
    CHECK_THAT(soft_error_of([&] { make_mesh_body(v, kCubeTriangles, 0, 1, mat); }), Catch::Contains("link_distance"));
    CHECK_THAT(soft_error_of([&] { make_mesh_body(v, kCubeTriangles, 1, -1, mat); }), Catch::Contains("total_mass"));
    CHECK_THAT(soft_error_of([&] { make_mesh_body({}, {}, 1, 1, mat); }), Catch::Contains("vertices"));
    std::vector<Vec3> bad = v;
    bad[3].z() = std::numeric_limits<Real>::infinity();
    CHECK_THAT(soft_error_of([&] { make_mesh_body(bad, kCubeTriangles, 1, 1, mat); }), Catch::Contains("vertices[3]"));

    // A ninth vertex no triangle uses: a free particle with its share of the mass and no links.
    v.emplace_back(5, 5, 5);
    const SoftBodyDef d = make_mesh_body(v, kCubeTriangles, 2, 9, mat);
    CHECK(d.positions.size() == 9);
    CHECK(d.links.size() == 27);
    for (Real m : d.masses) CHECK(m == Approx(1));
    for (const Link& l : d.links) CHECK((l.a != 8 && l.b != 8));
}
