// The stage table of the soft methods (soft/soft_methods.hpp).
#include "soft/soft_methods.hpp"

#include <string>

#include "soft/soft_integrators.hpp"

namespace sinew {

namespace {

// Force-based methods do their whole step from forces; only the long-range attachments (a constraint
// on the predicted positions) are left for the solve.
void solve_long_range_only(SoftBody& b, Real, ParticleCollision*) {
    if (!b.lra.empty()) apply_long_range_attachments(b);
}

void solve_fast_mass_spring_stage(SoftBody& b, Real h, ParticleCollision*) {
    solve_fast_mass_spring(b, h);
    if (!b.lra.empty()) apply_long_range_attachments(b);
}

// Indexed by SoftMethod.
const SoftMethodStages kStages[] = {
    /* Verlet */ {predict_verlet, relax_verlet, true, nullptr},
    /* ExplicitEuler */ {step_explicit_euler, solve_long_range_only, false, nullptr},
    /* SemiImplicitEuler */ {step_semi_implicit_euler, solve_long_range_only, false, nullptr},
    /* ImplicitEuler */ {step_implicit_euler, solve_long_range_only, false, nullptr},
    /* FastMassSpring */ {predict_fast_mass_spring, solve_fast_mass_spring_stage, false, shift_fast_mass_spring_prediction},
};
static_assert(sizeof(kStages) / sizeof(kStages[0]) == std::size_t(SoftMethod::Count), "one row per SoftMethod");

}  // namespace

const SoftMethodStages& soft_method_stages(SoftMethod m) {
    const auto i = std::size_t(m);
    if (i >= std::size_t(SoftMethod::Count)) throw SoftError("soft method " + std::to_string(i) + " is unknown");
    return kStages[i];
}

}  // namespace sinew
