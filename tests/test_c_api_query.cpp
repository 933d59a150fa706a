// C API queries and run-time settings (engine/api/capi_query.cpp): ray casts and overlaps against closed
// forms, solver, gravity and material changes with their physical effect, and every bad input rejected
// with its status, a message and an unchanged world.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "tests/test_c_api_util.hpp"

using namespace capi_test;

namespace {

sinew_body_id add_box(sinew_world_id w, sinew_body_type type, sinew_vec3 p, float half = 0.5f) {
    sinew_body_def d = sinew_body_def_default();
    d.type = type;
    d.transform.p = p;
    d.shape.half_extents = {half, half, half};
    sinew_body_id id{};
    REQUIRE(sinew_body_create(w, &d, &id) == SINEW_OK);
    return id;
}

bool same(sinew_body_id a, sinew_body_id b) { return a.world == b.world && a.index == b.index && a.generation == b.generation; }

}  // namespace

TEST_CASE("C API ray casts and overlaps find the bodies closed forms predict", "[capi][query]") {
    const sinew_world_id w = make_world();
    const sinew_body_id ground = add_box(w, SINEW_BODY_STATIC, {0, -0.5f, 0});
    (void)ground;
    const sinew_body_id a = add_box(w, SINEW_BODY_DYNAMIC, {0, 2, 0});
    const sinew_body_id b = add_box(w, SINEW_BODY_DYNAMIC, {3, 0.5f, 0});

    // Straight down from y = 10 over box a: enters its top face at y = 2.5.
    sinew_ray_hit hit;
    int found = -1;
    REQUIRE(sinew_world_ray_cast(w, {0, 10, 0}, {0, -10, 0}, &hit, &found) == SINEW_OK);
    REQUIRE(found == 1);
    CHECK(same(hit.body, a));
    CHECK(hit.point.y == Approx(2.5f).margin(1e-5));
    CHECK(hit.fraction == Approx(7.5f / 20).margin(1e-6));
    CHECK(hit.normal.y == Approx(1).margin(1e-6));
    // Sideways at y = 0.5 from x = -10: the ground box's top is at 0, so the first body is b at x = 2.5.
    REQUIRE(sinew_world_ray_cast(w, {-10, 0.7f, 0}, {10, 0.7f, 0}, &hit, &found) == SINEW_OK);
    REQUIRE(found == 1);
    CHECK(same(hit.body, b));
    CHECK(hit.point.x == Approx(2.5f).margin(1e-5));
    CHECK(hit.normal.x == Approx(-1).margin(1e-6));
    // Above everything: no hit.
    REQUIRE(sinew_world_ray_cast(w, {-10, 5, 0}, {10, 5, 0}, &hit, &found) == SINEW_OK);
    CHECK(found == 0);

    // Overlap box around a and b, not the ground (its top face is y = 0, the box starts at y = 0.1).
    sinew_body_id ids[4];
    int count = -1;
    REQUIRE(sinew_world_overlap_aabb(w, {-1, 0.1f, -1}, {4, 3, 1}, ids, 4, &count) == SINEW_OK);
    REQUIRE(count == 2);
    CHECK(same(ids[0], a));
    CHECK(same(ids[1], b));
    // Capacity smaller than the result: the count tells how many there are.
    REQUIRE(sinew_world_overlap_aabb(w, {-1, 0.1f, -1}, {4, 3, 1}, ids, 1, &count) == SINEW_OK);
    CHECK(count == 2);
    REQUIRE(sinew_world_overlap_aabb(w, {-1, 0.1f, -1}, {4, 3, 1}, nullptr, 0, &count) == SINEW_OK);
    CHECK(count == 2);

    // A sphere of radius 0.6 centred 1 m right of a's centre: a's face is 0.5 m from the centre, so the
    // gap is 0.5 - 0.6 < 0 (overlap); at 1.2 m the gap is +0.1 (no overlap).
    sinew_shape_def s{};
    s.type = SINEW_SHAPE_SPHERE;
    s.radius = 0.6f;
    sinew_transform at = {{1, 2, 0}, {0, 0, 0, 1}};
    REQUIRE(sinew_world_overlap_shape(w, &s, &at, ids, 4, &count) == SINEW_OK);
    REQUIRE(count == 1);
    CHECK(same(ids[0], a));
    at.p.x = 1.2f;
    REQUIRE(sinew_world_overlap_shape(w, &s, &at, ids, 4, &count) == SINEW_OK);
    CHECK(count == 0);
    sinew_world_destroy(w);
}

