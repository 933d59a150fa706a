// Ray casts and overlap queries (engine/core/ray_cast.hpp, rigid/rigid_queries.cpp): each shape against
// closed forms, a box against a hull of the same box (two independent routines), rays from inside, and
// the world queries against brute force over every body.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>

#include "engine/core/narrowphase.hpp"
#include "engine/core/shape_cast.hpp"
#include "engine/world/world.hpp"

using namespace sinew;

namespace {
const Real kTol = Real(2e-5);  // float rounding over segments of a few metres
}

TEST_CASE("ray casts against each shape match closed forms", "[query]") {
    const Transform xf{Vec3(1, 2, 3), Quat(Eigen::AngleAxis<Real>(Real(0.6), Vec3(0.3, 1, 0.2).normalized()))};
    RayHit hit;
    SECTION("sphere: along a line through the centre, the hit is r before the centre") {
        const Shape s = make_sphere(Real(0.5));
        const Vec3 from = xf.p + Vec3(-4, 0, 0), to = xf.p + Vec3(4, 0, 0);
        REQUIRE(ray_cast(s, xf, from, to, 1, hit));
        CHECK(hit.fraction == Approx((4 - 0.5) / 8).margin(kTol));
        CHECK((hit.normal - Vec3(-1, 0, 0)).norm() < kTol);
        CHECK_FALSE(ray_cast(s, xf, xf.p, to, 1, hit));  // from inside: no hit
        CHECK_FALSE(ray_cast(s, xf, from, to, Real(0.4), hit));  // beyond max_fraction
        CHECK_FALSE(ray_cast(s, xf, from + Vec3(0, 1, 0), to + Vec3(0, 1, 0), 1, hit));  // passes above
    }
    SECTION("box and a hull of the same box agree on random rays") {
        const Vec3 he(Real(0.4), Real(0.7), Real(1.0));
        std::vector<Vec3> corners;
        for (int i = 0; i < 8; ++i)
            corners.emplace_back(i & 1 ? he.x() : -he.x(), i & 2 ? he.y() : -he.y(), i & 4 ? he.z() : -he.z());
        const Shape box = make_box(he), hull = make_convex_hull(corners);
        std::mt19937 rng(3);
        std::uniform_real_distribution<Real> u(-3, 3);
        int hits = 0;
        for (int k = 0; k < 500; ++k) {
            const Vec3 from = xf.apply(Vec3(u(rng), u(rng), u(rng))), to = xf.apply(Vec3(u(rng), u(rng), u(rng)));
            RayHit a, b;
            const bool ha = ray_cast(box, xf, from, to, 1, a), hb = ray_cast(hull, xf, from, to, 1, b);
            REQUIRE(ha == hb);
            if (!ha) continue;
            ++hits;
            CHECK(a.fraction == Approx(b.fraction).margin(kTol));
            CHECK((a.normal - b.normal).norm() < 1e-4);
            // The hit point is on the box surface: its largest normalised coordinate is 1.
            const Vec3 q = xf.apply_inverse(a.point).cwiseAbs().cwiseQuotient(he);
            CHECK(q.maxCoeff() == Approx(1).margin(1e-4));
        }
        CHECK(hits > 50);
    }
    SECTION("capsule: side and cap") {
        const Shape s = make_capsule(Real(0.6), Real(0.25));
        REQUIRE(ray_cast(s, {}, Vec3(-2, Real(0.3), 0), Vec3(2, Real(0.3), 0), 1, hit));
        CHECK(hit.point.x() == Approx(-0.25).margin(kTol));
        REQUIRE(ray_cast(s, {}, Vec3(0, 3, 0), Vec3(0, -3, 0), 1, hit));
        CHECK(hit.point.y() == Approx(0.85).margin(kTol));
        CHECK((hit.normal - Vec3::UnitY()).norm() < kTol);
    }
    SECTION("plane: from above only") {
        const Shape s = make_plane(Vec3::UnitY(), Real(0.5));
        REQUIRE(ray_cast(s, {}, Vec3(0, 2, 0), Vec3(3, -1, 0), 1, hit));
        CHECK(hit.fraction == Approx(0.5).margin(kTol));
        CHECK_FALSE(ray_cast(s, {}, Vec3(0, 0, 0), Vec3(0, 3, 0), 1, hit));
    }
    SECTION("triangle mesh: both sides, normal against the ray") {
        const Shape s = make_triangle_mesh({{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}}, {0, 2, 1, 0, 3, 2});
        REQUIRE(ray_cast(s, {}, Vec3(Real(0.2), 1, Real(0.3)), Vec3(Real(0.2), -1, Real(0.3)), 1, hit));
        CHECK(hit.fraction == Approx(0.5).margin(kTol));
        CHECK((hit.normal - Vec3::UnitY()).norm() < kTol);
        REQUIRE(ray_cast(s, {}, Vec3(Real(0.2), -1, Real(0.3)), Vec3(Real(0.2), 3, Real(0.3)), 1, hit));
        CHECK(hit.fraction == Approx(0.25).margin(kTol));
        CHECK((hit.normal + Vec3::UnitY()).norm() < kTol);
    }
    SECTION("compound: the nearer child") {
        const Shape s = make_compound({{Transform{Vec3(2, 0, 0), Quat::Identity()}, make_sphere(Real(0.5))},
                                       {Transform{Vec3(-2, 0, 0), Quat::Identity()}, make_box(Vec3::Constant(Real(0.5)))}});
        REQUIRE(ray_cast(s, {}, Vec3(-5, 0, 0), Vec3(5, 0, 0), 1, hit));
        CHECK(hit.point.x() == Approx(-2.5).margin(kTol));
        REQUIRE(ray_cast(s, {}, Vec3(5, 0, 0), Vec3(-5, 0, 0), 1, hit));
        CHECK(hit.point.x() == Approx(2.5).margin(kTol));
    }
}

