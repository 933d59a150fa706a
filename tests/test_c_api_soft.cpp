// The C API's soft bodies: creation through the builders, bulk reads, pins, attachments, particle
// positions and forces give the physics the soft layer promises; bad input is rejected with the
// documented status, a message naming the argument and value, and an unchanged world.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "tests/test_c_api_util.hpp"

using namespace capi_test;

namespace {

constexpr float kH = 1.0f / 60;  // the default fixed step
constexpr float kG = 9.81f;

std::vector<sinew_vec3> positions(sinew_soft_body_id s) {
    int n = 0;
    REQUIRE(sinew_soft_particle_count(s, &n) == SINEW_OK);
    std::vector<sinew_vec3> x(std::size_t(n) + 1);
    int got = -1;
    REQUIRE(sinew_soft_get_positions(s, x.data(), n, &got) == SINEW_OK);
    REQUIRE(got == n);
    x.resize(std::size_t(n));
    return x;
}

sinew_vec3 centre(const std::vector<sinew_vec3>& x) {
    double c[3] = {0, 0, 0};
    for (const sinew_vec3& p : x) {
        c[0] += p.x;
        c[1] += p.y;
        c[2] += p.z;
    }
    const double n = double(x.size());
    return {float(c[0] / n), float(c[1] / n), float(c[2] / n)};
}

void steps(sinew_world_id w, int n) {
    for (int i = 0; i < n; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
}

sinew_soft_body_id make_cloth(sinew_world_id w, int pins, sinew_soft_method method = SINEW_SOFT_VERLET) {
    sinew_soft_def d = sinew_soft_def_default();
    d.method = method;
    sinew_cloth_def c = sinew_cloth_def_default();
    c.origin = {0, 4, 0};
    c.edge_u = {2, 0, 0};
    c.edge_v = {0, 0, 2};
    c.pinned_corners = pins;
    sinew_soft_body_id id{};
    REQUIRE(sinew_soft_create_cloth(w, &d, &c, &id) == SINEW_OK);
    return id;
}

}  // namespace

TEST_CASE("C API soft: defaults match the C++ soft body defaults", "[capi][soft]") {
    const sinew_soft_def d = sinew_soft_def_default();
    CHECK(d.method == SINEW_SOFT_VERLET);
    CHECK(d.iterations == 10);
    CHECK(d.friction == 0.5f);
    CHECK(d.thickness == 0.01f);
    CHECK(d.links.stretch == 1000.0f);
    CHECK(d.links.bend == 100.0f);
    CHECK(d.links.fraction == 1.0f);
    CHECK(d.total_mass == 1.0f);
    CHECK(d.allow_sleep == 1);
    const sinew_cloth_def c = sinew_cloth_def_default();
    CHECK(c.nx == 16);
    CHECK(c.ny == 16);
    CHECK(c.edge_u.x == 2.0f);
    CHECK(c.edge_v.y == -2.0f);
    CHECK(c.pinned_corners == 0);
}

TEST_CASE("C API soft: a cloth hangs from its two pinned corners, which never move", "[capi][soft]") {
    sinew_world_id w = make_world();
    sinew_soft_body_id cloth = make_cloth(w, SINEW_CLOTH_PIN_00 | SINEW_CLOTH_PIN_10);
    int n = 0;
    REQUIRE(sinew_soft_particle_count(cloth, &n) == SINEW_OK);
    CHECK(n == 16 * 16);
    steps(w, 180);
    const std::vector<sinew_vec3> x = positions(cloth);
    // Pinned: exactly where they were made (inverse mass 0, never written).
    CHECK(x[0].x == 0.0f);
    CHECK(x[0].y == 4.0f);
    CHECK(x[15].x == 2.0f);
    CHECK(x[15].y == 4.0f);
    // The free edge of the 2 m cloth swings below the pins: it cannot be more than 2 m (plus the link
    // stretch Verlet leaves at 10 iterations, under 15 %) below them, and after 3 s it is well below.
    float lowest = 10;
    for (const sinew_vec3& p : x) {
        REQUIRE(std::isfinite(p.y));
        lowest = std::min(lowest, p.y);
    }
    CHECK(lowest < 4.0f - 1.0f);
    CHECK(lowest > 4.0f - 2.0f * 1.15f);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API soft: the centre of mass of a free rope falls as g t^2 / 2 under every method", "[capi][soft]") {
    const sinew_soft_method methods[] = {SINEW_SOFT_VERLET, SINEW_SOFT_EXPLICIT, SINEW_SOFT_SEMI_IMPLICIT,
                                         SINEW_SOFT_IMPLICIT, SINEW_SOFT_FAST_MS};
    for (sinew_soft_method m : methods) {
        CAPTURE(int(m));
        sinew_world_id w = make_world();
        sinew_soft_def d = sinew_soft_def_default();
        d.method = m;
        // Soft links keep the explicit integrators inside their stability limit (omega h < 2 for the
        // chain's highest mode, 2 sqrt(k / m) h = 1.1 here); the internal forces cancel in the sum anyway.
        d.links.stretch = 100;
        d.links.damping = 0.1f;
        sinew_soft_body_id rope;
        REQUIRE(sinew_soft_create_rope(w, &d, {0, 10, 0}, {1, 10, 0}, 10, &rope) == SINEW_OK);
        const int n = 30;
        steps(w, n);
        const float t = n * kH;
        const sinew_vec3 c = centre(positions(rope));
        // Link forces are equal and opposite: the centre of mass moves under gravity alone. Every method
        // starts at rest with a first-order step, which puts it within g h t / 2 of the exact parabola
        // (x_n = g h^2 n (n +- 1) / 2 against g (n h)^2 / 2); float rounding adds ~1e-5 m.
        CHECK(std::abs(c.y - (10.0f - 0.5f * kG * t * t)) <= 0.5f * kG * kH * t + 1e-4f);
        CHECK(std::abs(c.x - 0.5f) < 1e-4f);
        REQUIRE(sinew_world_destroy(w) == SINEW_OK);
    }
}

TEST_CASE("C API soft: builders make the particle counts their geometry implies", "[capi][soft]") {
    sinew_world_id w = make_world();
    const sinew_soft_def d = sinew_soft_def_default();
    for (int s = 0; s <= 2; ++s) {
        sinew_soft_body_id ball;
        REQUIRE(sinew_soft_create_icosphere(w, &d, {0, 5, 0}, 0.5f, s, &ball) == SINEW_OK);
        int n = 0;
        REQUIRE(sinew_soft_particle_count(ball, &n) == SINEW_OK);
        CHECK(n == 10 * (1 << (2 * s)) + 2);  // a subdivided icosahedron: 10 * 4^s + 2 vertices
    }
    sinew_soft_body_id rope;
    REQUIRE(sinew_soft_create_rope(w, &d, {0, 1, 0}, {0, 2, 0}, 7, &rope) == SINEW_OK);
    int n = 0;
    REQUIRE(sinew_soft_particle_count(rope, &n) == SINEW_OK);
    CHECK(n == 8);
    const sinew_vec3 v[4] = {{0, 1, 0}, {1, 1, 0}, {0, 1, 1}, {0, 2, 0}};
    const uint32_t tri[12] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3};
    sinew_soft_body_id tet;
    REQUIRE(sinew_soft_create_mesh(w, &d, v, 4, tri, 12, 1, &tet) == SINEW_OK);
    const std::vector<sinew_vec3> x = positions(tet);
    REQUIRE(x.size() == 4);
    CHECK(x[3].y == 2.0f);
    int count = 0;
    REQUIRE(sinew_world_soft_body_count(w, &count) == SINEW_OK);
    CHECK(count == 5);
    sinew_soft_body_id ids[8];
    REQUIRE(sinew_world_get_soft_bodies(w, ids, 8, &count) == SINEW_OK);
    CHECK(count == 5);
    CHECK(ids[4].index == tet.index);
    CHECK(ids[4].generation == tet.generation);
    // A pressure body: an icosphere with pressure keeps its volume, so its top stays up.
    sinew_soft_def p = d;
    p.method = SINEW_SOFT_SEMI_IMPLICIT;
    p.pressure = 100;
    sinew_soft_body_id balloon;
    CHECK(sinew_soft_create_icosphere(w, &p, {5, 5, 0}, 0.5f, 1, &balloon) == SINEW_OK);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API soft: an attached particle follows its rigid point, detached it falls", "[capi][soft]") {
    sinew_world_id w = make_world();
    sinew_body_def k = sinew_body_def_default();
    k.type = SINEW_BODY_KINEMATIC;
    k.transform.p = {0, 5, 0};
    k.linear_velocity = {1, 0, 0};
    k.shape.half_extents = {0.2f, 0.2f, 0.2f};
    sinew_body_id carrier;
    REQUIRE(sinew_body_create(w, &k, &carrier) == SINEW_OK);
    sinew_soft_def d = sinew_soft_def_default();
    sinew_soft_body_id rope;
    REQUIRE(sinew_soft_create_rope(w, &d, {0, 4.5f, 0}, {0, 2.5f, 0}, 8, &rope) == SINEW_OK);
    REQUIRE(sinew_soft_attach(rope, 0, carrier, {0, -0.5f, 0}) == SINEW_OK);
    steps(w, 60);
    sinew_transform t;
    REQUIRE(sinew_body_get_transform(carrier, &t) == SINEW_OK);
    CHECK(t.p.x == Approx(1.0).margin(1e-4));  // 1 m/s for 1 s
    std::vector<sinew_vec3> x = positions(rope);
    // The particle is placed on the body's end-of-step point every step (one-way coupling).
    CHECK(x[0].x == Approx(t.p.x).margin(1e-5));
    CHECK(x[0].y == Approx(t.p.y - 0.5f).margin(1e-5));
    // The rest hangs below it: the rope's far end is below the attached end.
    CHECK(x[8].y < x[0].y - 1.0f);

