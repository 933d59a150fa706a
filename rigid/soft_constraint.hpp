// Catto 2011 ("Soft Constraints", GDC): a constraint row made an implicitly integrated damped spring of
// natural frequency f and damping ratio zeta, solved in the same sequential-impulse loop as a rigid row.
// With omega = 2 pi f and step h, each row solve is
//     lambda = -mass_scale K^-1 (C-dot + bias_rate C) - impulse_scale Lambda_accumulated,
//     bias_rate = omega / (2 zeta + h omega),
//     mass_scale = h omega (2 zeta + h omega) / (1 + h omega (2 zeta + h omega)),
//     impulse_scale = 1 / (1 + h omega (2 zeta + h omega)),
// Box2D v3's per-unit-mass form of the spring's gamma/beta (docs/theory.md, soft constraints): implicit
// Euler of the spring, so stable at any stiffness. A rigid row is {0, 1, 0} (no bias), Baumgarte's is
// {beta / h, 1, 0}. Used by the soft step's contacts and by the joints.
#pragma once

#include "engine/core/math.hpp"

namespace sinew {

struct SoftCoefficients {
    Real bias_rate = 0;      ///< 1/s: multiplies the position error C
    Real mass_scale = 1;
    Real impulse_scale = 0;
};

/// The coefficients for frequency `hertz` (Hz) and damping ratio `zeta` over a step h; a rigid,
/// unbiased row ({0, 1, 0}) when hertz <= 0.
inline SoftCoefficients soft_coefficients(Real hertz, Real zeta, Real h) {
    if (!(hertz > 0)) return {};
    const Real omega = 2 * kPi * hertz;
    const Real a1 = 2 * zeta + h * omega;
    const Real a2 = h * omega * a1;
    const Real a3 = 1 / (1 + a2);
    return {omega / a1, a2 * a3, a3};
}

}  // namespace sinew
