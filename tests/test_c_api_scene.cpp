// sinew_world_create_from_scene_file: the C API loads the same worlds the C++ loader builds (same bodies,
// joints and soft bodies, stepping identically), reports scene errors with the file and JSON pointer,
// and creates nothing from a bad file.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "engine/world/scene.hpp"
#include "tests/test_c_api_util.hpp"

using namespace capi_test;

namespace {

const std::string kSource = SINEW_SOURCE_DIR;
const std::string kShowcase = kSource + "/demos/scenes/showcase-c-loop.json";

std::vector<std::string>& log_lines() {
    static std::vector<std::string> lines;
    return lines;
}
void collect(sinew_log_level level, const char* message, void*) {
    log_lines().push_back(std::to_string(int(level)) + " " + message);
}

}  // namespace

TEST_CASE("C API scene: a loaded scene steps exactly like the C++ world built from the same file", "[capi][scene]") {
    sinew_world_id w;
    REQUIRE(sinew_world_create_from_scene_file(kShowcase.c_str(), &w) == SINEW_OK);
    int bodies = 0, softs = 0, particles = 0;
    REQUIRE(sinew_world_body_count(w, &bodies) == SINEW_OK);
    REQUIRE(sinew_world_soft_body_count(w, &softs) == SINEW_OK);
    CHECK(bodies == 4);
    CHECK(softs == 1);
    sinew_soft_body_id cloth;
    int n = 0;
    REQUIRE(sinew_world_get_soft_bodies(w, &cloth, 1, &n) == SINEW_OK);
    REQUIRE(sinew_soft_particle_count(cloth, &particles) == SINEW_OK);
    CHECK(particles == 16 * 16);

    const sinew::SceneDesc scene = sinew::parse_scene_file(kShowcase);
    std::vector<sinew::BodyId> ids;
    std::unique_ptr<sinew::World> cw = sinew::build_world(scene, &ids);
    for (int i = 0; i < 60; ++i) {
        REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
        cw->step();
    }
    // Same engine, same order of creation, same steps: equal to the last bit once converted to float.
    sinew_transform xf[4];
    REQUIRE(sinew_world_get_transforms(w, nullptr, xf, 4, &n) == SINEW_OK);
    for (int i = 0; i < 4; ++i) {
        const sinew::Transform t = cw->rigid().transform(ids[std::size_t(i)]);
        CHECK(xf[i].p.x == float(t.p.x()));
        CHECK(xf[i].p.y == float(t.p.y()));
        CHECK(xf[i].q.w == float(t.q.w()));
    }
    std::vector<sinew_vec3> x(256);
    REQUIRE(sinew_soft_get_positions(cloth, x.data(), 256, &n) == SINEW_OK);
    const sinew::SoftBody& sb = cw->soft().body(cw->soft().bodies().at(0));
    int identical = 0;
    for (int k = 0; k < 256; ++k)
        identical += x[std::size_t(k)].x == float(sb.p.x[std::size_t(k)].x()) &&
                     x[std::size_t(k)].y == float(sb.p.x[std::size_t(k)].y()) &&
                     x[std::size_t(k)].z == float(sb.p.x[std::size_t(k)].z());
    CHECK(identical == 256);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API scene: a scene's breakable joint reports its bodies when it breaks", "[capi][scene][events]") {
    sinew_world_id w;
    const std::string path = kSource + "/tests/data/scenes/good/joints.json";
    REQUIRE(sinew_world_create_from_scene_file(path.c_str(), &w) == SINEW_OK);
    // The hook (3 kg, weight 29.4 N) hangs from a distance joint that breaks above 20 N: first step.
    REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    sinew_events e;
    REQUIRE(sinew_world_get_events(w, &e) == SINEW_OK);
    REQUIRE(e.joint_break_count == 1);
    const sinew::SceneDesc scene = sinew::parse_scene_file(path);
    std::size_t beam = 0, hook = 0;
    for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
        if (scene.bodies[i].name == "beam") beam = i;
        if (scene.bodies[i].name == "hook") hook = i;
    }
    // Bodies are created in scene order in a fresh world: slot = scene index.
    CHECK(e.joint_break[0].body_a.index == beam);
    CHECK(e.joint_break[0].body_b.index == hook);
    CHECK(e.joint_break[0].joint.index == scene.joints.size() - 1);  // the last joint of the file
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API scene: a bad scene file is SINEW_ERROR_SCENE naming the file and JSON pointer", "[capi][scene][errors]") {
    log_lines().clear();
    REQUIRE(sinew_set_log_callback(collect, nullptr) == SINEW_OK);
    sinew_world_id w{77, 77};  // must stay untouched on failure
    const std::string bad = kSource + "/tests/data/scenes/bad/negative-mass.json";
    CHECK(sinew_world_create_from_scene_file(bad.c_str(), &w) == SINEW_ERROR_SCENE);
    CHECK_THAT(std::string(sinew_last_error()),
               Catch::Contains("sinew_world_create_from_scene_file: ") && Catch::Contains("negative-mass.json: /bodies/3/mass") &&
                   Catch::Contains("mass must be > 0, got -1"));
    CHECK(w.index == 77);
    CHECK(w.generation == 77);
    const std::string soft_bad = kSource + "/tests/data/scenes/bad/soft-body-bad-pin.json";
    CHECK(sinew_world_create_from_scene_file(soft_bad.c_str(), &w) == SINEW_ERROR_SCENE);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("/soft_bodies/0/pinned/1"));
    const std::string missing = kSource + "/tests/data/scenes/no-such-file.json";
    CHECK(sinew_world_create_from_scene_file(missing.c_str(), &w) == SINEW_ERROR_SCENE);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("no-such-file.json"));
    CHECK(sinew_world_create_from_scene_file(nullptr, &w) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK_THAT(std::string(sinew_last_error()), Catch::Contains("path is NULL"));
    CHECK(sinew_world_create_from_scene_file(kShowcase.c_str(), nullptr) == SINEW_ERROR_NULL_ARGUMENT);
    CHECK(w.index == 77);
    // Every failure also went to the log callback at SINEW_LOG_ERROR, with the same text.
    REQUIRE(log_lines().size() == 5);
    CHECK_THAT(log_lines()[0], Catch::StartsWith("0 ") && Catch::Contains("/bodies/3/mass"));

    // A good load is logged at SINEW_LOG_INFO.
    log_lines().clear();
    REQUIRE(sinew_world_create_from_scene_file(kShowcase.c_str(), &w) == SINEW_OK);
    REQUIRE(sinew_set_log_callback(nullptr, nullptr) == SINEW_OK);
    REQUIRE(log_lines().size() == 1);
    CHECK_THAT(log_lines()[0], Catch::StartsWith("2 ") && Catch::Contains("showcase-c-loop") &&
                                   Catch::Contains("4 bodies, 0 joints, 1 soft bodies"));
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}

