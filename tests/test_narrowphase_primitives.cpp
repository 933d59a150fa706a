// Narrow phase: the analytic pair routines (sphere, capsule, box, plane) and the dispatcher, checked on
// configurations whose contact normal, depth and points are known in closed form.
//
// Conventions under test: the normal points from A to B, depth > 0 is penetration, every point lies
// midway between the two surfaces, and points are reported within the margin (negative depth) but not
// beyond it.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <memory>
#include <set>
#include <vector>

#include "engine/core/narrowphase.hpp"

using namespace sinew;

namespace {

// Coordinates here are O(1) m. Each computed quantity goes through a rotation, a transform and a few dot
// products, i.e. tens of roundings of relative size kEpsilon: 2e-5 m in float (~170 ulp of 1.0) and 1e-10 m
// in double bound that with a wide safety factor while still catching any formula error (those are >1e-3).
const Real kTol = sizeof(Real) == sizeof(float) ? Real(2e-5) : Real(1e-10);
// The brief's accuracy target for a resting box: depth within 1e-5 m of the truth (float).
const Real kRestTol = sizeof(Real) == sizeof(float) ? Real(1e-5) : Real(1e-10);
const Real kSqrt2 = std::sqrt(Real(2));

Transform at(const Vec3& p, const Quat& q = Quat::Identity()) { return Transform{p, q}; }
Quat rot(Real degrees, const Vec3& axis) {
    return Quat(Eigen::AngleAxis<Real>(degrees * kPi / 180, axis.normalized()));
}
bool near(const Vec3& a, const Vec3& b, Real tol = kTol) { return (a - b).cwiseAbs().maxCoeff() <= tol; }

ManifoldList run(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin = Real(0.02)) {
    ManifoldList out;
    int n = collide(a, xa, b, xb, margin, out);
    REQUIRE(n == static_cast<int>(out.size()));
    for (const Manifold& m : out) {
        REQUIRE(m.count > 0);
        REQUIRE(m.count <= Manifold::kMaxPoints);
        REQUIRE(std::abs(m.normal.norm() - 1) < kTol);
    }
    return out;
}

std::vector<Real> sorted_depths(const Manifold& m) {
    std::vector<Real> d;
    for (int i = 0; i < m.count; ++i) d.push_back(m.points[i].depth);
    std::sort(d.begin(), d.end());
    return d;
}

std::set<std::uint32_t> ids(const Manifold& m) {
    std::set<std::uint32_t> s;
    for (int i = 0; i < m.count; ++i) s.insert(m.points[i].feature_id);
    return s;
}

/// collide(b, a) must give the flipped normal and the same depths and point set.
void check_swap_symmetry(const Shape& a, const Transform& xa, const Shape& b, const Transform& xb, Real margin = Real(0.02)) {
    ManifoldList ab = run(a, xa, b, xb, margin);
    ManifoldList ba = run(b, xb, a, xa, margin);
    REQUIRE(ab.size() == 1);
    REQUIRE(ba.size() == 1);
    CHECK(near(ab[0].normal, -ba[0].normal));
    REQUIRE(ab[0].count == ba[0].count);
    std::vector<Real> da = sorted_depths(ab[0]), db = sorted_depths(ba[0]);
    for (std::size_t i = 0; i < da.size(); ++i) CHECK(std::abs(da[i] - db[i]) < kTol);
}

// A box resting flat: depth d, centre height so its bottom is d below the ground top at y = 0.5.
const Real kD = Real(0.01);
const Shape kUnit = make_box(Vec3(Real(0.5), Real(0.5), Real(0.5)));
const Shape kGround = make_box(Vec3(5, Real(0.5), 5));

}  // namespace

TEST_CASE("sphere-sphere: normal from A to B, depth, midpoint, margin", "[narrowphase]") {
    Shape s = make_sphere(1);
    ManifoldList out = run(s, at(Vec3::Zero()), s, at(Vec3(Real(1.5), 0, 0)));
    REQUIRE(out.size() == 1);
    REQUIRE(out[0].count == 1);
    CHECK(near(out[0].normal, Vec3::UnitX()));
    CHECK(out[0].points[0].depth == Approx(0.5).margin(kTol));
    // A's surface at x = 1, B's at x = 0.5.
    CHECK(near(out[0].points[0].position, Vec3(Real(0.75), 0, 0)));

    // 5 cm apart: a speculative point within a 10 cm margin, nothing with a 1 cm one.
    out = run(s, at(Vec3::Zero()), s, at(Vec3(Real(2.05), 0, 0)), Real(0.1));
    REQUIRE(out.size() == 1);
    CHECK(out[0].points[0].depth == Approx(-0.05).margin(kTol));
    CHECK(run(s, at(Vec3::Zero()), s, at(Vec3(Real(2.05), 0, 0)), Real(0.01)).empty());

    // Coincident centres still give a unit normal and the full depth.
    out = run(s, at(Vec3::Zero()), s, at(Vec3::Zero()));
    REQUIRE(out.size() == 1);
    CHECK(out[0].points[0].depth == Approx(2).margin(kTol));
}

