// Mass-ratio bound along the support direction: which body of a contact holds the other up, and how
// much heavier the held one may look to the solver.
//
// Sequential impulses pass momentum between two bodies in proportion to their masses: a 1000 kg box
// landing on a 1 kg box resting on the ground loses about 2 m/M = 0.2 % of its speed per pass, so ten
// passes (or a hundred) cannot stop it and it squeezes the light box out (docs/RESULTS.md, bench
// robustness). Shock propagation (Guendelman et al. 2003; Erleben 2007) solves such stacks by freezing the
// lower body of each contact, level by level from the ground; game engines bound the mass ratio a
// contact sees instead (Havok's and True Axis's mass clamping, PhysX's contact mass scaling). Sinew does
// the latter along the support direction only: levels are breadth-first distances over this step's
// contact graph from the immovable bodies (static, kinematic, asleep: level 0), and in a contact whose
// higher body is more than contact_mass_ratio times heavier than its lower one, the lower body's inverse
// mass and inverse inertia are scaled by ratio_bound / ratio. The held body then stops within a few
// passes; the price is that the supporting body is pressed down as if the load were only ratio_bound
// times its own mass (its contact with the ground reports that much, and its friction there is bounded
// by that much). Bodies side by side (same level), bodies in free flight (unreached) and a light body
// resting on a heavy one are untouched, so collisions away from supports keep momentum exactly.
#include "rigid/rigid_system.hpp"

#include <algorithm>

namespace sinew {

namespace {
constexpr std::int32_t kUnreached = 0x3FFFFFFF;
}

void RigidSystem::compute_support_levels() {
    support_level_.clear();
    const Real bound = settings_.contact_mass_ratio;
    // The soft step alone reads them (rigid/soft_step_solver.cpp); the Newtonian solver has its own levels.
    if (bound <= 0 || settings_.solver != RigidSolverKind::SoftStep) return;
    const State& st = state_;
    // Most steps have no such contact: one pass over the manifolds decides.
    bool needed = false;
    for (const ContactManifold& c : contacts_) {
        const Real wa = st.inv_mass[c.body_a], wb = st.inv_mass[c.body_b];
        if (c.manifold.count > 0 && wa > 0 && wb > 0 && (wa > bound * wb || wb > bound * wa)) {
            needed = true;
            break;
        }
    }
    if (!needed) return;
    const std::size_t n = st.x.size();
    support_level_.assign(n, kUnreached);
    support_queue_.clear();
    for (std::uint32_t s = 0; s < n; ++s)
        if (st.inv_mass[s] == 0) {
            support_level_[s] = 0;
            support_queue_.push_back(s);
        }
    // Adjacency as compressed rows, rebuilt without allocating once grown.
    support_adj_start_.assign(n + 1, 0);
    for (const ContactManifold& c : contacts_)
        if (c.manifold.count > 0) {
            ++support_adj_start_[c.body_a + 1];
            ++support_adj_start_[c.body_b + 1];
        }
    for (std::size_t i = 0; i < n; ++i) support_adj_start_[i + 1] += support_adj_start_[i];
    support_adj_.resize(support_adj_start_[n]);
    support_fill_.assign(support_adj_start_.begin(), support_adj_start_.end() - 1);
    for (const ContactManifold& c : contacts_)
        if (c.manifold.count > 0) {
            support_adj_[support_fill_[c.body_a]++] = c.body_b;
            support_adj_[support_fill_[c.body_b]++] = c.body_a;
        }
    std::vector<std::uint32_t>& queue = support_queue_;
    for (std::size_t head = 0; head < queue.size(); ++head) {
        const std::uint32_t s = queue[head];
        for (std::uint32_t k = support_adj_start_[s]; k < support_adj_start_[s + 1]; ++k) {
            const std::uint32_t o = support_adj_[k];
            if (support_level_[o] == kUnreached) {
                support_level_[o] = support_level_[s] + 1;
                queue.push_back(o);
            }
        }
    }
}

void RigidSystem::support_scales(std::uint32_t a, std::uint32_t b, Real& scale_a, Real& scale_b) const {
    const std::int32_t la = support_level_[a], lb = support_level_[b];
    if (la == lb) return;  // side by side, or both in free flight
    const std::uint32_t lower = la < lb ? a : b, upper = la < lb ? b : a;
    const Real w_lower = state_.inv_mass[lower], w_upper = state_.inv_mass[upper];
    if (w_upper <= 0 || w_lower <= 0) return;
    const Real ratio = w_lower / w_upper;  // m_upper / m_lower
    const Real bound = settings_.contact_mass_ratio;
    if (ratio <= bound) return;
    (lower == a ? scale_a : scale_b) = bound / ratio;
}

}  // namespace sinew
