// Soft-body builders (soft/soft_builders.hpp): ropes, cloth grids, the particle ragdoll and the stick box.
// Counts against the closed forms of each layout, rest lengths against the built positions, triangle
// orientation against edge_u x edge_v, masses summing to the total, and bad input rejected with a
// SoftError that names the argument. Pure geometry: exact up to rounding of the positions, so the
// tolerances are a few ulps of the lengths involved (1e-5 relative holds in float).
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include "soft/soft_builders.hpp"

using namespace sinew;

namespace {

// Relative tolerance for lengths rebuilt from float positions of order 1 m: a few float ulps (1.2e-7).
constexpr double kRel = 1e-5;

double total_mass(const SoftBodyDef& d) {
    double m = 0;
    for (Real x : d.masses) m += double(x);
    return m;
}

int count_kind(const SoftBodyDef& d, LinkKind k) {
    int n = 0;
    for (const Link& l : d.links) n += l.kind == k;
    return n;
}

// Every link: ends in range and distinct, rest = distance of the built positions, Verlet bounds equal
// to the rest length (equality constraint), material from the kind.
void check_links_match_positions(const SoftBodyDef& d) {
    for (std::size_t i = 0; i < d.links.size(); ++i) {
        const Link& l = d.links[i];
        INFO("link " << i);
        REQUIRE(l.a < d.positions.size());
        REQUIRE(l.b < d.positions.size());
        REQUIRE(l.a != l.b);
        const double len = double((d.positions[l.a] - d.positions[l.b]).norm());
        CHECK(double(l.rest) == Approx(len).epsilon(kRel));
        CHECK(l.rest > 0);
    }
}

// SoftError whose message contains `what`.
template <class F>
void require_soft_error(F&& f, const std::string& what) {
    try {
        f();
        FAIL("no SoftError for " << what);
    } catch (const SoftError& e) {
        INFO(e.what());
        CHECK(std::string(e.what()).find(what) != std::string::npos);
    }
}

}  // namespace

TEST_CASE("rope: segments+1 particles on the segment, even mass, equal links", "[soft][builders]") {
    LinkMaterial m;
    m.stretch = 5000;
    m.damping = 2;
    m.fraction = Real(0.8);
    const Vec3 a(0, 2, 0), b(3, 2, 4);  // 5 m long
    const SoftBodyDef d = make_rope(a, b, 20, Real(2), m);
    REQUIRE(d.positions.size() == 21);
    REQUIRE(d.masses.size() == 21);
    REQUIRE(d.links.size() == 20);
    CHECK(d.triangles.empty());
    CHECK(d.pinned.empty());  // callers pin
    CHECK(total_mass(d) == Approx(2).epsilon(kRel));
    CHECK(double((d.positions.front() - a).norm()) < 1e-6);
    CHECK(double((d.positions.back() - b).norm()) < 1e-5);
    check_links_match_positions(d);
    double length = 0;
    for (const Link& l : d.links) {
        CHECK(double(l.rest) == Approx(0.25).epsilon(kRel));  // 5 m / 20
        CHECK(l.min_length == l.rest);
        CHECK(l.max_length == l.rest);
        CHECK(l.stiffness == Real(5000));
        CHECK(l.damping == Real(2));
        CHECK(l.fraction == Real(0.8));
        CHECK(l.kind == LinkKind::Structural);
        length += double(l.rest);
    }
    CHECK(length == Approx(5).epsilon(kRel));
}

TEST_CASE("rope: the base definition's settings are kept", "[soft][builders]") {
    SoftBodyDef base;
    base.iterations = 17;
    base.drag = Real(0.3);
    base.thickness = Real(0.05);
    const SoftBodyDef d = make_rope(Vec3(0, 0, 0), Vec3(1, 0, 0), 4, 1, LinkMaterial{}, base);
    CHECK(d.iterations == 17);
    CHECK(d.drag == Real(0.3));
    CHECK(d.thickness == Real(0.05));
    CHECK(d.positions.size() == 5);
}

TEST_CASE("cloth grid: node, link and triangle counts follow the layout", "[soft][builders]") {
    for (auto [nx, ny] : {std::pair<int, int>{2, 2}, {3, 2}, {7, 5}, {32, 32}}) {
        for (bool shear : {false, true})
            for (bool bend : {false, true}) {
                INFO("nx " << nx << " ny " << ny << " shear " << shear << " bend " << bend);
                ClothGridDesc g;
                g.nx = nx;
                g.ny = ny;
                g.shear = shear;
                g.bend = bend;
                g.total_mass = Real(1.5);
                const SoftBodyDef d = make_cloth_grid(g);
                CHECK(d.positions.size() == std::size_t(nx * ny));
                CHECK(d.masses.size() == std::size_t(nx * ny));
                CHECK(total_mass(d) == Approx(1.5).epsilon(kRel));
                const int structural = (nx - 1) * ny + nx * (ny - 1);
                const int shears = shear ? 2 * (nx - 1) * (ny - 1) : 0;
                const int bends = bend ? (nx - 2) * ny + nx * (ny - 2) : 0;
                CHECK(count_kind(d, LinkKind::Structural) == structural);
                CHECK(count_kind(d, LinkKind::Shear) == shears);
                CHECK(count_kind(d, LinkKind::Bend) == bends);
                CHECK(d.links.size() == std::size_t(structural + shears + bends));
                CHECK(d.triangles.size() == std::size_t(6 * (nx - 1) * (ny - 1)));
                CHECK(d.pinned.empty());
                check_links_match_positions(d);
            }
    }
}