TEST_CASE("sphere-capsule: side and cap, both argument orders", "[narrowphase]") {
    Shape ball = make_sphere(Real(0.5));
    Shape cap = make_capsule(1, Real(0.5));  // along y, segment y in [-1, 1]
    ManifoldList out = run(ball, at(Vec3(Real(0.9), Real(0.3), 0)), cap, at(Vec3::Zero()));
    REQUIRE(out.size() == 1);
    CHECK(near(out[0].normal, -Vec3::UnitX()));
    CHECK(out[0].points[0].depth == Approx(0.1).margin(kTol));
    CHECK(near(out[0].points[0].position, Vec3(Real(0.45), Real(0.3), 0)));

    out = run(ball, at(Vec3(0, Real(1.9), 0)), cap, at(Vec3::Zero()));
    REQUIRE(out.size() == 1);
    CHECK(near(out[0].normal, -Vec3::UnitY()));
    CHECK(out[0].points[0].depth == Approx(0.1).margin(kTol));

    // A lying capsule (rotated onto x) under the ball.
    out = run(cap, at(Vec3::Zero(), rot(90, Vec3::UnitZ())), ball, at(Vec3(Real(0.7), Real(0.9), 0)));
    REQUIRE(out.size() == 1);
    CHECK(near(out[0].normal, Vec3::UnitY()));
    CHECK(out[0].points[0].depth == Approx(0.1).margin(kTol));
    check_swap_symmetry(ball, at(Vec3(Real(0.9), Real(0.3), Real(0.2))), cap, at(Vec3::Zero(), rot(30, Vec3(1, 0, 1))));
}

TEST_CASE("sphere-box: face, edge and vertex regions, centre inside", "[narrowphase]") {
    Shape ball = make_sphere(Real(0.5));
    Shape box = make_box(Vec3(1, 1, 1));
    SECTION("face region") {
        ManifoldList out = run(ball, at(Vec3(Real(0.2), Real(1.4), Real(-0.3))), box, at(Vec3::Zero()));
        REQUIRE(out.size() == 1);
        CHECK(near(out[0].normal, -Vec3::UnitY()));
        CHECK(out[0].points[0].depth == Approx(0.1).margin(kTol));
        CHECK(near(out[0].points[0].position, Vec3(Real(0.2), Real(0.95), Real(-0.3))));
        // Same region after a small move: same feature id.
        ManifoldList moved = run(ball, at(Vec3(Real(0.21), Real(1.41), Real(-0.3))), box, at(Vec3::Zero()));
        REQUIRE(moved.size() == 1);
        CHECK(moved[0].points[0].feature_id == out[0].points[0].feature_id);
    }
    SECTION("edge region") {
        const Real off = Real(0.3);
        ManifoldList out = run(ball, at(Vec3(1 + off, 1 + off, 0)), box, at(Vec3::Zero()));
        REQUIRE(out.size() == 1);
        CHECK(near(out[0].normal, -Vec3(1, 1, 0).normalized()));
        CHECK(out[0].points[0].depth == Approx(0.5 - off * kSqrt2).margin(kTol));
    }
    SECTION("vertex region, box rotated") {
        const Real off = Real(0.2);
        Transform xb = at(Vec3(1, 2, 3), rot(40, Vec3(1, 2, 3)));
        Vec3 corner_dir = Vec3(1, 1, 1).normalized();
        ManifoldList out = run(ball, at(xb.apply(Vec3(1 + off, 1 + off, 1 + off))), box, xb);
        REQUIRE(out.size() == 1);
        CHECK(near(out[0].normal, -xb.rotate(corner_dir)));
        CHECK(out[0].points[0].depth == Approx(0.5 - off * std::sqrt(Real(3))).margin(kTol));
    }
    SECTION("centre inside: least-penetration face") {
        ManifoldList out = run(ball, at(Vec3(Real(0.1), Real(0.8), 0)), box, at(Vec3::Zero()));
        REQUIRE(out.size() == 1);
        CHECK(near(out[0].normal, -Vec3::UnitY()));
        CHECK(out[0].points[0].depth == Approx(0.7).margin(kTol));  // 0.2 to the face + the radius
        // Halfway between the box face (y = 1) and the sphere's lowest point (y = 0.3).
        CHECK(near(out[0].points[0].position, Vec3(Real(0.1), Real(0.65), 0)));
    }
    SECTION("margin") {
        CHECK(run(ball, at(Vec3(0, Real(1.53), 0)), box, at(Vec3::Zero()), Real(0.02)).empty());
        ManifoldList out = run(ball, at(Vec3(0, Real(1.51), 0)), box, at(Vec3::Zero()), Real(0.02));
        REQUIRE(out.size() == 1);
        CHECK(out[0].points[0].depth == Approx(-0.01).margin(kTol));
    }
    check_swap_symmetry(ball, at(Vec3(Real(1.2), Real(0.5), Real(1.1))), box, at(Vec3::Zero(), rot(10, Vec3::UnitY())));
}