    // Detached, the particle is free: from rest-ish it falls under gravity.
    REQUIRE(sinew_soft_detach(rope, 0) == SINEW_OK);
    const float y0 = x[0].y;
    steps(w, 30);
    x = positions(rope);
    CHECK(x[0].y < y0 - 0.1f);

    // Re-attached, then the rigid body destroyed: the particle stays where it was (still kinematic).
    REQUIRE(sinew_soft_attach(rope, 0, carrier, {0, -0.5f, 0}) == SINEW_OK);
    steps(w, 2);
    REQUIRE(sinew_body_destroy(carrier) == SINEW_OK);
    const sinew_vec3 held = positions(rope)[0];
    steps(w, 30);
    const sinew_vec3 after = positions(rope)[0];
    CHECK(after.x == held.x);
    CHECK(after.y == held.y);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API soft: pinning, unpinning and teleporting particles", "[capi][soft]") {
    for (sinew_soft_method m : {SINEW_SOFT_VERLET, SINEW_SOFT_FAST_MS}) {
        CAPTURE(int(m));
        sinew_world_id w = make_world();
        sinew_soft_body_id cloth = make_cloth(w, SINEW_CLOTH_PIN_00 | SINEW_CLOTH_PIN_10, m);
        steps(w, 30);
        // Pin a free particle where it is: it stays exactly there.
        const sinew_vec3 p100 = positions(cloth)[100];
        REQUIRE(sinew_soft_set_pinned(cloth, 100, 1) == SINEW_OK);
        steps(w, 30);
        CHECK(positions(cloth)[100].x == p100.x);
        CHECK(positions(cloth)[100].y == p100.y);
        CHECK(positions(cloth)[100].z == p100.z);
        // Unpin a corner: it falls (the cloth pulls it down and nothing holds it).
        REQUIRE(sinew_soft_set_pinned(cloth, 15, 0) == SINEW_OK);
        steps(w, 30);
        CHECK(positions(cloth)[15].y < 4.0f - 0.1f);
        // Teleport: read back exactly.
        REQUIRE(sinew_soft_set_particle_position(cloth, 200, {7, 8, 9}) == SINEW_OK);
        const sinew_vec3 q = positions(cloth)[200];
        CHECK(q.x == 7.0f);
        CHECK(q.y == 8.0f);
        CHECK(q.z == 9.0f);
        REQUIRE(sinew_world_destroy(w) == SINEW_OK);
    }
}

