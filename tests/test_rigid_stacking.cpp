// Stacks must stand: the issue-3 scenes (demos/scenes, shared with the benchmark) under the default
// solver (sequential impulses with soft-step position correction, 10 passes, warm starting).
// "Stood" = no box moved more than 5 cm from its start over 10 s (600 steps of 1/60 s), the benchmark's
// criterion: a box that slides or tips moves by centimetres within a second, while the elastic settling
// of a soft contact under the weight of 20 boxes is about a millimetre per layer.
#include <catch2/catch.hpp>

#include "tests/test_stack_util.hpp"

using namespace sinew;
using sinew::test::StackRun;

namespace {

StackRun run_scene(const std::string& name, bool warm = true, int steps = 600) {
    SceneDesc scene = sinew::test::load_stack_scene(name);
    scene.settings.rigid.warm_starting = warm;
    return sinew::test::run_stack(scene, steps);
}

}  // namespace

TEST_CASE("tower-20 stands under the default solver at 10 iterations", "[rigid][stacking]") {
    StackRun r = run_scene("tower-20");
    CHECK(r.max_drift < 0.05);
    // No energy gain: a resting stack's kinetic energy stays near zero. 1e-2 J is the energy of one 1-kg
    // box moving at 14 cm/s, far above solver noise and far below any toppling.
    CHECK(r.max_kinetic_energy_late < 1e-2);
}

TEST_CASE("pyramid-20 stands under the default solver at 10 iterations", "[rigid][stacking]") {
    StackRun r = run_scene("pyramid-20");
    CHECK(r.max_drift < 0.05);
    CHECK(r.max_kinetic_energy_late < 1e-2);
}

TEST_CASE("without warm starting the same pyramid does not stand", "[rigid][stacking]") {
    // What warm starting buys: 10 cold passes cannot carry the weight of 20 rows to the ground.
    StackRun r = run_scene("pyramid-20", false, 300);
    CHECK(r.max_drift > 0.05);
}

TEST_CASE("pyramid-40 stands under the default solver at 10 iterations", "[rigid][stacking][long]") {
    StackRun r = run_scene("pyramid-40");
    CHECK(r.max_drift < 0.05);
}

namespace {

/// Final heights of the dynamic bodies named in the scene, and the largest distance any of the others
/// moved from its start over the run.
struct MassRatioRun {
    std::vector<double> final_y;  // per dynamic body, scene order
    double others_max_drift = 0;
    double lowest_y = 1e30;       // lowest centre of any dynamic body over the run
};

MassRatioRun run_mass_ratio(SceneDesc scene, Real bound, const std::string& held,
                            RigidSolverKind solver = RigidSolverKind::SoftStep) {
    scene.settings.rigid.contact_mass_ratio = bound;
    scene.settings.rigid.solver = solver;
    std::vector<BodyId> ids;
    auto world = build_world(scene, &ids);
    std::vector<Vec3> start;
    for (BodyId id : ids) start.push_back(world->rigid().transform(id).p);
    MassRatioRun r;
    for (int s = 0; s < scene.steps; ++s) {
        world->step();
        for (std::size_t i = 0; i < ids.size(); ++i) {
            if (scene.bodies[i].def.type != BodyType::Dynamic) continue;
            const Vec3 p = world->rigid().transform(ids[i]).p;
            r.lowest_y = std::min(r.lowest_y, double(p.y()));
            if (scene.bodies[i].name != held) r.others_max_drift = std::max(r.others_max_drift, double((p - start[i]).norm()));
        }
    }
    for (std::size_t i = 0; i < ids.size(); ++i)
        if (scene.bodies[i].def.type == BodyType::Dynamic) r.final_y.push_back(double(world->rigid().transform(ids[i]).p.y()));
    return r;
}

}  // namespace

TEST_CASE("boxes 100 and 1000 times heavier rest on 1 kg boxes under the soft step", "[rigid][stacking][mass-ratio]") {
    // demos/scenes/hard-heavy-on-light.json: unit boxes, heavy on light on the ground, 10 s. Rigid boxes
    // sink nothing; 2 mm allows the soft contacts' elastic sag (measured 1.1 mm at the default bound).
    const SceneDesc scene = sinew::test::load_stack_scene("hard-heavy-on-light");
    MassRatioRun r = run_mass_ratio(scene, scene.settings.rigid.contact_mass_ratio, "");
    REQUIRE(r.final_y.size() == 4);
    CHECK(r.final_y[1] == Approx(1.5).margin(0.002));  // heavy-100
    CHECK(r.final_y[3] == Approx(1.5).margin(0.002));  // heavy-1000
    CHECK(r.others_max_drift < 0.01);
    SECTION("known failure without the bound: the 1000 kg box squeezes the light box out and lands on the ground") {
        MassRatioRun off = run_mass_ratio(scene, 0, "");
        CHECK(off.final_y[3] < 0.6);
        CHECK(off.others_max_drift > 0.5);
    }
}

TEST_CASE("a 1000 kg box dropped 1 m onto a 10-row pyramid of 1 kg boxes comes to rest on top", "[rigid][stacking][mass-ratio]") {
    // demos/scenes/hard-heavy-on-pyramid.json: 4.4 m/s at impact. Rigid boxes dropped square on the top
    // box hold: the heavy box rests with its centre at y = 10.5 (1 cm allows the sag of ten rows of soft
    // contacts under 1000 kg, measured 3.8 mm) and no pyramid box moves 5 cm (measured 4.7 cm at the
    // impact, then back; without the bound the box reaches the ground).
    const SceneDesc scene = sinew::test::load_stack_scene("hard-heavy-on-pyramid");
    MassRatioRun r = run_mass_ratio(scene, scene.settings.rigid.contact_mass_ratio, "heavy");
    CHECK(r.final_y[0] == Approx(10.5).margin(0.01));
    CHECK(r.others_max_drift < 0.05);
    MassRatioRun off = run_mass_ratio(scene, 0, "heavy");
    CHECK(off.final_y[0] < 1.0);
}

TEST_CASE("under split impulses and Baumgarte the 1000 kg impact never pushes a box through the ground", "[rigid][stacking][mass-ratio]") {
    // Without the bound both solvers drove pyramid boxes through the 1 m static ground (a centre reached
    // y = -29 m under Baumgarte). With it, the lowest centre of any unit box over the run stays within
    // 1 cm of resting on the ground (0.5 m; measured 0.493) and the heavy box ends on top within 2 cm
    // (measured drift of the pyramid: split impulses 4.8 cm, Baumgarte 6.5 cm at the impact).
    const SceneDesc scene = sinew::test::load_stack_scene("hard-heavy-on-pyramid");
    for (RigidSolverKind kind : {RigidSolverKind::SplitImpulse, RigidSolverKind::Baumgarte}) {
        INFO(rigid_solver_name(kind));
        MassRatioRun r = run_mass_ratio(scene, scene.settings.rigid.contact_mass_ratio, "heavy", kind);
        CHECK(r.lowest_y > 0.49);
        CHECK(r.final_y[0] == Approx(10.5).margin(0.02));
        CHECK(r.others_max_drift < 0.1);
    }
}