TEST_CASE("capsule-capsule: crossing gives one point, lying along gives two", "[narrowphase]") {
    Shape cap = make_capsule(1, Real(0.5));
    const Quat along_x = rot(90, Vec3::UnitZ());
    const Quat along_z = rot(90, Vec3::UnitX());
    SECTION("crossing") {
        ManifoldList out = run(cap, at(Vec3::Zero(), along_x), cap, at(Vec3(0, Real(0.9), 0), along_z));
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 1);
        CHECK(near(out[0].normal, Vec3::UnitY()));
        CHECK(out[0].points[0].depth == Approx(0.1).margin(kTol));
        CHECK(near(out[0].points[0].position, Vec3(0, Real(0.45), 0)));
    }
    SECTION("parallel, offset along the axis: two points at the overlap ends") {
        ManifoldList out = run(cap, at(Vec3::Zero(), along_x), cap, at(Vec3(Real(0.5), Real(0.9), 0), along_x));
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 2);
        CHECK(near(out[0].normal, Vec3::UnitY()));
        std::vector<Real> xs;
        for (int i = 0; i < 2; ++i) {
            CHECK(out[0].points[i].depth == Approx(0.1).margin(kTol));
            CHECK(out[0].points[i].position.y() == Approx(0.45).margin(kTol));
            xs.push_back(out[0].points[i].position.x());
        }
        std::sort(xs.begin(), xs.end());
        CHECK(xs[0] == Approx(-0.5).margin(kTol));
        CHECK(xs[1] == Approx(1.0).margin(kTol));
        check_swap_symmetry(cap, at(Vec3::Zero(), along_x), cap, at(Vec3(Real(0.5), Real(0.9), 0), along_x));
    }
    SECTION("slightly tilted: still two points, the lifted one shallower") {
        ManifoldList out =
            run(cap, at(Vec3::Zero(), along_x), cap, at(Vec3(0, Real(0.95), 0), rot(1, Vec3::UnitZ()) * along_x), Real(0.1));
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 2);
        std::vector<Real> d = sorted_depths(out[0]);
        // Ends at x = -+1 are lifted/lowered by sin(1 deg) = 0.01745 m around the 0.05 m centre depth.
        CHECK(d[0] == Approx(0.05 - 0.017452).margin(2e-4));
        CHECK(d[1] == Approx(0.05 + 0.017452).margin(2e-4));
    }
    SECTION("end to end on one axis") {
        ManifoldList out = run(cap, at(Vec3::Zero()), cap, at(Vec3(0, Real(2.9), 0)));
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 1);
        CHECK(near(out[0].normal, Vec3::UnitY()));
        CHECK(out[0].points[0].depth == Approx(0.1).margin(kTol));
    }
    SECTION("beyond the margin") {
        CHECK(run(cap, at(Vec3::Zero(), along_x), cap, at(Vec3(0, Real(1.05), 0), along_z), Real(0.02)).empty());
    }
}

