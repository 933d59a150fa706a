// General convex contact (libccd GJK/EPA + reference-face clipping), called directly.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "engine/core/narrowphase.hpp"

using namespace sinew;

namespace {

// Face-clipped points are plain plane arithmetic on unit-sized coordinates: Real rounding (~1e-7 in
// float) times a few operations. EPA depths are converged to 1e-7 of the shapes' size in libccd.
const Real kTol = std::max(Real(100) * kEpsilon, Real(1e-6));

Shape cube_hull(Real h) {
    std::vector<Vec3> pts;
    for (int i = 0; i < 8; ++i) pts.emplace_back(i & 1 ? h : -h, i & 2 ? h : -h, i & 4 ? h : -h);
    return make_convex_hull(pts);
}

Transform at(const Vec3& p, const Quat& q = Quat::Identity()) {
    Transform x;
    x.p = p;
    x.q = q;
    return x;
}

Quat axis_angle(Real angle, const Vec3& axis) { return Quat(Eigen::AngleAxis<Real>(angle, axis.normalized())); }

// Ground: a box whose top face is y = 0.
const Shape kGround = make_box(Vec3(5, 0.5, 5));
const Transform kGroundXf = at(Vec3(0, -0.5, 0));

std::vector<std::uint32_t> sorted_ids(const Manifold& m) {
    std::vector<std::uint32_t> ids;
    for (int i = 0; i < m.count; ++i) ids.push_back(m.points[i].feature_id);
    std::sort(ids.begin(), ids.end());
    return ids;
}

}  // namespace

TEST_CASE("unit cube hull resting on a box gets four points", "[convex]") {
    const Shape cube = cube_hull(0.5);
    const Real pen = Real(0.01);
    Manifold m;
    REQUIRE(narrow::convex_convex(cube, at(Vec3(0.2, 0.5 - pen, -0.1)), kGround, kGroundXf, Real(0.02), m));
    REQUIRE(m.count == 4);
    // Normal from A (cube) to B (ground): down.
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    for (int i = 0; i < m.count; ++i) {
        const ContactPoint& p = m.points[i];
        CHECK(p.depth == Approx(pen).margin(kTol));
        CHECK(p.position.y() == Approx(-pen / 2).margin(kTol));  // midway between the two surfaces
        CHECK(std::abs(std::abs(p.position.x() - Real(0.2)) - Real(0.5)) < kTol);  // the cube's corners
        CHECK(std::abs(std::abs(p.position.z() + Real(0.1)) - Real(0.5)) < kTol);
    }
    auto ids = sorted_ids(m);
    CHECK(std::unique(ids.begin(), ids.end()) == ids.end());

    // Swapped roles: the normal flips, the points do not move.
    Manifold s;
    REQUIRE(narrow::convex_convex(kGround, kGroundXf, cube, at(Vec3(0.2, 0.5 - pen, -0.1)), Real(0.02), s));
    REQUIRE(s.count == 4);
    CHECK((s.normal - Vec3(0, 1, 0)).norm() < kTol);
    for (int i = 0; i < s.count; ++i) CHECK(s.points[i].depth == Approx(pen).margin(kTol));
}

TEST_CASE("hull resting on a hull gets four points", "[convex]") {
    const Shape big = cube_hull(1), small = cube_hull(Real(0.25));
    const Real pen = Real(0.004);
    // Small cube rotated 30 degrees about the vertical, resting off-centre on the big one.
    Manifold m;
    REQUIRE(narrow::convex_convex(small, at(Vec3(0.3, 1 + Real(0.25) - pen, 0.4), axis_angle(Real(0.5236), Vec3::UnitY())),
                                  big, at(Vec3::Zero()), Real(0.01), m));
    REQUIRE(m.count == 4);
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    for (int i = 0; i < m.count; ++i) CHECK(m.points[i].depth == Approx(pen).margin(kTol));

    // Hanging half over the edge: the contact is the overlap of the two faces, still four corners.
    REQUIRE(narrow::convex_convex(small, at(Vec3(1, 1 + Real(0.25) - pen, 0)), big, at(Vec3::Zero()), Real(0.01), m));
    REQUIRE(m.count == 4);
    for (int i = 0; i < m.count; ++i) {
        CHECK(m.points[i].position.x() <= 1 + kTol);
        CHECK(m.points[i].position.x() >= Real(0.75) - kTol);
        CHECK(m.points[i].depth == Approx(pen).margin(kTol));
    }
}

