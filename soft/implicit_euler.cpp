// Implicit Euler for force-based soft bodies: one Newton step per frame (Baraff & Witkin 1998), the linear
// system solved by block-Jacobi preconditioned conjugate gradient (soft/block_cg.hpp). Each force model
// supplies its part of the product: springs matrix-free, link by link (Volino & Magnenat-Thalmann, seed
// 003 §2.3), FEM from its warped stiffness assembled once per step into a block-sparse matrix.
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
// The force models (soft/force_models.hpp) add their own linearisations: the springs' Jacobian blocks and
// their Volino blend are in soft/spring_forces.cpp; Matyka's pressure stays explicit. This file knows
// none of them.
// The drag (v *= 1/(1 + h drag) in every integrator) is the force -drag m v, also implicit here:
// ∂f/∂v = -drag M, so at λ = 1 a particle without springs gets exactly v_{n+1} = (v_n + h g)/(1 + h drag).
// External forces and Matyka's pressure are explicit (evaluated at x_n).
//
// Pinned particles (inverse mass 0) are removed by Baraff-Witkin's filter S = 0: their rows of the
// residual, the preconditioner and every product are zero, so Δv stays 0 there and CG runs in the free
// subspace. Their velocity counts as 0 in Δx (the system has already placed attached particles). An
// attached particle a two-way layer ties to its rigid body is not filtered: it solves for the
// change of the body's velocity at that point, which the layer hands to the body.
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

#include "soft/fem_elements.hpp"
#include "soft/force_models.hpp"
#include "soft/particle_collision.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/solver_caches.hpp"

