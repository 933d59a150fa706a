// The C API's joints: each type holds what it promises against an analytic answer (a hanging bob's
// reaction is its weight, a motor reaches its speed, limits stop, a spring sags by g / omega^2), break
// forces break, and bad input is rejected with the documented status, a message and an unchanged world.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>
#include <string>

#include "engine/world/scene.hpp"
#include "tests/test_c_api_util.hpp"

using namespace capi_test;

namespace {

constexpr float kG = 9.81f;
constexpr float kPi = 3.14159265f;

struct Rig {
    sinew_world_id world;
    sinew_body_id anchor, bob;
};

/// A static anchor at (0, 5, 0) and a 1 kg box (half extent 0.25 m) at `bob_at`; no ground.
Rig make_rig(float gravity_y = -kG, sinew_vec3 bob_at = {0, 4, 0}) {
    Rig r;
    r.world = make_world(gravity_y);
    sinew_body_def a = sinew_body_def_default();
    a.type = SINEW_BODY_STATIC;
    a.transform.p = {0, 5, 0};
    a.shape.half_extents = {0.1f, 0.1f, 0.1f};
    REQUIRE(sinew_body_create(r.world, &a, &r.anchor) == SINEW_OK);
    sinew_body_def b = sinew_body_def_default();
    b.transform.p = bob_at;
    b.mass = 1;
    b.shape.half_extents = {0.25f, 0.25f, 0.25f};
    REQUIRE(sinew_body_create(r.world, &b, &r.bob) == SINEW_OK);
    return r;
}

sinew_joint_def joint_between(const Rig& r, sinew_joint_type type) {
    sinew_joint_def j = sinew_joint_def_default();
    j.type = type;
    j.body_a = r.anchor;
    j.body_b = r.bob;
    return j;
}

void steps(sinew_world_id w, int n) {
    for (int i = 0; i < n; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
}

sinew_transform xf(sinew_body_id b) {
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(b, &t) == SINEW_OK);
    return t;
}

float angle_about_z(const sinew_quat& q) { return 2 * std::atan2(q.z, q.w); }

}  // namespace

TEST_CASE("C API joints: defaults match the C++ joint defaults", "[capi][joints]") {
    const sinew_joint_def d = sinew_joint_def_default();
    CHECK(d.type == SINEW_JOINT_BALL);
    CHECK(d.body_a.generation == 0);
    CHECK(d.local_axis_a.z == 1.0f);
    CHECK(d.length == -1.0f);
    CHECK(d.break_force == 0.0f);
    CHECK(d.collide_connected == 0);
}

TEST_CASE("C API joints: a bob on a ball joint hangs still and the joint carries its weight", "[capi][joints]") {
    Rig r = make_rig();
    sinew_joint_def j = joint_between(r, SINEW_JOINT_BALL);
    j.local_anchor_a = {0, -0.5f, 0};  // both anchors at (0, 4.5, 0)
    j.local_anchor_b = {0, 0.5f, 0};
    j.break_force = 20;  // twice the weight: holds
    sinew_joint_id joint;
    REQUIRE(sinew_joint_create(r.world, &j, &joint) == SINEW_OK);
    steps(r.world, 120);
    CHECK(xf(r.bob).p.y == Approx(4.0).margin(1e-3));  // a rigid joint: the anchors stay together
    sinew_vec3 force, torque;
    REQUIRE(sinew_joint_get_reaction(joint, &force, &torque) == SINEW_OK);
    // At rest the joint holds B up with m g (N); 1 % covers the solver's iteration error.
    CHECK(force.y == Approx(kG).epsilon(0.01));
    CHECK(std::abs(force.x) < 0.01f);
    sinew_events e;
    REQUIRE(sinew_world_get_events(r.world, &e) == SINEW_OK);
    CHECK(e.joint_break_count == 0);
    REQUIRE(sinew_joint_destroy(joint) == SINEW_OK);
    CHECK(sinew_joint_destroy(joint) == SINEW_ERROR_STALE_ID);
    steps(r.world, 30);  // free now: it falls
    CHECK(xf(r.bob).p.y < 3.0f);
    REQUIRE(sinew_world_destroy(r.world) == SINEW_OK);
}