TEST_CASE("world ray casts and overlaps equal brute force over every body", "[query]") {
    RigidSystem rigid;
    std::mt19937 rng(11);
    std::uniform_real_distribution<Real> u(-10, 10), size(Real(0.2), Real(1.0));
    const Shape shapes[] = {make_sphere(Real(0.6)), make_box(Vec3(Real(0.5), Real(0.3), Real(0.8))),
                            make_capsule(Real(0.4), Real(0.3))};
    std::vector<BodyId> ids;
    for (int k = 0; k < 300; ++k) {
        BodyDef d;
        d.type = k % 3 == 0 ? BodyType::Static : BodyType::Dynamic;
        d.shape = shapes[k % 3];
        d.pose.p = Vec3(u(rng), u(rng), u(rng));
        d.pose.q = Quat(Eigen::AngleAxis<Real>(u(rng), Vec3(u(rng), u(rng), u(rng)).normalized()));
        ids.push_back(rigid.create_body(d));
    }
    // Remove a few so the tree has holes and stale slots.
    for (int k = 0; k < 300; k += 17) rigid.destroy_body(ids[k]);

    int hits = 0;
    for (int r = 0; r < 300; ++r) {
        const Vec3 from(u(rng), u(rng), u(rng)), to(u(rng), u(rng), u(rng));
        RigidSystem::RayResult got;
        const bool found = rigid.ray_cast(from, to, got);
        Real best = 2;
        for (BodyId id : rigid.bodies()) {
            RayHit h;
            if (ray_cast(rigid.shape(id), rigid.transform(id), from, to, 1, h)) best = std::min(best, h.fraction);
        }
        REQUIRE(found == (best <= 1));
        if (found) {
            ++hits;
            CHECK(got.hit.fraction == Approx(best).margin(1e-6));
            CHECK(rigid.valid(got.body));
        }
    }
    CHECK(hits > 30);

    for (int q = 0; q < 100; ++q) {
        Aabb box;
        box.grow(Vec3(u(rng), u(rng), u(rng)));
        box = box.fattened(size(rng) * 3);
        std::vector<BodyId> got, expected;
        rigid.overlap_aabb(box, got);
        for (BodyId id : rigid.bodies())
            if (rigid.shape(id).bounds(rigid.transform(id)).overlaps(box)) expected.push_back(id);
        REQUIRE(got.size() == expected.size());
        for (std::size_t k = 0; k < got.size(); ++k) CHECK(got[k] == expected[k]);
    }

    // A sphere query: bodies whose surface lies within its radius of the centre.
    const Shape probe = make_sphere(Real(1.5));
    for (int q = 0; q < 50; ++q) {
        const Transform at{Vec3(u(rng), u(rng), u(rng)), Quat::Identity()};
        std::vector<BodyId> got;
        rigid.overlap_shape(probe, at, got);
        for (BodyId id : rigid.bodies()) {
            // Closed form through the point-shape distance routines of the narrow phase: a body overlaps
            // iff a sphere of the probe's radius touches it; compare with a slightly smaller and larger
            // probe to stay clear of the boundary.
            ManifoldList m;
            const bool in = std::find(got.begin(), got.end(), id) != got.end();
            m.clear();
            const bool clearly_in = collide(make_sphere(Real(1.49)), at, rigid.shape(id), rigid.transform(id), 0, m) > 0 &&
                                    m[0].points[0].depth > 0;
            m.clear();
            const bool clearly_out = collide(make_sphere(Real(1.51)), at, rigid.shape(id), rigid.transform(id), 0, m) == 0;
            if (clearly_in) CHECK(in);
            if (clearly_out) CHECK_FALSE(in);
        }
    }
    std::vector<BodyId> unused;
    CHECK_THROWS_WITH(rigid.overlap_shape(make_plane(Vec3::UnitY(), 0), {}, unused),
                      Catch::Contains("must be convex or a compound"));
    RigidSystem::RayResult r;
    CHECK_THROWS_WITH(rigid.ray_cast(Vec3(std::nan(""), 0, 0), Vec3::Zero(), r), Catch::Contains("must be finite"));
}