TEST_CASE("capsule-box: lying on a face gives two points", "[narrowphase]") {
    Shape box = make_box(Vec3(2, Real(0.5), 2));
    const Quat along_x = rot(90, Vec3::UnitZ());
    const Real r = Real(0.25);
    SECTION("lying inside the face") {
        Shape cap = make_capsule(1, r);
        ManifoldList out = run(cap, at(Vec3(0, Real(0.5) + r - kD, Real(0.3)), along_x), box, at(Vec3::Zero()));
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 2);
        CHECK(near(out[0].normal, -Vec3::UnitY()));
        std::vector<Real> xs;
        for (int i = 0; i < 2; ++i) {
            CHECK(out[0].points[i].depth == Approx(kD).margin(kTol));
            CHECK(out[0].points[i].position.y() == Approx(0.5 - kD / 2).margin(kTol));
            xs.push_back(out[0].points[i].position.x());
        }
        std::sort(xs.begin(), xs.end());
        CHECK(xs[0] == Approx(-1).margin(kTol));
        CHECK(xs[1] == Approx(1).margin(kTol));
        CHECK(out[0].points[0].feature_id != out[0].points[1].feature_id);
        check_swap_symmetry(cap, at(Vec3(0, Real(0.5) + r - kD, Real(0.3)), along_x), box, at(Vec3::Zero()));
    }
    SECTION("longer than the box: clipped at the face edges") {
        Shape cap = make_capsule(3, r);
        ManifoldList out = run(cap, at(Vec3(Real(0.5), Real(0.5) + r - kD, 0), along_x), box, at(Vec3::Zero()));
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 2);
        std::vector<Real> xs = {out[0].points[0].position.x(), out[0].points[1].position.x()};
        std::sort(xs.begin(), xs.end());
        CHECK(xs[0] == Approx(-2).margin(kTol));
        CHECK(xs[1] == Approx(2).margin(kTol));
    }
    SECTION("standing upright: one point") {
        Shape cap = make_capsule(1, r);
        ManifoldList out = run(cap, at(Vec3(Real(0.3), Real(0.5) + 1 + r - kD, 0)), box, at(Vec3::Zero()));
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 1);
        CHECK(near(out[0].normal, -Vec3::UnitY()));
        CHECK(out[0].points[0].depth == Approx(kD).margin(kTol));
    }
    SECTION("over an edge, parallel to it: normal from the edge") {
        Shape cap = make_capsule(1, r);
        Shape small = make_box(Vec3(Real(0.5), Real(0.5), Real(0.5)));
        // Capsule along z, beside and above the box edge at x = y = 0.5.
        const Real off = Real(0.15);
        ManifoldList out =
            run(cap, at(Vec3(Real(0.5) + off, Real(0.5) + off, 0), rot(90, Vec3::UnitX())), small, at(Vec3::Zero()));
        REQUIRE(out.size() == 1);
        CHECK(near(out[0].normal, -Vec3(1, 1, 0).normalized()));
        CHECK(out[0].points[0].depth == Approx(r - off * kSqrt2).margin(kTol));
    }
    SECTION("segment sunk into the box: face normal, depth through the face") {
        Shape cap = make_capsule(1, r);
        ManifoldList out = run(cap, at(Vec3(0, Real(0.4), 0), along_x), box, at(Vec3::Zero()));
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 2);
        CHECK(near(out[0].normal, -Vec3::UnitY()));
        CHECK(out[0].points[0].depth == Approx(0.1 + r).margin(kTol));
    }
    SECTION("margin") {
        Shape cap = make_capsule(1, r);
        ManifoldList out = run(cap, at(Vec3(0, Real(0.5) + r + Real(0.01), 0), along_x), box, at(Vec3::Zero()), Real(0.02));
        REQUIRE(out.size() == 1);
        CHECK(out[0].count == 2);
        CHECK(out[0].points[0].depth == Approx(-0.01).margin(kTol));
        CHECK(run(cap, at(Vec3(0, Real(0.5) + r + Real(0.03), 0), along_x), box, at(Vec3::Zero()), Real(0.02)).empty());
    }
}

TEST_CASE("box-box: box resting flat on a ground box gives four exact points", "[narrowphase][box]") {
    ManifoldList out = run(kUnit, at(Vec3(Real(0.7), 1 - kD, Real(-1.2))), kGround, at(Vec3::Zero()));
    REQUIRE(out.size() == 1);
    const Manifold& m = out[0];
    REQUIRE(m.count == 4);
    CHECK(near(m.normal, -Vec3::UnitY()));
    std::set<std::pair<int, int>> corners;
    for (int i = 0; i < 4; ++i) {
        CHECK(std::abs(m.points[i].depth - kD) <= kRestTol);
        const Vec3& p = m.points[i].position;
        CHECK(p.y() == Approx(0.5 - kD / 2).margin(kRestTol));  // midway between y = 0.5 - d and y = 0.5
        CHECK(std::abs(std::abs(p.x() - Real(0.7)) - Real(0.5)) < kTol);
        CHECK(std::abs(std::abs(p.z() + Real(1.2)) - Real(0.5)) < kTol);
        corners.insert({p.x() > Real(0.7) ? 1 : 0, p.z() > Real(-1.2) ? 1 : 0});
    }
    CHECK(corners.size() == 4);
    CHECK(ids(m).size() == 4);
    check_swap_symmetry(kUnit, at(Vec3(Real(0.7), 1 - kD, Real(-1.2))), kGround, at(Vec3::Zero()));

    // A wide, far-off ground (50 m): the depth is still exact to 1e-5 in float because the work is done
    // in the reference box's frame, where the numbers stay small.
    Shape wide = make_box(Vec3(50, Real(0.5), 50));
    out = run(kUnit, at(Vec3(Real(20.3), 1 - kD, Real(-7.9))), wide, at(Vec3::Zero()));
    REQUIRE(out.size() == 1);
    REQUIRE(out[0].count == 4);
    for (int i = 0; i < 4; ++i) CHECK(std::abs(out[0].points[i].depth - kD) <= kRestTol);
}

