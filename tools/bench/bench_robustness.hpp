// `sinew bench robustness`: the hard scenes (demos/scenes/hard-*.json), each where rigid solvers (or, for
// hard-soft-*, soft bodies under contact) are known to fail, under every Sinew solver (soft method) and
// Bullet, each checked against the scene's physical answer.
#pragma once

#include <string>
#include <vector>

namespace sinew::bench {

int cmd_bench_robustness(const std::vector<std::string>& args);

}  // namespace sinew::bench
