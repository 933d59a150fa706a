// Matyka's pressure soft body (Matyka & Ollila 2003, Matyka 2004; docs/theory.md#pressure): a closed
// triangle surface holding an ideal gas, P V = P_c, so the pressure follows the current volume and each
// face is pushed outward by F = P A n̂ = (P_c / V) A n̂, a third of it on each of its vertices.
#include <algorithm>

#include "soft/force_models.hpp"
#include "soft/soft_integrators.hpp"

namespace sinew {

namespace {

// Volumes are measured from the first vertex of the surface rather than the world origin. For a closed
// surface the divergence-theorem sum does not depend on that point, and measuring from a point on the
// surface keeps the terms of the order of the body's own size: a 1 m ball 100 m from the origin would
// otherwise sum terms ~1e4 times its volume and lose most of float's 7 digits to cancellation.
inline Vec3 reference_point(const std::vector<std::uint32_t>& triangles, const std::vector<Vec3>& x) {
    return triangles.empty() ? Vec3::Zero() : x[triangles[0]];
}

}  // namespace

Real enclosed_volume(const std::vector<std::uint32_t>& triangles, const std::vector<Vec3>& x) {
    // V = (1/6) Σ x0 · (x1 × x2) over counter-clockwise (outward) triangles: the flux of the field x/3
    // through the surface, whose divergence is 1. Summed in double: a 642-vertex ball adds 1280 terms of
    // both signs.
    const Vec3 o = reference_point(triangles, x);
    double six_v = 0;
    const std::size_t n = triangles.size() / 3;
    for (std::size_t t = 0; t < n; ++t) {
        const Vec3 a = x[triangles[3 * t]] - o;
        const Vec3 b = x[triangles[3 * t + 1]] - o;
        const Vec3 c = x[triangles[3 * t + 2]] - o;
        six_v += double(a.dot(b.cross(c)));
    }
    return Real(six_v / 6);
}

void add_pressure_forces(const SoftBody& b, const std::vector<Vec3>& x, std::vector<Vec3>& f) {
    const Real pc = b.def.pressure;
    if (pc == 0 || b.triangles.empty()) return;
    Real volume = enclosed_volume(b.triangles, x);
    if (!(volume > 0)) return;  // turned inside out or flat: no gas to push with (P = P_c / V needs V > 0)
    // P = P_c / V grows without bound as V -> 0; a body crushed to 1% of its rest volume would get 100
    // times its rest pressure in one step and explode under an explicit force. Capping the pressure there
    // changes nothing in any state a simulation should reach and keeps a crushed body finite.
    if (b.rest_volume > 0) volume = std::max(volume, Real(0.01) * b.rest_volume);
    // (x1 − x0) × (x2 − x0) = 2 A n̂ for a counter-clockwise triangle, so a third of F = (P_c/V) A n̂ is
    // (P_c / (6 V)) times that cross product.
    const Real scale = pc / (Real(6) * volume);
    const std::size_t n = b.triangles.size() / 3;
    for (std::size_t t = 0; t < n; ++t) {
        const std::uint32_t i0 = b.triangles[3 * t], i1 = b.triangles[3 * t + 1], i2 = b.triangles[3 * t + 2];
        const Vec3 third = scale * (x[i1] - x[i0]).cross(x[i2] - x[i0]);
        f[i0] += third;
        f[i1] += third;
        f[i2] += third;
    }
}

namespace {
bool has_pressure(const SoftBody& b) { return b.def.pressure != 0; }
void add_pressure(const SoftBody& b, const std::vector<Vec3>& x, const std::vector<Vec3>&, std::vector<Vec3>& f) {
    add_pressure_forces(b, x, f);
}
}  // namespace

// Explicit in every integrator (no implicit terms): its stiffness is small next to the springs'.
const ForceModel kPressureForces{"pressure", has_pressure, add_pressure, nullptr, nullptr};

}  // namespace sinew