TEST_CASE("box-box: on a bigger box turned 45 degrees the octagon is reduced to 4", "[narrowphase][box]") {
    // Squares of half size 0.5 (axis-aligned) and 0.6 (turned 45 deg) overlap in an octagon: the small
    // square's corners (at 0.707 along the diagonals) stick out past the big one's faces (at 0.6).
    Shape big = make_box(Vec3(Real(0.6), Real(0.5), Real(0.6)));
    const Transform xb = at(Vec3::Zero(), rot(45, Vec3::UnitY()));
    const Transform xa = at(Vec3(0, 1 - kD, 0));
    ManifoldList out = run(kUnit, xa, big, xb);
    REQUIRE(out.size() == 1);
    const Manifold& m = out[0];
    REQUIRE(m.count == 4);
    CHECK(near(m.normal, -Vec3::UnitY()));
    for (int i = 0; i < 4; ++i) {
        CHECK(std::abs(m.points[i].depth - kD) <= kRestTol);
        // Every kept point lies in both squares (on the octagon).
        Vec3 p = m.points[i].position;
        CHECK(std::abs(p.x()) <= Real(0.5) + kTol);
        CHECK(std::abs(p.z()) <= Real(0.5) + kTol);
        Vec3 q = xb.apply_inverse(p);
        CHECK(std::abs(q.x()) <= Real(0.6) + kTol);
        CHECK(std::abs(q.z()) <= Real(0.6) + kTol);
    }
    // The four kept points span a large part of the octagon, not a sliver: area of the quad they form.
    std::vector<Vec3> p;
    for (int i = 0; i < 4; ++i) p.push_back(m.points[i].position);
    Vec3 c = (p[0] + p[1] + p[2] + p[3]) / 4;
    std::sort(p.begin(), p.end(), [&](const Vec3& u, const Vec3& v) {
        return std::atan2(u.z() - c.z(), u.x() - c.x()) < std::atan2(v.z() - c.z(), v.x() - c.x());
    });
    Real area = 0;
    for (int i = 0; i < 4; ++i) area += (p[i].x() * p[(i + 1) % 4].z() - p[(i + 1) % 4].x() * p[i].z()) / 2;
    // Octagon area = 1 - 4 corner triangles of leg (0.5*sqrt2 - 0.6)*sqrt2 = 0.1515: 1 - 2*0.1515^2 = 0.954.
    // A quadrilateral through alternate octagon vertices keeps well over half of it.
    CHECK(std::abs(area) > Real(0.6));
    check_swap_symmetry(kUnit, xa, big, xb);
}

TEST_CASE("box-box: crossing edges give one point", "[narrowphase][box]") {
    // A turned 45 deg about z rests on its lowest edge (along z) across B's top edge (along x).
    const Transform xa = at(Vec3(0, kSqrt2 - kD, 0), rot(45, Vec3::UnitZ()));
    const Transform xb = at(Vec3::Zero(), rot(45, Vec3::UnitX()));
    ManifoldList out = run(kUnit, xa, kUnit, xb);
    REQUIRE(out.size() == 1);
    REQUIRE(out[0].count == 1);
    CHECK(near(out[0].normal, -Vec3::UnitY()));
    CHECK(out[0].points[0].depth == Approx(kD).margin(kTol));
    CHECK(near(out[0].points[0].position, Vec3(0, kSqrt2 / 2 - kD / 2, 0)));
    check_swap_symmetry(kUnit, xa, kUnit, xb);
    // Slightly moved, the same edges touch: same id.
    ManifoldList moved = run(kUnit, at(xa.p + Vec3(Real(1e-3), 0, Real(-1e-3)), xa.q), kUnit, xb);
    REQUIRE(moved.size() == 1);
    CHECK(moved[0].points[0].feature_id == out[0].points[0].feature_id);
}

TEST_CASE("box-box: a box on its edge on the ground gives two points", "[narrowphase][box]") {
    const Transform xa = at(Vec3(0, Real(0.5) + kSqrt2 / 2 - kD, 0), rot(45, Vec3::UnitZ()));
    ManifoldList out = run(kUnit, xa, kGround, at(Vec3::Zero()));
    REQUIRE(out.size() == 1);
    REQUIRE(out[0].count == 2);
    CHECK(near(out[0].normal, -Vec3::UnitY()));
    for (int i = 0; i < 2; ++i) {
        CHECK(out[0].points[i].depth == Approx(kD).margin(kTol));
        CHECK(std::abs(out[0].points[i].position.x()) < kTol);
        CHECK(std::abs(std::abs(out[0].points[i].position.z()) - Real(0.5)) < kTol);
    }
}

