// `sinew bench threads`: the same scenes on 1, 2, ... workers in one run (issue 18): wall time per step,
// the speed-up over the first worker count, and whether the end state is bit-identical to it.
#pragma once

#include <string>
#include <vector>

namespace sinew::bench {

int cmd_bench_threads(const std::vector<std::string>& args);

}  // namespace sinew::bench
