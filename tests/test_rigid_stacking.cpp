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