TEST_CASE("cloth grid: node (i, j) sits at origin + i/(nx-1) edge_u + j/(ny-1) edge_v", "[soft][builders]") {
    ClothGridDesc g;
    g.nx = 5;
    g.ny = 4;
    g.origin = Vec3(-1, 3, 0);
    g.edge_u = Vec3(2, 0, 0);
    g.edge_v = Vec3(0, 0, Real(1.5));
    g.bend = true;
    const SoftBodyDef d = make_cloth_grid(g);
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i) {
            const Vec3 want = g.origin + g.edge_u * (Real(i) / 4) + g.edge_v * (Real(j) / 3);
            CHECK(double((d.positions[cloth_node(g, i, j)] - want).norm()) < 1e-6);
        }
    // Rest lengths per kind: structural du or dv, shear the quad diagonal, bend twice du or dv.
    const double du = 0.5, dv = 0.5, diag = std::sqrt(du * du + dv * dv);
    for (const Link& l : d.links) {
        const double r = double(l.rest);
        switch (l.kind) {
            case LinkKind::Structural: CHECK((std::abs(r - du) < 1e-6 || std::abs(r - dv) < 1e-6)); break;
            case LinkKind::Shear: CHECK(r == Approx(diag).epsilon(kRel)); break;
            case LinkKind::Bend: CHECK((std::abs(r - 2 * du) < 1e-6 || std::abs(r - 2 * dv) < 1e-6)); break;
            default: FAIL("unexpected link kind");
        }
    }
}

TEST_CASE("cloth grid: triangles are counter-clockwise around edge_u x edge_v and tile the patch",
          "[soft][builders]") {
    // A skewed, tilted grid so the test does not pass by an axis coincidence.
    ClothGridDesc g;
    g.nx = 6;
    g.ny = 9;
    g.origin = Vec3(Real(0.3), 1, Real(-0.2));
    g.edge_u = Vec3(2, Real(0.5), Real(0.1));
    g.edge_v = Vec3(Real(0.4), Real(-0.3), Real(-1.7));
    const SoftBodyDef d = make_cloth_grid(g);
    const Vec3 n = g.edge_u.cross(g.edge_v);
    double area = 0;
    for (std::size_t t = 0; t < d.triangles.size(); t += 3) {
        const Vec3& a = d.positions[d.triangles[t]];
        const Vec3& b = d.positions[d.triangles[t + 1]];
        const Vec3& c = d.positions[d.triangles[t + 2]];
        const Vec3 tn = (b - a).cross(c - a);
        CHECK(tn.dot(n) > 0);
        // parallel to n: |tn x n| is zero up to rounding
        CHECK(double(tn.cross(n).norm()) < 1e-5 * double(tn.norm() * n.norm()));
        area += 0.5 * double(tn.norm());
    }
    // The triangles cover the parallelogram exactly once.
    CHECK(area == Approx(double(n.norm())).epsilon(kRel));
}

TEST_CASE("cloth grid: bad input names the argument", "[soft][builders]") {
    ClothGridDesc g;
    g.nx = 1;
    require_soft_error([&] { make_cloth_grid(g); }, "nx");
    g = ClothGridDesc{};
    g.ny = 0;
    require_soft_error([&] { make_cloth_grid(g); }, "ny");
    g = ClothGridDesc{};
    g.total_mass = 0;
    require_soft_error([&] { make_cloth_grid(g); }, "total_mass");
    g.total_mass = std::numeric_limits<Real>::quiet_NaN();
    require_soft_error([&] { make_cloth_grid(g); }, "total_mass");
    g = ClothGridDesc{};
    g.origin.x() = std::numeric_limits<Real>::infinity();
    require_soft_error([&] { make_cloth_grid(g); }, "origin");
    g = ClothGridDesc{};
    g.edge_v = g.edge_u * 2;
    require_soft_error([&] { make_cloth_grid(g); }, "edge_u");
    g = ClothGridDesc{};
    g.material.fraction = Real(1.5);
    require_soft_error([&] { make_cloth_grid(g); }, "fraction");

    require_soft_error([] { make_rope(Vec3(0, 0, 0), Vec3(1, 0, 0), 0, 1, LinkMaterial{}); }, "segments");
    require_soft_error([] { make_rope(Vec3(0, 0, 0), Vec3(1, 0, 0), 3, -1, LinkMaterial{}); }, "total_mass");
    require_soft_error([] { make_rope(Vec3(0, 0, 0), Vec3(0, 0, 0), 3, 1, LinkMaterial{}); }, "coincide");
    require_soft_error([] { make_stick_box(Vec3(0, 0, 0), Vec3(1, 0, 1), 1); }, "half_extents");
    require_soft_error([] { make_stick_box(Vec3(0, 0, 0), Vec3(1, 1, 1), 0); }, "total_mass");
    require_soft_error([] { make_particle_ragdoll(Vec3(0, 0, 0), -1, 70); }, "height");
    require_soft_error([] { make_particle_ragdoll(Vec3(0, 0, 0), Real(1.8), 0); }, "total_mass");
}

