// Stacks must stand under the Newtonian-impulse solver (Guendelman, Bridson & Fedkiw 2003): collision
// passes, velocities, contact passes with restitution rising from -1 to 0, shock propagation level by
// level from the ground, penetration projection. Holding stacks up is the point of shock propagation
// (seed 001 ch.2), so the issue-3 scenes (demos/scenes, shared with `sinew bench rigid`) are run with
// RigidSolverKind::Newton at the benchmark's 10 contact passes.
// "Stood" = no box moved more than 5 cm from its start over 10 s (600 steps of 1/60 s), the benchmark's
// criterion: a box that slides or tips moves by centimetres within a second, while a resting stack
// under this solver settles by well under a millimetre per layer (docs/rigid-solvers.md).
#include <catch2/catch.hpp>

#include "tests/test_stack_util.hpp"

using namespace sinew;
using sinew::test::StackRun;

namespace {

StackRun run_newton(const std::string& name, int steps = 600, bool shock = true) {
    SceneDesc scene = sinew::test::load_stack_scene(name);
    scene.settings.rigid.solver = RigidSolverKind::Newton;
    scene.settings.rigid.newton_contact_iterations = 10;  // the benchmark's count
    scene.settings.rigid.newton_shock_propagation = shock;
    return sinew::test::run_stack(scene, steps);
}

}  // namespace

TEST_CASE("tower-20 stands under the Newtonian solver with shock propagation", "[rigid][newton][stacking]") {
    StackRun r = run_newton("tower-20");
    CHECK(r.max_drift < 0.05);
    // No energy gain: an impulse that only pushes, repeated, leaves contact points separating and the
    // stack climbing and spinning. 1e-2 J is one 1-kg box moving at 14 cm/s: far above solver noise,
    // far below any toppling.
    CHECK(r.max_kinetic_energy_late < 1e-2);
}

TEST_CASE("tower-10 stands under the Newtonian solver with shock propagation", "[rigid][newton][stacking]") {
    StackRun r = run_newton("tower-10");
    CHECK(r.max_drift < 0.05);
    CHECK(r.max_kinetic_energy_late < 1e-2);
}

TEST_CASE("without shock propagation the Newtonian solver cannot hold tower-20", "[rigid][newton][stacking]") {
    // What shock propagation buys: 10 contact passes with negative restitution only slow the boxes, the
    // weight of 19 boxes never reaches the ground within a step, and the tower sinks into itself and
    // falls within the first seconds (the benchmark's collapse criterion is a box dropping 0.5 m).
    StackRun r = run_newton("tower-20", 180, false);
    CHECK(r.max_drift > 0.5);
}

TEST_CASE("pyramid-20 stands under the Newtonian solver with shock propagation", "[rigid][newton][stacking][long]") {
    // About 5 s in Release (210 boxes, 20 levels each iterated to convergence): hence [long].
    StackRun r = run_newton("pyramid-20");
    CHECK(r.max_drift < 0.05);
    CHECK(r.max_kinetic_energy_late < 1e-2);
}

TEST_CASE("pyramid-10 stands under the Newtonian solver with shock propagation", "[rigid][newton][stacking]") {
    // The fast stand-in for pyramid-20: rows that touch side by side share a contact-graph level.
    StackRun r = run_newton("pyramid-10");
    CHECK(r.max_drift < 0.05);
    CHECK(r.max_kinetic_energy_late < 1e-2);
}
