// Damped Hooke springs along the links (Baraff & Witkin 1998 §"damped springs";
// docs/theory.md#mass-spring-forces):
//   Δx = x_a - x_b, x̂ = Δx/|Δx|,
//   f_a = -[ k_s (|Δx| - L) + k_d (Δv · x̂) ] x̂,   f_b = -f_a.
// The damping acts along the link only, so a spring never resists rigid rotation of its two ends, and the
// pair of forces is equal and opposite, so links conserve linear momentum exactly.
#include "soft/soft_integrators.hpp"

namespace sinew {

namespace {
// Below this length the direction of a link is undefined and its force is skipped (1e-9 m is far below any
// rest length; the same threshold as the Verlet relaxation).
constexpr Real kMinLinkLength = Real(1e-9);
}  // namespace

void add_spring_forces(const SoftBody& b, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                       std::vector<Vec3>& f) {
    for (const Link& l : b.links) {
        const Vec3 d = x[l.a] - x[l.b];
        const Real len = d.norm();
        if (len < kMinLinkLength) continue;
        const Vec3 dir = d / len;
        const Real stretch_force = l.stiffness * (len - l.rest);
        const Real damping_force = l.damping * dir.dot(v[l.a] - v[l.b]);
        const Vec3 fa = -(stretch_force + damping_force) * dir;
        f[l.a] += fa;
        f[l.b] -= fa;
    }
}

}  // namespace sinew