TEST_CASE("C API joints: a joint weaker than the load breaks, reported once with its user data", "[capi][joints]") {
    Rig r = make_rig();
    sinew_joint_def j = joint_between(r, SINEW_JOINT_BALL);
    j.local_anchor_a = {0, -0.5f, 0};
    j.local_anchor_b = {0, 0.5f, 0};
    j.break_force = 5;  // the bob weighs 9.81 N
    j.user_data = 77;
    sinew_joint_id joint;
    REQUIRE(sinew_joint_create(r.world, &j, &joint) == SINEW_OK);
    REQUIRE(sinew_world_step_fixed(r.world) == SINEW_OK);
    sinew_events e;
    REQUIRE(sinew_world_get_events(r.world, &e) == SINEW_OK);
    REQUIRE(e.joint_break_count == 1);
    CHECK(e.joint_break[0].joint.index == joint.index);
    CHECK(e.joint_break[0].joint.generation == joint.generation);
    CHECK(e.joint_break[0].user_data == 77);
    CHECK(e.joint_break[0].body_a.index == r.anchor.index);
    CHECK(e.joint_break[0].body_b.index == r.bob.index);
    CHECK(e.joint_break[0].step == 1);
    // The broken joint is gone: its handle is stale.
    sinew_vec3 f;
    CHECK(sinew_joint_get_reaction(joint, &f, nullptr) == SINEW_ERROR_STALE_ID);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("broken"));
    REQUIRE(sinew_world_step_fixed(r.world) == SINEW_OK);
    REQUIRE(sinew_world_get_events(r.world, &e) == SINEW_OK);
    CHECK(e.joint_break_count == 0);  // the next step's events start empty
    REQUIRE(sinew_world_destroy(r.world) == SINEW_OK);
}

TEST_CASE("C API joints: a hinge motor reaches its speed, the limit stops it", "[capi][joints]") {
    Rig r = make_rig(0.0f, {0, 5, 0});
    sinew_joint_def j = joint_between(r, SINEW_JOINT_HINGE);
    j.local_axis_a = {0, 0, 1};
    j.enable_motor = 1;
    j.motor_speed = 2;  // rad/s
    j.max_motor_force = 100;  // N m, far above what the box's inertia needs
    sinew_joint_id hinge;
    REQUIRE(sinew_joint_create(r.world, &j, &hinge) == SINEW_OK);
    steps(r.world, 30);
    sinew_vec3 v, w;
    REQUIRE(sinew_body_get_velocity(r.bob, &v, &w) == SINEW_OK);
    CHECK(w.z == Approx(2.0).epsilon(0.01));
    CHECK(std::abs(w.x) < 1e-3f);
    REQUIRE(sinew_joint_set_motor(hinge, 1, -1, 100) == SINEW_OK);
    steps(r.world, 30);
    REQUIRE(sinew_body_get_velocity(r.bob, &v, &w) == SINEW_OK);
    CHECK(w.z == Approx(-1.0).epsilon(0.01));
    REQUIRE(sinew_world_destroy(r.world) == SINEW_OK);

    Rig s = make_rig(0.0f, {0, 5, 0});
    j = joint_between(s, SINEW_JOINT_HINGE);
    j.enable_motor = 1;
    j.motor_speed = 2;
    j.max_motor_force = 100;
    j.enable_limit = 1;
    j.lower = -0.5f;
    j.upper = 0.5f;  // rad
    REQUIRE(sinew_joint_create(s.world, &j, &hinge) == SINEW_OK);
    steps(s.world, 120);  // 2 rad/s would reach 0.5 rad in 15 steps
    // The limit is a velocity constraint with position correction: it holds within a few mrad.
    CHECK(angle_about_z(xf(s.bob).q) == Approx(0.5).margin(0.02));
    REQUIRE(sinew_world_destroy(s.world) == SINEW_OK);
}

