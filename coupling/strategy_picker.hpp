// The "auto" coupling strategy (issue 11 item 4; docs/compare.md, "Picking a strategy: auto"): per soft
// body, the cheapest strategy expected to keep a run within a position tolerance of a converged run of
// the same scene. Rules, in order, each resting on a measurement of `sinew compare` (docs/RESULTS.md):
//
//   1. held by a joint                       -> embed-rigid: only a rigid proxy gives a joint something to hold
//                                               (soft-door runs embedded only).
//   2. a volumetric body (closed surface: FEM or pressure) stacked on or under another one under gravity
//                                            -> embed-rigid: every coupling strategy let stack-of-soft-cubes
//                                               collapse (>= 823 mm RMS), embed-rigid stands (0.22 mm).
//   3. no dynamic rigid body it can touch    -> one-way: nothing it could push moves, so coupling back is moot,
//                                               and one-way does the least work (cloth-on-arm, a kinematic arm:
//                                               one-way 131 mm RMS off, two-way 990 mm at the same step, its
//                                               contacts held in the implicit solve).
//   4. otherwise, one-way's error is estimated from how hard the soft body can push back: fully if it is
//      supported (a pinned particle, an attachment to a static or kinematic body, or lying on a static
//      body: it can stop a rigid body, which one-way lets through, as far as the soft body is big), else by
//      its share of the momentum, m_s / (m_s + m_r), times its size plus their relative speed over 1 s
//      (what a free soft body takes from or gives a rigid body, followed for a second), but no less than a
//      quarter of its size (one-way's contacts act after the soft solve, two-way's in the rigid solve: a
//      cloth thrown at a box 2000 times heavier moved it 1.3 mm differently, its own nodes 0.11-0.14 m
//      RMS, tests/test_coupling.cpp). Within the
//      tolerance -> one-way; else -> two-way: the best variant at the scene's step on all four comparison
//      scenes with a dynamic rigid body. Speeds are those at the pick (see CouplingLayer::picks).
// Hybrid, interleaved, one-solver and embed-fem are never picked: on the four comparison scenes with a
// dynamic rigid body, two-way at the same step was closer than each (1.2 to 240 times; one-solver tied it
// on box-on-soft-block) at no more than 1.4 x its time.
#pragma once

#include <string>
#include <vector>

#include "coupling/coupling_settings.hpp"

namespace sinew {

class RigidSystem;
class SoftSystem;
class RigidEmbedding;
class FemEmbedding;

struct StrategyPick {
    SoftBodyId soft;
    CouplingStrategy strategy = CouplingStrategy::OneWay;
    /// m: rule 4's estimate of one-way's error for this body (0 where rules 1-3 decided).
    Real one_way_error = 0;
    std::string reason;  ///< the rule and the figures it used, for `sinew compare --recommend` and logs
};

/// Strategies ranked by the work they do per step: by the median over the comparison scenes of their
/// time at the scene's step relative to one-way's (`sinew compare`, docs/compare.md): 0 one-way; 1 hybrid,
/// interleaved and two-way (1.0-1.1 x); 2 embed-rigid and embed-fem (about 2.4 x); 3 one-solver (3.5 x).
/// Auto never picks a strategy ranked above the one a scene's reference uses.
int strategy_cost_rank(CouplingStrategy s);

/// One pick per soft body of `soft` (FEM proxies of rigid bodies excluded), in slot order. Rigid proxies
/// of embedded soft bodies are not rigid bodies here. `held`: soft bodies a joint holds (or will).
std::vector<StrategyPick> pick_strategies(const RigidSystem& rigid, const SoftSystem& soft,
                                          const RigidEmbedding& proxies, const FemEmbedding& fem_proxies,
                                          Real tolerance, const std::vector<SoftBodyId>& held);

}  // namespace sinew