TEST_CASE("box-box: feature ids survive small motion of a resting box", "[narrowphase][box]") {
    // Stacked unit boxes (the pyramid case) and a box on the ground: translate by 1 mm, turn by 0.5 deg
    // about the vertical and about a horizontal axis. The margin (5 cm) keeps all four corners of the
    // tilted box (its high side rises 0.5 * sin 0.5 deg = 4.4 mm).
    const Real margin = Real(0.05);
    const Real deg = Real(0.5);
    const Shape* grounds[2] = {&kUnit, &kGround};
    for (const Shape* ground : grounds) {
        // Offset in x and z so no corner of one box sits exactly over an edge of the other (where the
        // point's naming, not its position, legitimately depends on which side of the edge it is).
        const Transform rest = at(Vec3(Real(0.1), 1 - kD, Real(0.15)));
        ManifoldList base = run(kUnit, rest, *ground, at(Vec3::Zero()), margin);
        REQUIRE(base.size() == 1);
        REQUIRE(base[0].count == 4);
        const std::set<std::uint32_t> base_ids = ids(base[0]);
        REQUIRE(base_ids.size() == 4);
        const Transform moves[] = {
            at(rest.p + Vec3(Real(1e-3), Real(-1e-3), Real(1e-3))),
            at(rest.p, rot(deg, Vec3::UnitY())),
            at(rest.p, rot(deg, Vec3::UnitX())),
            at(rest.p + Vec3(Real(-1e-3), 0, Real(1e-3)), rot(deg, Vec3(1, 0, 1))),
        };
        for (const Transform& xf : moves) {
            ManifoldList moved = run(kUnit, xf, *ground, at(Vec3::Zero()), margin);
            REQUIRE(moved.size() == 1);
            CHECK(moved[0].count == 4);
            CHECK(ids(moved[0]) == base_ids);
        }
        // Same ids when the resting box is B: the ids name features, not which box was the reference.
        ManifoldList swapped = run(*ground, at(Vec3::Zero()), kUnit, at(rest.p, rot(deg, Vec3::UnitX())), margin);
        REQUIRE(swapped.size() == 1);
        CHECK(swapped[0].count == 4);
        CHECK(ids(swapped[0]).size() == 4);
    }
}

TEST_CASE("box-box: margin reports speculative points, none beyond", "[narrowphase][box]") {
    ManifoldList out = run(kUnit, at(Vec3(0, Real(1.005), 0)), kGround, at(Vec3::Zero()), Real(0.01));
    REQUIRE(out.size() == 1);
    REQUIRE(out[0].count == 4);
    for (int i = 0; i < 4; ++i) CHECK(out[0].points[i].depth == Approx(-0.005).margin(kTol));
    CHECK(run(kUnit, at(Vec3(0, Real(1.02), 0)), kGround, at(Vec3::Zero()), Real(0.01)).empty());
    // Far apart sideways: nothing.
    CHECK(run(kUnit, at(Vec3(3, 0, 0)), kUnit, at(Vec3::Zero()), Real(0.01)).empty());
}

TEST_CASE("box-box: random overlapping pairs give sane manifolds", "[narrowphase][box]") {
    // Not an analytic answer: a guard that arbitrary orientations never produce more than 4 points, a
    // non-unit normal, a normal facing from B to A, or a point far from either box.
    std::uint32_t seed = 12345;
    auto rnd = [&]() {
        seed = seed * 1664525u + 1013904223u;
        return Real(seed >> 8) / Real(1 << 24);
    };
    Shape a = make_box(Vec3(Real(0.5), Real(0.3), Real(0.7)));
    Shape b = make_box(Vec3(Real(0.4), Real(0.6), Real(0.2)));
    int hits = 0;
    for (int trial = 0; trial < 300; ++trial) {
        Transform xa = at(Vec3::Zero(), rot(360 * rnd(), Vec3(rnd() - Real(0.5), rnd() - Real(0.5), rnd() - Real(0.5)) + Vec3(0, 0, Real(1e-3))));
        Transform xb = at(Vec3(rnd() - Real(0.5), rnd() - Real(0.5), rnd() - Real(0.5)) * Real(2.4),
                          rot(360 * rnd(), Vec3(rnd() - Real(0.5), rnd() + Real(0.1), rnd() - Real(0.5))));
        ManifoldList ab = run(a, xa, b, xb);
        if (ab.empty()) continue;
        ++hits;
        REQUIRE(ab.size() == 1);
        // The normal points from A to B (the centres are on either side of the contact plane or, for deep
        // overlaps, at least not behind each other along it).
        CHECK(ab[0].normal.dot(xb.p - xa.p) >= -Real(1e-3));
        for (int i = 0; i < ab[0].count; ++i) {
            // Each point is near both boxes (within depth/margin of their surfaces).
            Vec3 pa = xa.apply_inverse(ab[0].points[i].position).cwiseAbs() - a.half_extents;
            Vec3 pb = xb.apply_inverse(ab[0].points[i].position).cwiseAbs() - b.half_extents;
            CHECK(pa.maxCoeff() < Real(0.05) + std::abs(ab[0].points[i].depth));
            CHECK(pb.maxCoeff() < Real(0.05) + std::abs(ab[0].points[i].depth));
        }
    }
    CHECK(hits > 50);
}