TEST_CASE("C API scene: a saved world loads back into the same state", "[capi][scene][save]") {
    sinew_world_id w;
    REQUIRE(sinew_world_create_from_scene_file(kShowcase.c_str(), &w) == SINEW_OK);
    for (int i = 0; i < 40; ++i) REQUIRE(sinew_world_step_fixed(w) == SINEW_OK);
    const std::string path = std::string(SINEW_BIN_DIR) + "/c-api-saved-scene.json";
    REQUIRE(sinew_world_save_scene(w, path.c_str()) == SINEW_OK);
    sinew_world_id back;
    REQUIRE(sinew_world_create_from_scene_file(path.c_str(), &back) == SINEW_OK);
    // Everything a caller can read (transforms, velocities, particle positions) is identical.
    CHECK(fingerprint(back) == fingerprint(w));
    // An unwritable path: SINEW_ERROR_SCENE naming it, and the world is untouched.
    const std::vector<float> before = fingerprint(w);
    expect_rejected(w, before, sinew_world_save_scene(w, "/no/such/dir/scene.json"), SINEW_ERROR_SCENE,
                    "/no/such/dir/scene.json");
    REQUIRE(sinew_world_destroy(back) == SINEW_OK);
    REQUIRE(sinew_world_destroy(w) == SINEW_OK);
}