TEST_CASE("C API run-time settings change the physics: gravity, solver, material", "[capi][query]") {
    const sinew_world_id w = make_world();
    // Gravity: a free body in zero gravity keeps its height (and falls asleep); turned to +9.81 it wakes
    // and rises by g t^2 / 2.
    REQUIRE(sinew_world_set_gravity(w, {0, 0, 0}) == SINEW_OK);
    const sinew_body_id box = add_box(w, SINEW_BODY_DYNAMIC, {0, 5, 0});
    for (int k = 0; k < 30; ++k) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(box, &t) == SINEW_OK);
    CHECK(t.p.y == Approx(5).margin(1e-6));
    REQUIRE(sinew_world_set_gravity(w, {0, 9.81f, 0}) == SINEW_OK);
    for (int k = 0; k < 60; ++k) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    REQUIRE(sinew_body_get_transform(box, &t) == SINEW_OK);
    // The default soft-step solver integrates 5 sub-steps of h/5 per step (semi-implicit Euler): after
    // N = 300 sub-steps of 1/300 s, g h_s^2 N (N + 1) / 2 = 9.81 * 301 / 600 = 4.921 m.
    CHECK(t.p.y - 5 == Approx(9.81 * 301 / 600.0).epsilon(1e-4));

    // Solver: switching to the Newtonian solver and back keeps a resting box at rest.
    REQUIRE(sinew_world_set_gravity(w, {0, -9.81f, 0}) == SINEW_OK);
    add_box(w, SINEW_BODY_STATIC, {3, -0.5f, 0});
    const sinew_body_id rest = add_box(w, SINEW_BODY_DYNAMIC, {3, 0.5f, 0});
    for (sinew_solver s : {SINEW_SOLVER_NEWTON, SINEW_SOLVER_SPLIT_IMPULSE, SINEW_SOLVER_SOFT_STEP}) {
        REQUIRE(sinew_world_set_solver(w, s, 8) == SINEW_OK);
        for (int k = 0; k < 30; ++k) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    }
    REQUIRE(sinew_body_get_transform(rest, &t) == SINEW_OK);
    CHECK(t.p.y == Approx(0.5f).margin(0.01));  // within the 5 mm slop of any solver, plus margin

    // Material: a box sliding at 2 m/s on the ground stops after v^2 / (2 mu g) with mu = sqrt(mu_a mu_b)
    // (the rigid system's mixing rule): both set to 0.2 gives 4 / (2 * 0.2 * 9.81) = 1.019 m.
    sinew_world_id w2 = make_world();
    sinew_body_def fd = sinew_body_def_default();
    fd.type = SINEW_BODY_STATIC;
    fd.shape.half_extents = {10, 0.5f, 2};  // one long floor: no seams for the box's edge to catch on
    fd.transform.p = {0, -0.5f, 0};
    sinew_body_id floor{};
    REQUIRE(sinew_body_create(w2, &fd, &floor) == SINEW_OK);
    sinew_body_def d = sinew_body_def_default();
    d.shape.half_extents = {0.5f, 0.5f, 0.5f};
    d.transform.p = {0, 0.5f, 0};
    d.linear_velocity = {2, 0, 0};
    sinew_body_id slider{};
    REQUIRE(sinew_body_create(w2, &d, &slider) == SINEW_OK);
    REQUIRE(sinew_body_set_material(floor, 0.2f, 0) == SINEW_OK);
    REQUIRE(sinew_body_set_material(slider, 0.2f, 0) == SINEW_OK);
    for (int k = 0; k < 120; ++k) REQUIRE(sinew_world_step_fixed(w2) == SINEW_OK);
    REQUIRE(sinew_body_get_transform(slider, &t) == SINEW_OK);
    // 5%: the friction impulse acts per step (the stop lands within one step of 0.0167 s, 1.7 cm).
    CHECK(t.p.x == Approx(4.0 / (2 * 0.2 * 9.81)).epsilon(0.05));
    sinew_world_destroy(w2);
    sinew_world_destroy(w);
}

