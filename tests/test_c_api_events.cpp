// The C API's events after a step: contact begin/end (with point, normal and impulse), sleep/wake of
// rigid bodies, joint breaks (tests/test_c_api_joints.cpp), in a deterministic order, checked against
// what the physics of a dropped box says must happen and when.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>
#include <string>

#include "tests/test_c_api_util.hpp"

using namespace capi_test;

namespace {

constexpr float kG = 9.81f;
constexpr float kH = 1.0f / 60;

sinew_body_id add_ground(sinew_world_id w) {
    sinew_body_def g = sinew_body_def_default();
    g.type = SINEW_BODY_STATIC;
    g.shape.half_extents = {10, 0.5f, 10};
    g.transform.p = {0, -0.5f, 0};  // top face at y = 0
    sinew_body_id id;
    REQUIRE(sinew_body_create(w, &g, &id) == SINEW_OK);
    return id;
}

sinew_body_id add_box(sinew_world_id w, sinew_vec3 at) {
    sinew_body_def b = sinew_body_def_default();
    b.mass = 1;
    b.transform.p = at;
    sinew_body_id id;
    REQUIRE(sinew_body_create(w, &b, &id) == SINEW_OK);
    return id;
}

sinew_events step_events(sinew_world_id w) {
    REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    sinew_events e;
    REQUIRE(sinew_world_get_events(w, &e) == SINEW_OK);
    REQUIRE(e.dropped == 0);
    return e;
}

bool same(const sinew_body_id& a, const sinew_body_id& b) {
    return a.world == b.world && a.index == b.index && a.generation == b.generation;
}

}  // namespace