TEST_CASE("C API joints: a slider falls to its lower limit along its axis only", "[capi][joints]") {
    Rig r = make_rig(-kG, {0, 5, 0});
    sinew_joint_def j = joint_between(r, SINEW_JOINT_SLIDER);
    j.local_axis_a = {0, 1, 0};
    j.enable_limit = 1;
    j.lower = -0.5f;  // m
    j.upper = 0.5f;
    sinew_joint_id slider;
    REQUIRE(sinew_joint_create(r.world, &j, &slider) == SINEW_OK);
    steps(r.world, 90);
    const sinew_transform t = xf(r.bob);
    CHECK(t.p.y == Approx(4.5).margin(0.01));  // translation = lower
    CHECK(std::abs(t.p.x) < 1e-3f);
    CHECK(std::abs(t.q.w) == Approx(1.0).margin(1e-4));  // no rotation
    REQUIRE(sinew_world_destroy(r.world) == SINEW_OK);
}

TEST_CASE("C API joints: a distance spring sags by g / omega^2, a weld holds", "[capi][joints]") {
    Rig r = make_rig();
    sinew_joint_def j = joint_between(r, SINEW_JOINT_DISTANCE);
    j.length = 1;           // the anchors (body origins) are 1 m apart at creation
    j.frequency = 2;        // Hz
    j.damping_ratio = 1;    // critical: settles in about a second
    sinew_joint_id spring;
    REQUIRE(sinew_joint_create(r.world, &j, &spring) == SINEW_OK);
    steps(r.world, 240);
    // Static equilibrium of a spring k = m omega^2: stretch = m g / k = g / (2 pi f)^2 = 0.0621 m. The
    // soft constraint reproduces it to a few percent at h = 1/60 (omega h = 0.21).
    const float sag = kG / ((2 * kPi * 2) * (2 * kPi * 2));
    CHECK(5.0f - xf(r.bob).p.y - 1.0f == Approx(sag).epsilon(0.05));
    REQUIRE(sinew_world_destroy(r.world) == SINEW_OK);

    Rig f = make_rig();
    j = joint_between(f, SINEW_JOINT_FIXED);
    j.local_anchor_a = {0, -1, 0};
    sinew_joint_id weld;
    REQUIRE(sinew_joint_create(f.world, &j, &weld) == SINEW_OK);
    steps(f.world, 120);
    CHECK(xf(f.bob).p.y == Approx(4.0).margin(1e-3));
    CHECK(std::abs(xf(f.bob).q.w) == Approx(1.0).margin(1e-4));
    // Destroying a body removes its joints.
    REQUIRE(sinew_body_destroy(f.bob) == SINEW_OK);
    CHECK(sinew_joint_destroy(weld) == SINEW_ERROR_STALE_ID);
    REQUIRE(sinew_world_destroy(f.world) == SINEW_OK);
}