TEST_CASE("tetrahedron hull vertex-down on a box gets one point", "[convex]") {
    // Apex at the local origin, base triangle at y = 1: apex down.
    const Shape tet = make_convex_hull({{0, 0, 0}, {1, 1, 0}, {-0.5, 1, 0.866}, {-0.5, 1, -0.866}});
    REQUIRE(tet.hull->faces.size() == 4);
    const Real pen = Real(0.02);
    Manifold m;
    REQUIRE(narrow::convex_convex(tet, at(Vec3(0.3, -pen, 0.1)), kGround, kGroundXf, Real(0.05), m));
    REQUIRE(m.count == 1);
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    CHECK(m.points[0].depth == Approx(pen).margin(kTol));
    CHECK((m.points[0].position - Vec3(0.3, -pen / 2, 0.1)).norm() < kTol);
}

TEST_CASE("sphere against a hull matches the analytic depth", "[convex]") {
    const Shape cube = cube_hull(0.5);
    const Shape ball = make_sphere(0.5);
    Manifold m;
    // Above the top face: depth = r - (0.9 - 0.5).
    REQUIRE(narrow::convex_convex(ball, at(Vec3(0.1, 0.9, -0.2)), cube, at(Vec3::Zero()), Real(0.01), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.1).margin(kTol));
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    CHECK((m.points[0].position - Vec3(0.1, 0.45, -0.2)).norm() < kTol);

    // Beside the edge x = y = 0.5: depth = r - |(0.7, 0.7) - (0.5, 0.5)|, normal along (-1, -1, 0)/sqrt2.
    REQUIRE(narrow::convex_convex(ball, at(Vec3(0.7, 0.7, 0.1)), cube, at(Vec3::Zero()), Real(0.01), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.5 - std::sqrt(0.08)).margin(kTol));
    CHECK((m.normal - Vec3(-1, -1, 0).normalized()).norm() < kTol);

    // Centre inside the hull (EPA on the cores): depth = r + distance from the centre to the top face.
    REQUIRE(narrow::convex_convex(ball, at(Vec3(0, 0.3, 0)), cube, at(Vec3::Zero()), Real(0.01), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.7).margin(kTol));
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);

    // Hull as A, rotated: the normal points from the hull to the sphere.
    const Quat q = axis_angle(Real(0.7), Vec3(1, 2, 3));
    const Vec3 top = q * Vec3(0, 1, 0);
    REQUIRE(narrow::convex_convex(cube, at(Vec3(1, 2, 3), q), ball, at(Vec3(1, 2, 3) + top * Real(0.95)), Real(0.01), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.05).margin(kTol));
    CHECK((m.normal - top).norm() < kTol);
}

TEST_CASE("capsule lying on a hull gets two points", "[convex]") {
    const Shape cube = cube_hull(1);
    const Shape cap = make_capsule(Real(0.4), Real(0.1));
    const Real pen = Real(0.005);
    // Capsule axis (local y) turned onto the x axis, lying on the top face y = 1.
    const Transform xf = at(Vec3(0.2, 1 + Real(0.1) - pen, 0.3), axis_angle(kPi / 2, Vec3::UnitZ()));
    Manifold m;
    REQUIRE(narrow::convex_convex(cap, xf, cube, at(Vec3::Zero()), Real(0.01), m));
    REQUIRE(m.count == 2);
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    std::vector<Real> xs;
    for (int i = 0; i < 2; ++i) {
        CHECK(m.points[i].depth == Approx(pen).margin(kTol));
        CHECK(m.points[i].position.z() == Approx(0.3).margin(kTol));
        xs.push_back(m.points[i].position.x());
    }
    std::sort(xs.begin(), xs.end());
    CHECK(xs[0] == Approx(-0.2).margin(kTol));  // the segment's ends, 0.2 -/+ 0.4
    CHECK(xs[1] == Approx(0.6).margin(kTol));
    CHECK(m.points[0].feature_id != m.points[1].feature_id);

    // Hull as A: normal up, same points.
    Manifold s;
    REQUIRE(narrow::convex_convex(cube, at(Vec3::Zero()), cap, xf, Real(0.01), s));
    REQUIRE(s.count == 2);
    CHECK((s.normal - Vec3(0, 1, 0)).norm() < kTol);
}

