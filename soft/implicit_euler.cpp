// Implicit Euler for mass-spring bodies: one Newton step per frame (Baraff & Witkin 1998), the linear
// system solved by block-Jacobi preconditioned conjugate gradient, matrix-free over the links (Volino &
// Magnenat-Thalmann, seed 003 §2.3: the products are accumulated link by link, no matrix is built).
// Equations: Baraff & Witkin 1998, Volino & Magnenat-Thalmann 2000; docs/theory.md#euler and
// docs/theory.md#mass-spring-forces.
//
// The λ blend (b.def.implicit_lambda, written λ below). We use the one-step "θ-method" form, linearised
// once at state n:
//     v_{n+1} = v_n + Δv,   x_{n+1} = x_n + h (v_n + λ Δv),
//     M Δv = h [ f_n + λ (∂f/∂x Δx + ∂f/∂v Δv) ],   Δx = h (v_n + λ Δv),
// that is
//     (M - hλ ∂f/∂v - h²λ² ∂f/∂x) Δv = h (f_n + hλ ∂f/∂x v_n).
// λ = 1 is Baraff-Witkin's backward Euler step exactly; λ = ½ is the trapezoidal rule, which for linear
// forces is the implicit midpoint rule (energy-conserving on an undamped spring; the test checks it).
// Volino & Magnenat-Thalmann (seed 003, eq. 13-15) blend backward Euler into the implicit midpoint step
// the same way but through the previous step's state (their λ = 0 is backward Euler, 1 the midpoint
// step), which needs the state n-1 and a special first step; the θ form has the same end points, keeps
// one state, and is why our λ runs from 1 (backward Euler) down to ½ (midpoint).
//
// Jacobians per link j = (a, b), d = x_a - x_b, x̂ = d/|d|, L rest length, β = b.def.isotropic_blend:
//     ∂f_a/∂x_a = -k [ c (I - x̂x̂ᵀ) + x̂x̂ᵀ ],   c = (1-β)(1 - L/|d|) + β,
// Baraff-Witkin's exact (anisotropic) block for β = 0 and the isotropic -k I for β = 1 (Volino's linear
// blend, seed 003 §2.4). A compressed link (|d| < L) has c < 0 at β = 0: the exact block is then
// indefinite and CG can break down, so c is clamped at 0 (a compressed link loses its lateral stiffness
// term, the common remedy). Volino's blend alone keeps c ≥ 0 down to |d| = (1-β) L.
//     ∂f_a/∂v_a = -k_d x̂x̂ᵀ   (the damping force's dependence on x is neglected, as Baraff-Witkin do).
// The drag (v *= 1/(1 + h drag) in every integrator) is the force -drag m v, also implicit here:
// ∂f/∂v = -drag M, so at λ = 1 a particle without springs gets exactly v_{n+1} = (v_n + h g)/(1 + h drag).
// External forces and Matyka's pressure are explicit (evaluated at x_n).
//
// Pinned particles (inverse mass 0) are removed by Baraff-Witkin's filter S = 0: their rows of the
// residual, the preconditioner and every product are zero, so Δv stays 0 there and CG runs in the free
// subspace. Their velocity counts as 0 in Δx (the system has already placed attached particles).
//
// CG: block-Jacobi (3x3 diagonal blocks, inverted once per step) preconditioner; stops when
// sqrt(rᵀPr / bᵀPb) <= b.def.cg_tolerance or after b.def.iterations iterations (the cap). The cap is the
// user's speed/accuracy knob. Started from 0, a capped CG returns the Δv of least A-norm error in its
// Krylov space and stays stable: a 1 m, 1 kg, 32x32 cloth with k = 1e4 N/m falls and hangs from two
// corners at h = 1/60 with a cap of 10 (largest stretch after 10 s 1.008, converged CG 1.009).
// Warm-starting from the previous step's Δv saves a quarter of the iterations when CG converges, but with
// the cap binding it diverged on that cloth (caps 10-40): the unconverged error is carried from step to
// step. So CG starts from the previous Δv only if that step converged, and from 0 otherwise. To be a true
// backward Euler step the cap must let CG reach the tolerance (1e-4); measured (h = 1/60): a 10x10 hanging
// cloth needs 25 iterations at k = 100 N/m and 43 at 1000; the 32x32 cloth 104 on average (max 135) at
// k = 1e3 and 152 (max 236) at k = 1e4 (the condition number grows with h² k/m). The tests set the cap
// high enough and check cg_converged.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "soft/soft_integrators.hpp"
#include "soft/solver_caches.hpp"