TEST_CASE("C API soft: a particle force changes the body's momentum by F h", "[capi][soft]") {
    sinew_world_id w = make_world(0.0f);  // no gravity
    sinew_soft_def d = sinew_soft_def_default();
    d.method = SINEW_SOFT_SEMI_IMPLICIT;
    d.total_mass = 1;
    // Symplectic Euler is stable while the chain's highest mode has 2 sqrt(k / m) h < 2: with 0.2 kg
    // particles that needs k < 720 N/m at 60 Hz (the default 1000 N/m would blow up).
    d.links.stretch = 100;
    sinew_soft_body_id rope;
    REQUIRE(sinew_soft_create_rope(w, &d, {0, 0, 0}, {0, 1, 0}, 4, &rope) == SINEW_OK);
    const float x0 = centre(positions(rope)).x;
    REQUIRE(sinew_soft_apply_particle_force(rope, 0, {2, 0, 0}) == SINEW_OK);  // for one step only
    const int n = 60;
    steps(w, n);
    // Symplectic Euler: the step with the force gives the body momentum F h; link forces are internal,
    // so the centre of mass then drifts at F h / M: after n steps it moved n h (F h / M).
    const float expected = float(n) * kH * (2.0f * kH / 1.0f);
    CHECK(centre(positions(rope)).x - x0 == Approx(expected).epsilon(1e-3));
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API soft: bulk reads write at most capacity particles", "[capi][soft]") {
    sinew_world_id w = make_world();
    sinew_soft_body_id cloth = make_cloth(w, 0);
    sinew_vec3 buf[10];
    int count = -1;
    REQUIRE(sinew_soft_get_positions(cloth, buf, 10, &count) == SINEW_OK);
    CHECK(count == 10);
    CHECK(buf[1].x == Approx(2.0 / 15).margin(1e-6));  // node (1, 0): one 15th of edge_u
    REQUIRE(sinew_soft_get_positions(cloth, nullptr, 0, &count) == SINEW_OK);
    CHECK(count == 0);
    uint64_t ud = 1;
    REQUIRE(sinew_soft_user_data(cloth, &ud) == SINEW_OK);
    CHECK(ud == 0);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API soft: bad input is rejected with a status, a message and an unchanged world", "[capi][soft][errors]") {
    sinew_world_id w = make_world();
    sinew_body_def gd = sinew_body_def_default();
    gd.type = SINEW_BODY_STATIC;
    sinew_body_id ground;
    REQUIRE(sinew_body_create(w, &gd, &ground) == SINEW_OK);
    sinew_soft_body_id cloth = make_cloth(w, SINEW_CLOTH_PIN_00);
    steps(w, 3);
    const std::vector<float> before = fingerprint(w);
    auto expect = [&](sinew_status got, sinew_status want, const char* fragment) {
        expect_rejected(w, before, got, want, fragment);
    };
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const sinew_soft_def ok = sinew_soft_def_default();
    const sinew_cloth_def cok = sinew_cloth_def_default();
    sinew_soft_body_id out;

    SECTION("creation: pointers, world and definition") {
        expect(sinew_soft_create_cloth(w, nullptr, &cok, &out), SINEW_ERROR_NULL_ARGUMENT, "def is NULL");
        expect(sinew_soft_create_cloth(w, &ok, nullptr, &out), SINEW_ERROR_NULL_ARGUMENT, "cloth is NULL");
        expect(sinew_soft_create_cloth(w, &ok, &cok, nullptr), SINEW_ERROR_NULL_ARGUMENT, "out is NULL");
        expect(sinew_soft_create_cloth(sinew_world_id{}, &ok, &cok, &out), SINEW_ERROR_STALE_ID, "null handle");
        struct Case {
            void (*edit)(sinew_soft_def&);
            const char* fragment;
        };
        const Case cases[] = {
            {[](sinew_soft_def& d) { poke(d.method, 9); }, "def->method = 9"},
            {[](sinew_soft_def& d) { d.total_mass = 0; }, "def->total_mass = 0"},
            {[](sinew_soft_def& d) { d.total_mass = -1; }, "def->total_mass = -1"},
            {[](sinew_soft_def& d) { d.total_mass = std::numeric_limits<float>::quiet_NaN(); }, "def->total_mass = nan"},
            {[](sinew_soft_def& d) { d.iterations = 0; }, "def->iterations = 0"},
            {[](sinew_soft_def& d) { d.drag = -1; }, "def->drag = -1"},
            {[](sinew_soft_def& d) { d.friction = std::numeric_limits<float>::infinity(); }, "def->friction = inf"},
            {[](sinew_soft_def& d) { d.restitution = 2; }, "def->restitution = 2"},
            {[](sinew_soft_def& d) { d.thickness = 0; }, "def->thickness = 0"},
            {[](sinew_soft_def& d) { d.pressure = -3; }, "def->pressure = -3"},
            {[](sinew_soft_def& d) { d.long_range_attachments = 3; }, "def->long_range_attachments = 3"},
            {[](sinew_soft_def& d) { d.links.stretch = std::numeric_limits<float>::quiet_NaN(); }, "def->links.stretch = nan"},
            {[](sinew_soft_def& d) { d.links.damping = -1; }, "def->links.damping = -1"},
            {[](sinew_soft_def& d) { d.links.fraction = 0; }, "def->links.fraction = 0"},
            {[](sinew_soft_def& d) { d.velocity.y = std::numeric_limits<float>::quiet_NaN(); }, "def->velocity"},
            {[](sinew_soft_def& d) { d.gravity_scale = std::numeric_limits<float>::infinity(); }, "def->gravity_scale"},
            {[](sinew_soft_def& d) { d.allow_sleep = 2; }, "def->allow_sleep = 2"},
        };
        for (const Case& c : cases) {
            sinew_soft_def bad = ok;
            c.edit(bad);
            CAPTURE(c.fragment);
            expect(sinew_soft_create_cloth(w, &bad, &cok, &out), SINEW_ERROR_INVALID_ARGUMENT, c.fragment);
            expect(sinew_soft_create_rope(w, &bad, {0, 0, 0}, {1, 0, 0}, 4, &out), SINEW_ERROR_INVALID_ARGUMENT, c.fragment);
        }
        // A pressure body needs a closed surface: the soft layer's own check (SoftError) names it.
        sinew_soft_def pressured = ok;
        pressured.pressure = 10;
        expect(sinew_soft_create_cloth(w, &pressured, &cok, &out), SINEW_ERROR_INVALID_ARGUMENT, "closed");
    }
    SECTION("creation: builder parameters") {
        sinew_cloth_def c = cok;
        c.nx = 1;
        expect(sinew_soft_create_cloth(w, &ok, &c, &out), SINEW_ERROR_INVALID_ARGUMENT, "cloth->nx = 1");
        c = cok;
        c.ny = 5000;
        expect(sinew_soft_create_cloth(w, &ok, &c, &out), SINEW_ERROR_INVALID_ARGUMENT, "cloth->ny = 5000");
        c = cok;
        c.edge_v = {4, 0, 0};  // parallel to edge_u
        expect(sinew_soft_create_cloth(w, &ok, &c, &out), SINEW_ERROR_INVALID_ARGUMENT, "not parallel");
        c = cok;
        c.origin.z = nan;
        expect(sinew_soft_create_cloth(w, &ok, &c, &out), SINEW_ERROR_INVALID_ARGUMENT, "cloth->origin");
        c = cok;
        c.pinned_corners = 16;
        expect(sinew_soft_create_cloth(w, &ok, &c, &out), SINEW_ERROR_INVALID_ARGUMENT, "cloth->pinned_corners = 16");
        c = cok;
        c.shear = 2;
        expect(sinew_soft_create_cloth(w, &ok, &c, &out), SINEW_ERROR_INVALID_ARGUMENT, "cloth->shear = 2");
        expect(sinew_soft_create_rope(w, &ok, {1, 1, 1}, {1, 1, 1}, 4, &out), SINEW_ERROR_INVALID_ARGUMENT, "same point");
        expect(sinew_soft_create_rope(w, &ok, {0, 0, 0}, {1, 0, 0}, 0, &out), SINEW_ERROR_INVALID_ARGUMENT, "segments = 0");
        expect(sinew_soft_create_rope(w, &ok, {nan, 0, 0}, {1, 0, 0}, 3, &out), SINEW_ERROR_INVALID_ARGUMENT, "from = (nan");
        expect(sinew_soft_create_icosphere(w, &ok, {0, 0, 0}, 0, 1, &out), SINEW_ERROR_INVALID_ARGUMENT, "radius = 0");
        expect(sinew_soft_create_icosphere(w, &ok, {0, 0, 0}, -1, 1, &out), SINEW_ERROR_INVALID_ARGUMENT, "radius = -1");
        expect(sinew_soft_create_icosphere(w, &ok, {0, nan, 0}, 1, 1, &out), SINEW_ERROR_INVALID_ARGUMENT, "center");
        expect(sinew_soft_create_icosphere(w, &ok, {0, 0, 0}, 1, 7, &out), SINEW_ERROR_INVALID_ARGUMENT, "subdivisions = 7");

        const sinew_vec3 v[4] = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {0, 1, 0}};
        const uint32_t tri[6] = {0, 2, 1, 0, 1, 3};
        expect(sinew_soft_create_mesh(w, &ok, nullptr, 4, tri, 6, 1, &out), SINEW_ERROR_NULL_ARGUMENT, "vertices is NULL");
        expect(sinew_soft_create_mesh(w, &ok, v, 4, nullptr, 6, 1, &out), SINEW_ERROR_NULL_ARGUMENT, "indices is NULL");
        expect(sinew_soft_create_mesh(w, &ok, v, 0, tri, 6, 1, &out), SINEW_ERROR_INVALID_ARGUMENT, "vertex_count = 0");
        expect(sinew_soft_create_mesh(w, &ok, v, 4, tri, 4, 1, &out), SINEW_ERROR_INVALID_ARGUMENT, "index_count = 4");
        expect(sinew_soft_create_mesh(w, &ok, v, 3, tri, 6, 1, &out), SINEW_ERROR_INVALID_ARGUMENT, "indices[5] = 3 is out of range");
        expect(sinew_soft_create_mesh(w, &ok, v, 4, tri, 6, 0, &out), SINEW_ERROR_INVALID_ARGUMENT, "link_distance = 0");
        sinew_vec3 vn[4] = {v[0], v[1], v[2], v[3]};
        vn[2].x = nan;
        expect(sinew_soft_create_mesh(w, &ok, vn, 4, tri, 6, 1, &out), SINEW_ERROR_INVALID_ARGUMENT, "vertices[2]");
        const sinew_vec3 line[3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};  // a zero-area triangle
        const uint32_t one[3] = {0, 1, 2};
        expect(sinew_soft_create_mesh(w, &ok, line, 3, one, 3, 1, &out), SINEW_ERROR_INVALID_ARGUMENT, "sinew_soft_create_mesh: ");
    }
    SECTION("handles") {
        expect(sinew_soft_destroy(sinew_soft_body_id{}), SINEW_ERROR_STALE_ID, "null handle");
        sinew_soft_body_id gone = cloth;
        gone.generation += 1;
        expect(sinew_soft_destroy(gone), SINEW_ERROR_STALE_ID, "destroyed");
        int n;
        expect(sinew_soft_particle_count(gone, &n), SINEW_ERROR_STALE_ID, "destroyed");
        sinew_world_id other = make_world();
        sinew_soft_body_id foreign = make_cloth(other, 0);
        REQUIRE(sinew_world_destroy(other) == SINEW_OK);
        expect(sinew_soft_set_particle_position(foreign, 0, {0, 0, 0}), SINEW_ERROR_STALE_ID, "destroyed or was never created");
    }
    SECTION("reads") {
        sinew_vec3 buf[4];
        int n;
        expect(sinew_soft_particle_count(cloth, nullptr), SINEW_ERROR_NULL_ARGUMENT, "out is NULL");
        expect(sinew_soft_get_positions(cloth, buf, 4, nullptr), SINEW_ERROR_NULL_ARGUMENT, "count is NULL");
        expect(sinew_soft_get_positions(cloth, buf, -1, &n), SINEW_ERROR_INVALID_ARGUMENT, "capacity = -1");
        expect(sinew_soft_get_positions(cloth, nullptr, 4, &n), SINEW_ERROR_NULL_ARGUMENT, "positions is NULL");
        expect(sinew_soft_user_data(cloth, nullptr), SINEW_ERROR_NULL_ARGUMENT, "out is NULL");
        expect(sinew_world_get_soft_bodies(w, nullptr, 2, &n), SINEW_ERROR_NULL_ARGUMENT, "ids is NULL");
        expect(sinew_world_get_soft_bodies(w, &out, -2, &n), SINEW_ERROR_INVALID_ARGUMENT, "capacity = -2");
        expect(sinew_world_soft_body_count(w, nullptr), SINEW_ERROR_NULL_ARGUMENT, "out is NULL");
    }
    SECTION("particles") {
        expect(sinew_soft_set_pinned(cloth, -1, 1), SINEW_ERROR_INVALID_ARGUMENT, "particle = -1 is out of range (256 particles)");
        expect(sinew_soft_set_pinned(cloth, 256, 1), SINEW_ERROR_INVALID_ARGUMENT, "particle = 256");
        expect(sinew_soft_set_pinned(cloth, 3, 2), SINEW_ERROR_INVALID_ARGUMENT, "pinned = 2");
        expect(sinew_soft_set_particle_position(cloth, 3, {0, nan, 0}), SINEW_ERROR_INVALID_ARGUMENT, "position = (0, nan, 0)");
        expect(sinew_soft_set_particle_position(cloth, 999, {0, 0, 0}), SINEW_ERROR_INVALID_ARGUMENT, "particle = 999");
        expect(sinew_soft_apply_particle_force(cloth, 3, {nan, 0, 0}), SINEW_ERROR_INVALID_ARGUMENT, "force = (nan");
        expect(sinew_soft_apply_particle_force(cloth, -5, {1, 0, 0}), SINEW_ERROR_INVALID_ARGUMENT, "particle = -5");
        expect(sinew_soft_detach(cloth, 3), SINEW_ERROR_INVALID_ARGUMENT, "not attached");
        expect(sinew_soft_attach(cloth, 3, ground, {nan, 0, 0}), SINEW_ERROR_INVALID_ARGUMENT, "local_point");
        expect(sinew_soft_attach(cloth, 300, ground, {0, 0, 0}), SINEW_ERROR_INVALID_ARGUMENT, "particle = 300");
        expect(sinew_soft_attach(cloth, 3, sinew_body_id{}, {0, 0, 0}), SINEW_ERROR_STALE_ID, "rigid_body");
        sinew_world_id other = make_world();
        sinew_body_id elsewhere;
        REQUIRE(sinew_body_create(other, &gd, &elsewhere) == SINEW_OK);
        expect(sinew_soft_attach(cloth, 3, elsewhere, {0, 0, 0}), SINEW_ERROR_STALE_ID, "not to the soft body's world");
        REQUIRE(sinew_world_destroy(other) == SINEW_OK);
    }
    SECTION("an attached particle cannot be unpinned") {
        REQUIRE(sinew_soft_attach(cloth, 5, ground, {0, 0, 0}) == SINEW_OK);
        const std::vector<float> attached = fingerprint(w);
        expect_rejected(w, attached, sinew_soft_set_pinned(cloth, 5, 0), SINEW_ERROR_INVALID_ARGUMENT, "detach it first");
    }
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API soft: calls that change a stepping world are rejected with SINEW_ERROR_IN_STEP", "[capi][soft][errors]") {
    sinew_world_id w = make_world();
    sinew_body_def gd = sinew_body_def_default();
    gd.type = SINEW_BODY_STATIC;
    gd.transform.p = {-50, 0, 0};
    sinew_body_id ground;
    REQUIRE(sinew_body_create(w, &gd, &ground) == SINEW_OK);
    sinew_soft_body_id cloth = make_cloth(w, SINEW_CLOTH_PIN_00);
    std::vector<sinew_status> got;
    int count_during_step = -1;
    run_during_step(w, [&] {
        const sinew_soft_def d = sinew_soft_def_default();
        const sinew_cloth_def c = sinew_cloth_def_default();
        sinew_soft_body_id out;
        const sinew_vec3 v[3] = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}};
        const uint32_t tri[3] = {0, 1, 2};
        got = {sinew_soft_create_cloth(w, &d, &c, &out),
               sinew_soft_create_rope(w, &d, {0, 0, 0}, {1, 0, 0}, 2, &out),
               sinew_soft_create_icosphere(w, &d, {0, 0, 0}, 1, 0, &out),
               sinew_soft_create_mesh(w, &d, v, 3, tri, 3, 1, &out),
               sinew_soft_destroy(cloth),
               sinew_soft_set_pinned(cloth, 7, 1),
               sinew_soft_attach(cloth, 7, ground, {0, 0, 0}),
               sinew_soft_detach(cloth, 7),
               sinew_soft_set_particle_position(cloth, 7, {9, 9, 9}),
               sinew_soft_apply_particle_force(cloth, 7, {1, 0, 0})};
        // Reading is allowed while stepping.
        if (sinew_soft_particle_count(cloth, &count_during_step) != SINEW_OK) count_during_step = -2;
    });
    REQUIRE(got.size() == 10);
    for (sinew_status s : got) CHECK(s == SINEW_ERROR_IN_STEP);
    CHECK(count_during_step == 256);
    int softs = 0;
    REQUIRE(sinew_world_soft_body_count(w, &softs) == SINEW_OK);
    CHECK(softs == 1);  // nothing created, nothing destroyed
    CHECK(positions(cloth)[7].x != 9.0f);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