TEST_CASE("C API queries and settings reject bad input and leave the world unchanged", "[capi][query][errors]") {
    const sinew_world_id w = make_world();
    const sinew_body_id a = add_box(w, SINEW_BODY_DYNAMIC, {0, 2, 0});
    const std::vector<float> before = fingerprint(w);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    sinew_ray_hit hit;
    int found = 0, count = 0;
    sinew_body_id ids[2];

    expect_rejected(w, before, sinew_world_ray_cast(w, {nan, 0, 0}, {0, 0, 0}, &hit, &found), SINEW_ERROR_INVALID_ARGUMENT,
                    "from = (nan");
    expect_rejected(w, before, sinew_world_ray_cast(w, {0, 0, 0}, {0, 0, 0}, nullptr, &found), SINEW_ERROR_NULL_ARGUMENT,
                    "hit is NULL");
    expect_rejected(w, before, sinew_world_ray_cast(w, {0, 0, 0}, {0, 0, 0}, &hit, nullptr), SINEW_ERROR_NULL_ARGUMENT,
                    "found is NULL");
    expect_rejected(w, before, sinew_world_ray_cast(sinew_world_id{99, 7}, {0, 0, 0}, {1, 0, 0}, &hit, &found),
                    SINEW_ERROR_STALE_ID, "sinew_world_ray_cast");
    expect_rejected(w, before, sinew_world_overlap_aabb(w, {1, 0, 0}, {0, 1, 1}, ids, 2, &count),
                    SINEW_ERROR_INVALID_ARGUMENT, "must be <= hi");
    expect_rejected(w, before, sinew_world_overlap_aabb(w, {0, 0, 0}, {1, 1, 1}, nullptr, 2, &count),
                    SINEW_ERROR_NULL_ARGUMENT, "ids is NULL");
    expect_rejected(w, before, sinew_world_overlap_aabb(w, {0, 0, 0}, {1, 1, 1}, ids, -1, &count),
                    SINEW_ERROR_INVALID_ARGUMENT, "capacity = -1");
    sinew_shape_def s{};
    s.type = SINEW_SHAPE_SPHERE;
    s.radius = -1;
    sinew_transform at = {{0, 0, 0}, {0, 0, 0, 1}};
    expect_rejected(w, before, sinew_world_overlap_shape(w, &s, &at, ids, 2, &count), SINEW_ERROR_INVALID_ARGUMENT,
                    "radius");
    s.radius = 1;
    poke(s.type, 17);
    expect_rejected(w, before, sinew_world_overlap_shape(w, &s, &at, ids, 2, &count), SINEW_ERROR_INVALID_ARGUMENT,
                    "shape->type = 17");
    s.type = SINEW_SHAPE_SPHERE;
    at.q = {0, 0, 0, 0};
    expect_rejected(w, before, sinew_world_overlap_shape(w, &s, &at, ids, 2, &count), SINEW_ERROR_INVALID_ARGUMENT,
                    "transform->q");

    // A C caller can pass any int as an enum argument. In C++ even loading an out-of-range enum is UB
    // (UBSan flags it), so the call is made from C (tests/c_api_enum_calls.c).
    expect_rejected(w, before, sinew_test_set_solver_int(w, 9, 10), SINEW_ERROR_INVALID_ARGUMENT, "solver = 9");
    expect_rejected(w, before, sinew_world_set_solver(w, SINEW_SOLVER_NEWTON, 0), SINEW_ERROR_INVALID_ARGUMENT,
                    "velocity_iterations");
    expect_rejected(w, before, sinew_world_set_gravity(w, {0, nan, 0}), SINEW_ERROR_INVALID_ARGUMENT, "gravity");
    expect_rejected(w, before, sinew_body_set_material(a, -1, 0), SINEW_ERROR_INVALID_ARGUMENT, "friction");
    expect_rejected(w, before, sinew_body_set_material(a, 0.5f, 2), SINEW_ERROR_INVALID_ARGUMENT, "restitution");
    sinew_body_id stale = a;
    stale.generation += 5;
    expect_rejected(w, before, sinew_body_set_material(stale, 0.5f, 0), SINEW_ERROR_STALE_ID, "sinew_body_set_material");
    expect_rejected(w, before, sinew_world_save_scene(w, nullptr), SINEW_ERROR_NULL_ARGUMENT, "path is NULL");
    sinew_world_destroy(w);
}