namespace sinew {

void ImplicitEulerCache::resize(std::size_t n, std::size_t m) {
    if (force.size() != n) {
        force.assign(n, Vec3::Zero());
        rhs.assign(n, Vec3::Zero());
        dv.assign(n, Vec3::Zero());
        mass.assign(n, Real(0));
        pinned.clear();
        pinned.reserve(n);
    }
    cg.resize(n);
    if (links.size() != m) links.assign(m, LinkBlock{});
}

namespace {

constexpr Real kMinLinkLength = Real(1e-9);  // as in spring_forces.cpp: no direction below it

// The CG product q = A u with A = M (1 + hλ drag) + Σ_j S_j (u_a - u_b) scattered to a (+) and b (-), and
// the rows of pinned particles zeroed (the filter).
void system_product(const ImplicitEulerCache& c, const std::vector<Vec3>& u, std::vector<Vec3>& q) {
    const std::size_t n = u.size();
    for (std::size_t i = 0; i < n; ++i) q[i] = c.mass[i] * u[i];
    for (const ImplicitEulerCache::LinkBlock& l : c.links) {
        const Vec3 du = u[l.a] - u[l.b];
        const Vec3 s = l.iso * du + (l.aniso * l.dir.dot(du)) * l.dir;
        q[l.a] += s;
        q[l.b] -= s;
    }
    for (const std::uint32_t i : c.pinned) q[i].setZero();
}

}  // namespace

void step_implicit_euler(SoftBody& b, Real h) {
    if (!(is_finite(h) && h > 0))
        throw SoftError("step_implicit_euler: time step h must be finite and > 0, got " + std::to_string(h));
    Particles& p = b.p;
    const std::size_t n = p.size();
    const std::size_t m = b.links.size();
    if (!b.implicit_cache) b.implicit_cache = std::make_unique<ImplicitEulerCache>();
    ImplicitEulerCache& c = *b.implicit_cache;
    c.resize(n, m);

    const Real lambda = b.def.implicit_lambda;
    const Real blend = b.def.isotropic_blend;
    const Real hl = h * lambda;        // coefficient of ∂f/∂v in the matrix
    const Real h2l2 = hl * hl;         // coefficient of ∂f/∂x in the matrix
    const Real h2l = h * hl;           // coefficient of ∂f/∂x v_n in the right-hand side
    const Real drag = b.def.drag;
    const Real mass_scale = Real(1) + hl * drag;

    // Forces of state n without springs, and the diagonal blocks' mass part. rhs first collects
    // hλ ∂f/∂x v_n (times h below).
    std::vector<Vec3>& f = c.force;
    c.pinned.clear();
    for (std::size_t i = 0; i < n; ++i) {
        f[i] = p.f[i] + p.mass[i] * (b.gravity - drag * p.v[i]);
        c.rhs[i].setZero();
        Real* B = c.cg.block(i);
        const Real md = p.mass[i] * mass_scale;
        c.mass[i] = md;
        B[0] = B[1] = B[2] = md;
        B[3] = B[4] = B[5] = 0;
        if (p.inv_mass[i] == 0) c.pinned.push_back(std::uint32_t(i));  // capacity n: no allocation
    }

    // One pass over the links: spring force, the link's block S_j, its share of the diagonal blocks, and
    // of ∂f/∂x v_n (with the velocity of pinned particles taken as 0, see above).
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
        c.rhs[l.a] += kv;
        c.rhs[l.b] -= kv;
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
    if (b.def.pressure != 0) add_pressure_forces(b, p.x, f);

    // Right-hand side h (f_n + hλ ∂f/∂x v_n), the preconditioner, and the filter.
    for (std::size_t i = 0; i < n; ++i) {
        if (p.inv_mass[i] == 0) {
            c.rhs[i].setZero();
            std::fill(c.cg.block(i), c.cg.block(i) + 6, Real(0));
            continue;
        }
        c.rhs[i] = h * f[i] + h2l * c.rhs[i];
    }
    c.cg.invert_blocks();

    // Preconditioned CG on A Δv = rhs (soft/block_cg.hpp), from the last step's Δv if that one converged,
    // else from 0.
    const bool warm = c.cg_converged;
    if (warm)
        for (std::uint32_t i : c.pinned) c.dv[i].setZero();
    const BlockCg::Result res = c.cg.solve([&c](const std::vector<Vec3>& u, std::vector<Vec3>& q) { system_product(c, u, q); },
                                           c.rhs, c.dv, b.def.cg_tolerance, b.def.iterations, warm);
    c.cg_iterations = res.iterations;
    c.cg_residual = res.residual;
    c.cg_converged = res.converged;

    // State n+1.
    for (std::size_t i = 0; i < n; ++i) {
        p.x_prev[i] = p.x[i];
        if (p.inv_mass[i] == 0) {
            p.v[i].setZero();
            continue;
        }
        p.x[i] += h * (p.v[i] + lambda * c.dv[i]);
        p.v[i] += c.dv[i];
    }
}

}  // namespace sinew