TEST_CASE("C API joints: bad input is rejected with a status, a message and an unchanged world", "[capi][joints][errors]") {
    // Two identical rigs; only the first receives the bad calls. Stepping both afterwards and comparing
    // them exactly shows nothing was created or changed (a stray joint or a woken body would show).
    Rig r = make_rig();
    Rig twin = make_rig();
    sinew_joint_def good = joint_between(r, SINEW_JOINT_HINGE);
    good.local_anchor_a = {0, -0.5f, 0};
    good.local_anchor_b = {0, 0.5f, 0};
    sinew_joint_id hinge, twin_hinge;
    REQUIRE(sinew_joint_create(r.world, &good, &hinge) == SINEW_OK);
    sinew_joint_def tg = good;
    tg.body_a = twin.anchor;
    tg.body_b = twin.bob;
    REQUIRE(sinew_joint_create(twin.world, &tg, &twin_hinge) == SINEW_OK);
    sinew_body_def sd = sinew_body_def_default();
    sd.type = SINEW_BODY_STATIC;
    sd.transform.p = {5, 0, 0};
    sinew_body_id other_static, twin_static;
    REQUIRE(sinew_body_create(r.world, &sd, &other_static) == SINEW_OK);
    REQUIRE(sinew_body_create(twin.world, &sd, &twin_static) == SINEW_OK);
    const std::vector<float> before = fingerprint(r.world);
    auto expect = [&](sinew_status got, sinew_status want, const char* fragment) {
        expect_rejected(r.world, before, got, want, fragment);
    };
    const float nan = std::numeric_limits<float>::quiet_NaN();
    sinew_joint_id out;

    expect(sinew_joint_create(r.world, nullptr, &out), SINEW_ERROR_NULL_ARGUMENT, "def is NULL");
    expect(sinew_joint_create(r.world, &good, nullptr), SINEW_ERROR_NULL_ARGUMENT, "out is NULL");
    expect(sinew_joint_create(sinew_world_id{}, &good, &out), SINEW_ERROR_STALE_ID, "null handle");
    sinew_joint_def bad = good;
    poke(bad.type, 7);
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "def->type = 7");
    // Issue 18: an anchor 40 km from a 0.5 m box (1000 radii of gyration are 204 m) turned the first step NaN.
    bad = good;
    bad.local_anchor_b = {40000, 0, 0};
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT,
           "local_anchor_b (40000, 0, 0) lies 40000 m from body_b's centre of mass, more than 1000 times");
    bad = good;
    bad.body_a = sinew_body_id{};
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_STALE_ID, "def->body_a is the null handle");
    bad = good;
    bad.body_b = twin.bob;  // another world's body
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_STALE_ID, "def->body_b");
    bad = good;
    bad.body_b.generation += 5;
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_STALE_ID, "destroyed or was never created");
    bad = good;
    bad.body_b = r.bob;
    bad.body_a = r.bob;
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "same body");
    bad = good;
    bad.body_b = other_static;
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "at least one body must be dynamic");
    bad = good;
    bad.local_anchor_b.y = nan;
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "def->local_anchor_b = (0, nan, 0)");
    bad = good;
    bad.local_axis_a = {0, 0, 0};
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "def->local_axis_a");
    bad = good;
    bad.lower = 1;
    bad.upper = -1;
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "def->lower = 1 is greater than def->upper = -1");
    bad = good;
    bad.enable_limit = 1;
    bad.lower = -4;  // beyond -pi: the joint set's own check
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "[-pi, pi]");
    bad = good;
    bad.enable_motor = 2;
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "def->enable_motor = 2");
    bad = good;
    bad.max_motor_force = -1;
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "def->max_motor_force = -1");
    bad = good;
    bad.break_force = -3;
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "def->break_force = -3");
    bad = good;
    bad.frequency = nan;
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "def->frequency = nan");
    bad = good;
    bad.type = SINEW_JOINT_DISTANCE;
    bad.local_anchor_a = {0, -1, 0};
    bad.local_anchor_b = {0, 0, 0};  // coincident anchors: zero rest length
    expect(sinew_joint_create(r.world, &bad, &out), SINEW_ERROR_INVALID_ARGUMENT, "rest length");

    expect(sinew_joint_destroy(sinew_joint_id{}), SINEW_ERROR_STALE_ID, "null handle");
    sinew_joint_id stale = hinge;
    stale.generation += 1;
    expect(sinew_joint_destroy(stale), SINEW_ERROR_STALE_ID, "never created");
    sinew_vec3 f;
    expect(sinew_joint_get_reaction(hinge, nullptr, nullptr), SINEW_ERROR_NULL_ARGUMENT, "force and torque are NULL");
    expect(sinew_joint_get_reaction(stale, &f, nullptr), SINEW_ERROR_STALE_ID, "joint {index");
    expect(sinew_joint_set_motor(hinge, 2, 1, 1), SINEW_ERROR_INVALID_ARGUMENT, "enable = 2");
    expect(sinew_joint_set_motor(hinge, 1, nan, 1), SINEW_ERROR_INVALID_ARGUMENT, "speed = nan");
    expect(sinew_joint_set_motor(hinge, 1, 1, -2), SINEW_ERROR_INVALID_ARGUMENT, "max_force = -2");
    sinew_joint_def ball = joint_between(r, SINEW_JOINT_BALL);
    ball.body_b = r.bob;
    sinew_joint_def tb = ball;
    tb.body_a = twin.anchor;
    tb.body_b = twin.bob;
    sinew_joint_id ball_id, twin_ball;
    REQUIRE(sinew_joint_create(r.world, &ball, &ball_id) == SINEW_OK);
    REQUIRE(sinew_joint_create(twin.world, &tb, &twin_ball) == SINEW_OK);
    const std::vector<float> with_ball = fingerprint(r.world);
    expect_rejected(r.world, with_ball, sinew_joint_set_motor(ball_id, 1, 1, 1), SINEW_ERROR_INVALID_ARGUMENT,
                    "only hinge and slider joints have a motor");

    steps(r.world, 60);
    steps(twin.world, 60);
    CHECK(fingerprint(r.world) == fingerprint(twin.world));
    REQUIRE(sinew_world_destroy(r.world) == SINEW_OK);
    REQUIRE(sinew_world_destroy(twin.world) == SINEW_OK);
}