// ---- shape casts and closest points (engine/core/shape_cast.hpp) -------------------------------------------

TEST_CASE("shape casts meet the analytic time of impact within 1e-4", "[query][cast]") {
    const Shape sphere = make_sphere(Real(0.5));
    const Shape box = make_box(Vec3(1, 1, 1));
    const Transform at_origin{Vec3::Zero(), Quat::Identity()};
    const Vec3 sweep(10, 0, 0);
    ShapeCastHit hit;
    SECTION("a sphere onto a box face") {
        REQUIRE(shape_cast(sphere, at_origin, sweep, box, {Vec3(5, 0.3, 0), Quat::Identity()}, 1, hit));
        CHECK(std::abs(hit.fraction - Real(0.35)) <= Real(1e-4));  // surface at x = 4, centre stops at 3.5
        CHECK((hit.normal - Vec3(-1, 0, 0)).norm() < Real(1e-4));
        CHECK(std::abs(hit.point.x() - 4) < Real(1e-3));
    }
    SECTION("a sphere onto a box edge (the box turned 45 degrees about y)") {
        const Quat q(Eigen::AngleAxis<Real>(Real(M_PI / 4), Vec3::UnitY()));
        REQUIRE(shape_cast(sphere, at_origin, sweep, box, {Vec3(5, 0, 0), q}, 1, hit));
        CHECK(std::abs(hit.fraction - Real((5 - std::sqrt(2.0) - 0.5) / 10)) <= Real(1e-4));
        CHECK((hit.normal - Vec3(-1, 0, 0)).norm() < Real(1e-3));
    }
    SECTION("a sphere onto a box corner, off the corner's line") {
        // Corner (4, 1, 1) of the box at (5, 2, 2); the centre moves along x at y = z = 0.9, so it
        // touches when (x - 4)^2 + 0.01 + 0.01 = 0.25: x = 4 - sqrt(0.23).
        REQUIRE(shape_cast(sphere, {Vec3(0, 0.9, 0.9), Quat::Identity()}, sweep, box, {Vec3(5, 2, 2), Quat::Identity()}, 1, hit));
        CHECK(std::abs(hit.fraction - Real((4 - std::sqrt(0.23)) / 10)) <= Real(1e-4));
    }
    SECTION("a box turned about z onto a box: its lower corner leads") {
        // A unit cube (half 0.5) turned 45 degrees about z reaches sqrt(0.5) along x.
        const Shape cube = make_box(Vec3(0.5, 0.5, 0.5));
        const Quat q(Eigen::AngleAxis<Real>(Real(M_PI / 4), Vec3::UnitZ()));
        REQUIRE(shape_cast(cube, {Vec3::Zero(), q}, sweep, box, {Vec3(5, 0, 0), Quat::Identity()}, 1, hit));
        CHECK(std::abs(hit.fraction - Real((4 - std::sqrt(0.5)) / 10)) <= Real(1e-4));
    }
    SECTION("a capsule dropped onto a plane lands on its lower cap") {
        const Shape capsule = make_capsule(Real(0.6), Real(0.3));
        REQUIRE(shape_cast(capsule, {Vec3(0, 5, 0), Quat::Identity()}, Vec3(0, -10, 0), make_plane(Vec3::UnitY(), 0), at_origin, 1, hit));
        CHECK(std::abs(hit.fraction - Real((5 - 0.9) / 10)) <= Real(1e-4));
        CHECK((hit.normal - Vec3::UnitY()).norm() < Real(1e-5));
    }
    SECTION("a sphere onto a triangle mesh and onto a compound's nearer child") {
        const Shape ground = make_triangle_mesh({Vec3(-5, 0, -5), Vec3(5, 0, -5), Vec3(5, 0, 5), Vec3(-5, 0, 5)}, {0, 2, 1, 0, 3, 2});
        REQUIRE(shape_cast(sphere, {Vec3(0.2, 3, 0.1), Quat::Identity()}, Vec3(0, -4, 0), ground, at_origin, 1, hit));
        CHECK(std::abs(hit.fraction - Real(2.5 / 4)) <= Real(1e-4));
        const Shape compound = make_compound({{{Vec3(0, 0, 0), Quat::Identity()}, box},
                                              {{Vec3(-3, 0, 0), Quat::Identity()}, make_sphere(1)}});
        REQUIRE(shape_cast(sphere, at_origin, sweep, compound, {Vec3(8, 0, 0), Quat::Identity()}, 1, hit));
        CHECK(std::abs(hit.fraction - Real((8 - 3 - 1 - 0.5) / 10.0)) <= Real(1e-4));  // the sphere child at x = 5
    }
    SECTION("misses, paths moving away, max_fraction and a start inside") {
        CHECK_FALSE(shape_cast(sphere, at_origin, sweep, box, {Vec3(5, 2, 0), Quat::Identity()}, 1, hit));  // passes over
        CHECK_FALSE(shape_cast(sphere, at_origin, -sweep, box, {Vec3(5, 0, 0), Quat::Identity()}, 1, hit));
        CHECK_FALSE(shape_cast(sphere, at_origin, sweep, box, {Vec3(5, 0, 0), Quat::Identity()}, Real(0.3), hit));
        REQUIRE(shape_cast(sphere, at_origin, sweep, box, {Vec3(1, 0, 0), Quat::Identity()}, 1, hit));
        CHECK(hit.fraction == 0);
        CHECK_THROWS_AS(shape_cast(make_plane(Vec3::UnitY(), 0), at_origin, sweep, box, at_origin, 1, hit), ShapeError);
    }
}

