// Helpers shared by the C API test files (tests/test_c_api_*.cpp): storing out-of-range enums the way a C
// caller can, a fingerprint of a world's whole state (to check that a rejected call changed nothing), and
// a way to run calls while a world is stepping (from the log callback, when a joint breaks mid-step).
#pragma once

#include <catch2/catch.hpp>

#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "engine/api/sinew.h"

// Calls with an enum argument given as an int, made from C (tests/c_api_enum_calls.c).
extern "C" {
sinew_status sinew_test_set_solver_int(sinew_world_id world, int solver, int velocity_iterations);
sinew_status sinew_test_set_coupling_int(sinew_world_id world, int strategy, float gain);
sinew_status sinew_test_set_embed_proxies_int(sinew_world_id world, int proxies, int mass);
sinew_status sinew_test_set_body_type_int(sinew_body_id body, int type);
}

namespace capi_test {

/// Stores an out-of-range value in a C enum field the way a C caller can (a C++ cast would be UB).
template <class E>
void poke(E& field, int value) {
    std::memcpy(&field, &value, sizeof value);
}

inline sinew_world_id make_world(float gravity_y = -9.81f) {
    sinew_world_def d = sinew_world_def_default();
    d.gravity.y = gravity_y;
    sinew_world_id w{};
    REQUIRE(sinew_world_create(&d, &w) == SINEW_OK);
    return w;
}

/// Every number a caller can read about the world: counts, rigid transforms and velocities, and every
/// soft body's particle positions, in slot order. Equal fingerprints = nothing observable changed.
inline std::vector<float> fingerprint(sinew_world_id w) {
    std::vector<float> f;
    int bodies = 0, softs = 0;
    REQUIRE(sinew_world_body_count(w, &bodies) == SINEW_OK);
    REQUIRE(sinew_world_soft_body_count(w, &softs) == SINEW_OK);
    f.push_back(float(bodies));
    f.push_back(float(softs));
    std::vector<sinew_body_id> ids(std::size_t(bodies) + 1);
    std::vector<sinew_transform> xf(std::size_t(bodies) + 1);
    int n = 0;
    REQUIRE(sinew_world_get_transforms(w, ids.data(), xf.data(), bodies, &n) == SINEW_OK);
    for (int i = 0; i < n; ++i) {
        const sinew_transform& t = xf[std::size_t(i)];
        f.insert(f.end(), {float(ids[std::size_t(i)].index), t.p.x, t.p.y, t.p.z, t.q.x, t.q.y, t.q.z, t.q.w});
        sinew_vec3 v, a;
        REQUIRE(sinew_body_get_velocity(ids[std::size_t(i)], &v, &a) == SINEW_OK);
        f.insert(f.end(), {v.x, v.y, v.z, a.x, a.y, a.z});
    }
    std::vector<sinew_soft_body_id> soft(std::size_t(softs) + 1);
    REQUIRE(sinew_world_get_soft_bodies(w, soft.data(), softs, &n) == SINEW_OK);
    for (int s = 0; s < n; ++s) {
        int count = 0;
        REQUIRE(sinew_soft_particle_count(soft[std::size_t(s)], &count) == SINEW_OK);
        std::vector<sinew_vec3> x(static_cast<std::size_t>(count));
        int got = 0;
        REQUIRE(sinew_soft_get_positions(soft[std::size_t(s)], x.data(), count, &got) == SINEW_OK);
        f.push_back(float(count));
        for (const sinew_vec3& p : x) f.insert(f.end(), {p.x, p.y, p.z});
    }
    return f;
}

/// Checks a rejected call: its status, a message naming `fragment`, and an unchanged world.
inline void expect_rejected(sinew_world_id w, const std::vector<float>& before, sinew_status got, sinew_status want,
                            const std::string& fragment) {
    CHECK(got == want);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains(fragment));
    CHECK(fingerprint(w) == before);
}

// ---- calls made during a step ---------------------------------------------------------------------

/// What the log callback runs when it hears that a joint broke (i.e. inside World::step).
inline std::function<void()>& in_step_probe() {
    static std::function<void()> probe;
    return probe;
}

inline void probe_on_break(sinew_log_level level, const char* message, void*) {
    if (level == SINEW_LOG_INFO && std::strstr(message, "broke") && in_step_probe()) {
        auto probe = in_step_probe();
        in_step_probe() = nullptr;  // once
        probe();
    }
}

/// Adds to `w` a 1 kg box hanging from a static anchor by a ball joint too weak to hold it, so the joint
/// breaks in the next step; `probe` then runs inside that step (from the log callback). Returns after
/// the step, with the callback removed. The box and anchor sit far from everything else (x = 100).
inline void run_during_step(sinew_world_id w, std::function<void()> probe) {
    sinew_body_def anchor = sinew_body_def_default();
    anchor.type = SINEW_BODY_STATIC;
    anchor.transform.p = {100, 10, 0};
    anchor.shape.half_extents = {0.1f, 0.1f, 0.1f};
    sinew_body_id a, b;
    REQUIRE(sinew_body_create(w, &anchor, &a) == SINEW_OK);
    sinew_body_def bob = sinew_body_def_default();
    bob.transform.p = {100, 9, 0};
    bob.mass = 1;
    bob.shape.half_extents = {0.1f, 0.1f, 0.1f};
    REQUIRE(sinew_body_create(w, &bob, &b) == SINEW_OK);
    sinew_joint_def j = sinew_joint_def_default();
    j.body_a = a;
    j.body_b = b;
    j.local_anchor_a = {0, -0.5f, 0};
    j.local_anchor_b = {0, 0.5f, 0};
    j.break_force = 0.01f;  // the bob weighs 9.81 N
    sinew_joint_id joint;
    REQUIRE(sinew_joint_create(w, &j, &joint) == SINEW_OK);
    in_step_probe() = std::move(probe);
    REQUIRE(sinew_set_log_callback(probe_on_break, nullptr) == SINEW_OK);
    REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    REQUIRE(sinew_set_log_callback(nullptr, nullptr) == SINEW_OK);
    CHECK(!in_step_probe());  // the probe ran
    in_step_probe() = nullptr;
}

}  // namespace capi_test
