// Damped Hooke springs along the links (Baraff & Witkin 1998 §"damped springs";
// docs/theory.md#mass-spring-forces):
//   Δx = x_a - x_b, x̂ = Δx/|Δx|,
//   f_a = -[ k_s (|Δx| - L) + k_d (Δv · x̂) ] x̂,   f_b = -f_a.
// The damping acts along the link only, so a spring never resists rigid rotation of its two ends, and the
// pair of forces is equal and opposite, so links conserve linear momentum exactly.
#include <algorithm>

#include "soft/force_models.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/solver_caches.hpp"

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

namespace {

// Implicit Euler's linearisation of the springs (Baraff & Witkin 1998; docs/theory.md#mass-spring-forces).
// Per link j = (a, b), d = x_a - x_b, x̂ = d/|d|, L rest length, β = b.def.isotropic_blend:
//     ∂f_a/∂x_a = -k [ c (I - x̂x̂ᵀ) + x̂x̂ᵀ ],   c = (1-β)(1 - L/|d|) + β,
// Baraff-Witkin's exact (anisotropic) block for β = 0 and the isotropic -k I for β = 1 (Volino's linear
// blend). A compressed link (|d| < L) has c < 0 at β = 0: the exact block is then indefinite and CG can
// break down, so c is clamped at 0 (a compressed link loses its lateral stiffness term, the common
// remedy). Volino's blend alone keeps c ≥ 0 down to |d| = (1-β) L.
//     ∂f_a/∂v_a = -k_d x̂x̂ᵀ   (the damping force's dependence on x is neglected, as Baraff-Witkin do).
// One pass over the links: spring force, the link's block S_j = -h²λ² ∂f_a/∂x_a - hλ ∂f_a/∂v_a (kept for
// the product), its share of the diagonal blocks, and of ∂f/∂x v_n (pinned particles' velocity taken as 0:
// the system has already placed attached particles).
void prepare_springs_implicit(const SoftBody& b, ImplicitTerms& t) {
    const Particles& p = b.p;
    ImplicitEulerCache& c = *t.cache;
    std::vector<Vec3>& f = *t.force;
    std::vector<Vec3>& dfdx_v = *t.dfdx_v;
    const std::size_t m = b.links.size();
    if (c.links.size() != m) c.links.assign(m, ImplicitEulerCache::LinkBlock{});
    const Real hl = t.h * t.lambda;
    const Real h2l2 = hl * hl;
    const Real blend = b.def.isotropic_blend;
    for (std::size_t j = 0; j < m; ++j) {
        const Link& l = b.links[j];
        const Vec3 va = p.inv_mass[l.a] != 0 ? p.v[l.a] : Vec3::Zero();
        const Vec3 vb = p.inv_mass[l.b] != 0 ? p.v[l.b] : Vec3::Zero();
        const Vec3 dvel = va - vb;
        const Vec3 dx = p.x[l.a] - p.x[l.b];
        const Real len = dx.norm();
        Real iso, aniso;
        Vec3 e;
        Vec3 kv;  // ∂f_a/∂x_a (v_a - v_b)
        if (len < kMinLinkLength) {
            // No direction: no force, isotropic stiffness (Volino's β = 1 for this link).
            e.setZero();
            iso = h2l2 * l.stiffness;
            aniso = 0;
            kv = -l.stiffness * dvel;
        } else {
            e = dx / len;
            const Real fs = l.stiffness * (len - l.rest) + l.damping * e.dot(p.v[l.a] - p.v[l.b]);
            const Vec3 fa = -fs * e;
            f[l.a] += fa;
            f[l.b] -= fa;
            const Real cl = std::max(Real(0), (1 - blend) * (1 - l.rest / len) + blend);
            iso = h2l2 * l.stiffness * cl;
            aniso = h2l2 * l.stiffness * (1 - cl) + hl * l.damping;
            kv = -l.stiffness * (cl * dvel + ((1 - cl) * e.dot(dvel)) * e);
        }
        c.links[j] = ImplicitEulerCache::LinkBlock{l.a, l.b, iso, aniso, e};
        dfdx_v[l.a] += kv;
        dfdx_v[l.b] -= kv;
        const Real sxx = iso + aniso * e.x() * e.x(), syy = iso + aniso * e.y() * e.y(),
                   szz = iso + aniso * e.z() * e.z();
        const Real sxy = aniso * e.x() * e.y(), sxz = aniso * e.x() * e.z(), syz = aniso * e.y() * e.z();
        for (const std::uint32_t i : {l.a, l.b}) {
            Real* B = c.cg.block(i);
            B[0] += sxx;
            B[1] += syy;
            B[2] += szz;
            B[3] += sxy;
            B[4] += sxz;
            B[5] += syz;
        }
    }
}

// q += Σ_j S_j (u_a - u_b) scattered to a (+) and b (-).
void add_springs_product(const SoftBody&, const ImplicitEulerCache& c, const std::vector<Vec3>& u, std::vector<Vec3>& q) {
    for (const ImplicitEulerCache::LinkBlock& l : c.links) {
        const Vec3 du = u[l.a] - u[l.b];
        const Vec3 s = l.iso * du + (l.aniso * l.dir.dot(du)) * l.dir;
        q[l.a] += s;
        q[l.b] -= s;
    }
}

bool has_links(const SoftBody& b) { return !b.links.empty(); }

}  // namespace

const ForceModel kSpringForces{"springs", has_links, add_spring_forces, prepare_springs_implicit, add_springs_product};

}  // namespace sinew
