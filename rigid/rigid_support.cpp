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

void RigidSystem::compute_support_levels() {
    support_level_.clear();
    const Real bound = settings_.contact_mass_ratio;
    // The sequential-impulse solvers read them (soft_step_solver.cpp, si_solver.cpp); the Newtonian
    // solver's shock propagation has its own levels and freezes lower bodies outright.
    if (bound <= 0 || settings_.solver == RigidSolverKind::Newton) return;
    // No two dynamic bodies differ enough in mass (one box size throughout: pyramid-40 spent about 7 us
    // a step on the pass below finding so).
    if (!(dynamic_inv_mass_.second > bound * dynamic_inv_mass_.first)) return;
    const State& st = state_;
    // Most steps have no such contact: one pass over the manifolds decides.
    // Sleeping islands' contacts join immovable bodies to immovable ones: they change no level.
    const std::vector<std::uint32_t>& active = active_contacts_;
    bool needed = false;
    for (const std::uint32_t ci : active) {
        const ContactManifold& c = contacts_[ci];
        const Real wa = st.inv_mass[c.body_a], wb = st.inv_mass[c.body_b];
        if (c.manifold.count > 0 && wa > 0 && wb > 0 && (wa > bound * wb || wb > bound * wa)) {
            needed = true;
            break;
        }
    }
    if (!needed) return;
    support_level_.compute(st.inv_mass, active.size(), [&](std::size_t i, std::uint32_t& a, std::uint32_t& b) {
        const ContactManifold& c = contacts_[active[i]];
        a = c.body_a;
        b = c.body_b;
        return c.manifold.count > 0;
    });
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
