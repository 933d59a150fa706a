// Coupling strategies between rigid and soft bodies (coupling/coupling_layer.hpp): what each exchanges,
// checked against conservation laws and against the contrast the strategies exist to show.
#include <catch2/catch.hpp>

#include <string>

#include "engine/world/scene.hpp"

using namespace sinew;

namespace {

std::string scene_path(const char* name) { return std::string(SINEW_SOURCE_DIR) + "/demos/scenes/" + name; }

// A 0.5 kg, 0.6 m implicit cloth (7 x 7 nodes) moving at 3 m/s in -z towards a free 2 kg box, off
// centre so the box also spins; no gravity, nothing else in the world.
std::string thrown_cloth_scene(const char* strategy, const char* method) {
    return std::string(R"({"format": "sinew-scene", "version": 1,
      "settings": {"gravity": [0, 0, 0], "sleeping": {"enabled": false}},
      "bodies": [{"name": "box", "shape": {"type": "box", "half_extents": [0.3, 0.3, 0.3]}, "mass": 2,
                  "position": [0.1, 0.05, 0], "material": {"friction": 0.4}}],
      "soft_bodies": [{"name": "cloth", "builder": "cloth", "nodes": [7, 7], "origin": [-0.3, -0.3, 0.6],
                  "edge_u": [0.6, 0, 0], "edge_v": [0, 0.6, 0], "mass": 0.5, "method": ")") + method + R"(",
                  "links": {"stretch": 2000, "shear": 200, "damping": 1}, "velocity": [0, 0, -3],
                  "material": {"friction": 0.4, "thickness": 0.02}}],
      "coupling": {"strategy": ")" + strategy + R"("}})";
}

Vec3 total_momentum(const World& w) {
    Vec3 p = Vec3::Zero();
    for (BodyId id : w.rigid().bodies()) p += w.rigid().mass(id) * w.rigid().linear_velocity(id);
    for (SoftBodyId id : w.soft().bodies()) {
        const Particles& q = w.soft().body(id).p;
        for (std::size_t i = 0; i < q.size(); ++i) p += q.mass[i] * q.v[i];
    }
    return p;
}

}  // namespace

namespace {
void check_momentum_after_impact(const char* method, Real tolerance) {
    auto w = build_world(parse_scene_string(thrown_cloth_scene("two-way", method), "thrown-cloth"));
    const Vec3 p0 = total_momentum(*w);  // 0.5 kg at 3 m/s: 1.5 N s along -z
    for (int s = 0; s < 60; ++s) w->step();
    const BodyId box = w->rigid().bodies()[0];
    CHECK(w->rigid().linear_velocity(box).z() < Real(-0.2));  // struck: it took a good share
    CHECK((total_momentum(*w) - p0).norm() <= tolerance * p0.norm());
}
}  // namespace

TEST_CASE("two-way coupling conserves linear momentum when a Verlet cloth hits a free box", "[coupling]") {
    // Rows and sent-back contact impulses are equal and opposite; a Verlet particle's contact pushes are
    // counted as impulses m dx / h and become its velocity through the position difference. Measured
    // 2.4e-4 of the 1.5 N s in float; 1e-3 leaves room for rounding over ~10^4 row updates per step.
    check_momentum_after_impact("verlet", Real(1e-3));
}

// Open (issue 15): the implicit solve's mass shares are exact only when CG converges; at the default
// cap of 10 iterations the internal forces leave a net momentum (measured 5.8% of the 1.5 N s; 0.58%
// at 200 iterations and tolerance 1e-6). Kept as the requirement, marked as failing until fixed.
TEST_CASE("two-way coupling conserves linear momentum when an implicit cloth hits a free box", "[coupling][!shouldfail]") {
    check_momentum_after_impact("implicit", Real(1e-3));
}

TEST_CASE("one-way coupling leaves the rigid body's path unchanged; two-way does not", "[coupling]") {
    auto one = build_world(parse_scene_string(thrown_cloth_scene("one-way", "implicit"), "one-way"));
    auto two = build_world(parse_scene_string(thrown_cloth_scene("two-way", "implicit"), "two-way"));
    for (int s = 0; s < 60; ++s) {
        one->step();
        two->step();
    }
    const BodyId a = one->rigid().bodies()[0], b = two->rigid().bodies()[0];
    // No gravity, nothing else touches it: under one-way the box must not have moved at all, bit for bit.
    CHECK(one->rigid().linear_velocity(a) == Vec3::Zero());
    CHECK(one->rigid().angular_velocity(a) == Vec3::Zero());
    CHECK(one->rigid().transform(a).p == Vec3(Real(0.1), Real(0.05), 0));
    CHECK(two->rigid().linear_velocity(b).norm() > Real(0.2));
    CHECK(one->coupling().impulses().empty());
}