TEST_CASE("convex-plane: sphere, capsule, box and hull", "[narrowphase][plane]") {
    // Plane y = 0 given as offset 1 in a frame moved down by 1: tests that the plane's transform is used.
    Shape plane = make_plane(Vec3::UnitY(), 1);
    const Transform xp = at(Vec3(0, -1, 0));
    SECTION("sphere") {
        ManifoldList out = run(make_sphere(1), at(Vec3(Real(0.3), Real(0.9), 0)), plane, xp);
        REQUIRE(out.size() == 1);
        CHECK(near(out[0].normal, -Vec3::UnitY()));
        CHECK(out[0].points[0].depth == Approx(0.1).margin(kTol));
        CHECK(near(out[0].points[0].position, Vec3(Real(0.3), Real(-0.05), 0)));
        // Plane as A: flipped normal, same point.
        ManifoldList ba = run(plane, xp, make_sphere(1), at(Vec3(Real(0.3), Real(0.9), 0)));
        REQUIRE(ba.size() == 1);
        CHECK(near(ba[0].normal, Vec3::UnitY()));
        CHECK(near(ba[0].points[0].position, out[0].points[0].position));
    }
    SECTION("capsule lying and standing") {
        Shape cap = make_capsule(1, Real(0.25));
        ManifoldList out = run(cap, at(Vec3(0, Real(0.25) - kD, 0), rot(90, Vec3::UnitZ())), plane, xp);
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 2);
        for (int i = 0; i < 2; ++i) CHECK(out[0].points[i].depth == Approx(kD).margin(kTol));
        out = run(cap, at(Vec3(0, Real(1.25) - kD, 0)), plane, xp);
        REQUIRE(out.size() == 1);
        CHECK(out[0].count == 1);
    }
    SECTION("box flat: the four bottom corners, ids = vertex index") {
        ManifoldList out = run(kUnit, at(Vec3(2, Real(0.5) - kD, 1)), plane, xp);
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 4);
        std::set<std::uint32_t> expect;
        for (std::uint32_t v : {0u, 1u, 4u, 5u}) expect.insert(make_feature_id(8, v, 0));  // y bit clear
        CHECK(ids(out[0]) == expect);
        for (int i = 0; i < 4; ++i) {
            CHECK(out[0].points[i].depth == Approx(kD).margin(kRestTol));
            CHECK(out[0].points[i].position.y() == Approx(-kD / 2).margin(kRestTol));
        }
        // Sunk deep and tilted: more than four corners below, the four deepest are kept.
        out = run(kUnit, at(Vec3(0, Real(0.2), 0), rot(10, Vec3::UnitX())), plane, xp);
        REQUIRE(out.size() == 1);
        CHECK(out[0].count == 4);
    }
    SECTION("hull: an octagonal prism lying on a face is reduced to four spread points") {
        auto hull = std::make_shared<ConvexHullData>();
        for (int i = 0; i < 8; ++i) {
            Real ang = 2 * kPi * Real(i) / 8;
            hull->vertices.push_back(Vec3(std::cos(ang), Real(-0.5), std::sin(ang)));
            hull->vertices.push_back(Vec3(std::cos(ang), Real(0.5), std::sin(ang)));
        }
        Shape prism;
        prism.type = ShapeType::ConvexHull;
        prism.hull = hull;
        ManifoldList out = run(prism, at(Vec3(0, Real(0.5) - kD, 0)), plane, xp);
        REQUIRE(out.size() == 1);
        REQUIRE(out[0].count == 4);
        CHECK(ids(out[0]).size() == 4);
        Vec3 centroid = Vec3::Zero();
        for (int i = 0; i < 4; ++i) {
            CHECK(out[0].points[i].depth == Approx(kD).margin(kTol));
            centroid += out[0].points[i].position / 4;
        }
        // Spread: four octagon vertices around the centre, not bunched on one side.
        CHECK(std::abs(centroid.x()) < Real(0.3));
        CHECK(std::abs(centroid.z()) < Real(0.3));
    }
    SECTION("margin") {
        ManifoldList out = run(kUnit, at(Vec3(0, Real(0.51), 0)), plane, xp, Real(0.02));
        REQUIRE(out.size() == 1);
        CHECK(out[0].points[0].depth == Approx(-0.01).margin(kTol));
        CHECK(run(kUnit, at(Vec3(0, Real(0.53), 0)), plane, xp, Real(0.02)).empty());
    }
}