namespace sinew {

void ImplicitEulerCache::resize(std::size_t n, std::size_t m, std::size_t rigid_rows) {
    if (force.size() != n) {
        contact_rows.clear();
        contact_rows.reserve(n);
        contact_released.assign(n, 0);
        force.assign(n, Vec3::Zero());
        expanded.assign(n, Vec3::Zero());
        expanded_product.assign(n, Vec3::Zero());
        rhs.clear();
        dv.clear();
        mass.assign(n, Real(0));
        pinned.clear();
        pinned.reserve(n);
    }
    if (rhs.size() != n + rigid_rows) {  // the coupled bodies' rows come and go: the particles' stay
        rhs.resize(n + rigid_rows, Vec3::Zero());
        dv.resize(n + rigid_rows, Vec3::Zero());
    }
    cg.resize(n + rigid_rows);
    if (links.size() != m) links.assign(m, LinkBlock{});
}

namespace {

// The CG product q = A u with A = M (1 + hλ drag) plus each force model's part, and the rows of pinned
// particles zeroed (the filter).
// Reads and writes the particles' rows only (u and q may be longer: the coupled bodies' rows follow).
void system_product(const SoftBody& b, const ImplicitEulerCache& c, const std::vector<Vec3>& u, std::vector<Vec3>& q,
                    bool filter_pinned = true) {
    const std::size_t n = c.mass.size();
    const bool by_rows = c.link_rows.built_for(n);
    if (by_rows) {
        // On the workers: each link's S_j (u_a - u_b), then the mass and the springs row by row, row i's
        // sum taking its links in ascending order, as add_springs_product's scatter does.
        Vec3* product = c.link_product.data();
        c.cg.each(c.links.size(), [&](std::size_t begin, std::size_t end) {
            const ImplicitEulerCache::LinkBlock* links = c.links.data();
            const Vec3* uu = u.data();
            Vec3* out = product;
            for (std::size_t j = begin; j < end; ++j) {
                const ImplicitEulerCache::LinkBlock& l = links[j];
                const Vec3 du = uu[l.a] - uu[l.b];
                out[j] = l.iso * du + (l.aniso * l.dir.dot(du)) * l.dir;
            }
        });
        c.cg.each(n, [&](std::size_t begin, std::size_t end) {
            const Vec3* uu = u.data();
            const Vec3* in = product;
            Vec3* qq = q.data();
            for (std::size_t i = begin; i < end; ++i) {
                Vec3 qi = c.mass[i] * uu[i];
                for (std::uint32_t k = c.link_rows.start[i]; k < c.link_rows.start[i + 1]; ++k) {
                    const std::uint32_t e = c.link_rows.entry[k];
                    if (e & 1u) qi -= in[e >> 1];
                    else qi += in[e >> 1];
                }
                qq[i] = qi;
            }
        });
    } else {
        for (std::size_t i = 0; i < n; ++i) q[i] = c.mass[i] * u[i];
    }
    for (const ForceModel* model : force_models())
        if (model->add_implicit_product && model->present(b) && !(by_rows && model == &kSpringForces))
            model->add_implicit_product(b, c, u, q);
    if (filter_pinned)
        for (const std::uint32_t i : c.pinned) q[i].setZero();
}

// Rigid bodies in the solve (two-way coupling, coupling/coupling_layer.cpp, tie_rigid_bodies). A particle
// tied to a dynamic rigid body moves with the body's point in the tied directions C (n nᵀ, or I where
// friction holds): v_i = P u_i + C (V + ω × r_i), P = I - C. The unknowns are the particles' free parts
// u and each body's (ΔV, Δω), and with J that map, the step minimises the particles' implicit Euler
// energy plus the bodies' kinetic energy: (Jᵀ A J + diag(M, I)) Δq = Jᵀ (rhs - A z), z the start
// mismatch C (V* + ω* × r - v) (the body's velocity at the start, the step's gravity included). Still
// symmetric positive definite, so CG solves it as before: the body's inertia meets the springs inside
// the solve, and every tied particle ends at the body's velocity there. The impulse the body gave
// particle i is its row of the unconstrained system, λ_i = C (A Δv - rhs)_i; the layer takes Σ λ from
// the body (it is M ΔV, I Δω once CG has converged). This replaced independent shares (the body's mass
// split evenly over the particles, each moving on its own): their impulses did not agree with one body
// velocity, and a ball resting in a cloth rocked at 1-3 cm/s for good, the set of particles carrying it
// alternating between two sides of it every step (docs/coupling.md).

// A 3x3 block of BlockCg's storage (xx, yy, zz, xy, xz, yz) as a matrix, and a matrix into it.
Mat3 block_matrix(const Real* B) {
    Mat3 a;
    a << B[0], B[3], B[4], B[3], B[1], B[5], B[4], B[5], B[2];
    return a;
}
void set_block(Real* B, const Mat3& a) {
    B[0] = a(0, 0), B[1] = a(1, 1), B[2] = a(2, 2), B[3] = a(0, 1), B[4] = a(0, 2), B[5] = a(1, 2);
}

// J on a tied row: the particle's own part where it is free, its body's point velocity where tied. u holds
// the particles' rows, then two per body.
Vec3 tied_row(const ImplicitEulerCache::CoupledRow& r, const std::vector<Vec3>& u, std::size_t n) {
    const Vec3& own = u[r.particle];
    return own + r.tied * (u[n + 2 * r.rigid] + u[n + 2 * r.rigid + 1].cross(r.arm) - own);
}

// Jᵀ on a tied row: of the particle's row x, the tied part goes to its body's rows (force, and moment if
// the body turns), the rest stays.
void scatter_tied(const SoftBody& b, const ImplicitEulerCache::CoupledRow& r, const Vec3& tied, std::vector<Vec3>& q,
                  std::size_t n) {
    q[n + 2 * r.rigid] += tied;
    if (b.coupled_rigids[r.rigid].rotates) q[n + 2 * r.rigid + 1] += r.arm.cross(tied);
}

// q = (Jᵀ A J + diag(M, I)) u on the reduced rows, the contact constraints' S applied (the particles' own
// filter, Baraff & Witkin 1998 §5.3). The bodies' rows follow the particles' (u.size() - n, two per body).
void reduced_product(const SoftBody& b, ImplicitEulerCache& c, const std::vector<Vec3>& u, std::vector<Vec3>& q) {
    const std::size_t n = c.mass.size();
    const std::size_t bodies = (u.size() - n) / 2;
    if (bodies == 0) {
        system_product(b, c, u, q);
    } else {
        std::vector<Vec3>& y = c.expanded;
        std::vector<Vec3>& ay = c.expanded_product;
        std::copy(u.begin(), u.begin() + std::ptrdiff_t(n), y.begin());
        for (const ImplicitEulerCache::CoupledRow& r : c.coupled_rows) y[r.particle] = tied_row(r, u, n);
        system_product(b, c, y, ay);
        std::copy(ay.begin(), ay.end(), q.begin());
        for (std::size_t k = 0; k < bodies; ++k) {
            const SoftBody::CoupledRigid& body = b.coupled_rigids[k];
            q[n + 2 * k] = body.mass * u[n + 2 * k];
            q[n + 2 * k + 1] = body.rotates ? Vec3(body.inertia * u[n + 2 * k + 1]) : Vec3::Zero();
        }
        for (const ImplicitEulerCache::CoupledRow& r : c.coupled_rows) {
            const Vec3 tied = r.tied * ay[r.particle];
            q[r.particle] -= tied;
            scatter_tied(b, r, tied, q, n);
        }
    }
    for (const ImplicitEulerCache::ContactRow& r : c.contact_rows) q[r.particle] -= r.normal.dot(q[r.particle]) * r.normal;
}

// CG stopped before converging leaves a residual r = A Δv - rhs whose sum is a net force: the internal
// forces cancel only in the exact solution, so a free cloth at the default cap of 10 iterations changed
// its momentum by 1e-4 N s a step, with nothing touching it (5.8% of a thrown 0.5 kg cloth's in a
// second). K and D annihilate a uniform velocity (translation invariance), so shifting every particle's Δv
// by δ with (Σ m P) δ = -Σ P r leaves the internal forces' residual as it was and makes the momentum
// change exactly the external impulses and the tied bodies' (a tied particle's impulse, which its body
// takes back, absorbs the residual in its tied directions C; P = I - C, I for a free particle). Only for
// bodies with no pinned particle and no contact constraint, whose own rows fix parts of Δv. Returns δ,
// from the reduced solution (before the tied particles' rows are expanded).
Vec3 momentum_correction(const SoftBody& b, ImplicitEulerCache& c) {
    const std::size_t n = c.mass.size();
    reduced_product(b, c, c.dv, c.cg.q);
    Vec3 net = Vec3::Zero();
    Mat3 mass = Mat3::Zero();
    for (std::size_t i = 0; i < n; ++i) {
        net += c.cg.q[i] - c.rhs[i];  // the tied rows are P-filtered already
        mass.diagonal().array() += c.mass[i];
    }
    for (const ImplicitEulerCache::CoupledRow& r : c.coupled_rows) mass -= c.mass[r.particle] * r.tied;
    if (!(mass.determinant() > Real(1e-12) * mass.trace() * mass.trace() * mass.trace())) return Vec3::Zero();
    return -(mass.inverse() * net);
}

// The rest-factor preconditioner of an FEM body: A₀ = diag(m (1 + hλ drag) + hλ α m) + (h²λ² + hλ β) K₀
// (the FEM model's scales, soft/fem_forces.cpp), pinned rows identity; refactored only when these change.
bool prepare_rest_factor(const SoftBody& b, ImplicitEulerCache& c) {
    const FemState& s = *b.fem;
    if (!c.rest_factor) c.rest_factor = std::make_shared<FemRestFactor>();
    c.factor_diagonal.resize(c.mass.size());
    c.factor_fixed.clear();  // capacity n after the first step: no allocation
    for (std::size_t i = 0; i < c.mass.size(); ++i) {
        c.factor_diagonal[i] = c.mass[i] + s.m_scale * b.p.mass[i];
        if (b.p.inv_mass[i] == 0) c.factor_fixed.push_back(std::uint32_t(i));
    }
    return c.rest_factor->prepare(s, c.factor_diagonal, s.k_scale, c.factor_fixed);
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
    // A two-way coupling layer's dynamic rigid bodies (coupling/coupling_layer.cpp, tie_rigid_bodies): tied
    // to contact particles, and to attached particles, which then join the solve (not pinned) moving
    // with their target's point, so the body feels the springs inside this solve.
    const bool coupled = !b.coupled_rigids.empty() && b.contact_rigid.size() == n && b.contact_stick.size() == n &&
                         b.contact_arm.size() == n;
    const std::size_t rigid_rows = coupled ? 2 * b.coupled_rigids.size() : 0;
    c.resize(n, m, rigid_rows);
    // An attached particle tied to its body stands at the body's predicted end-of-step point (the soft
    // system placed it there), but in this solve it moves with the body from where the body is now: its
    // forces are taken at the body's point now, or the solve's own motion of it, h v, would count twice
    // (a 0.1 kg crate on a stiff rope then swung in a growing period-two oscillation). Put back after.
    c.tied_attached.clear();
    if (coupled)
        for (const Attachment& at : b.attachments) {
            const std::uint32_t i = at.particle;
            if (b.contact_rigid[i] == SoftBody::kNoRigid) continue;
            c.tied_attached.push_back({i, p.x[i]});
            p.x[i] = b.coupled_rigids[b.contact_rigid[i]].com + b.contact_arm[i];
        }
    for (const ForceModel* model : force_models())
        if (model->begin_step && model->present(b)) model->begin_step(b, h);

    const Real lambda = b.def.implicit_lambda;
    const Real hl = h * lambda;        // coefficient of ∂f/∂v in the matrix
    const Real h2l = h * hl;           // coefficient of ∂f/∂x v_n in the right-hand side
    const Real drag = b.def.drag;
    const Real mass_scale = Real(1) + hl * drag;

    // Forces of state n without the force models, and the diagonal blocks' mass part. rhs first collects
    // ∂f/∂x v_n (times h²λ below).
    std::vector<Vec3>& f = c.force;
    c.pinned.clear();
    const auto tied = [&](std::size_t i) { return coupled && b.contact_rigid[i] != SoftBody::kNoRigid; };
    const auto held_by_target = [&](std::size_t i) { return p.inv_mass[i] == 0 && !tied(i); };
    for (std::size_t i = 0; i < n; ++i) {
        f[i] = p.f[i] + p.mass[i] * (b.gravity - drag * p.v[i]);
        c.rhs[i].setZero();
        Real* B = c.cg.block(i);
        const Real md = p.mass[i] * mass_scale;
        c.mass[i] = md;
        B[0] = B[1] = B[2] = md;
        B[3] = B[4] = B[5] = 0;
        if (held_by_target(i)) c.pinned.push_back(std::uint32_t(i));  // capacity n: no allocation
    }

    // Each force model the body has adds its forces, its share of ∂f/∂x v_n and of the diagonal blocks
    // (soft/force_models.hpp: springs, pressure, which stays explicit, and FEM).
    ImplicitTerms terms;
    terms.h = h;
    terms.lambda = lambda;
    terms.force = &f;
    terms.dfdx_v = &c.rhs;
    terms.cache = &c;
    for (const ForceModel* model : force_models()) {
        if (!model->present(b)) continue;
        if (model->prepare_implicit)
            model->prepare_implicit(b, terms);
        else
            model->add_forces(b, p.x, p.v, f);
    }
    // A large body's CG runs its loops over the rows on the soft system's workers, the springs' product
    // gathered by rows (system_product), from this step's links.
    c.cg.region = b.region;
    c.link_rows.clear();
    if (b.region && b.region->workers() > 1 && n >= BlockCg::kBlockedRows && !c.links.empty()) {
        c.link_rows.build(n, c.links.size(), [&](std::size_t e) { return e % 2 ? c.links[e / 2].b : c.links[e / 2].a; });
        c.link_product.resize(c.links.size());
    }

    // Attachments whose reaction a coupling layer asks for (SoftBody::attachment_impulse): the unfiltered
    // right-hand side of their particles, kept before the filter zeroes it.
    const bool attachment_reactions = !b.attachments.empty() && b.attachment_impulse.size() == b.attachments.size();
    if (attachment_reactions)
        for (std::size_t k = 0; k < b.attachments.size(); ++k) {
            const std::uint32_t i = b.attachments[k].particle;
            b.attachment_impulse[k] = held_by_target(i) ? Vec3(-(h * f[i] + h2l * c.rhs[i])) : Vec3::Zero();
        }

    // Right-hand side h (f_n + hλ ∂f/∂x v_n), the preconditioner, and the filter.
    for (std::size_t i = 0; i < n; ++i) {
        if (held_by_target(i)) {
            c.rhs[i].setZero();
            std::fill(c.cg.block(i), c.cg.block(i) + 6, Real(0));
            continue;
        }
        c.rhs[i] = h * f[i] + h2l * c.rhs[i];
    }

    // Contacts (Baraff & Witkin 1998 §5.3): a particle the last contact pass found touching a collider,
    // and not moving away from it, gets its normal velocity change fixed to z = (collider speed - v_n · n) n
    // (resting: none), and the solve runs for the rest of Δv in the plane orthogonal to n, through the
    // filter S = I - n nᵀ: (S A S) y = S (rhs - A z), Δv = z + y. Without it the solve sees a body on the
    // ground as falling freely and the contact pass pushes its bottom back each step: a resting FEM block
    // then settled at 0.920 of its volume, against 0.975 clamped at its base; with the filter 0.968 (a 1 m
    // cube of 1,080 tets, E = 1e5, dropped 0.5 m), and a 20k-tet block ends its landing with no inverted
    // tet (674 without). The soft system records contacts for FEM bodies and for bodies under two-way
    // coupling (SoftSystem::record_contacts); against a dynamic rigid body the particle is tied to the
    // body instead (above, "Rigid bodies in the solve"), whose velocity the solve finds.
    c.contact_rows.clear();
    c.coupled_rows.clear();
    std::vector<Vec3>& z = c.force;  // free now: the forces are in rhs
    std::fill(z.begin(), z.end(), Vec3::Zero());
    const auto add_coupled_row = [&](std::uint32_t i, bool stick) {
        const std::uint32_t k = b.contact_rigid[i];
        const SoftBody::CoupledRigid& body = b.coupled_rigids[k];
        const Vec3& arm = b.contact_arm[i];
        const Mat3 C = stick ? Mat3(Mat3::Identity()) : Mat3(b.contact_normal[i] * b.contact_normal[i].transpose());
        const Vec3 friction = !stick && b.contact_friction.size() == n ? Vec3(b.contact_friction[i]) : Vec3::Zero();
        c.rhs[i] += friction;
        c.coupled_rows.push_back({i, k, C, arm, c.rhs[i], friction});
        // An attached particle's velocity is kept at 0 between steps (the force models read it so), so the
        // body starts it from rest every step (docs/coupling.md, open: m v a step taken from the body).
        const Vec3 v_start = p.inv_mass[i] == 0 ? Vec3::Zero() : p.v[i];
        z[i] = C * (body.point_velocity(arm) - v_start);
        // A tied particle's gap beyond its thickness is closed within the step, up to the contact slop.
        // Tied along the normal, it moves with the body's point to first order, but on a curved body it
        // leaves the surface by the square of its sliding over twice the radius: under a ball resting in a
        // cloth the particles drifted past the slop, dropped out of the contact set, and came back, two
        // steps in three; the ball never slept. Not beyond the slop: a tie held from further away (the
        // rows' contacts) is not pulled in at up to 3 thicknesses a step; not inside (the contact pass's
        // projection has that): pushed out at depth / h, particles striking a box off centre kept 2e-2 of
        // their angular momentum (1e-3 without).
        if (p.inv_mass[i] != 0 && b.contact_gap.size() == n)
            z[i] -= (std::min(std::max(b.contact_gap[i], Real(0)), kContactSlop * b.def.thickness) / h) * b.contact_normal[i];
    };
    if (coupled)
        for (const Attachment& at : b.attachments)
            if (tied(at.particle)) add_coupled_row(at.particle, true);
    if (b.contact_normal.size() == n)
        for (std::uint32_t i = 0; i < n; ++i) {
            const Vec3& nrm = b.contact_normal[i];
            if (p.inv_mass[i] == 0 || nrm.isZero()) continue;
            const Real approach = b.contact_speed[i] - nrm.dot(p.v[i]);  // > 0: moving into the collider
            if (approach < Real(-1e-3) || c.contact_released[i]) continue;  // leaving, or pulled last step
            if (tied(i)) {
                add_coupled_row(i, b.contact_stick[i] != 0);
                continue;
            }
            c.contact_rows.push_back({i, nrm, std::max(approach, Real(0)) * nrm, nrm.dot(c.rhs[i])});
            z[i] = c.contact_rows.back().dv_normal;
        }
    // The bodies' rows: their inertia on the diagonal, and the tied particles' blocks carried over
    // (Jᵀ B J's diagonal, before the blocks are inverted).
    for (std::size_t k = 0; k < rigid_rows / 2; ++k) {
        const SoftBody::CoupledRigid& body = b.coupled_rigids[k];
        Real* BV = c.cg.block(n + 2 * k);
        Real* BW = c.cg.block(n + 2 * k + 1);
        BV[0] = BV[1] = BV[2] = body.mass;
        BV[3] = BV[4] = BV[5] = 0;
        set_block(BW, body.rotates ? body.inertia : Mat3::Zero());
        c.rhs[n + 2 * k].setZero();
        c.rhs[n + 2 * k + 1].setZero();
    }
    const auto add_block = [](Real* B, const Mat3& a) { set_block(B, block_matrix(B) + a); };
    for (const ImplicitEulerCache::CoupledRow& r : c.coupled_rows) {
        const Mat3 cac = r.tied * block_matrix(c.cg.block(r.particle)) * r.tied;
        add_block(c.cg.block(n + 2 * r.rigid), cac);
        if (b.coupled_rigids[r.rigid].rotates) {
            const Mat3 R = skew(r.arm);
            add_block(c.cg.block(n + 2 * r.rigid + 1), -(R * cac * R));
        }
    }
    c.cg.invert_blocks();
    // The right side S (rhs - A z) on the particles, Jᵀ of it on the tied ones and their bodies.
    if (!c.contact_rows.empty() || !c.coupled_rows.empty()) {
        system_product(b, c, z, c.cg.q);
        for (std::size_t i = 0; i < n; ++i) c.rhs[i] -= c.cg.q[i];
    }
    const auto filter_block = [&](std::uint32_t i, const Mat3& S) {
        // The preconditioner filtered as the system is: S B⁻¹ S.
        Real* B = c.cg.block(i);
        set_block(B, S * block_matrix(B) * S);
    };
    for (const ImplicitEulerCache::ContactRow& r : c.contact_rows) {
        c.rhs[r.particle] -= r.normal.dot(c.rhs[r.particle]) * r.normal;
        filter_block(r.particle, Mat3::Identity() - r.normal * r.normal.transpose());
    }
    for (const ImplicitEulerCache::CoupledRow& r : c.coupled_rows) {
        const Vec3 tied = r.tied * c.rhs[r.particle];
        c.rhs[r.particle] -= tied;
        scatter_tied(b, r, tied - r.friction, c.rhs, n);  // the body takes the friction's opposite
        filter_block(r.particle, Mat3::Identity() - r.tied);
    }
    const auto filtered_product = [&](const std::vector<Vec3>& u, std::vector<Vec3>& q) { reduced_product(b, c, u, q); };
    // The reduced unknowns' filter, for vectors CG starts from or the rest factor returns.
    const auto filter_unknowns = [&](std::vector<Vec3>& u) {
        for (const std::uint32_t i : c.pinned) u[i].setZero();
        for (const ImplicitEulerCache::ContactRow& r : c.contact_rows) u[r.particle] -= r.normal.dot(u[r.particle]) * r.normal;
        for (const ImplicitEulerCache::CoupledRow& r : c.coupled_rows) u[r.particle] -= r.tied * u[r.particle];
    };

    // Preconditioned CG on A Δv = rhs (soft/block_cg.hpp), from the last step's Δv if that one converged,
    // else from 0. The bodies' rows always start from 0 (the bodies may not be last step's).
    const bool warm = c.cg_converged;
    if (warm) {
        filter_unknowns(c.dv);
        for (std::size_t k = n; k < c.dv.size(); ++k) c.dv[k].setZero();
    }
    BlockCg::Result res;
    if (b.fem && b.def.preconditioner == SoftPreconditioner::RestFactor && prepare_rest_factor(b, c)) {
        // P = S R_N A₀⁻¹ R_Nᵀ S (soft/fem_rest_factor.hpp), filtered as the system is; block Jacobi on the
        // bodies' rows.
        const auto rest_factor = [&](const std::vector<Vec3>& r, std::vector<Vec3>& z) {
            c.rest_factor->apply(r, z);
            filter_unknowns(z);
            for (std::size_t k = n; k < r.size(); ++k) z[k] = c.cg.precondition(k, r[k]);
        };
        res = c.cg.solve(filtered_product, rest_factor, c.rhs, c.dv, b.def.cg_tolerance, b.def.iterations, warm);
    } else {
        res = c.cg.solve(filtered_product, c.rhs, c.dv, b.def.cg_tolerance, b.def.iterations, warm);
    }
    const Vec3 shift = c.pinned.empty() && c.contact_rows.empty() && !res.converged ? momentum_correction(b, c) : Vec3::Zero();
    // Δv = J Δq + z on the particles: the tied ones take their body's velocity change at their arm.
    for (const ImplicitEulerCache::CoupledRow& r : c.coupled_rows) c.dv[r.particle] = tied_row(r, c.dv, n);
    for (std::size_t i = 0; i < n; ++i) c.dv[i] += z[i] + shift;
    for (std::size_t k = 0; k < rigid_rows / 2; ++k) {
        b.coupled_rigids[k].dv = c.dv[n + 2 * k];
        b.coupled_rigids[k].dw = c.dv[n + 2 * k + 1];
    }
    // The impulse each constraint applied, n · (A Δv - rhs): negative means it held the particle down
    // (the collider pulled), and that contact is released for the next step; positive, its normal velocity
    // change is the contact pass's friction budget (SoftBody::contact_dvn).
    std::fill(c.contact_released.begin(), c.contact_released.end(), std::uint8_t(0));
    if (b.contact_dvn.size() != n) b.contact_dvn.assign(n, Real(0));
    std::fill(b.contact_dvn.begin(), b.contact_dvn.end(), Real(0));
    std::fill(b.contact_tie_impulse.begin(), b.contact_tie_impulse.end(), Vec3::Zero());
    if (!c.contact_rows.empty() || !c.coupled_rows.empty()) system_product(b, c, c.dv, c.cg.q);
    for (const ImplicitEulerCache::ContactRow& r : c.contact_rows) {
        const Real impulse = r.normal.dot(c.cg.q[r.particle]) - r.rhs_normal;
        if (impulse < 0)
            c.contact_released[r.particle] = 1;
        else
            b.contact_dvn[r.particle] = impulse / c.mass[r.particle];
    }

    // The tied particles: the impulse the body gave each, λ = C (A Δv - rhs), is what the coupling layer
    // takes from the body. One that pulled along the normal is released for the next step, as the
    // constraints above are.
    if (!c.coupled_rows.empty()) {
        if (b.contact_tie_impulse.size() != n) b.contact_tie_impulse.assign(n, Vec3::Zero());
        for (const ImplicitEulerCache::CoupledRow& r : c.coupled_rows) {
            const Vec3 j = r.tied * (c.cg.q[r.particle] - r.rhs) + r.friction;
            b.contact_tie_impulse[r.particle] = j;
            if (p.inv_mass[r.particle] == 0) continue;  // an attachment: bilateral, it may pull
            const Real jn = j.dot(b.contact_normal[r.particle]);
            if (jn < 0) c.contact_released[r.particle] = 1;
            else b.contact_dvn[r.particle] = jn / c.mass[r.particle];  // the contact pass's friction budget
        }
    }

    // What holding each attached particle on its target took: its row of the unfiltered system, the
    // impulse J = (A Δv - rhs)_i the filter's constraint supplied (its own Δv is 0), for a hybrid or
    // interleaved layer to send back to the body. A two-way tie reports through contact_tie_impulse.
    if (attachment_reactions) {
        system_product(b, c, c.dv, c.cg.q, false);
        for (std::size_t k = 0; k < b.attachments.size(); ++k) {
            const std::uint32_t i = b.attachments[k].particle;
            if (held_by_target(i)) b.attachment_impulse[k] += c.cg.q[i];
        }
    }

    c.cg_iterations = res.iterations;
    c.cg_residual = res.residual;
    c.cg_converged = res.converged;

    // State n+1.
    for (const auto& [i, at] : c.tied_attached) p.x[i] = at;
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
