// Stability limits of the soft methods at a step h (soft/soft_stability.hpp).
#include "soft/soft_stability.hpp"

#include <cmath>

#include "engine/core/format.hpp"

namespace sinew {

Real semi_implicit_step_bound(const SoftBody& b) {
    Real omega2 = 0;
    for (const Link& l : b.links) {
        const Real ia = b.p.inv_mass[l.a], ib = b.p.inv_mass[l.b];
        if (!(l.stiffness > 0) || (ia == 0 && ib == 0)) continue;
        // A spring to a pinned particle: omega^2 = k / m of the free end.
        const Real w2 = (ia == 0 || ib == 0) ? l.stiffness * (ia + ib)
                                             : 4 * l.stiffness / (b.p.mass[l.a] + b.p.mass[l.b]);
        omega2 = std::max(omega2, w2);
    }
    return omega2 > 0 ? 2 / std::sqrt(omega2) : kRealMax;
}

std::string stability_warning(const SoftBody& b, Real h) {
    switch (b.def.method) {
        case SoftMethod::SemiImplicitEuler: {
            const Real bound = semi_implicit_step_bound(b);
            if (!(h > bound)) return {};
            return "semi-implicit Euler diverges above h = 2/omega; its stiffest spring alone gives " +
                   to_text(bound) + " s and the world steps at " + to_text(h) +
                   " s: soften the springs, use a smaller step, or the implicit method";
        }
        case SoftMethod::ExplicitEuler:
            for (const Link& l : b.links)
                if (l.stiffness > 0 && !(l.damping > 0))
                    return "explicit Euler grows an undamped spring's oscillation by sqrt(1 + omega^2 h^2) every "
                           "step at any h: give the springs damping, or use the semi-implicit or implicit method";
            return {};
        default: return {};
    }
}

std::string stability_hint(const SoftBody& b, Real h) {
    std::string w = stability_warning(b, h);
    if (!w.empty()) return w;
    switch (b.def.method) {
        case SoftMethod::SemiImplicitEuler:
            return b.fem ? "semi-implicit Euler diverges above h = 2/omega_max of the elements: stiffer or smaller "
                           "tets need a smaller step; the implicit method is stable at any step"
                         : "semi-implicit Euler diverges above h = 2/omega_max (springs in series oscillate faster "
                           "than one alone): soften the springs, use a smaller step, or the implicit method";
        case SoftMethod::ExplicitEuler:
            return "explicit Euler is unstable for any undamped oscillation: use the semi-implicit or implicit method";
        case SoftMethod::ImplicitEuler:
            return "implicit Euler is stable at any step: a force beyond the solve (a pressure, an attachment pulled "
                   "far away, a collider crushing the body) drove it; raise the CG iterations or lower the force";
        default:
            return "a constraint or collider drove the particles past what the method can project: raise the "
                   "iterations or lower the step";
    }
}

}  // namespace sinew