TEST_CASE("C API shape casts, closest points and filtered and all-hit ray casts", "[capi][query][cast]") {
    sinew_world_id w = make_world();
    // Three static 1 m cubes along x at 3, 5 and 7, categories 1, 2 and 4.
    sinew_body_id cubes[3];
    for (int k = 0; k < 3; ++k) {
        sinew_body_def d = sinew_body_def_default();
        d.type = SINEW_BODY_STATIC;
        d.transform.p = {float(3 + 2 * k), 0, 0};
        d.filter.category_bits = 1u << k;
        REQUIRE(sinew_body_create(w, &d, &cubes[k]) == SINEW_OK);
    }
    sinew_body_def def = sinew_body_def_default();
    const sinew_filter all = sinew_filter_default();
    sinew_shape_def sphere = def.shape;
    sphere.type = SINEW_SHAPE_SPHERE;
    sphere.radius = 0.25f;
    const sinew_transform origin = {{0, 0.1f, 0}, {0, 0, 0, 1}};
    sinew_shape_cast_hit hit;
    int found = 0;
    // The sphere's centre stops 0.25 m before the first cube's face at x = 2.5: fraction 2.25 / 10.
    REQUIRE(sinew_world_cast_shape(w, &sphere, &origin, {10, 0, 0}, all, &hit, &found) == SINEW_OK);
    REQUIRE(found == 1);
    CHECK(same(hit.body, cubes[0]));
    CHECK(std::abs(hit.fraction - 0.225f) <= 1e-4f);
    CHECK(std::abs(hit.normal.x + 1) < 1e-4f);
    CHECK(std::abs(hit.point.x - 2.5f) < 1e-3f);
    sinew_filter skip_first = all;
    skip_first.mask_bits = ~1u;
    REQUIRE(sinew_world_cast_shape(w, &sphere, &origin, {10, 0, 0}, skip_first, &hit, &found) == SINEW_OK);
    REQUIRE(found == 1);
    CHECK(same(hit.body, cubes[1]));
    CHECK(std::abs(hit.fraction - 0.425f) <= 1e-4f);
    REQUIRE(sinew_world_cast_shape(w, &sphere, &origin, {0, 10, 0}, all, &hit, &found) == SINEW_OK);
    CHECK(found == 0);

    sinew_ray_hit ray;
    REQUIRE(sinew_world_ray_cast_filtered(w, {0, 0, 0}, {10, 0, 0}, skip_first, &ray, &found) == SINEW_OK);
    REQUIRE(found == 1);
    CHECK(same(ray.body, cubes[1]));
    sinew_ray_hit hits[2];
    int count = 0;
    REQUIRE(sinew_world_ray_cast_all(w, {0, 0, 0}, {10, 0, 0}, all, hits, 2, &count) == SINEW_OK);
    CHECK(count == 3);  // more than the buffer holds: the first two written, by fraction
    CHECK(same(hits[0].body, cubes[0]));
    CHECK(same(hits[1].body, cubes[1]));
    CHECK(std::abs(hits[1].fraction - 0.45f) < 1e-5f);

    sinew_closest_points cp;
    REQUIRE(sinew_world_closest_points(w, &sphere, &origin, cubes[2], 10, &cp, &found) == SINEW_OK);
    REQUIRE(found == 1);
    CHECK(std::abs(cp.distance - (6.5f - 0.25f)) < 1e-4f);
    CHECK(std::abs(cp.point_on_body.x - 6.5f) < 1e-4f);
    REQUIRE(sinew_world_closest_points(w, &sphere, &origin, cubes[2], 1, &cp, &found) == SINEW_OK);
    CHECK(found == 0);

    // Misuse: each refused with the world unchanged.
    const std::vector<float> before = fingerprint(w);
    const sinew_transform bad_q = {{0, 0, 0}, {0, 0, 0, 0}};
    CHECK(sinew_world_cast_shape(w, nullptr, &origin, {1, 0, 0}, all, &hit, &found) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(sinew_world_cast_shape(w, &sphere, &bad_q, {1, 0, 0}, all, &hit, &found) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_world_cast_shape(w, &sphere, &origin, {NAN, 0, 0}, all, &hit, &found) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(std::string(sinew_last_error()).find("translation") != std::string::npos);
    sinew_shape_def bad_shape = sphere;
    bad_shape.radius = -1;
    CHECK(sinew_world_cast_shape(w, &bad_shape, &origin, {1, 0, 0}, all, &hit, &found) == SINEW_ERROR_INVALID_ARGUMENT);
    poke(bad_shape.type, 99);
    CHECK(sinew_world_closest_points(w, &bad_shape, &origin, cubes[0], 1, &cp, &found) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_world_closest_points(w, &sphere, &origin, cubes[0], -1, &cp, &found) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_world_closest_points(w, &sphere, &origin, sinew_body_id{}, 1, &cp, &found) == SINEW_ERROR_STALE_ID);
    CHECK(sinew_world_ray_cast_all(w, {0, 0, 0}, {1, 0, 0}, all, nullptr, 2, &count) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(sinew_world_ray_cast_all(w, {0, 0, 0}, {1, 0, 0}, all, hits, -1, &count) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_world_ray_cast_filtered(w, {INFINITY, 0, 0}, {1, 0, 0}, all, &ray, &found) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(fingerprint(w) == before);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API shapes: hulls, planes, meshes and compounds rest where closed forms put them", "[capi][shapes]") {
    sinew_world_id w = make_world();
    // Ground: a plane at y = 0 on the left (x < 0), a two-triangle mesh at y = 1 on the right.
    sinew_body_def plane = sinew_body_def_default();
    plane.type = SINEW_BODY_STATIC;
    plane.shape.type = SINEW_SHAPE_PLANE;
    sinew_body_id ground;
    REQUIRE(sinew_body_create(w, &plane, &ground) == SINEW_OK);
    const sinew_vec3 quad[4] = {{2, 1, -3}, {8, 1, -3}, {8, 1, 3}, {2, 1, 3}};
    const uint32_t tris[6] = {0, 2, 1, 0, 3, 2};
    sinew_body_def mesh = sinew_body_def_default();
    mesh.type = SINEW_BODY_STATIC;
    mesh.shape.type = SINEW_SHAPE_MESH;
    mesh.shape.points = quad;
    mesh.shape.point_count = 4;
    mesh.shape.indices = tris;
    mesh.shape.index_count = 6;
    sinew_body_id shelf;
    REQUIRE(sinew_body_create(w, &mesh, &shelf) == SINEW_OK);
    // A hull of a 0.6 m cube's corners (plus its centre, which the hull drops) on the plane at x = -3.
    sinew_vec3 corners[9];
    for (int k = 0; k < 8; ++k) corners[k] = {k & 1 ? 0.3f : -0.3f, k & 2 ? 0.3f : -0.3f, k & 4 ? 0.3f : -0.3f};
    corners[8] = {0, 0, 0};
    sinew_body_def hull = sinew_body_def_default();
    hull.shape.type = SINEW_SHAPE_HULL;
    hull.shape.points = corners;
    hull.shape.point_count = 9;
    hull.transform.p = {-3, 1, 0};
    sinew_body_id cube;
    REQUIRE(sinew_body_create(w, &hull, &cube) == SINEW_OK);
    // A dumbbell on the mesh: two 0.2 m spheres 1 m apart on a thin capsule along x (turned from y).
    sinew_compound_child parts[3];
    parts[0].transform = {{-0.5f, 0, 0}, {0, 0, 0, 1}};
    parts[0].shape = sinew_shape_def_default();
    parts[0].shape.type = SINEW_SHAPE_SPHERE;
    parts[0].shape.radius = 0.2f;
    parts[1] = parts[0];
    parts[1].transform.p.x = 0.5f;
    parts[2].transform = {{0, 0, 0}, sinew_quat_from_axis_angle({0, 0, 1}, 1.5707963f)};
    parts[2].shape = sinew_shape_def_default();
    parts[2].shape.type = SINEW_SHAPE_CAPSULE;
    parts[2].shape.radius = 0.05f;
    parts[2].shape.half_height = 0.5f;
    sinew_body_def bell = sinew_body_def_default();
    bell.shape.type = SINEW_SHAPE_COMPOUND;
    bell.shape.children = parts;
    bell.shape.child_count = 3;
    bell.transform.p = {5, 2, 0};
    sinew_body_id dumbbell;
    REQUIRE(sinew_body_create(w, &bell, &dumbbell) == SINEW_OK);
    // Mass from density 1000: the spheres' 2 x 33.5 kg plus the capsule's 8.4 kg.
    float mass = 0;
    REQUIRE(sinew_body_get_mass(dumbbell, &mass) == SINEW_OK);
    const double pi = 3.14159265358979;
    const double expected = 1000 * (2 * 4.0 / 3 * pi * 0.008 + pi * 0.0025 * 1.0 + 4.0 / 3 * pi * 0.000125);
    CHECK(mass == Approx(expected).epsilon(1e-3));
    for (int i = 0; i < 120; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(cube, &t) == SINEW_OK);
    CHECK(t.p.y == Approx(0.3).margin(0.01));  // the hull's half height above the plane
    REQUIRE(sinew_body_get_transform(dumbbell, &t) == SINEW_OK);
    CHECK(t.p.y == Approx(1.2).margin(0.01));  // the spheres' radius above the mesh
    CHECK(t.p.x == Approx(5).margin(0.01));

    // Misuse, each naming the field, the world unchanged.
    const std::vector<float> before = fingerprint(w);
    sinew_body_id id;
    auto refused = [&](const sinew_body_def& d, const char* fragment) {
        CHECK(sinew_body_create(w, &d, &id) == SINEW_ERROR_INVALID_ARGUMENT);
        CHECK_THAT(std::string(sinew_last_error()), Catch::Contains(fragment));
    };
    sinew_body_def d = hull;
    d.shape.point_count = 3;
    refused(d, "def->shape.point_count");
    d = hull;
    d.shape.points = nullptr;
    refused(d, "def->shape.points is NULL");
    sinew_vec3 nan_corners[9];
    for (int k = 0; k < 9; ++k) nan_corners[k] = corners[k];
    nan_corners[4].y = NAN;
    d.shape.points = nan_corners;
    refused(d, "def->shape.points[4]");
    d = mesh;
    const uint32_t far[6] = {0, 2, 1, 0, 3, 9};
    d.shape.indices = far;
    refused(d, "index");
    d = mesh;
    d.shape.index_count = 5;
    refused(d, "def->shape.index_count");
    d = mesh;
    d.type = SINEW_BODY_DYNAMIC;
    refused(d, "static");
    d = plane;
    d.type = SINEW_BODY_DYNAMIC;
    refused(d, "static");
    sinew_compound_child nested[1];
    nested[0].transform = {{0, 0, 0}, {0, 0, 0, 1}};
    nested[0].shape = bell.shape;
    d = bell;
    d.shape.children = nested;
    d.shape.child_count = 1;
    refused(d, "def->shape.children[0].shape.type");
    d = bell;
    d.shape.child_count = 0;
    refused(d, "def->shape.child_count");
    parts[1].transform.q = {0, 0, 0, 0};
    refused(bell, "def->shape.children[1].transform");
    CHECK(fingerprint(w) == before);
    // A hull as a query shape; a plane is refused as one.
    sinew_body_id ids[4];
    int count = 0;
    const sinew_transform at_cube = {{-3, 0.3f, 0}, {0, 0, 0, 1}};
    REQUIRE(sinew_world_overlap_shape(w, &hull.shape, &at_cube, ids, 4, &count) == SINEW_OK);
    CHECK(count == 2);  // the hull body and the plane
    CHECK(sinew_world_overlap_shape(w, &plane.shape, &at_cube, ids, 4, &count) == SINEW_ERROR_INVALID_ARGUMENT);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

namespace {
struct DrawCounts {
    int spheres = 0, capsules = 0, boxes = 0, triangles = 0, segments = 0, points = 0;
    float sphere_radius_sum = 0;
};
}  // namespace

TEST_CASE("C API debug draw hands every shape, joint, contact and soft surface to the host", "[capi][draw]") {
    sinew_world_id w = make_world();
    sinew_body_def plane = sinew_body_def_default();
    plane.type = SINEW_BODY_STATIC;
    plane.shape.type = SINEW_SHAPE_PLANE;
    sinew_body_id id;
    REQUIRE(sinew_body_create(w, &plane, &id) == SINEW_OK);                          // 2 triangles
    sinew_body_def box = sinew_body_def_default();
    box.transform.p = {0, 0.5f, 0};
    REQUIRE(sinew_body_create(w, &box, &id) == SINEW_OK);                            // 1 box, 4 contact points
    sinew_vec3 corners[8];
    for (int k = 0; k < 8; ++k) corners[k] = {k & 1 ? 0.3f : -0.3f, k & 2 ? 0.3f : -0.3f, k & 4 ? 0.3f : -0.3f};
    sinew_body_def hull = sinew_body_def_default();
    hull.shape.type = SINEW_SHAPE_HULL;
    hull.shape.points = corners;
    hull.shape.point_count = 8;
    hull.transform.p = {3, 5, 0};
    hull.gravity_scale = 0;
    REQUIRE(sinew_body_create(w, &hull, &id) == SINEW_OK);                           // 6 faces: 12 triangles
    sinew_body_def ball = sinew_body_def_default();
    ball.shape.type = SINEW_SHAPE_SPHERE;
    ball.shape.radius = 0.25f;
    ball.transform.p = {-3, 5, 0};
    ball.gravity_scale = 0;
    sinew_body_id a, b;
    REQUIRE(sinew_body_create(w, &ball, &a) == SINEW_OK);                            // 1 sphere
    sinew_body_def cap = ball;
    cap.shape.type = SINEW_SHAPE_CAPSULE;
    cap.transform.p = {-3, 4, 0};
    REQUIRE(sinew_body_create(w, &cap, &b) == SINEW_OK);                             // 1 capsule
    sinew_joint_def j = sinew_joint_def_default();
    j.body_a = a;
    j.body_b = b;
    j.local_anchor_a = {0, -0.5f, 0};
    j.local_anchor_b = {0, 0.5f, 0};
    sinew_joint_id joint;
    REQUIRE(sinew_joint_create(w, &j, &joint) == SINEW_OK);                          // 3 segments
    sinew_soft_def sd = sinew_soft_def_default();
    sinew_cloth_def cloth = sinew_cloth_def_default();
    cloth.nx = cloth.ny = 3;
    cloth.origin = {10, 3, 0};
    sinew_soft_body_id soft;
    REQUIRE(sinew_soft_create_cloth(w, &sd, &cloth, &soft) == SINEW_OK);             // 8 triangles
    for (int i = 0; i < 30; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);

    DrawCounts n;
    sinew_debug_draw dd = sinew_debug_draw_default();
    dd.context = &n;
    dd.draw_sphere = [](void* c, sinew_vec3, float r, uint32_t) {
        static_cast<DrawCounts*>(c)->spheres++;
        static_cast<DrawCounts*>(c)->sphere_radius_sum += r;
    };
    dd.draw_capsule = [](void* c, sinew_vec3, sinew_vec3, float, uint32_t) { static_cast<DrawCounts*>(c)->capsules++; };
    dd.draw_box = [](void* c, sinew_transform, sinew_vec3, uint32_t) { static_cast<DrawCounts*>(c)->boxes++; };
    dd.draw_triangle = [](void* c, sinew_vec3, sinew_vec3, sinew_vec3, uint32_t) { static_cast<DrawCounts*>(c)->triangles++; };
    dd.draw_segment = [](void* c, sinew_vec3, sinew_vec3, uint32_t) { static_cast<DrawCounts*>(c)->segments++; };
    dd.draw_point = [](void* c, sinew_vec3, float, uint32_t) { static_cast<DrawCounts*>(c)->points++; };
    REQUIRE(sinew_world_draw(w, &dd) == SINEW_OK);
    CHECK(n.spheres == 1);
    CHECK(n.sphere_radius_sum == 0.25f);
    CHECK(n.capsules == 1);
    CHECK(n.boxes == 1);
    CHECK(n.triangles == 2 + 12 + 8);
    CHECK(n.points == 4);
    CHECK(n.segments == 3 + 4);
    // Switched off, or with no callbacks, nothing is drawn and nothing fails.
    DrawCounts none;
    dd.context = &none;
    dd.draw_shapes = dd.draw_joints = dd.draw_contacts = dd.draw_soft_bodies = 0;
    REQUIRE(sinew_world_draw(w, &dd) == SINEW_OK);
    CHECK(none.triangles + none.segments + none.points + none.spheres == 0);
    const sinew_debug_draw empty = sinew_debug_draw_default();
    CHECK(sinew_world_draw(w, &empty) == SINEW_OK);
    CHECK(sinew_world_draw(w, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
    CHECK(sinew_world_draw(w, &empty) == SINEW_ERROR_STALE_ID);
}
