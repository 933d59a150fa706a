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

void solve_fast_mass_spring_stage(SoftBody& b, Real h, ParticleCollision* collision) {
    solve_fast_mass_spring(b, h, collision);
    if (!b.lra.empty()) apply_long_range_attachments(b);
}

// A body solved by a coupling layer's rows inside the rigid solver (SoftBody::solved_by_rows): its method
// only predicts, with every force explicit (Verlet's prediction: gravity, drag, pressure, external forces;
// its links are rows there), and the velocity the rows start from is the predicted one.
void predict_for_rows(SoftBody& b, Real h) {
    predict_verlet(b, h);
    Particles& p = b.p;
    const Real inv_h = Real(1) / h;
    for (std::size_t i = 0; i < p.size(); ++i)
        if (p.inv_mass[i] != 0) p.v[i] = (p.x[i] - p.x_prev[i]) * inv_h;
}

const SoftMethodStages kRowsStages = {predict_for_rows, solve_long_range_only, false, nullptr};

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

const SoftMethodStages& soft_stages_of(const SoftBody& b) {
    return b.solved_by_rows ? kRowsStages : soft_method_stages(b.def.method);
}

}  // namespace sinew
