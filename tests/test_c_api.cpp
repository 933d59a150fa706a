// The C API: valid use gives the same physics as the C++ world; invalid use (NULL, stale handles, NaN,
// negative mass, out-of-range enums, calls during a step) returns the documented status with a message
// naming the argument, and leaves the world as it was.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "engine/api/sinew.h"
#include "engine/world/world.hpp"

namespace {

/// Stores an out-of-range value in a C enum field the way a C caller can (a C++ cast would be UB).
template <class E>
void poke(E& field, int value) {
    std::memcpy(&field, &value, sizeof value);
}

sinew_world_id make_world() {
    sinew_world_def d = sinew_world_def_default();
    sinew_world_id w{};
    REQUIRE(sinew_world_create(&d, &w) == SINEW_OK);
    return w;
}

int body_count(sinew_world_id w) {
    int n = -1;
    REQUIRE(sinew_world_body_count(w, &n) == SINEW_OK);
    return n;
}

}  // namespace

TEST_CASE("C API: a box dropped through the C API lands where the C++ world puts it", "[capi]") {
    sinew_world_id w = make_world();
    sinew_body_def g = sinew_body_def_default();
    g.type = SINEW_BODY_STATIC;
    g.shape.half_extents = {10, 0.5f, 10};
    g.transform.p.y = -0.5f;
    sinew_body_id gid;
    REQUIRE(sinew_body_create(w, &g, &gid) == SINEW_OK);
    sinew_body_def b = sinew_body_def_default();
    b.transform.p.y = 2;
    b.mass = 1;
    b.user_data = 42;
    sinew_body_id bid;
    REQUIRE(sinew_body_create(w, &b, &bid) == SINEW_OK);

    // The same scene in C++.
    sinew::World cw;
    sinew::BodyDef cg;
    cg.type = sinew::BodyType::Static;
    cg.shape = sinew::make_box(sinew::Vec3(10, 0.5f, 10));
    cg.pose.p = sinew::Vec3(0, -0.5f, 0);
    cw.rigid().create_body(cg);
    sinew::BodyDef cb;
    cb.shape = sinew::make_box(sinew::Vec3(0.5f, 0.5f, 0.5f));
    cb.pose.p = sinew::Vec3(0, 2, 0);
    cb.mass = 1;
    sinew::BodyId cid = cw.rigid().create_body(cb);

    for (int i = 0; i < 90; ++i) {
        REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
        cw.step();
    }
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(bid, &t) == SINEW_OK);
    // Same engine, same steps: identical to float rounding (the C API converts at the boundary).
    CHECK(t.p.y == Approx(double(cw.rigid().transform(cid).p.y())).margin(1e-6));
    CHECK(t.p.y == Approx(0.5).margin(0.01));  // resting on the ground
    uint64_t ud = 0;
    REQUIRE(sinew_body_user_data(bid, &ud) == SINEW_OK);
    CHECK(ud == 42);

    sinew_body_id ids[4];
    sinew_transform xf[4];
    int count = 0;
    REQUIRE(sinew_world_get_transforms(w, ids, xf, 4, &count) == SINEW_OK);
    CHECK(count == 2);
    CHECK(ids[1].index == bid.index);
    CHECK(xf[1].p.y == t.p.y);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API: accumulator stepping reports steps and the interpolation fraction", "[capi]") {
    sinew_world_def d = sinew_world_def_default();
    d.time_step = 0.01f;
    sinew_world_id w;
    REQUIRE(sinew_world_create(&d, &w) == SINEW_OK);
    int steps = 0;
    float alpha = 0;
    REQUIRE(sinew_world_step(w, 0.025f, &steps, &alpha) == SINEW_OK);
    CHECK(steps == 2);
    CHECK(alpha == Approx(0.5).margin(1e-3));
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API: bad input is rejected with a status, a message, and an unchanged world", "[capi][errors]") {
    sinew_world_id w = make_world();
    sinew_body_def ok = sinew_body_def_default();
    sinew_body_id id;
    REQUIRE(sinew_body_create(w, &ok, &id) == SINEW_OK);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    auto expect = [&](sinew_status got, sinew_status want, const char* fragment) {
        CHECK(got == want);
        CHECK_THAT(std::string(sinew_last_error()), Catch::Contains(fragment));
        CHECK(body_count(w) == 1);
    };

    expect(sinew_body_create(w, nullptr, &id), SINEW_ERROR_NULL_ARGUMENT, "def is NULL");
    expect(sinew_body_create(w, &ok, nullptr), SINEW_ERROR_NULL_ARGUMENT, "out is NULL");
    sinew_body_def bad = ok;
    bad.mass = -1;
    expect(sinew_body_create(w, &bad, &id), SINEW_ERROR_INVALID_ARGUMENT, "def->mass = -1");
    bad = ok;
    bad.transform.p.x = nan;
    expect(sinew_body_create(w, &bad, &id), SINEW_ERROR_INVALID_ARGUMENT, "def->transform.p");
    bad = ok;
    bad.transform.q = {0, 0, 0, 0};
    expect(sinew_body_create(w, &bad, &id), SINEW_ERROR_INVALID_ARGUMENT, "def->transform.q");
    bad = ok;
    poke(bad.type, 7);
    expect(sinew_body_create(w, &bad, &id), SINEW_ERROR_INVALID_ARGUMENT, "def->type = 7");
    bad = ok;
    poke(bad.shape.type, 9);
    expect(sinew_body_create(w, &bad, &id), SINEW_ERROR_INVALID_ARGUMENT, "shape.type = 9");
    bad = ok;
    bad.shape.half_extents.y = 0;  // degenerate box
    expect(sinew_body_create(w, &bad, &id), SINEW_ERROR_INVALID_ARGUMENT, "half extent y");
    bad = ok;
    bad.restitution = 2;
    expect(sinew_body_create(w, &bad, &id), SINEW_ERROR_INVALID_ARGUMENT, "restitution");

    sinew_transform before;
    REQUIRE(sinew_body_get_transform(id, &before) == SINEW_OK);
    sinew_transform nan_xf = before;
    nan_xf.p.y = nan;
    expect(sinew_body_set_transform(id, &nan_xf), SINEW_ERROR_INVALID_ARGUMENT, "transform->p");
    expect(sinew_body_set_velocity(id, {nan, 0, 0}, {0, 0, 0}), SINEW_ERROR_INVALID_ARGUMENT, "finite");
    expect(sinew_body_apply_force(id, {0, nan, 0}, {0, 0, 0}), SINEW_ERROR_INVALID_ARGUMENT, "finite");
    sinew_transform after;
    REQUIRE(sinew_body_get_transform(id, &after) == SINEW_OK);
    CHECK(after.p.y == before.p.y);

    expect(sinew_world_step(w, -1, nullptr, nullptr), SINEW_ERROR_INVALID_ARGUMENT, "frame_dt = -1");
    expect(sinew_world_step(w, nan, nullptr, nullptr), SINEW_ERROR_INVALID_ARGUMENT, "frame_dt");

    // Handles: null, stale (destroyed), foreign (another world's).
    sinew_body_id null_body{};
    expect(sinew_body_get_transform(null_body, &after), SINEW_ERROR_STALE_ID, "null handle");
    sinew_body_id gone;
    REQUIRE(sinew_body_create(w, &ok, &gone) == SINEW_OK);
    REQUIRE(sinew_body_destroy(gone) == SINEW_OK);
    expect(sinew_body_get_transform(gone, &after), SINEW_ERROR_STALE_ID, "destroyed");
    expect(sinew_body_destroy(gone), SINEW_ERROR_STALE_ID, "destroyed");
    sinew_world_id other = make_world();
    sinew_body_id foreign;
    REQUIRE(sinew_body_create(other, &ok, &foreign) == SINEW_OK);
    REQUIRE(sinew_world_destroy(other) == SINEW_OK);
    expect(sinew_body_get_transform(foreign, &after), SINEW_ERROR_STALE_ID, "destroyed or was never created");
    expect(sinew_world_destroy(other), SINEW_ERROR_STALE_ID, "destroyed or was never created");
    sinew_world_id null_world{};
    CHECK(sinew_world_step_fixed(null_world) == SINEW_ERROR_STALE_ID);

    sinew_world_def wd = sinew_world_def_default();
    poke(wd.solver, 12);
    sinew_world_id w2;
    CHECK(sinew_world_create(&wd, &w2) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("def->solver = 12"));
    wd = sinew_world_def_default();
    wd.time_step = 0;
    CHECK(sinew_world_create(&wd, &w2) == SINEW_ERROR_INVALID_ARGUMENT);
    // Issue 18: no upper bound let a huge frame time run for ever. At the bound, a frame of 1e30 s returns
    // after 1000 steps.
    wd = sinew_world_def_default();
    wd.max_steps_per_frame = 1001;
    expect(sinew_world_create(&wd, &w2), SINEW_ERROR_INVALID_ARGUMENT, "max_steps_per_frame must be in [1, 1000]");
    wd.max_steps_per_frame = 1000;
    REQUIRE(sinew_world_create(&wd, &w2) == SINEW_OK);
    int taken = 0;
    REQUIRE(sinew_world_step(w2, 1e30f, &taken, nullptr) == SINEW_OK);
    CHECK(taken == 1000);
    // Issue 18: a static body given a velocity was accepted and the velocity dropped in silence.
    sinew_body_def ground = sinew_body_def_default();
    ground.type = SINEW_BODY_STATIC;
    sinew_body_id ground_id;
    REQUIRE(sinew_body_create(w2, &ground, &ground_id) == SINEW_OK);
    expect(sinew_body_set_velocity(ground_id, {1, 0, 0}, {0, 0, 0}), SINEW_ERROR_INVALID_ARGUMENT, "is static");
    expect(sinew_body_set_velocity(ground_id, {0, 0, 0}, {0, 2, 0}), SINEW_ERROR_INVALID_ARGUMENT, "is static");
    CHECK(sinew_body_set_velocity(ground_id, {0, 0, 0}, {0, 0, 0}) == SINEW_OK);
    // Issue 18: after set_velocity(FLT_MAX) no later step succeeded ("collide: margin must be finite").
    sinew_body_def ball = sinew_body_def_default();
    sinew_body_id ball_id;
    REQUIRE(sinew_body_create(w2, &ball, &ball_id) == SINEW_OK);
    const float huge = std::numeric_limits<float>::max();
    expect(sinew_body_set_velocity(ball_id, {huge, 0, 0}, {0, 0, 0}), SINEW_ERROR_INVALID_ARGUMENT,
           "linear velocity must be at most");
    expect(sinew_body_set_velocity(ball_id, {0, 0, 0}, {0, -huge, 0}), SINEW_ERROR_INVALID_ARGUMENT,
           "angular velocity must be at most");
    ball.linear_velocity = {0, 2e4f, 0};
    expect(sinew_body_create(w2, &ball, &ball_id), SINEW_ERROR_INVALID_ARGUMENT, "linear velocity must be at most");
    REQUIRE(sinew_body_set_velocity(ball_id, {1000, 0, 0}, {0, 0, 0}) == SINEW_OK);  // a bullet's speed is fine
    // Issue 18: masses of 1e30 and 1e-38, and a 0.3 mm sphere at the default density, went non-finite.
    sinew_body_def odd = sinew_body_def_default();
    sinew_body_id odd_id;
    odd.mass = 1e30f;
    expect(sinew_body_create(w2, &odd, &odd_id), SINEW_ERROR_INVALID_ARGUMENT, "mass must be in [1e-06, 1e+12] kg");
    odd.mass = 1e-38f;
    expect(sinew_body_create(w2, &odd, &odd_id), SINEW_ERROR_INVALID_ARGUMENT, "mass must be in");
    odd = sinew_body_def_default();
    odd.shape.type = SINEW_SHAPE_SPHERE;
    odd.shape.radius = 3e-4f;
    expect(sinew_body_create(w2, &odd, &odd_id), SINEW_ERROR_INVALID_ARGUMENT, "times the shape's volume");
    REQUIRE(sinew_world_step_fixed(w2) == SINEW_OK);
    REQUIRE(sinew_world_destroy(w2) == SINEW_OK);
    CHECK(sinew_world_create(nullptr, &w2) == SINEW_ERROR_NULL_ARGUMENT);

    // A successful call clears the message.
    REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    CHECK(std::string(sinew_last_error()).empty());
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API: collision filters on bodies and soft bodies, set at creation and at run time", "[capi][filter]") {
    sinew_world_id w = make_world();
    sinew_body_def g = sinew_body_def_default();
    CHECK(g.filter.category_bits == 1u);
    CHECK(g.filter.mask_bits == 0xFFFFFFFFu);
    CHECK(g.filter.group_index == 0);
    g.type = SINEW_BODY_STATIC;
    g.shape.half_extents = {10, 0.5f, 10};
    g.transform.p.y = -0.5f;
    sinew_body_id gid;
    REQUIRE(sinew_body_create(w, &g, &gid) == SINEW_OK);
    sinew_body_def b = sinew_body_def_default();
    b.transform.p.y = 2;
    b.filter = {2u, ~1u, 0};  // debris: passes through category 1 (the ground)
    sinew_body_id bid;
    REQUIRE(sinew_body_create(w, &b, &bid) == SINEW_OK);
    sinew_filter f{};
    REQUIRE(sinew_body_get_filter(bid, &f) == SINEW_OK);
    CHECK(f.category_bits == 2u);
    CHECK(f.mask_bits == ~1u);
    for (int i = 0; i < 36; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(bid, &t) == SINEW_OK);
    // 0.6 s of free fall from 2 m: 2 - 4.9 * 0.36 = 0.24 m, a quarter of the box inside the ground.
    CHECK(t.p.y == Approx(0.24).margin(0.03));
    // Admit the ground: the box is pushed out and rests on it.
    REQUIRE(sinew_body_set_filter(bid, sinew_filter{2u, 0xFFFFFFFFu, 0}) == SINEW_OK);
    for (int i = 0; i < 120; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    REQUIRE(sinew_body_get_transform(bid, &t) == SINEW_OK);
    CHECK(t.p.y == Approx(0.5).margin(0.02));

    // Misuse: NULL out, stale ids; the filter stays.
    CHECK(sinew_body_get_filter(bid, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    sinew_body_id stale = bid;
    stale.generation += 7;
    CHECK(sinew_body_set_filter(stale, sinew_filter{1u, 0u, 0}) == SINEW_ERROR_STALE_ID);
    REQUIRE(sinew_body_get_filter(bid, &f) == SINEW_OK);
    CHECK(f.mask_bits == 0xFFFFFFFFu);

    // Soft bodies: the def carries one, and it can be read back and changed.
    sinew_soft_def sd = sinew_soft_def_default();
    CHECK(sd.filter.mask_bits == 0xFFFFFFFFu);
    sd.filter = {1u, ~1u, 0};
    sinew_soft_body_id rope;
    REQUIRE(sinew_soft_create_rope(w, &sd, sinew_vec3{0, 3, 2}, sinew_vec3{1, 3, 2}, 4, &rope) == SINEW_OK);
    REQUIRE(sinew_soft_get_filter(rope, &f) == SINEW_OK);
    CHECK(f.mask_bits == ~1u);
    for (int i = 0; i < 90; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    sinew_vec3 p[5];
    int n = 0;
    REQUIRE(sinew_soft_get_positions(rope, p, 5, &n) == SINEW_OK);
    REQUIRE(n == 5);
    CHECK(p[0].y < -1);  // through the ground it does not meet
    REQUIRE(sinew_soft_set_filter(rope, sinew_filter{1u, 0xFFFFFFFFu, 0}) == SINEW_OK);
    REQUIRE(sinew_soft_get_filter(rope, &f) == SINEW_OK);
    CHECK(f.mask_bits == 0xFFFFFFFFu);
    CHECK(sinew_soft_get_filter(rope, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API: a kinematic platform moved by target transforms carries a box at its speed", "[capi][kinematic]") {
    sinew_world_id w = make_world();
    sinew_body_def p = sinew_body_def_default();
    p.type = SINEW_BODY_KINEMATIC;
    p.shape.half_extents = {3, 0.1f, 3};
    p.transform.p.y = 0.1f;
    sinew_body_id platform;
    REQUIRE(sinew_body_create(w, &p, &platform) == SINEW_OK);
    sinew_body_def b = sinew_body_def_default();
    b.shape.half_extents = {0.25f, 0.25f, 0.25f};
    b.transform.p.y = 0.45f;
    b.mass = 1;
    sinew_body_id box;
    REQUIRE(sinew_body_create(w, &b, &box) == SINEW_OK);
    const float h = 1.0f / 60;
    for (int i = 1; i <= 120; ++i) {
        sinew_transform t = p.transform;
        t.p.x = 1.0f * float(i) * h;
        REQUIRE(sinew_body_set_target_transform(platform, &t, h) == SINEW_OK);
        REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    }
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(platform, &t) == SINEW_OK);
    CHECK(t.p.x == Approx(2.0).margin(1e-4));
    sinew_vec3 v, a;
    REQUIRE(sinew_body_get_velocity(box, &v, &a) == SINEW_OK);
    CHECK(v.x == Approx(1.0).epsilon(0.01));
    // Misuse: NULL target, a zero step, a NaN target, a static body; the platform stays where it is.
    CHECK(sinew_body_set_target_transform(platform, nullptr, h) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(sinew_body_set_target_transform(platform, &t, 0) == SINEW_ERROR_INVALID_ARGUMENT);
    sinew_transform bad = t;
    bad.p.y = std::numeric_limits<float>::quiet_NaN();
    CHECK(sinew_body_set_target_transform(platform, &bad, h) == SINEW_ERROR_INVALID_ARGUMENT);
    sinew_body_def g = sinew_body_def_default();
    g.type = SINEW_BODY_STATIC;
    g.transform.p.y = -5;
    sinew_body_id ground;
    REQUIRE(sinew_body_create(w, &g, &ground) == SINEW_OK);
    CHECK(sinew_body_set_target_transform(ground, &t, h) == SINEW_ERROR_INVALID_ARGUMENT);
    sinew_vec3 pv;
    REQUIRE(sinew_body_get_velocity(platform, &pv, &a) == SINEW_OK);
    CHECK(pv.x == Approx(1.0).epsilon(1e-4));
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API: body control: sleep and wake, mass, gravity scale, damping", "[capi][body]") {
    sinew_world_id w = make_world();
    sinew_body_def g = sinew_body_def_default();
    g.type = SINEW_BODY_STATIC;
    g.shape.half_extents = {10, 0.5f, 10};
    g.transform.p.y = -0.5f;
    sinew_body_id ground;
    REQUIRE(sinew_body_create(w, &g, &ground) == SINEW_OK);
    sinew_body_def b = sinew_body_def_default();
    b.transform.p.y = 0.5f;  // resting on the ground
    b.mass = 3;
    sinew_body_id box;
    REQUIRE(sinew_body_create(w, &b, &box) == SINEW_OK);
    float m = 0;
    REQUIRE(sinew_body_get_mass(box, &m) == SINEW_OK);
    CHECK(m == 3.0f);
    REQUIRE(sinew_body_get_mass(ground, &m) == SINEW_OK);
    CHECK(m == 0.0f);
    int awake = -1;
    REQUIRE(sinew_body_is_awake(box, &awake) == SINEW_OK);
    CHECK(awake == 1);
    for (int i = 0; i < 90; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);  // 1.5 s at rest: asleep after 0.5 s
    REQUIRE(sinew_body_is_awake(box, &awake) == SINEW_OK);
    CHECK(awake == 0);
    REQUIRE(sinew_body_wake(box) == SINEW_OK);
    REQUIRE(sinew_body_is_awake(box, &awake) == SINEW_OK);
    CHECK(awake == 1);
    REQUIRE(sinew_body_is_awake(ground, &awake) == SINEW_OK);
    CHECK(awake == 0);

    // Gravity scale -1: the box rises at g from rest. The default solver takes 5 sub-steps a step, so after
    // 30 steps (n = 150 sub-steps of h/5) semi-implicit Euler's sum gives 0.5 + g (h/5)^2 n (n + 1) / 2.
    REQUIRE(sinew_body_set_gravity_scale(box, -1) == SINEW_OK);
    for (int i = 0; i < 30; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(box, &t) == SINEW_OK);
    const double hs = 1.0 / 300;
    CHECK(t.p.y == Approx(0.5 + 9.81 * hs * hs * 150 * 151 / 2).epsilon(1e-3));
    // Damping c = 2/s with gravity off: v *= 1 / (1 + 2 h/5) at each of the 150 sub-steps.
    REQUIRE(sinew_body_set_gravity_scale(box, 0) == SINEW_OK);
    REQUIRE(sinew_body_set_damping(box, 2, 0) == SINEW_OK);
    sinew_vec3 v0, v1, a;
    REQUIRE(sinew_body_get_velocity(box, &v0, &a) == SINEW_OK);
    for (int i = 0; i < 30; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    REQUIRE(sinew_body_get_velocity(box, &v1, &a) == SINEW_OK);
    CHECK(v1.y == Approx(v0.y / std::pow(1 + 2 * hs, 150)).epsilon(1e-3));
    // Misuse: the state is unchanged.
    CHECK(sinew_body_set_damping(box, -1, 0) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_body_set_gravity_scale(box, std::numeric_limits<float>::infinity()) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_body_is_awake(box, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(sinew_body_get_mass(box, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    sinew_body_id stale = box;
    stale.generation += 3;
    CHECK(sinew_body_wake(stale) == SINEW_ERROR_STALE_ID);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

namespace {
// A one-way platform for the C test: keep the contact only while the other body is above the top face.
struct OneWay {
    sinew_body_id platform;
    int disabled = 0;
};
int one_way(void* context, sinew_presolve_contact* c) {
    OneWay* o = static_cast<OneWay*>(context);
    const bool a_is = c->body_a.index == o->platform.index && c->body_a.generation == o->platform.generation;
    const bool b_is = c->body_b.index == o->platform.index && c->body_b.generation == o->platform.generation;
    if (!a_is && !b_is) return 1;
    sinew_transform t;
    if (sinew_body_get_transform(a_is ? c->body_b : c->body_a, &t) != SINEW_OK) return 1;
    const int keep = t.p.y - 0.2f > 2.0f - 0.05f;
    o->disabled += keep ? 0 : 1;
    return keep;
}
}  // namespace

TEST_CASE("C API: a one-way platform through the pre-solve callback", "[capi][presolve]") {
    sinew_world_id w = make_world();
    sinew_body_def slab = sinew_body_def_default();
    slab.type = SINEW_BODY_STATIC;
    slab.shape.half_extents = {2, 0.1f, 2};
    slab.transform.p.y = 1.9f;
    OneWay o;
    REQUIRE(sinew_body_create(w, &slab, &o.platform) == SINEW_OK);
    sinew_body_def ball = sinew_body_def_default();
    ball.shape.type = SINEW_SHAPE_SPHERE;
    ball.shape.radius = 0.2f;
    ball.transform.p.y = 0.5f;
    ball.linear_velocity = {0, 8, 0};
    sinew_body_id b;
    REQUIRE(sinew_body_create(w, &ball, &b) == SINEW_OK);
    REQUIRE(sinew_world_set_presolve(w, one_way, &o) == SINEW_OK);
    float highest = 0;
    sinew_transform t;
    for (int i = 0; i < 180; ++i) {
        REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
        REQUIRE(sinew_body_get_transform(b, &t) == SINEW_OK);
        highest = std::max(highest, t.p.y);
    }
    CHECK(o.disabled > 0);
    CHECK(highest == Approx(3.76).margin(0.05));
    CHECK(t.p.y == Approx(2.2).margin(0.01));
    // Removed: the next ball thrown from below is stopped by the slab.
    REQUIRE(sinew_world_set_presolve(w, nullptr, nullptr) == SINEW_OK);
    sinew_body_id b2;
    ball.transform.p.x = 1.0f;
    REQUIRE(sinew_body_create(w, &ball, &b2) == SINEW_OK);
    float top = 0;
    for (int i = 0; i < 60; ++i) {
        REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
        REQUIRE(sinew_body_get_transform(b2, &t) == SINEW_OK);
        top = std::max(top, t.p.y);
    }
    CHECK(top < 1.81f);
    sinew_world_id stale = w;
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
    CHECK(sinew_world_set_presolve(stale, one_way, &o) == SINEW_ERROR_STALE_ID);
}
