// Whether the bench tool was built with its peers (SINEW_BUILD_BENCH_PEERS): without them the benchmarks
// run Sinew alone (tools/bench/peer_none.cpp stands in for peer_bullet*.cpp).
#pragma once

namespace sinew::bench {
/// True if Bullet is linked into this tool.
bool bullet_peer_available();
}  // namespace sinew::bench