TEST_CASE("ball-on-trampoline: two-way holds the ball that falls through under one-way", "[coupling]") {
    SceneDesc scene = parse_scene_file(scene_path("ball-on-trampoline.json"));
    const auto ball_and_cloth_after = [&](CouplingStrategy s, Real seconds, Real& ball_y, Real& cloth_min_y) {
        SceneDesc d = scene;
        d.coupling.settings.strategy = s;
        std::vector<BodyId> ids;
        auto w = build_world(d, &ids);
        const int steps = int(seconds / w->settings().time_step + Real(0.5));
        for (int k = 0; k < steps; ++k) w->step();
        ball_y = w->rigid().transform(ids[1]).p.y();
        cloth_min_y = 1e9f;
        for (const Vec3& x : w->soft().body(w->soft().bodies()[0]).p.x) cloth_min_y = std::min(cloth_min_y, x.y());
    };
    // The ball (r = 0.2) reaches the cloth (y = 1) at about 0.45 s, at 4.7 m/s.
    Real ball_y, cloth_y;
    ball_and_cloth_after(CouplingStrategy::OneWay, Real(1), ball_y, cloth_y);
    CHECK(ball_y < Real(0.25));  // on the ground: the cloth did not slow it
    ball_and_cloth_after(CouplingStrategy::TwoWay, Real(0.75), ball_y, cloth_y);
    // Still in the cloth, above its lowest point, having been stopped well above the ground.
    CHECK(ball_y > cloth_y);
    CHECK(ball_y > Real(0.3));
}

TEST_CASE("coupling settings: bad input is refused with the field named, nothing changed", "[coupling][errors]") {
    const auto load_error = [](const std::string& coupling) {
        const std::string text = R"({"format": "sinew-scene", "version": 1,
          "bodies": [{"name": "box", "shape": {"type": "box", "half_extents": [0.3, 0.3, 0.3]}}],
          "soft_bodies": [{"name": "rope", "builder": "rope", "from": [0, 2, 0], "to": [1, 2, 0], "segments": 4}],
          "coupling": )" + coupling + "}";
        try {
            parse_scene_string(text, "bad-coupling");
        } catch (const SceneError& e) {
            return e.json_path + ": " + e.problem;
        }
        return std::string("no error");
    };
    CHECK_THAT(load_error(R"({"strategy": "three-way"})"), Catch::Contains("/coupling/strategy") && Catch::Contains("three-way"));
    CHECK_THAT(load_error(R"({"gain": -1})"), Catch::Contains("/coupling/gain"));
    CHECK_THAT(load_error(R"({"exchange_iterations": 0})"), Catch::Contains("/coupling/exchange_iterations"));
    CHECK_THAT(load_error(R"({"pairs": [{"soft": "cloth", "strategy": "two-way"}]})"),
               Catch::Contains("/coupling/pairs/0/soft") && Catch::Contains("cloth"));
    CHECK_THAT(load_error(R"({"pairs": [{"soft": "rope", "rigid": "crate", "strategy": "two-way"}]})"),
               Catch::Contains("/coupling/pairs/0/rigid") && Catch::Contains("crate"));
    CHECK_THAT(load_error(R"({"pairs": [{"soft": "rope"}]})"), Catch::Contains("strategy"));
    CHECK_THAT(load_error(R"({"sub_steps": 2})"), Catch::Contains("sub_steps"));
    CHECK(load_error(R"([])") == "no error");  // files from before the section existed

    // Through the world: a pair naming a destroyed soft body.
    World w;
    SoftBodyDef def;
    def.positions = {Vec3(0, 1, 0), Vec3(1, 1, 0)};
    def.masses = {1, 1};
    const SoftBodyId gone = w.soft().create_body(def);
    w.soft().destroy_body(gone);
    CouplingSettings s;
    s.strategy = CouplingStrategy::TwoWay;
    s.pairs.push_back({gone, BodyId{}, CouplingStrategy::Hybrid});
    CHECK_THROWS_WITH(w.set_coupling(s), Catch::Contains("pair 0") && Catch::Contains("does not exist"));
    CHECK(w.coupling().settings().strategy == CouplingStrategy::OneWay);
    s.pairs.clear();
    s.gain = Real(1.5);
    CHECK_THROWS_WITH(w.set_coupling(s), Catch::Contains("gain"));
    CHECK(w.coupling().settings().strategy == CouplingStrategy::OneWay);
}

TEST_CASE("a per-pair strategy overrides the world's, and scenes save and reload it", "[coupling]") {
    SceneDesc d = parse_scene_string(R"({"format": "sinew-scene", "version": 1,
      "bodies": [{"name": "a", "shape": {"type": "sphere", "radius": 0.2}}, {"name": "b", "shape": {"type": "sphere", "radius": 0.2}, "position": [2, 0, 0]}],
      "soft_bodies": [{"name": "rope", "builder": "rope", "from": [0, 2, 0], "to": [1, 2, 0], "segments": 4}],
      "coupling": {"strategy": "hybrid", "gain": 0.5, "pairs": [{"soft": "rope", "strategy": "one-way"},
                                                                  {"soft": "rope", "rigid": "b", "strategy": "two-way"}]}})",
                                     "pairs");
    std::vector<BodyId> ids;
    auto w = build_world(d, &ids);
    const SoftBodyId rope = w->soft().bodies()[0];
    CHECK(w->coupling().strategy(rope, ids[0]) == CouplingStrategy::OneWay);  // the pair naming no rigid body
    CHECK(w->coupling().strategy(rope, ids[1]) == CouplingStrategy::TwoWay);  // the exact pair wins
    const std::string text = scene_to_json_text(*w, "pairs-saved");
    auto again = build_world(parse_scene_string(text, "pairs-saved"));
    const CouplingSettings& s = again->coupling().settings();
    CHECK(s.strategy == CouplingStrategy::Hybrid);
    CHECK(s.gain == Real(0.5));
    REQUIRE(s.pairs.size() == 2);
    CHECK(again->coupling().strategy(again->soft().bodies()[0], again->rigid().bodies()[1]) == CouplingStrategy::TwoWay);
}