TEST_CASE("C API events: a dropped box begins touching once, falls asleep once, and leaves when kicked", "[capi][events]") {
    // The begin event's impulse is the step's total (summed over the soft step's sub-steps), so the
    // landing impulse can be checked against the momentum it removes, under both solver families.
    const sinew_solver solver = GENERATE(SINEW_SOLVER_SOFT_STEP, SINEW_SOLVER_SPLIT_IMPULSE);
    INFO("solver " << int(solver));
    sinew_world_def wd = sinew_world_def_default();
    wd.solver = solver;
    sinew_world_id w;
    REQUIRE(sinew_world_create(&wd, &w) == SINEW_OK);
    const sinew_body_id ground = add_ground(w);
    const sinew_body_id box = add_box(w, {0, 1.5f, 0});  // bottom face 1 m above the ground
    int begins = 0, ends = 0, sleeps = 0, begin_step = -1, sleep_step = -1;
    sinew_vec3 v_before{0, 0, 0};
    for (int i = 1; i <= 120; ++i) {
        sinew_vec3 v_now;
        REQUIRE(sinew_body_get_velocity(box, &v_now, nullptr) == SINEW_OK);
        if (begins == 0) v_before = v_now;
        const sinew_events e = step_events(w);
        sinew_vec3 v_after;
        REQUIRE(sinew_body_get_velocity(box, &v_after, nullptr) == SINEW_OK);
        for (int k = 0; k < e.contact_begin_count; ++k) {
            const sinew_contact_begin_event& c = e.contact_begin[k];
            ++begins;
            begin_step = int(c.step);
            CHECK(c.step == uint64_t(i));
            CHECK(same(c.body_a, ground));  // lower slot first
            CHECK(same(c.body_b, box));
            // The normal points from A (ground) to B (the box).
            CHECK(c.normal.y == Approx(1.0).margin(1e-3));
            // The point lies midway between the surfaces, which are at most one step's travel apart
            // (h v = 0.074 m at 4.4 m/s, plus the 0.02 m margin): |y| < 0.05 m.
            CHECK(std::abs(c.point.y) < 0.05f);
            // Momentum balance of the 1 kg box over the step: the contact impulse is what gravity and
            // the fall brought in minus what is left, |v_before| + g h - |v_after|. The speculative
            // contact is found while a gap is still open, so the first step only lets the box close it
            // (v_after = -gap / h) and the next step stops it; 1 % covers the solver's iterations.
            CHECK(c.normal_impulse == Approx(std::abs(v_before.y) + kG * kH - std::abs(v_after.y)).epsilon(0.01));
            CHECK(c.normal_impulse > 0);
            // The hit's strength: the box's fall speed when the step began (the soft step gives gravity
            // inside the solve, split impulses before it: within g h = 0.16 m/s of |v_before|).
            CHECK(c.approach_speed == Approx(std::abs(v_before.y)).margin(kG * kH + 1e-3f));
            CHECK(c.approach_speed > 4.0f);  // sqrt(2 g 1 m) = 4.43 m/s, a step or two early
        }
        ends += e.contact_end_count;
        for (int k = 0; k < e.sleep_count; ++k) {
            ++sleeps;
            sleep_step = int(e.sleep[k].step);
            CHECK(same(e.sleep[k].body, box));
            CHECK(e.sleep[k].awake == 0);
        }
    }
    CHECK(begins == 1);
    CHECK(ends == 0);  // a resting contact persists (its manifold is kept while asleep)
    CHECK(sleeps == 1);
    // Free fall over 1 m takes sqrt(2 / g) = 0.4515 s = 27.1 steps; the speculative contact is found up
    // to two steps early.
    CHECK(begin_step >= 25);
    CHECK(begin_step <= 28);
    // Asleep after resting for sleep_time = 0.5 s = 30 steps, the landing step (which stops it) included.
    CHECK(sleep_step >= begin_step + 29);
    CHECK(sleep_step <= begin_step + 31);

    // A kick from the game wakes the box: not an event (only what a step does is reported) ...
    REQUIRE(sinew_body_apply_impulse(box, {0, 5, 0}, {0, 1, 0}) == SINEW_OK);
    sinew_events e = step_events(w);
    CHECK(e.sleep_count == 0);
    // ... it rises 5^2 / (2 g) = 1.27 m and lands 1.02 s later: the contact ends, then begins again.
    int end_step = -1;
    begin_step = -1;
    for (int i = 0; i < 90; ++i) {
        e = step_events(w);
        if (e.contact_end_count == 1 && end_step < 0) {
            end_step = int(e.contact_end[0].step);
            CHECK(same(e.contact_end[0].body_a, ground));
            CHECK(same(e.contact_end[0].body_b, box));
        }
        if (e.contact_begin_count == 1 && end_step >= 0 && begin_step < 0) begin_step = int(e.contact_begin[0].step);
    }
    CHECK(end_step > 0);
    // Time in the air: 2 v / g = 1.02 s = 61 steps, less the speculative steps at either end.
    CHECK(begin_step - end_step == Approx(61).margin(4));
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API events: a box landing on a sleeping one wakes it during the step", "[capi][events]") {
    sinew_world_id w = make_world();
    add_ground(w);
    const sinew_body_id lower = add_box(w, {0, 0.5f, 0});
    for (int i = 0; i < 60; ++i) step_events(w);
    sinew_vec3 v;
    // Asleep (velocity zeroed) after 0.5 s at rest.
    REQUIRE(sinew_body_get_velocity(lower, &v, nullptr) == SINEW_OK);
    CHECK(v.y == 0.0f);
    const sinew_body_id upper = add_box(w, {0, 2.0f, 0});  // 0.5 m above the lower box
    int wakes = 0;
    for (int i = 0; i < 30; ++i) {
        const sinew_events e = step_events(w);
        for (int k = 0; k < e.sleep_count; ++k) {
            if (e.sleep[k].awake == 1) {
                ++wakes;
                CHECK(same(e.sleep[k].body, lower));
            }
        }
        for (int k = 0; k < e.contact_begin_count; ++k) {
            CHECK(same(e.contact_begin[k].body_a, lower));
            CHECK(same(e.contact_begin[k].body_b, upper));
        }
    }
    CHECK(wakes == 1);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API events: one call's events span its fixed steps, in order, and identical runs agree", "[capi][events]") {
    auto build = [] {
        sinew_world_id w = make_world();
        add_ground(w);
        for (int i = 0; i < 12; ++i)  // a loose heap: boxes dropped with offsets, many pairs
            add_box(w, {0.3f * float(i % 3) - 0.3f, 1.0f + 1.2f * float(i), 0.25f * float(i % 2)});
        return w;
    };
    sinew_world_id a = build(), b = build();
    int total = 0;
    for (int frame = 0; frame < 40; ++frame) {
        int sa = 0, sb = 0;
        REQUIRE(sinew_world_step(a, 5 * kH, &sa, nullptr) == SINEW_OK);  // about 5 fixed steps a call
        REQUIRE(sinew_world_step(b, 5 * kH, &sb, nullptr) == SINEW_OK);
        REQUIRE(sa == sb);
        sinew_events ea, eb;
        REQUIRE(sinew_world_get_events(a, &ea) == SINEW_OK);
        REQUIRE(sinew_world_get_events(b, &eb) == SINEW_OK);
        REQUIRE(ea.contact_begin_count == eb.contact_begin_count);
        REQUIRE(ea.contact_end_count == eb.contact_end_count);
        REQUIRE(ea.sleep_count == eb.sleep_count);
        total += ea.contact_begin_count + ea.contact_end_count + ea.sleep_count;
        for (int k = 0; k < ea.contact_begin_count; ++k) {
            const sinew_contact_begin_event &x = ea.contact_begin[k], &y = eb.contact_begin[k];
            CHECK(x.body_a.index == y.body_a.index);
            CHECK(x.body_b.index == y.body_b.index);
            CHECK(x.step == y.step);
            CHECK(x.point.x == y.point.x);  // bit for bit: the same computation
            CHECK(x.normal_impulse == y.normal_impulse);
            CHECK(x.body_a.index < x.body_b.index);
            if (k > 0) {  // step order, then pair order within a step
                const sinew_contact_begin_event& p = ea.contact_begin[k - 1];
                CHECK((p.step < x.step || (p.step == x.step && (p.body_a.index < x.body_a.index ||
                                                               (p.body_a.index == x.body_a.index &&
                                                                p.body_b.index < x.body_b.index)))));
            }
        }
        for (int k = 0; k < ea.sleep_count; ++k) {
            CHECK(ea.sleep[k].body.index == eb.sleep[k].body.index);
            CHECK(ea.sleep[k].step == eb.sleep[k].step);
            if (k > 0) CHECK(ea.sleep[k - 1].step <= ea.sleep[k].step);
        }
    }
    CHECK(total > 12);  // every box lands at least once
    REQUIRE(sinew_world_destroy(a) == SINEW_OK);
    REQUIRE(sinew_world_destroy(b) == SINEW_OK);
}

