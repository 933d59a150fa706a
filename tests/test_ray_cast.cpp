// Ray casts and overlap queries (engine/core/ray_cast.hpp, rigid/rigid_queries.cpp): each shape against
// closed forms, a box against a hull of the same box (two independent routines), rays from inside, and
// the world queries against brute force over every body.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>

#include "engine/core/narrowphase.hpp"
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