TEST_CASE("closest points of separated and overlapping shapes match closed forms", "[query][cast]") {
    ClosestPoints cp;
    const Shape box = make_box(Vec3(1, 1, 1));
    // Two boxes corner to corner: the distance is between the corners (an axis test would give 1).
    REQUIRE(closest_points(box, {Vec3::Zero(), Quat::Identity()}, box, {Vec3(3, 3, 3), Quat::Identity()}, 10, cp));
    CHECK(std::abs(cp.distance - Real(std::sqrt(3.0))) < Real(1e-4));
    CHECK((cp.point_a - Vec3(1, 1, 1)).norm() < Real(1e-3));
    CHECK((cp.point_b - Vec3(2, 2, 2)).norm() < Real(1e-3));
    CHECK((cp.normal - Vec3(1, 1, 1).normalized()).norm() < Real(1e-3));
    CHECK_FALSE(closest_points(box, {Vec3::Zero(), Quat::Identity()}, box, {Vec3(3, 3, 3), Quat::Identity()}, 1, cp));
    // A sphere sunk 0.2 m into a plane.
    REQUIRE(closest_points(make_sphere(Real(0.5)), {Vec3(0, 0.3, 0), Quat::Identity()}, make_plane(Vec3::UnitY(), 0),
                           {Vec3::Zero(), Quat::Identity()}, 1, cp));
    CHECK(std::abs(cp.distance + Real(0.2)) < Real(1e-5));
    CHECK((cp.point_a - Vec3(0, -0.2, 0)).norm() < Real(1e-5));
}