TEST_CASE("C API events: bad input", "[capi][events][errors]") {
    sinew_world_id w = make_world();
    sinew_events e;
    CHECK(sinew_world_get_events(w, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("out is NULL"));
    CHECK(sinew_world_get_events(sinew_world_id{}, &e) == SINEW_ERROR_STALE_ID);
    // Before any step: empty arrays.
    REQUIRE(sinew_world_get_events(w, &e) == SINEW_OK);
    CHECK(e.contact_begin_count == 0);
    CHECK(e.sleep_count == 0);
    CHECK(e.joint_break_count == 0);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
    CHECK(sinew_world_get_events(w, &e) == SINEW_ERROR_STALE_ID);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("destroyed"));
}

TEST_CASE("C API sensors: a ball falling through a trigger box gives one begin and one end, and a query in between", "[capi][events][sensor]") {
    sinew_world_id w = make_world();
    sinew_body_def sd = sinew_body_def_default();
    sd.type = SINEW_BODY_STATIC;
    sd.is_sensor = 1;
    sd.transform.p = {0, 5, 0};  // a 1 m cube, top face at y = 5.5
    sinew_body_id sensor;
    REQUIRE(sinew_body_create(w, &sd, &sensor) == SINEW_OK);
    sinew_body_def bd = sinew_body_def_default();
    bd.shape.type = SINEW_SHAPE_SPHERE;
    bd.shape.radius = 0.25f;
    bd.transform.p = {0, 10, 0};
    bd.allow_sleep = 0;
    bd.user_data = 7;
    sinew_body_id ball;
    REQUIRE(sinew_body_create(w, &bd, &ball) == SINEW_OK);
    int begins = 0, ends = 0;
    uint64_t begin_step = 0, end_step = 0;
    int inside_while_overlapping = 0;
    for (int i = 0; i < 90; ++i) {
        const sinew_events e = step_events(w);
        for (int k = 0; k < e.sensor_begin_count; ++k) {
            CHECK(same(e.sensor_begin[k].sensor, sensor));
            CHECK(e.sensor_begin[k].is_soft == 0);
            CHECK(same(e.sensor_begin[k].body, ball));
            begin_step = e.sensor_begin[k].step;
            ++begins;
        }
        for (int k = 0; k < e.sensor_end_count; ++k) {
            CHECK(same(e.sensor_end[k].body, ball));
            end_step = e.sensor_end[k].step;
            ++ends;
        }
        int count = -1;
        sinew_sensor_event now[2];
        REQUIRE(sinew_sensor_get_overlaps(sensor, now, 2, &count) == SINEW_OK);
        if (count == 1 && same(now[0].body, ball)) ++inside_while_overlapping;
    }
    CHECK(begins == 1);
    CHECK(ends == 1);
    // Enters after falling 4.25 m, leaves after 5.75 m (within a step, as the C++ test argues).
    CHECK(std::abs(float(begin_step) * kH - std::sqrt(2 * 4.25f / kG)) <= kH);
    CHECK(std::abs(float(end_step) * kH - std::sqrt(2 * 5.75f / kG)) <= kH);
    CHECK(inside_while_overlapping == int(end_step - begin_step));
    // Misuse: NULL count, negative capacity, NULL buffer with capacity, a body that is no sensor, stale id.
    int count = 0;
    CHECK(sinew_sensor_get_overlaps(sensor, nullptr, 0, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(sinew_sensor_get_overlaps(sensor, nullptr, -1, &count) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_sensor_get_overlaps(sensor, nullptr, 3, &count) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(sinew_sensor_get_overlaps(ball, nullptr, 0, &count) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(std::string(sinew_last_error()).find("not a sensor") != std::string::npos);
    REQUIRE(sinew_body_destroy(ball) == SINEW_OK);
    CHECK(sinew_sensor_get_overlaps(ball, nullptr, 0, &count) == SINEW_ERROR_STALE_ID);
    // Body definition misuse leaves the world unchanged.
    const std::vector<float> before = fingerprint(w);
    sinew_body_def bad = sinew_body_def_default();
    bad.is_sensor = 2;
    sinew_body_id id;
    CHECK(sinew_body_create(w, &bad, &id) == SINEW_ERROR_INVALID_ARGUMENT);
    bad = sinew_body_def_default();
    bad.gravity_scale = NAN;
    CHECK(sinew_body_create(w, &bad, &id) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(std::string(sinew_last_error()).find("gravity_scale") != std::string::npos);
    bad = sinew_body_def_default();
    bad.allow_sleep = -1;
    CHECK(sinew_body_create(w, &bad, &id) == SINEW_ERROR_INVALID_ARGUMENT);
    bad = sinew_body_def_default();
    CHECK(bad.is_bullet == 0);
    bad.is_bullet = 2;
    CHECK(sinew_body_create(w, &bad, &id) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(std::string(sinew_last_error()).find("is_bullet") != std::string::npos);
    bad.is_bullet = 1;
    bad.type = SINEW_BODY_STATIC;
    CHECK(sinew_body_create(w, &bad, &id) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(std::string(sinew_last_error()).find("dynamic") != std::string::npos);
    CHECK(fingerprint(w) == before);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API body def: gravity_scale and allow_sleep are honoured at creation", "[capi][events]") {
    sinew_world_id w = make_world();
    sinew_body_def bd = sinew_body_def_default();
    bd.gravity_scale = 0;
    bd.allow_sleep = 0;
    sinew_body_id floating;
    REQUIRE(sinew_body_create(w, &bd, &floating) == SINEW_OK);
    for (int i = 0; i < 120; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(floating, &t) == SINEW_OK);
    CHECK(t.p.y == 0.0f);  // no gravity, nothing else: it stays where it was made
    int awake = 0;
    REQUIRE(sinew_body_is_awake(floating, &awake) == SINEW_OK);
    CHECK(awake == 1);  // at rest for 2 s, yet never asleep
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API body control: put to sleep in mid-air, mass data, world counters", "[capi][events]") {
    sinew_world_id w = make_world();
    const sinew_body_id ground = add_ground(w);
    sinew_body_def d = sinew_body_def_default();
    d.mass = 6;
    d.shape.half_extents = {0.5f, 0.25f, 0.125f};
    d.transform.p = {0, 3, 0};
    sinew_body_id box;
    REQUIRE(sinew_body_create(w, &d, &box) == SINEW_OK);
    // A box's inertia about its centre: m (b^2 + c^2) / 3 for half extents a, b, c.
    sinew_mass_data md;
    REQUIRE(sinew_body_get_mass_data(box, &md) == SINEW_OK);
    CHECK(md.mass == Approx(6));
    CHECK(md.inertia[0] == Approx(2 * (0.0625 + 0.015625)).epsilon(1e-5));
    CHECK(md.inertia[4] == Approx(2 * (0.25 + 0.015625)).epsilon(1e-5));
    CHECK(md.inertia[8] == Approx(2 * (0.25 + 0.0625)).epsilon(1e-5));
    CHECK(md.inertia[1] == 0.0f);
    CHECK(md.local_center.x == 0.0f);
    // Put to sleep while falling: it hangs where it is until woken, then falls on.
    for (int i = 0; i < 10; ++i) step_events(w);
    REQUIRE(sinew_body_sleep(box) == SINEW_OK);
    sinew_transform before, after;
    REQUIRE(sinew_body_get_transform(box, &before) == SINEW_OK);
    int awake = 1;
    REQUIRE(sinew_body_is_awake(box, &awake) == SINEW_OK);
    CHECK(awake == 0);
    for (int i = 0; i < 60; ++i) step_events(w);
    REQUIRE(sinew_body_get_transform(box, &after) == SINEW_OK);
    CHECK(after.p.y == before.p.y);
    REQUIRE(sinew_body_wake(box) == SINEW_OK);
    for (int i = 0; i < 120; ++i) step_events(w);
    REQUIRE(sinew_body_get_transform(box, &after) == SINEW_OK);
    CHECK(after.p.y == Approx(0.25).margin(0.01));  // on the ground
    // Counters: two bodies, one touching pair of four points, the steps taken.
    sinew_world_counters c;
    REQUIRE(sinew_world_get_counters(w, &c) == SINEW_OK);
    CHECK(c.body_count == 2);
    CHECK(c.soft_body_count == 0);
    CHECK(c.joint_count == 0);
    CHECK(c.contact_count == 1);
    CHECK(c.contact_point_count == 4);
    CHECK(c.step_count == 190);
    CHECK(c.step_ms >= 0);
    for (float ms : c.stage_ms) CHECK(ms >= 0);
    // An off-centre compound: spheres of radius 0.2 and 0.1 at x = -0.5 and 0.5 (masses 8 : 1).
    sinew_compound_child parts[2];
    for (int k = 0; k < 2; ++k) {
        parts[k].transform = {{k == 0 ? -0.5f : 0.5f, 0, 0}, {0, 0, 0, 1}};
        parts[k].shape = sinew_shape_def_default();
        parts[k].shape.type = SINEW_SHAPE_SPHERE;
        parts[k].shape.radius = k == 0 ? 0.2f : 0.1f;
    }
    sinew_body_def cd = sinew_body_def_default();
    cd.shape.type = SINEW_SHAPE_COMPOUND;
    cd.shape.children = parts;
    cd.shape.child_count = 2;
    cd.transform.p = {3, 3, 0};
    sinew_body_id lopsided;
    REQUIRE(sinew_body_create(w, &cd, &lopsided) == SINEW_OK);
    REQUIRE(sinew_body_get_mass_data(lopsided, &md) == SINEW_OK);
    CHECK(md.local_center.x == Approx((8 * -0.5 + 1 * 0.5) / 9.0).margin(1e-5));
    // Misuse.
    CHECK(sinew_body_sleep(ground) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_body_get_mass_data(box, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(sinew_world_get_counters(w, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    REQUIRE(sinew_body_destroy(box) == SINEW_OK);
    CHECK(sinew_body_sleep(box) == SINEW_ERROR_STALE_ID);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API body type and enabled state at run time", "[capi][events]") {
    sinew_world_id w = make_world();
    add_ground(w);
    const sinew_body_id box = add_box(w, {0, 3, 0});
    sinew_body_type type;
    REQUIRE(sinew_body_set_type(box, SINEW_BODY_STATIC) == SINEW_OK);
    REQUIRE(sinew_body_get_type(box, &type) == SINEW_OK);
    CHECK(type == SINEW_BODY_STATIC);
    for (int i = 0; i < 30; ++i) step_events(w);
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(box, &t) == SINEW_OK);
    CHECK(t.p.y == 3.0f);  // static: it stays up
    REQUIRE(sinew_body_set_type(box, SINEW_BODY_DYNAMIC) == SINEW_OK);
    float mass = 0;
    REQUIRE(sinew_body_get_mass(box, &mass) == SINEW_OK);
    CHECK(mass == 1.0f);  // the mass it was created with
    REQUIRE(sinew_body_set_enabled(box, 0) == SINEW_OK);
    int enabled = 1;
    REQUIRE(sinew_body_is_enabled(box, &enabled) == SINEW_OK);
    CHECK(enabled == 0);
    CHECK(sinew_body_set_velocity(box, {1, 0, 0}, {0, 0, 0}) == SINEW_ERROR_INVALID_ARGUMENT);
    for (int i = 0; i < 30; ++i) step_events(w);
    REQUIRE(sinew_body_get_transform(box, &t) == SINEW_OK);
    CHECK(t.p.y == 3.0f);  // out of the simulation
    REQUIRE(sinew_body_set_enabled(box, 1) == SINEW_OK);
    for (int i = 0; i < 90; ++i) step_events(w);
    REQUIRE(sinew_body_get_transform(box, &t) == SINEW_OK);
    CHECK(t.p.y == Approx(0.5).margin(0.01));  // fell onto the ground
    // Misuse.
    CHECK(sinew_test_set_body_type_int(box, 7) == SINEW_ERROR_INVALID_ARGUMENT);  // from C: C++ may not hold a 7
    CHECK(sinew_body_set_enabled(box, 2) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK(sinew_body_get_type(box, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(sinew_body_is_enabled(box, nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    REQUIRE(sinew_body_destroy(box) == SINEW_OK);
    CHECK(sinew_body_set_type(box, SINEW_BODY_STATIC) == SINEW_ERROR_STALE_ID);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}