TEST_CASE("C API joints: calls that change a stepping world are rejected with SINEW_ERROR_IN_STEP", "[capi][joints][errors]") {
    Rig r = make_rig(-kG, {0, 5, 0});
    sinew_joint_def h = joint_between(r, SINEW_JOINT_HINGE);
    sinew_joint_id hinge;
    REQUIRE(sinew_joint_create(r.world, &h, &hinge) == SINEW_OK);
    std::vector<sinew_status> got;
    sinew_status read = SINEW_ERROR_INTERNAL;
    run_during_step(r.world, [&] {
        sinew_joint_id out;
        got = {sinew_joint_create(r.world, &h, &out), sinew_joint_destroy(hinge), sinew_joint_set_motor(hinge, 1, 1, 1)};
        sinew_vec3 f;
        read = sinew_joint_get_reaction(hinge, &f, nullptr);  // reading is allowed while stepping
    });
    REQUIRE(got.size() == 3);
    for (sinew_status s : got) CHECK(s == SINEW_ERROR_IN_STEP);
    CHECK(read == SINEW_OK);
    sinew_vec3 f;
    CHECK(sinew_joint_get_reaction(hinge, &f, nullptr) == SINEW_OK);  // still there
    REQUIRE(sinew_world_destroy(r.world) == SINEW_OK);
}

