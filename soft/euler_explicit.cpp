// Explicit and semi-implicit (symplectic) Euler for mass-spring bodies (seed 001 ch.3;
// equations and their stability analysis: docs/theory.md#euler).
//
//   explicit:       x_{n+1} = x_n + h v_n,        v_{n+1} = (v_n + h a_n) / (1 + h drag)
//   semi-implicit:  v_{n+1} = (v_n + h a_n) / (1 + h drag),   x_{n+1} = x_n + h v_{n+1}
// with a_n = M⁻¹ (springs(x_n, v_n) + p.f + pressure(x_n)) + gravity. Dividing by (1 + h drag) is implicit
// Euler of the drag term alone (v_{n+1} = v_n + h a_n - h drag v_{n+1}), the drag every method shares.
//
// On an undamped spring of frequency ω, explicit Euler multiplies the energy norm sqrt(v² + ω² u²) by
// exactly sqrt(1 + ω²h²) every step (unstable at any h); semi-implicit Euler has determinant 1 and is
// stable iff ω h < 2 (tests/test_soft_integrators.cpp measures both).
#include <memory>
#include <string>

#include "soft/force_models.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/solver_caches.hpp"

namespace sinew {

namespace {

void check_step(Real h, const char* who) {
    if (!(is_finite(h) && h > 0))
        throw SoftError(std::string(who) + ": time step h must be finite and > 0, got " + std::to_string(h));
}

// Total force of state n into the cache (which doubles as the Euler integrators' scratch, see
// solver_caches.hpp): external forces, gravity as m g (pinned particles' entries are never read), and each
// force model the body has (springs, pressure, FEM: soft/force_models.hpp), after their begin_step.
std::vector<Vec3>& total_forces(SoftBody& b, Real h) {
    if (!b.implicit_cache) b.implicit_cache = std::make_unique<ImplicitEulerCache>();
    ImplicitEulerCache& c = *b.implicit_cache;
    c.resize(b.p.size(), b.links.size());
    std::vector<Vec3>& f = c.force;
    for (std::size_t i = 0; i < b.p.size(); ++i) f[i] = b.p.f[i] + b.p.mass[i] * b.gravity;
    for (const ForceModel* model : force_models())
        if (model->begin_step && model->present(b)) model->begin_step(b, h);
    for (const ForceModel* model : force_models())
        if (model->present(b)) model->add_forces(b, b.p.x, b.p.v, f);
    return f;
}

}  // namespace

void step_explicit_euler(SoftBody& b, Real h) {
    check_step(h, "step_explicit_euler");
    const std::vector<Vec3>& f = total_forces(b, h);
    Particles& p = b.p;
    const Real keep = Real(1) / (Real(1) + h * b.def.drag);
    for (std::size_t i = 0; i < p.size(); ++i) {
        p.x_prev[i] = p.x[i];
        const Real w = p.inv_mass[i];
        if (w == 0) {  // pinned or attached: stays where it is
            p.v[i].setZero();
            continue;
        }
        p.x[i] += h * p.v[i];  // with v_n: the forward (explicit) step
        p.v[i] = keep * (p.v[i] + (h * w) * f[i]);
    }
}

void step_semi_implicit_euler(SoftBody& b, Real h) {
    check_step(h, "step_semi_implicit_euler");
    const std::vector<Vec3>& f = total_forces(b, h);
    Particles& p = b.p;
    const Real keep = Real(1) / (Real(1) + h * b.def.drag);
    for (std::size_t i = 0; i < p.size(); ++i) {
        p.x_prev[i] = p.x[i];
        const Real w = p.inv_mass[i];
        if (w == 0) {
            p.v[i].setZero();
            continue;
        }
        p.v[i] = keep * (p.v[i] + (h * w) * f[i]);
        p.x[i] += h * p.v[i];  // with v_{n+1}: symplectic Euler
    }
}

}  // namespace sinew