TEST_CASE("dispatch: compounds recurse with stable, distinct sub keys", "[narrowphase][dispatch]") {
    Shape ball = make_sphere(Real(0.5));
    Transform left = at(Vec3(-1, 0, 0)), right = at(Vec3(1, 0, 0));
    Shape dumbbell = make_compound({{left, ball}, {right, ball}});
    Shape plane = make_plane(Vec3::UnitY(), 0);
    const Transform xd = at(Vec3(0, Real(0.45), 0));

    ManifoldList out = run(dumbbell, xd, plane, at(Vec3::Zero()));
    REQUIRE(out.size() == 2);
    CHECK(out[0].sub_key != out[1].sub_key);
    for (const Manifold& m : out) {
        CHECK(near(m.normal, -Vec3::UnitY()));
        CHECK(m.points[0].depth == Approx(0.05).margin(kTol));
    }
    // Swapped: flipped normals, same keys.
    ManifoldList ba = run(plane, at(Vec3::Zero()), dumbbell, xd);
    REQUIRE(ba.size() == 2);
    for (const Manifold& m : ba) CHECK(near(m.normal, Vec3::UnitY()));
    CHECK(std::set<std::uint32_t>{ba[0].sub_key, ba[1].sub_key} == std::set<std::uint32_t>{out[0].sub_key, out[1].sub_key});

    // The child transform composes with the body's: rotate the dumbbell 90 deg about z so it stands on
    // one ball; only that child touches.
    out = run(dumbbell, at(Vec3(0, Real(1.45), 0), rot(90, Vec3::UnitZ())), plane, at(Vec3::Zero()));
    REQUIRE(out.size() == 1);
    CHECK(out[0].points[0].position.y() == Approx(-0.025).margin(kTol));

    // Compound against compound: four child pairs, four distinct keys, the same on the next call.
    Shape four = make_compound({{at(Vec3(-1, 0, 0)), kUnit}, {at(Vec3(1, 0, 0)), kUnit}});
    ManifoldList cc = run(dumbbell, at(Vec3(0, Real(0.95), 0)), four, at(Vec3::Zero()));
    REQUIRE(cc.size() == 2);  // each ball above its own box only
    std::set<std::uint32_t> keys;
    for (const Manifold& m : cc) keys.insert(m.sub_key);
    CHECK(keys.size() == 2);
    Shape wide = make_compound({{at(Vec3::Zero()), make_box(Vec3(2, Real(0.5), Real(0.5)))}, {at(Vec3(0, 0, 3)), kUnit}});
    cc = run(dumbbell, at(Vec3(0, Real(0.95), 0)), wide, at(Vec3::Zero()));
    REQUIRE(cc.size() == 2);
    CHECK(cc[0].sub_key != cc[1].sub_key);
    ManifoldList again = run(dumbbell, at(Vec3(Real(1e-3), Real(0.95), 0)), wide, at(Vec3::Zero()));
    REQUIRE(again.size() == 2);
    CHECK(again[0].sub_key == cc[0].sub_key);
    CHECK(again[1].sub_key == cc[1].sub_key);
}

TEST_CASE("dispatch: type table, static pairs, meshes, bad input", "[narrowphase][dispatch]") {
    const ShapeType all[] = {ShapeType::Sphere, ShapeType::Box, ShapeType::Capsule, ShapeType::ConvexHull,
                             ShapeType::Plane, ShapeType::TriangleMesh, ShapeType::Compound};
    for (ShapeType x : all)
        for (ShapeType y : all) {
            const bool is_static_x = x == ShapeType::Plane || x == ShapeType::TriangleMesh;
            const bool is_static_y = y == ShapeType::Plane || y == ShapeType::TriangleMesh;
            CHECK(can_collide(x, y) == !(is_static_x && is_static_y));
            CHECK(can_collide(x, y) == can_collide(y, x));
        }
    Shape plane = make_plane(Vec3::UnitY(), 0);
    CHECK(run(plane, at(Vec3::Zero()), plane, at(Vec3::Zero())).empty());

    // A two-triangle quad mesh (built by hand: one BVH leaf). Whatever convex_triangle reports, every
    // manifold is keyed by its own triangle and points from the sphere down into the mesh.
    auto mesh = std::make_shared<TriangleMeshData>();
    mesh->vertices = {Vec3(-2, 0, -2), Vec3(2, 0, -2), Vec3(2, 0, 2), Vec3(-2, 0, 2)};
    mesh->indices = {0, 2, 1, 0, 3, 2};
    TriangleMeshData::Node leaf;
    leaf.box.grow(Vec3(-2, 0, -2));
    leaf.box.grow(Vec3(2, 0, 2));
    leaf.first = 0;
    leaf.count = 2;
    mesh->nodes = {leaf};
    mesh->tri_order = {0, 1};
    Shape ground;
    ground.type = ShapeType::TriangleMesh;
    ground.mesh = mesh;
    Shape ball = make_sphere(Real(0.5));
    ManifoldList out = run(ball, at(Vec3(0, Real(0.45), 0)), ground, at(Vec3::Zero()));
    std::set<std::uint32_t> keys;
    for (const Manifold& m : out) {
        keys.insert(m.sub_key);
        CHECK(m.sub_key < 2);
        CHECK(m.normal.y() < 0);
    }
    CHECK(keys.size() == out.size());
    ManifoldList flipped = run(ground, at(Vec3::Zero()), ball, at(Vec3(0, Real(0.45), 0)));
    CHECK(flipped.size() == out.size());
    for (const Manifold& m : flipped) CHECK(m.normal.y() > 0);
    // Far away: the BVH query finds nothing.
    CHECK(run(ball, at(Vec3(10, 5, 0)), ground, at(Vec3::Zero())).empty());

    ManifoldList sink;
    Transform bad = at(Vec3(0, std::numeric_limits<Real>::quiet_NaN(), 0));
    CHECK_THROWS_AS(collide(ball, bad, plane, at(Vec3::Zero()), Real(0.01), sink), ShapeError);
    CHECK_THROWS_AS(collide(ball, at(Vec3::Zero()), plane, at(Vec3::Zero()), Real(-1), sink), ShapeError);
    CHECK(sink.empty());
}