TEST_CASE("C API joints: hinge and slider coordinates and speeds, limits changed at run time", "[capi][joints]") {
    // A hinge driven at 2 rad/s: the reported speed is the motor's and the angle advances 2 rad/s
    // (0.5 s: 1 rad, read from the body's own rotation too).
    Rig r = make_rig(0.0f, {0, 5, 0});
    sinew_joint_def j = joint_between(r, SINEW_JOINT_HINGE);
    j.enable_motor = 1;
    j.motor_speed = 2;
    j.max_motor_force = 100;
    sinew_joint_id hinge;
    REQUIRE(sinew_joint_create(r.world, &j, &hinge) == SINEW_OK);
    steps(r.world, 30);
    float angle = 0, speed = 0;
    REQUIRE(sinew_joint_get_coordinate(hinge, &angle, &speed) == SINEW_OK);
    CHECK(speed == Approx(2.0).epsilon(0.01));
    CHECK(angle == Approx(angle_about_z(xf(r.bob).q)).margin(1e-4));
    CHECK(angle == Approx(1.0).margin(0.03));  // the first step or so spins up
    // A limit set now stops it at 1.2 rad; taken away, the motor turns on.
    REQUIRE(sinew_joint_set_limits(hinge, 1, -1.2f, 1.2f) == SINEW_OK);
    steps(r.world, 60);
    REQUIRE(sinew_joint_get_coordinate(hinge, &angle, &speed) == SINEW_OK);
    CHECK(angle == Approx(1.2).margin(0.02));
    CHECK(std::abs(speed) < 0.05f);
    REQUIRE(sinew_joint_set_limits(hinge, 0, 0, 0) == SINEW_OK);
    steps(r.world, 10);
    REQUIRE(sinew_joint_get_coordinate(hinge, nullptr, &speed) == SINEW_OK);
    CHECK(speed == Approx(2.0).epsilon(0.01));
    // Misuse: both pointers NULL, a reversed or out-of-range limit, a ball joint's limit, a bad flag.
    const std::vector<float> before = fingerprint(r.world);
    CHECK(sinew_joint_get_coordinate(hinge, nullptr, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(sinew_joint_set_limits(hinge, 1, 1, -1) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(std::string(sinew_last_error()).find("greater than") != std::string::npos);
    CHECK(sinew_joint_set_limits(hinge, 1, -4, 4) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_joint_set_limits(hinge, 1, NAN, 0) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_joint_set_limits(hinge, 2, 0, 0) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(fingerprint(r.world) == before);
    REQUIRE(sinew_joint_destroy(hinge) == SINEW_OK);
    CHECK(sinew_joint_get_coordinate(hinge, &angle, &speed) == SINEW_ERROR_STALE_ID);
    REQUIRE(sinew_world_destroy(r.world) == SINEW_OK);

    // A slider along y under gravity: free fall, so after 0.5 s the translation is -g t^2 / 2 and the
    // speed -g t (semi-implicit Euler: within a step's worth).
    Rig s = make_rig(-kG, {0, 5, 0});
    j = joint_between(s, SINEW_JOINT_SLIDER);
    j.local_axis_a = {0, 1, 0};
    sinew_joint_id slider;
    REQUIRE(sinew_joint_create(s.world, &j, &slider) == SINEW_OK);
    steps(s.world, 30);
    float x = 0;
    REQUIRE(sinew_joint_get_coordinate(slider, &x, &speed) == SINEW_OK);
    CHECK(x == Approx(-kG * 0.25f / 2).margin(kG * 0.5f / 60));
    CHECK(speed == Approx(-kG * 0.5f).epsilon(0.01));
    CHECK(x == Approx(xf(s.bob).p.y - 5).margin(1e-4));
    REQUIRE(sinew_world_destroy(s.world) == SINEW_OK);
}

TEST_CASE("C API helpers: quaternions, interpolation and handle equality", "[capi]") {
    const sinew_quat q = sinew_quat_from_axis_angle({0, 0, 2}, kPi / 2);  // any axis length
    const sinew_vec3 y = sinew_quat_rotate(q, {1, 0, 0});
    CHECK(y.x == Approx(0).margin(1e-6));
    CHECK(y.y == Approx(1).margin(1e-6));
    const sinew_quat id = sinew_quat_from_axis_angle({0, 0, 0}, 1);
    CHECK(id.w == 1.0f);
    // Euler angles as scene files read rotation_deg (x, then y, then z about fixed axes).
    const sinew_quat e = sinew_quat_from_euler({0.3f, -0.7f, 1.1f});
    const sinew::Quat ref = sinew::quat_from_euler_xyz_deg(sinew::Vec3(0.3, -0.7, 1.1) * sinew::Real(180 / M_PI));
    CHECK(std::abs(std::abs(e.w * ref.w() + e.x * ref.x() + e.y * ref.y() + e.z * ref.z()) - 1) < 1e-5f);
    // The product applies b first: 90 degrees about z then 90 about x takes x to y, then y to z.
    const sinew_quat qx = sinew_quat_from_axis_angle({1, 0, 0}, kPi / 2);
    const sinew_vec3 z = sinew_quat_rotate(sinew_quat_multiply(qx, q), {1, 0, 0});
    CHECK(z.z == Approx(1).margin(1e-6));
    // Halfway between the identity and a 90 degree turn: 45 degrees, and the midpoint.
    const sinew_transform a = {{0, 0, 0}, {0, 0, 0, 1}}, b = {{2, 4, 0}, q};
    const sinew_transform m = sinew_transform_interpolate(a, b, 0.5f);
    CHECK(m.p.y == 2.0f);
    CHECK(2 * std::atan2(m.q.z, m.q.w) == Approx(kPi / 4).margin(1e-5));
    // The shorter arc: -q is the same rotation.
    const sinew_transform nb = {{2, 4, 0}, {-q.x, -q.y, -q.z, -q.w}};
    const sinew_transform m2 = sinew_transform_interpolate(a, nb, 0.5f);
    CHECK(std::abs(2 * std::atan2(m2.q.z, m2.q.w)) == Approx(kPi / 4).margin(1e-5));
    const sinew_body_id b1 = {1, 2, 3}, b2 = {1, 2, 4};
    CHECK(sinew_body_id_equal(b1, b1) == 1);
    CHECK(sinew_body_id_equal(b1, b2) == 0);
    CHECK(sinew_joint_id_equal({1, 2, 3}, {1, 2, 3}) == 1);
    CHECK(sinew_soft_body_id_equal({1, 2, 3}, {2, 2, 3}) == 0);
    CHECK(sinew_world_id_equal({1, 1}, {1, 1}) == 1);
}