TEST_CASE("world shape casts, filtered and all-hit ray casts", "[query][cast]") {
    WorldSettings ws;
    World w(ws);
    RigidSystem& r = w.rigid();
    std::vector<BodyId> walls;
    for (int k = 0; k < 3; ++k) {
        BodyDef d;
        d.type = BodyType::Static;
        d.shape = make_box(Vec3(0.1, 2, 2));
        d.pose.p = Vec3(Real(3 + 2 * k), 0, 0);
        d.filter.category = 1u << k;
        walls.push_back(r.create_body(d));
    }
    RigidSystem::ShapeCastResult hit;
    REQUIRE(r.shape_cast(make_sphere(Real(0.5)), {Vec3::Zero(), Quat::Identity()}, Vec3(10, 0, 0), {}, hit));
    CHECK(hit.body == walls[0]);
    CHECK(std::abs(hit.hit.fraction - Real(0.24)) <= Real(1e-4));  // face at 2.9, centre at 2.4
    // A query filter whose mask leaves out the first wall's category finds the second.
    CollisionFilter skip_first;
    skip_first.mask = ~1u;
    REQUIRE(r.shape_cast(make_box(Vec3(0.5, 0.5, 0.5)), {Vec3::Zero(), Quat::Identity()}, Vec3(10, 0, 0), skip_first, hit));
    CHECK(hit.body == walls[1]);
    CHECK(std::abs(hit.hit.fraction - Real(0.44)) <= Real(1e-4));
    RigidSystem::RayResult ray;
    REQUIRE(r.ray_cast(Vec3(0, 0, 0), Vec3(10, 0, 0), skip_first, ray));
    CHECK(ray.body == walls[1]);
    std::vector<RigidSystem::RayResult> all;
    r.ray_cast_all(Vec3(10, 0, 0), Vec3(0, 0, 0), {}, all);
    REQUIRE(all.size() == 3);
    CHECK(all[0].body == walls[2]);  // by fraction along the ray
    CHECK(all[2].body == walls[0]);
    CHECK(std::abs(all[1].hit.fraction - Real(0.49)) < Real(1e-5));  // the middle wall's face at x = 5.1
    ClosestPoints cp;
    REQUIRE(r.closest_points(make_sphere(Real(0.5)), {Vec3::Zero(), Quat::Identity()}, walls[0], 5, cp));
    CHECK(std::abs(cp.distance - Real(2.4)) < Real(1e-4));
    CHECK_THROWS_AS(r.shape_cast(make_sphere(1), {Vec3::Zero(), Quat::Identity()}, Vec3(NAN, 0, 0), {}, hit), RigidError);
    CHECK_THROWS_AS(r.closest_points(make_sphere(1), {Vec3::Zero(), Quat::Identity()}, BodyId{}, 1, cp), RigidError);
}
