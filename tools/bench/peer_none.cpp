// Built instead of peer_bullet*.cpp when SINEW_BUILD_BENCH_PEERS is OFF (no Bullet on the machine, or a
// build that wants none): the benchmarks run Sinew's own settings only and say so.
#include <stdexcept>

#include "tools/bench/bench_cloth.hpp"
#include "tools/bench/bench_fem.hpp"
#include "tools/bench/bench_rigid.hpp"
#include "tools/bench/peers.hpp"

namespace sinew::bench {

namespace {
[[noreturn]] void no_peer() {
    throw std::runtime_error("this sinew was built with SINEW_BUILD_BENCH_PEERS=OFF: no Bullet to compare with");
}
}  // namespace

bool bullet_peer_available() { return false; }
std::unique_ptr<RigidContender> make_bullet_contender(const SceneDesc&, int) { no_peer(); }
ClothRun run_bullet_soft(const ClothScene&, int, BenchClock) { no_peer(); }
FemRun run_bullet_fem(const FemScene&, int, BenchClock) { no_peer(); }

}  // namespace sinew::bench
