// Tetrahedral FEM as a force model (soft/force_models.hpp): the force-based integrators (explicit,
// semi-implicit and implicit Euler) step FEM bodies through this row, as they step springs.
//
// Implicit Euler (Müller & Gross 2004 §4 with Rayleigh damping C = α M + β K'): the rotations are taken
// at x_n and held through the step (stiffness warping: ∂f/∂x = -K'), so the system the integrator solves,
// (M + hλ C + h²λ² K') Δv = h (f_n - hλ K' v_n), is symmetric positive definite; for λ = 1 it is Müller's
// (M + h C + h² K') v_{n+1} = M v_n - h (K' x_n + f₀ - f_ext) (docs/theory.md#fem). K' is assembled once
// per step into the body's block-sparse matrix, and the CG product is one pass over its rows.
#include "soft/fem_elements.hpp"
#include "soft/force_models.hpp"
#include "soft/solver_caches.hpp"

namespace sinew {

namespace {

bool has_tets(const SoftBody& b) { return b.fem != nullptr; }

// Plasticity once per step, at x_n (O'Brien et al. 2002; the rule needs h, which the force pass has not).
void fem_begin_step(SoftBody& b, Real h) {
    if (!b.def.fem.plastic()) return;
    fem_update_rotations(*b.fem, b.p.x, b.def.fem.rotation);
    fem_update_plasticity(*b.fem, b.p.x, b.def.fem, h);
    b.fem->rotations_current = true;  // the force pass at x_n reuses them
}

// -α m v on the free particles (pinned ones have no force to feel).
void add_mass_damping(const SoftBody& b, const std::vector<Vec3>& v, std::vector<Vec3>& f) {
    const Real alpha = b.def.fem.mass_damping;
    if (alpha == 0) return;
    for (std::size_t i = 0; i < b.p.size(); ++i)
        if (b.p.inv_mass[i] != 0) f[i] -= (alpha * b.p.mass[i]) * v[i];
}

// The FEM state is this model's scratch: evaluating forces updates its rotations.
void add_fem_forces(const SoftBody& b, const std::vector<Vec3>& x, const std::vector<Vec3>& v, std::vector<Vec3>& f) {
    FemState& s = *b.fem;
    fem_kernel(s, x, &v, b.def.fem.stiffness_damping, b.def.fem.rotation, !s.rotations_current, &f, false, b.region);
    s.rotations_current = false;
    add_mass_damping(b, v, f);
}

void prepare_fem_implicit(const SoftBody& b, ImplicitTerms& t) {
    FemState& s = *b.fem;
    const Particles& p = b.p;
    const FemMaterial& mat = b.def.fem;
    fem_kernel(s, p.x, &p.v, mat.stiffness_damping, mat.rotation, !s.rotations_current, t.force, true, b.region);
    s.rotations_current = false;
    add_mass_damping(b, p.v, *t.force);

    const Real hl = t.h * t.lambda;
    s.k_scale = hl * hl + hl * mat.stiffness_damping;
    s.m_scale = hl * mat.mass_damping;
    ImplicitEulerCache& c = *t.cache;
    for (std::size_t i = 0; i < p.size(); ++i) {
        const Mat3& K = s.stiffness.block[s.stiffness.diagonal[i]];
        Real* B = c.cg.block(i);
        B[0] += s.k_scale * K(0, 0) + s.m_scale * p.mass[i];
        B[1] += s.k_scale * K(1, 1) + s.m_scale * p.mass[i];
        B[2] += s.k_scale * K(2, 2) + s.m_scale * p.mass[i];
        B[3] += s.k_scale * K(0, 1);
        B[4] += s.k_scale * K(0, 2);
        B[5] += s.k_scale * K(1, 2);
        s.scratch[i] = p.inv_mass[i] != 0 ? p.v[i] : Vec3::Zero();  // pinned: velocity taken as 0
    }
    // ∂f/∂x v_n = -K' v_n.
    s.stiffness.add_product(s.scratch, Real(-1), *t.dfdx_v);
}

void add_fem_product(const SoftBody& b, const ImplicitEulerCache&, const std::vector<Vec3>& u, std::vector<Vec3>& q) {
    const FemState& s = *b.fem;
    s.stiffness.add_product(u, s.k_scale, q, b.region);
    if (s.m_scale != 0)
        for (std::size_t i = 0; i < b.p.size(); ++i) q[i] += (s.m_scale * b.p.mass[i]) * u[i];  // particles' rows only
}

}  // namespace

const ForceModel kFemForces{"fem", has_tets, add_fem_forces, prepare_fem_implicit, add_fem_product, fem_begin_step};

}  // namespace sinew
