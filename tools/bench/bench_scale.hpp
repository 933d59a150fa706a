// `sinew bench scale`: cost per body from about a thousand to fifty thousand bodies (issue 18 item 4):
// square grids of 10-row pyramids on one ground box (many-pyramids' layout), sleeping off, and as many
// single boxes asleep on the ground; each world stepped past its first impacts, then all timed in
// alternating chunks; microseconds per body per step, split by stage, the ratio to the grid nearest
// 5,000 bodies, and heap bytes per body.
#pragma once

#include <string>
#include <vector>

namespace sinew::bench {

int cmd_bench_scale(const std::vector<std::string>& args);

}  // namespace sinew::bench
