// What a soft body's method can take at a step h (docs/soft-bodies.md, "fails where"): the bound past
// which semi-implicit Euler diverges, the warning a host gets when it creates a body beyond its method's
// documented limit, and the hint a blow-up is reported with (engine/core/step_fault.hpp).
#pragma once

#include <string>

#include "soft/soft_body.hpp"

namespace sinew {

/// An upper bound of the step at which semi-implicit Euler is stable on the body's springs: 2 / omega for
/// its stiffest spring alone, omega^2 = 4 k / (m_a + m_b) (the Rayleigh quotient of the spring's
/// stretching mode; a particle held by several springs oscillates faster, so the body's own critical step
/// is no larger). kRealMax for a body without springs of positive stiffness between free particles.
Real semi_implicit_step_bound(const SoftBody& b);

/// Empty, or a sentence saying that the body's method is past its documented stability limit at step h:
/// semi-implicit Euler with h above semi_implicit_step_bound, explicit Euler with an undamped spring.
std::string stability_warning(const SoftBody& b, Real h);

/// The method's stability limit and what to change, for a body whose state turned non-finite at step h.
std::string stability_hint(const SoftBody& b, Real h);

}  // namespace sinew