TEST_CASE("stick box: 8 corners, all 28 pairs linked, closed outward surface", "[soft][builders]") {
    const Vec3 c(1, 2, 3), e(Real(0.5), Real(0.25), Real(1));
    const SoftBodyDef d = make_stick_box(c, e, Real(4));
    REQUIRE(d.positions.size() == 8);
    CHECK(total_mass(d) == Approx(4).epsilon(kRel));
    REQUIRE(d.links.size() == 28);
    CHECK(count_kind(d, LinkKind::Structural) == 12);  // edges
    CHECK(count_kind(d, LinkKind::Shear) == 12);       // face diagonals
    CHECK(count_kind(d, LinkKind::Other) == 4);        // body diagonals
    check_links_match_positions(d);
    // every unordered pair exactly once
    std::vector<int> seen(64, 0);
    for (const Link& l : d.links) {
        ++seen[l.a * 8 + l.b];
        ++seen[l.b * 8 + l.a];
        CHECK(l.min_length == l.rest);
        CHECK(l.max_length == l.rest);
    }
    for (int a = 0; a < 8; ++a)
        for (int b = 0; b < 8; ++b) CHECK(seen[a * 8 + b] == (a == b ? 0 : 1));
    // corners at centre +- half extents
    for (const Vec3& p : d.positions) CHECK(double(((p - c).cwiseAbs() - e).norm()) < 1e-6);
    // 12 triangles enclosing the box's volume (divergence theorem, positive = outward)
    REQUIRE(d.triangles.size() == 36);
    double volume = 0;
    for (std::size_t t = 0; t < 36; t += 3) {
        const Vec3 a = d.positions[d.triangles[t]] - c, b = d.positions[d.triangles[t + 1]] - c,
                   cc = d.positions[d.triangles[t + 2]] - c;
        volume += double(a.dot(b.cross(cc))) / 6;
        // each triangle's normal points away from the centre
        CHECK((b - a).cross(cc - a).dot(a + b + cc) > 0);
    }
    CHECK(volume == Approx(8 * 0.5 * 0.25 * 1.0).epsilon(kRel));
}

TEST_CASE("particle ragdoll: sticks and min-distance limits, mass and height", "[soft][builders]") {
    const Vec3 feet(2, 0, -1);
    const Real height = Real(1.8);
    const SoftBodyDef d = make_particle_ragdoll(feet, height, Real(70));
    REQUIRE(d.positions.size() == 14);
    CHECK(total_mass(d) == Approx(70).epsilon(kRel));
    for (Real m : d.masses) CHECK(m > 0);
    check_links_match_positions(d);
    // Standing: the highest particle (head) below the height, the lowest (feet) at the ground.
    Real top = -1e9, bottom = 1e9;
    for (const Vec3& p : d.positions) {
        top = std::max(top, p.y());
        bottom = std::min(bottom, p.y());
    }
    CHECK(top <= feet.y() + height);
    CHECK(top > feet.y() + Real(0.85) * height);
    CHECK(bottom >= feet.y());
    CHECK(bottom < feet.y() + Real(0.05) * height);
    int sticks = 0, limits = 0;
    for (const Link& l : d.links) {
        if (l.min_length == l.rest && l.max_length == l.rest) {
            ++sticks;
        } else {
            ++limits;
            // an inequality link: acts only below its minimum, which is below the posed distance
            CHECK(l.min_length < l.rest);
            CHECK(l.min_length > 0);
            CHECK(l.max_length > Real(1e6));
            CHECK(l.kind == LinkKind::Other);
        }
    }
    CHECK(sticks == 19);  // torso 10 (5 particles, all pairs) + head 1 + limbs 8
    CHECK(limits == 11);
    // The layout in the builder's comment: knees 10 and 11 have a limit between them.
    bool knee_limit = false;
    for (const Link& l : d.links)
        if (((l.a == 10 && l.b == 11) || (l.a == 11 && l.b == 10)) && l.min_length < l.rest) knee_limit = true;
    CHECK(knee_limit);
}