TEST_CASE("separated hulls: speculative points inside the margin, nothing beyond", "[convex]") {
    const Shape cube = cube_hull(0.5);
    Manifold m;
    const Real gap = Real(0.02);
    REQUIRE(narrow::convex_convex(cube, at(Vec3(0, 0.5 + gap, 0)), kGround, kGroundXf, Real(0.05), m));
    REQUIRE(m.count == 4);
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    for (int i = 0; i < m.count; ++i) CHECK(m.points[i].depth == Approx(-gap).margin(kTol));

    // Tilted by 0.1 rad about z: the low corners are within the margin, the high ones (0.1 higher) not.
    REQUIRE(narrow::convex_convex(cube, at(Vec3(0, 0.5 * std::cos(0.1) + 0.5 * std::sin(0.1) + gap, 0),
                                           axis_angle(Real(0.1), Vec3::UnitZ())),
                                  kGround, kGroundXf, Real(0.05), m));
    REQUIRE(m.count == 2);
    for (int i = 0; i < m.count; ++i) CHECK(m.points[i].depth == Approx(-gap).margin(kTol));

    // Sphere above a hull, within and beyond the margin.
    const Shape ball = make_sphere(0.25);
    REQUIRE(narrow::convex_convex(ball, at(Vec3(0, 0.5 + 0.25 + 0.03, 0)), cube, at(Vec3::Zero()), Real(0.05), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(-0.03).margin(kTol));

    // Exactly touching (the degenerate case for GJK/EPA): four points at zero depth.
    REQUIRE(narrow::convex_convex(cube, at(Vec3(0.1, 0.5, 0.2)), kGround, kGroundXf, Real(0.05), m));
    REQUIRE(m.count == 4);
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    for (int i = 0; i < m.count; ++i) CHECK(std::abs(m.points[i].depth) < kTol);

    CHECK_FALSE(narrow::convex_convex(cube, at(Vec3(0, 0.5 + 0.1, 0)), kGround, kGroundXf, Real(0.05), m));
    CHECK(m.count == 0);
    CHECK_FALSE(narrow::convex_convex(ball, at(Vec3(3, 0, 0)), cube, at(Vec3::Zero()), Real(0.05), m));
    CHECK(m.count == 0);
}

TEST_CASE("edge-on-edge hulls give one point at the crossing", "[convex]") {
    // Upper cube turned 45 degrees about z (an edge along z at the bottom), lower cube turned 45 degrees
    // about x (an edge along x at the top): the edges cross at one point on the y axis.
    const Shape cube = cube_hull(0.5);
    const Real h = Real(0.5 * std::sqrt(2.0));  // centre-to-edge distance
    const Real pen = Real(0.01);
    Manifold m;
    REQUIRE(narrow::convex_convex(cube, at(Vec3(0, 2 * h - pen, 0), axis_angle(kPi / 4, Vec3::UnitZ())), cube,
                                  at(Vec3::Zero(), axis_angle(kPi / 4, Vec3::UnitX())), Real(0.02), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(pen).margin(kTol));
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    CHECK((m.points[0].position - Vec3(0, h - pen / 2, 0)).norm() < 10 * kTol);
}

TEST_CASE("feature ids are stable under a small motion", "[convex]") {
    const Shape cube = cube_hull(0.5);
    Manifold m0, m1, m2;
    REQUIRE(narrow::convex_convex(cube, at(Vec3(0, 0.49, 0)), kGround, kGroundXf, Real(0.02), m0));
    REQUIRE(narrow::convex_convex(cube, at(Vec3(0.01, 0.492, -0.005)), kGround, kGroundXf, Real(0.02), m1));
    REQUIRE(narrow::convex_convex(cube, at(Vec3(0.01, 0.49, 0.003), axis_angle(Real(0.02), Vec3::UnitY())),
                                  kGround, kGroundXf, Real(0.02), m2));
    REQUIRE(m0.count == 4);
    CHECK(sorted_ids(m0) == sorted_ids(m1));
    CHECK(sorted_ids(m0) == sorted_ids(m2));
    // And each point keeps its id: the point with a given id moves only as far as the cube did.
    for (int i = 0; i < m0.count; ++i)
        for (int j = 0; j < m2.count; ++j)
            if (m0.points[i].feature_id == m2.points[j].feature_id)
                CHECK((m0.points[i].position - m2.points[j].position).norm() < Real(0.03));

    // A sphere rolling on a hull face keeps its one id (the face, not a tie between its corners).
    const Shape ball = make_sphere(Real(0.2));
    REQUIRE(narrow::convex_convex(ball, at(Vec3(0, 0.69, 0)), cube, at(Vec3::Zero()), Real(0.02), m0));
    REQUIRE(narrow::convex_convex(ball, at(Vec3(0.05, 0.69, -0.03)), cube,
                                  at(Vec3::Zero(), axis_angle(Real(1e-3), Vec3(1, 0, 1))), Real(0.02), m1));
    REQUIRE(m0.count == 1);
    REQUIRE(m1.count == 1);
    CHECK(m0.points[0].feature_id == m1.points[0].feature_id);

    // A capsule rolling slightly on a hull keeps its two ids too.
    const Shape cap = make_capsule(Real(0.3), Real(0.1));
    const Quat lie = axis_angle(kPi / 2, Vec3::UnitZ());
    REQUIRE(narrow::convex_convex(cap, at(Vec3(0, 0.59, 0), lie), cube, at(Vec3::Zero()), Real(0.02), m0));
    REQUIRE(narrow::convex_convex(cap, at(Vec3(0.01, 0.591, 0.01), axis_angle(Real(0.01), Vec3::UnitY()) * lie), cube,
                                  at(Vec3::Zero()), Real(0.02), m1));
    REQUIRE(m0.count == 2);
    CHECK(sorted_ids(m0) == sorted_ids(m1));
}

TEST_CASE("convex_convex also handles the basic pairs", "[convex]") {
    // Box on box (the dedicated routine exists elsewhere; this one must agree on a resting contact).
    const Shape box = make_box(Vec3(0.5, 0.25, 0.5));
    Manifold m;
    REQUIRE(narrow::convex_convex(box, at(Vec3(0, 0.24, 0)), kGround, kGroundXf, Real(0.02), m));
    CHECK(m.count == 4);
    for (int i = 0; i < m.count; ++i) CHECK(m.points[i].depth == Approx(0.01).margin(kTol));

    // Sphere on sphere: depth = r1 + r2 - distance.
    const Shape a = make_sphere(0.5), b = make_sphere(0.25);
    REQUIRE(narrow::convex_convex(a, at(Vec3(1, 1, 1)), b, at(Vec3(1, 1, 1) + Vec3(1, 2, 2) / 3 * Real(0.7)), Real(0.01), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.05).margin(kTol));
    CHECK((m.normal - Vec3(1, 2, 2) / 3).norm() < kTol);

    // Capsule standing on a box: one point under its lower end.
    const Shape cap = make_capsule(Real(0.5), Real(0.2));
    REQUIRE(narrow::convex_convex(cap, at(Vec3(0.1, 0.69, 0)), kGround, kGroundXf, Real(0.02), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.01).margin(kTol));

    // Sphere centred on the capsule's segment (the cores overlap: EPA on the rounded shapes, converged
    // to libccd's tolerance on curved surfaces, hence the looser 1e-3): depth = r1 + r2, any horizontal normal.
    REQUIRE(narrow::convex_convex(b, at(Vec3(0, 0.3, 0)), cap, at(Vec3::Zero()), Real(0.01), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.25 + 0.2).margin(1e-3));
    CHECK(std::abs(m.normal.y()) < Real(1e-2));
    // Off the segment by 0.1 (cores apart: exact): depth = r1 + r2 - 0.1, normal from sphere to capsule.
    REQUIRE(narrow::convex_convex(b, at(Vec3(0.1, 0.3, 0)), cap, at(Vec3::Zero()), Real(0.01), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.25 + 0.2 - 0.1).margin(kTol));
    CHECK((m.normal - Vec3(-1, 0, 0)).norm() < kTol);
}

TEST_CASE("box resting on a two-triangle ground mesh", "[convex][triangle]") {
    // Ground square [-2, 2]^2 at y = 0, counter-clockwise seen from above, so its normal is +y.
    const std::vector<Vec3> v{{-2, 0, -2}, {-2, 0, 2}, {2, 0, 2}, {2, 0, -2}};
    const Shape ground = make_triangle_mesh(v, {0, 1, 2, 0, 2, 3});
    REQUIRE(ground.mesh->triangle_count() == 2);
    for (std::size_t t = 0; t < 2; ++t) {
        const Triangle tri = ground.mesh->triangle(t);
        REQUIRE((tri.b - tri.a).cross(tri.c - tri.a).normalized().isApprox(Vec3(0, 1, 0)));
    }

    const Shape box = make_box(Vec3(0.5, 0.5, 0.5));
    const Real pen = Real(0.01);
    // The box straddles the shared diagonal x = z: both triangles touch it.
    const Transform xf = at(Vec3(0.3, 0.5 - pen, 0.2), axis_angle(Real(0.3), Vec3::UnitY()));
    int total = 0;
    for (std::size_t t = 0; t < 2; ++t) {
        Manifold m;
        REQUIRE(narrow::convex_triangle(box, xf, ground.mesh->triangle(t), Real(0.02), m));
        REQUIRE(m.count >= 1);
        // From A (the box) to B (the ground): pointing down, into the ground. The face normal, not the
        // shared edge's: no snagging on the diagonal.
        CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
        for (int i = 0; i < m.count; ++i) {
            CHECK(m.points[i].depth == Approx(pen).margin(kTol));
            CHECK(m.points[i].position.y() == Approx(-pen / 2).margin(kTol));
        }
        total += m.count;
    }
    CHECK(total >= 4);

    // Wholly over one triangle: that triangle gives the four corners, the other nothing.
    const Transform over = at(Vec3(1.2, 0.5 - pen, -1.2));
    Manifold m;
    REQUIRE(narrow::convex_triangle(box, over, ground.mesh->triangle(1), Real(0.02), m));
    CHECK(m.count == 4);
    CHECK_FALSE(narrow::convex_triangle(box, over, ground.mesh->triangle(0), Real(0.02), m));

    // Within the margin above the mesh: speculative, negative depth. Beyond it: nothing.
    REQUIRE(narrow::convex_triangle(box, at(Vec3(1.2, 0.51, -1.2)), ground.mesh->triangle(1), Real(0.02), m));
    CHECK(m.count == 4);
    for (int i = 0; i < m.count; ++i) CHECK(m.points[i].depth == Approx(-0.01).margin(kTol));
    CHECK_FALSE(narrow::convex_triangle(box, at(Vec3(1.2, 0.6, -1.2)), ground.mesh->triangle(1), Real(0.02), m));

    // A hull and a sphere on the mesh too.
    const Shape cube = cube_hull(0.5);
    REQUIRE(narrow::convex_triangle(cube, over, ground.mesh->triangle(1), Real(0.02), m));
    CHECK(m.count == 4);
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    const Shape cap = make_capsule(Real(0.3), Real(0.1));
    REQUIRE(narrow::convex_triangle(cap, at(Vec3(1, 0.09, -1), axis_angle(kPi / 2, Vec3::UnitX())),
                                    ground.mesh->triangle(1), Real(0.02), m));
    CHECK(m.count == 2);  // lying along z: both ends of the segment
    for (int i = 0; i < m.count; ++i) CHECK(m.points[i].depth == Approx(0.01).margin(kTol));
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);
    const Shape ball = make_sphere(0.5);
    REQUIRE(narrow::convex_triangle(ball, at(Vec3(1, 0.45, -1)), ground.mesh->triangle(1), Real(0.02), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.05).margin(kTol));
    CHECK((m.normal - Vec3(0, -1, 0)).norm() < kTol);

    // Behind the triangle (centre below its plane) the face normal is not forced: a shape poking up
    // through the ground from below is pushed back down, normal from it to the triangle pointing up.
    REQUIRE(narrow::convex_triangle(ball, at(Vec3(1, -0.45, -1)), ground.mesh->triangle(1), Real(0.02), m));
    REQUIRE(m.count == 1);
    CHECK(m.points[0].depth == Approx(0.05).margin(kTol));
    CHECK((m.normal - Vec3(0, 1, 0)).norm() < kTol);
}

TEST_CASE("non-convex shapes are refused by convex_convex", "[convex]") {
    Manifold m;
    const Shape plane = make_plane(Vec3(0, 1, 0), 0);
    CHECK_THROWS_AS(narrow::convex_convex(plane, at(Vec3::Zero()), kGround, kGroundXf, Real(0.01), m), ShapeError);
}
