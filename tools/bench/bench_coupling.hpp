// `sinew bench coupling`: the coupling scenes (issue 15) under every strategy in one run, time per step
// against what the strategy buys (the rigid body held by the soft one, its weight carried).
#pragma once

#include <string>
#include <vector>

namespace sinew::bench {

int cmd_bench_coupling(const std::vector<std::string>& args);

}  // namespace sinew::bench