// ---- FEM solids ------------------------------------------------------------------------------------

namespace {

sinew_soft_def fem_def() {
    sinew_soft_def d = sinew_soft_def_default();
    d.method = SINEW_SOFT_IMPLICIT;
    d.iterations = 100;
    return d;
}

}  // namespace

TEST_CASE("C API soft: a tet box falls, lands on the ground and keeps its shape", "[capi][soft][fem]") {
    sinew_world_id w = make_world();
    sinew_body_def gd = sinew_body_def_default();
    gd.type = SINEW_BODY_STATIC;
    gd.transform.p = {0, -0.5f, 0};
    gd.shape.half_extents = {10, 0.5f, 10};
    sinew_body_id ground;
    REQUIRE(sinew_body_create(w, &gd, &ground) == SINEW_OK);
    sinew_fem_material m = sinew_fem_material_default();
    m.young = 2e5f;
    m.mass_damping = 1;
    const sinew_soft_def d = fem_def();
    sinew_soft_body_id s{};
    REQUIRE(sinew_soft_create_tet_box(w, &d, &m, {-0.3f, 1, -0.3f}, {0.6f, 0.4f, 0.6f}, 6, 4, 6, 5, &s) == SINEW_OK);
    int n = 0, tets = 0;
    REQUIRE(sinew_soft_particle_count(s, &n) == SINEW_OK);
    REQUIRE(sinew_soft_tet_count(s, &tets) == SINEW_OK);
    CHECK(n == 7 * 5 * 7);
    CHECK(tets == 5 * 6 * 4 * 6);
    steps(w, 180);
    const std::vector<sinew_vec3> x = positions(s);
    float lowest = 1e9f, highest = -1e9f;
    for (const sinew_vec3& p : x) {
        lowest = std::min(lowest, p.y);
        highest = std::max(highest, p.y);
    }
    INFO("lowest node " << lowest << " m, highest " << highest << " m");
    // On the ground (its top is y = 0; particles are 1 cm spheres), upright and not flattened: its 0.4 m
    // height within 10% (its own weight squashes the bottom by rho g H / E = 2%; 3 s after landing it still
    // moves: measured 0.375 m top to bottom).
    CHECK(lowest == Approx(0.01).margin(0.005));
    CHECK(highest > 0.37f);
    CHECK(highest < 0.42f);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API soft: tet meshes from arrays, pins, materials and bad input", "[capi][soft][fem]") {
    sinew_world_id w = make_world();
    const sinew_soft_def d = fem_def();
    const sinew_fem_material m = sinew_fem_material_default();
    // One tet, three nodes pinned: the fourth hangs below them under gravity.
    const sinew_vec3 nodes[4] = {{0, 1, 0}, {1, 1, 0}, {0, 1, 1}, {0, 0, 0}};
    const uint32_t tet_ok[4] = {0, 1, 2, 3};
    sinew_soft_body_id s{};
    REQUIRE(sinew_soft_create_tet_mesh(w, &d, &m, nodes, 4, tet_ok, 1, &s) == SINEW_OK);
    for (int i = 0; i < 3; ++i) REQUIRE(sinew_soft_set_pinned(s, i, 1) == SINEW_OK);
    steps(w, 120);
    const float sag = positions(s)[3].y;
    CHECK(sag < 0.0f);  // it stretched down
    CHECK(sag > -0.5f);
    // A stiffer material sags less.
    sinew_fem_material stiff = m;
    stiff.young = 1e7f;
    REQUIRE(sinew_soft_set_fem_material(s, &stiff) == SINEW_OK);
    steps(w, 240);
    CHECK(positions(s)[3].y > sag);

    const auto refused = [&](sinew_status status, const char* text) {
        CHECK(status == SINEW_ERROR_INVALID_ARGUMENT);
        CHECK_THAT(sinew_last_error(), Catch::Contains(text));
    };
    int before = 0;
    REQUIRE(sinew_world_soft_body_count(w, &before) == SINEW_OK);
    sinew_soft_body_id bad{};
    const uint32_t tet_inverted[4] = {0, 2, 1, 3};
    refused(sinew_soft_create_tet_mesh(w, &d, &m, nodes, 4, tet_inverted, 1, &bad), "tet 0 (nodes 0 2 1 3) has volume -0.1666");
    const uint32_t tet_range[4] = {0, 1, 2, 9};
    refused(sinew_soft_create_tet_mesh(w, &d, &m, nodes, 4, tet_range, 1, &bad), "tet 0 refers to node 9");
    sinew_vec3 nan_nodes[4] = {nodes[0], nodes[1], nodes[2], {std::nanf(""), 0, 0}};
    refused(sinew_soft_create_tet_mesh(w, &d, &m, nan_nodes, 4, tet_ok, 1, &bad), "nodes[3]");
    sinew_fem_material half = m;
    half.poisson = 0.5f;
    refused(sinew_soft_create_tet_mesh(w, &d, &half, nodes, 4, tet_ok, 1, &bad), "material->poisson = 0.5");
    sinew_fem_material negative = m;
    negative.young = -1;
    refused(sinew_soft_create_tet_box(w, &d, &negative, {0, 0, 0}, {1, 1, 1}, 2, 2, 2, 5, &bad), "material->young = -1");
    sinew_soft_def verlet = d;
    verlet.method = SINEW_SOFT_VERLET;
    refused(sinew_soft_create_tet_box(w, &verlet, &m, {0, 0, 0}, {1, 1, 1}, 2, 2, 2, 5, &bad), "needs SINEW_SOFT_IMPLICIT");
    refused(sinew_soft_create_tet_box(w, &d, &m, {0, 0, 0}, {1, 1, 1}, 2, 2, 2, 7, &bad), "split = 7");
    refused(sinew_soft_set_fem_material(s, &half), "material->poisson");
    int after = 0;
    REQUIRE(sinew_world_soft_body_count(w, &after) == SINEW_OK);
    CHECK(after == before);
    // A cloth is not a solid.
    const sinew_soft_body_id cloth = make_cloth(w, 0);
    int tets = -1;
    REQUIRE(sinew_soft_tet_count(cloth, &tets) == SINEW_OK);
    CHECK(tets == 0);
    refused(sinew_soft_set_fem_material(cloth, &m), "no tets");
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API soft: a stiff cantilever of quadratic tets with the rest-factor preconditioner", "[capi][soft][fem]") {
    // The bench's cantilever (1 x 0.1 x 0.1 m, E = 1e8 Pa, 20 x 2 x 2 cells) from plain C calls: clamped at
    // x = 0 and settled with mass damping, its tip sags to Euler-Bernoulli's 14.715 mm within 2% (the
    // quadratic mesh's own error is 0.7%; linear tets on these cells reach 0.64 of it).
    sinew_world_id w = make_world();
    sinew_soft_def d = fem_def();
    d.tet_order = 2;
    d.preconditioner = SINEW_PRECONDITIONER_REST_FACTOR;
    d.iterations = 200;
    sinew_fem_material m = sinew_fem_material_default();
    m.young = 1e8f;
    m.mass_damping = 40;
    sinew_soft_body_id beam{};
    REQUIRE(sinew_soft_create_tet_box(w, &d, &m, {0, 1, -0.05f}, {1, 0.1f, 0.1f}, 20, 2, 2, 6, &beam) == SINEW_OK);
    int n = 0;
    REQUIRE(sinew_soft_particle_count(beam, &n) == SINEW_OK);
    CHECK(n == 41 * 5 * 5);  // the 21 x 3 x 3 corners and a node on every edge: the 41 x 5 x 5 half-grid
    const std::vector<sinew_vec3> rest = positions(beam);
    for (int i = 0; i < n; ++i)
        if (rest[std::size_t(i)].x < 1e-6f) REQUIRE(sinew_soft_set_pinned(beam, i, 1) == SINEW_OK);
    steps(w, 240);
    const std::vector<sinew_vec3> x = positions(beam);
    double sag = 0;
    int count = 0;
    for (int i = 0; i < n; ++i)
        if (rest[std::size_t(i)].x > 1 - 1e-6f) sag += double(rest[std::size_t(i)].y - x[std::size_t(i)].y), ++count;
    sag /= count;
    INFO("tip sag " << sag << " m");
    CHECK(sag == Approx(0.014715).epsilon(0.02));

    sinew_soft_body_id bad{};
    sinew_soft_def order3 = d;
    order3.tet_order = 3;
    CHECK(sinew_soft_create_tet_box(w, &order3, &m, {0, 3, 0}, {1, 1, 1}, 2, 2, 2, 5, &bad) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK_THAT(sinew_last_error(), Catch::Contains("def->tet_order = 3"));
    sinew_soft_def self2 = d;
    self2.self_collision = 2;
    CHECK(sinew_soft_create_tet_box(w, &self2, &m, {0, 3, 0}, {1, 1, 1}, 2, 2, 2, 5, &bad) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK_THAT(sinew_last_error(), Catch::Contains("def->self_collision = 2"));
    sinew_fem_material plastic = m;
    plastic.creep = 1;
    plastic.max_plastic = 0.1f;
    CHECK(sinew_soft_set_fem_material(beam, &plastic) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK_THAT(sinew_last_error(), Catch::Contains("needs linear tets"));
    sinew_soft_def cloth = sinew_soft_def_default();
    cloth.method = SINEW_SOFT_IMPLICIT;
    cloth.preconditioner = SINEW_PRECONDITIONER_REST_FACTOR;
    sinew_cloth_def c = sinew_cloth_def_default();
    CHECK(sinew_soft_create_cloth(w, &cloth, &c, &bad) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK_THAT(sinew_last_error(), Catch::Contains("rest-factor is for FEM bodies"));
    sinew_soft_def relax = sinew_soft_def_default();
    relax.relaxation = static_cast<sinew_soft_relaxation>(7);
    CHECK(sinew_soft_create_cloth(w, &relax, &c, &bad) == SINEW_ERROR_INVALID_ARGUMENT);
    CHECK_THAT(sinew_last_error(), Catch::Contains("def->relaxation = 7"));
    int count_after = 0;
    REQUIRE(sinew_world_soft_body_count(w, &count_after) == SINEW_OK);
    CHECK(count_after == 1);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}
