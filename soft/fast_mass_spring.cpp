// Fast mass-spring (Liu, Bargteil, O'Brien, Kavan 2013; seed 002; docs/theory.md#fast-mass-spring):
// implicit Euler written as
//     x_{n+1} = argmin_x  1/(2h²) (x - y)ᵀ M' (x - y) + Σ_j ½ k_j (|x_a - x_b| - L_j)²,
//     y = x_n + h (v_n + h M⁻¹ f_ext) / (1 + h drag),   M' = (1 + h drag) M,
// with each spring's energy rewritten as min over a direction p_j, |p_j| = L_j, of ½ k_j |x_a - x_b - p_j|².
// Block coordinate descent then alternates
//     local:  p_j = L_j (x_a - x_b) / |x_a - x_b|   (the optimal direction for fixed x),
//     global: (M'/h² + L) x = M' y / h² + J p      (the optimal x for fixed p),
// with L = Σ_j k_j A_j A_jᵀ ⊗ I_3 and J = Σ_j k_j A_j S_jᵀ ⊗ I_3 (A_j the incidence vector of link j). The
// matrix does not depend on the state, so one scalar sparse matrix (the three coordinates decouple) is
// factored once (Eigen SimplicialLDLT, in a fill-reducing AMD order) and each iteration is two triangular
// solves with three right-hand sides, run row by row on the factor's arrays. b.def.iterations local/global iterations per step. Velocities are read
// back: v_{n+1} = (x_{n+1} - x_n)/h.
//
// Initial guess: x = x_n + h v_n / (1 + h drag), the momentum prediction without the external forces. Under
// gravity alone it differs from y by a uniform translation, which the local step cannot see (directions
// are translation-invariant), so a free-flying body gets the same iterates as from x = y. But at rest
// (v = 0) it starts from x_n, which makes a static equilibrium an exact fixed point of the step whatever
// the iteration count. Starting from y instead, the pinned particles (which y does not move) bias the rest
// shape by an error that only more iterations reduce: measured 8.5e-5 m on the 10x10 cloth of
// tests/test_soft_cloth_equilibrium.cpp at k = 1000 N/m and 10 iterations, a force imbalance of half a
// node's weight (the x_n + h v_n guess: 4e-7 m, float round-off).
//
// Pinned particles (inverse mass 0) are eliminated: they are not unknowns; a link to a pinned particle
// adds k to its free end's diagonal and k x_pinned (+/- k p_j) to its right-hand side. The factorization is
// redone only when h, the drag, the pin set, the masses, or the links' ends or stiffnesses change.
//
// Damping: the method minimises a conservative energy, so it ignores the links' k_d (Liu et al. have no
// spring damping either); bodies are damped by the drag and by implicit Euler's own numerical damping. The
// drag is the implicit force -drag M v_{n+1}, v_{n+1} = (x - x_n)/h: moved to the left it scales the mass
// to M' and divides Liu's inertial velocity v_n + h M⁻¹ f_ext by (1 + h drag), so the step gives
// v_{n+1} = (v_n + h M⁻¹ (f_ext + f_springs(x_{n+1}))) / (1 + h drag), the drag every integrator shares, and
// a body at rest feels all of its weight (scaling y alone would lighten gravity by 1/(1 + h drag) at
// equilibrium). External forces (with gravity) and Matyka's pressure are explicit (at x_n), inside y.
//
// Linear tets: projective dynamics (Bouaziz, Martin, Liu, Kavan & Pauly 2014, seed 002). Each element adds
// the energies ½ w_s ‖F − R‖² (R the element rotation: as-rigid-as-possible) and ½ w_v ‖F − T_v‖²
// (T_v = F det(F)^(-1/3), F scaled to its volume: a volume constraint), F = Σ_a x_a g_aᵀ linear in the
// nodes, so the global matrix gains (w_s + w_v) Σ_e (g_a · g_b) at nodes (a, b), the same for x, y and z,
// and the right-hand side (w_s R + w_v T_v) g_a at node a. w_s = 2 μ V and w_v = 3 λ V make the energy
// μ ‖ε‖² + ½ λ tr(ε)² per volume for small strains, linear elasticity's, so the method converges to the
// same static answer as the corotational elements. The local step takes R from the element's rotation
// method (the batched polar iteration, warm-started, soft/fem_kernel.cpp); an inverted element
// (det F <= 0) targets R alone. Rayleigh damping is the force-based methods' (ignored here: the drag
// and the method's own damping act); plasticity and quadratic tets are refused under it.
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <string>

#include "soft/fem_elements.hpp"
#include "soft/ldlt_solve.hpp"
#include "soft/particle_collision.hpp"
#include "soft/soft_integrators.hpp"
#include "soft/solver_caches.hpp"

namespace sinew {

namespace {

constexpr Real kMinLinkLength = Real(1e-9);  // as in spring_forces.cpp: no direction below it
// Contacts inside the global step: CG over the touching particles stops when every gap is within this
// fraction of the particle's thickness, or after this many products (each one more pair of solves).
constexpr double kContactTolerance = 0.01;
constexpr int kContactIterations = 20;

// The workers of a large body's solve: the soft system's region when its run() has helpers and the
// system has enough rows to repay a stage's hand-off (about 1 µs; a 32 x 32 cloth's whole solve takes 34).
constexpr std::size_t kParallelRows = 2048;
ParallelRegion* parallel_region(const SoftBody& b, const FastMassSpringCache& c) {
    return b.region && b.region->workers() > 1 && c.factor.rows() >= kParallelRows ? b.region : nullptr;
}

// Projective dynamics' weights: w_s = 2 μ V (as-rigid-as-possible), w_v = 3 λ V (volume).
double shape_weight(const FemState& s, std::size_t e) { return 2.0 * double(s.mu) * double(s.volume[e]); }
double volume_weight(const FemState& s, std::size_t e) { return 3.0 * double(s.lambda) * double(s.volume[e]); }
double tet_weight(const FemState& s, std::size_t e) { return shape_weight(s, e) + volume_weight(s, e); }

// The local step of projective dynamics: each element's target (w_s R + w_v T_v) g_a added to the
// right-hand side at its free nodes, R from the element's rotation method at the current iterate.
void add_tet_projections(SoftBody& b, FastMassSpringCache& c) {
    FemState& s = *b.fem;
    fem_update_rotations(s, b.p.x, b.def.fem.rotation);
    const std::vector<Vec3>& x = b.p.x;
    for (std::size_t e = 0; e < s.size(); ++e) {
        const std::uint32_t* tet = &s.tets[4 * e];
        Mat3 ds;
        ds.col(0) = x[tet[1]] - x[tet[0]];
        ds.col(1) = x[tet[2]] - x[tet[0]];
        ds.col(2) = x[tet[3]] - x[tet[0]];
        const Mat3 F = ds * s.dm_inv[e];
        const Real det = F.determinant();
        const Mat3& R = s.rotation[e];
        // The volume target: F scaled to det 1; an inverted or flat element aims at its rotation.
        const Mat3 volume_target = det > 0 ? Mat3(F * Real(std::cbrt(1.0 / double(det)))) : R;
        const Mat3 T = Real(shape_weight(s, e)) * R + Real(volume_weight(s, e)) * volume_target;
        Vec3 g[4];
        shape_gradients(s.dm_inv[e], g);
        for (int a = 0; a < 4; ++a) {
            const int r = c.row[tet[a]];
            if (r < 0) continue;
            const Vec3 target = T * g[a];
            for (int k = 0; k < 3; ++k) c.rhs[3 * std::size_t(r) + k] += double(target[k]);
        }
    }
}

bool factorization_is_current(const SoftBody& b, const FastMassSpringCache& c, double h) {
    if (!c.factored || c.h != h || c.drag != b.def.drag) return false;
    const std::size_t tets = b.fem ? b.fem->size() : 0;
    if (c.tet_count != tets || (b.fem && (c.tet_mu != b.fem->mu || c.tet_lambda != b.fem->lambda))) return false;
    const std::size_t n = b.p.size(), m = b.links.size();
    if (c.inv_mass.size() != n || c.link_stiffness.size() != m) return false;
    // Every particle and link, every step (a user may change a mass or a link between steps): on the
    // workers for a large body (cloth-64: 4,096 masses and 16,002 links, 6% of a 2-worker step on one
    // thread).
    std::atomic<bool> changed{false};
    for_ranges(parallel_region(b, c), n + m, 256, [&](std::size_t begin, std::size_t end) {
        for (std::size_t k = begin; k < end; ++k) {
            bool same;
            if (k < n) {
                same = c.inv_mass[k] == b.p.inv_mass[k];
            } else {
                const std::size_t j = k - n;
                const Link& l = b.links[j];
                same = c.link_ends[2 * j] == l.a && c.link_ends[2 * j + 1] == l.b && c.link_stiffness[j] == l.stiffness;
            }
            if (!same) {
                changed.store(true, std::memory_order_relaxed);
                return;
            }
        }
    });
    return !changed.load(std::memory_order_relaxed);
}

// Builds and factors M'/h² + L over the free particles (allocates; runs only when something changed).
void factor(const SoftBody& b, FastMassSpringCache& c, double h) {
    const Particles& p = b.p;
    const std::size_t n = p.size(), m = b.links.size();
    using Triplet = Eigen::Triplet<double, int>;
    using SparseMatrix = FastMassSpringCache::SparseMatrix;

    // Free particles in natural order first, to find a fill-reducing order.
    std::vector<int> natural(n, -1);
    int nf = 0;
    for (std::size_t i = 0; i < n; ++i)
        if (p.inv_mass[i] != 0) natural[i] = nf++;
    auto assemble = [&](const std::vector<int>& row, bool lower_only) {
        std::vector<Triplet> t;
        t.reserve(std::size_t(nf) + 4 * m);
        const double mass_scale = (1.0 + h * double(b.def.drag)) / (h * h);
        for (std::size_t i = 0; i < n; ++i)
            if (row[i] >= 0) t.emplace_back(row[i], row[i], double(p.mass[i]) * mass_scale);
        for (const Link& l : b.links) {
            const int ra = row[l.a], rb = row[l.b];
            const double k = l.stiffness;
            if (ra >= 0) t.emplace_back(ra, ra, k);
            if (rb >= 0) t.emplace_back(rb, rb, k);
            if (ra >= 0 && rb >= 0) {
                if (!lower_only || ra > rb) t.emplace_back(ra, rb, -k);
                if (!lower_only || rb > ra) t.emplace_back(rb, ra, -k);
            }
        }
        if (b.fem) {
            // Projective dynamics: (w_s + w_v) (g_a · g_b) per element and pair of its nodes.
            const FemState& s = *b.fem;
            for (std::size_t e = 0; e < s.size(); ++e) {
                const std::uint32_t* tet = &s.tets[4 * e];
                Vec3 g[4];
                shape_gradients(s.dm_inv[e], g);
                const double w = tet_weight(s, e);
                for (int a = 0; a < 4; ++a)
                    for (int c2 = 0; c2 < 4; ++c2) {
                        const int ra = row[tet[a]], rc = row[tet[c2]];
                        if (ra < 0 || rc < 0 || (lower_only && rc > ra)) continue;
                        t.emplace_back(ra, rc, w * double(g[a].dot(g[c2])));
                    }
            }
        }
        SparseMatrix a(nf, nf);
        a.setFromTriplets(t.begin(), t.end());  // sums duplicates
        return a;
    };

    c.row.assign(n, -1);
    if (nf > 0) {
        // AMD on the full symmetric pattern; Eigen returns the inverse permutation (new -> old).
        Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> new_to_old;
        Eigen::AMDOrdering<int> amd;
        amd(assemble(natural, false), new_to_old);
        std::vector<int> old_row(std::size_t(nf), 0);  // natural row -> particle
        for (std::size_t i = 0; i < n; ++i)
            if (natural[i] >= 0) old_row[std::size_t(natural[i])] = int(i);
        for (int k = 0; k < nf; ++k) c.row[std::size_t(old_row[std::size_t(new_to_old.indices()[k])])] = k;
        c.matrix = assemble(c.row, true);
        // The rows are already in AMD order: the factorization keeps them.
        const Eigen::SimplicialLDLT<FastMassSpringCache::SparseMatrix, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt(c.matrix);
        if (ldlt.info() != Eigen::Success)
            throw SoftError("step_fast_mass_spring: the global matrix M/h^2 + L could not be factored (h = " +
                            std::to_string(h) + ", " + std::to_string(nf) + " free particles)");
        c.factor.assign(ldlt.matrixL().nestedExpression(), ldlt.vectorD());
    } else {
        // Nothing free (every particle pinned or attached): no system to solve, and the step runs no
        // local/global iteration while the factor is empty.
        c.factor.clear();
    }
    c.inertia.assign(3 * std::size_t(nf), 0.0);
    c.rhs.assign(3 * std::size_t(nf), 0.0);
    c.h = h;
    c.drag = b.def.drag;
    c.inv_mass = p.inv_mass;
    c.tet_count = b.fem ? b.fem->size() : 0;
    c.tet_mu = b.fem ? b.fem->mu : 0;
    c.tet_lambda = b.fem ? b.fem->lambda : 0;
    c.link_ends.resize(2 * m);
    c.link_stiffness.resize(m);
    for (std::size_t j = 0; j < m; ++j) {
        c.link_ends[2 * j] = b.links[j].a;
        c.link_ends[2 * j + 1] = b.links[j].b;
        c.link_stiffness[j] = b.links[j].stiffness;
    }
    // The links by row (both ends) and the links to a pinned particle, for the gathers of the step.
    c.pinned_links.clear();
    for (std::size_t j = 0; j < m; ++j)
        if ((c.row[b.links[j].a] >= 0) != (c.row[b.links[j].b] >= 0)) c.pinned_links.push_back(std::uint32_t(j));
    c.link_rows.build(std::size_t(nf), m, [&](std::size_t e) { return c.row[c.link_ends[e]]; });
    c.row_link_k.resize(c.link_rows.entry.size());
    for (std::size_t q = 0; q < c.row_link_k.size(); ++q) {
        const std::uint32_t e = c.link_rows.entry[q];
        const double k = c.link_stiffness[e / 2];
        c.row_link_k[q] = e % 2 ? -k : k;
    }
    c.schedule.clear();
    if (c.dir.size() != m) c.dir.assign(m, Vec3::Zero());
    if (c.force.size() != n) c.force.assign(n, Vec3::Zero());
    c.factored = true;
    ++c.factorizations;
}

// Solves L D Lᵀ x = b in place, b holding 3 values per row (soft/ldlt_solve.hpp), split among the workers
// along the factor's elimination tree when there are some (soft/ldlt_schedule.hpp: bit-identical).
void solve_in_place(FastMassSpringCache& c, std::vector<double>& b, ParallelRegion* region) {
    if (!region) {
        c.factor.solve_in_place<3>(b.data());
        return;
    }
    if (c.schedule.parts != region->workers()) c.schedule.build(c.factor, region->workers());
    solve_in_place_parallel<3>(c.factor, c.schedule, *region, b.data());
}

// Contacts inside the global step (issue 14: seed 002 treats collisions as constraints of the
// minimisation, not as a projection after it). The step's collision planes of free particles become rows
// n · x_r >= offset (the plane lifted by the particle's thickness), each with a normal force λ on the
// right-hand side, A x = b + N λ. As Baraff & Witkin (1998 §5.3) do for implicit Euler, a contact is an
// equality while it is active and is released for the next step when its force pulls: a particle whose
// plane pulled last step (`released`) is left to the contact pass this step.
void gather_contacts(const SoftBody& b, FastMassSpringCache& c, const ParticleCollision* collision_or_null, Real h) {
    c.contacts.clear();
    if (c.released.size() != b.p.size()) c.released.assign(b.p.size(), 0);
    // Other soft bodies' surfaces where the step starts (SoftContactPass::gather_planes): normal rows
    // without friction; the soft contact pass after the solves resolves what is left, friction included.
    // Such a particle takes no tangent rows for its collider planes either (with two of them and a soft
    // plane's normal it would be held along four rows in three dimensions); the contact pass gives it
    // the colliders' friction.
    c.soft_at.assign(b.p.size(), 0);
    for (const SoftBody::SoftPlane& sp : b.soft_planes) {
        const int r = c.row[sp.particle];
        if (r < 0 || c.released[sp.particle]) continue;
        c.contacts.push_back({FastMassSpringCache::kSoftPlane, sp.particle, r, sp.normal, double(sp.offset) + double(b.def.thickness), 0.0, 0, 0, false});
        c.soft_at[sp.particle] = 1;
    }
    if (!collision_or_null) return;
    const ParticleCollision& collision = *collision_or_null;
    // How many planes each particle has (one per collider it may touch), and its first: friction's tangent
    // rows must not fight another plane's normal row (a particle wedged between two colliders: one's
    // tangent is the other's normal).
    c.planes_at.assign(b.p.size(), 0);
    c.first_plane.resize(b.p.size());
    for (std::size_t k = 0; k < collision.plane_count(); ++k) {
        const std::uint32_t i = collision.plane_particle(k);
        if (c.planes_at[i] == 0) c.first_plane[i] = std::uint32_t(k);
        if (c.planes_at[i] < 3) ++c.planes_at[i];
    }
    for (std::size_t k = 0; k < collision.plane_count(); ++k) {
        const ParticleCollision::PlaneView pl = collision.plane(k);
        const int r = c.row[pl.particle];
        if (r < 0 || c.released[pl.particle]) continue;  // pinned or attached (not an unknown), or released
        // The approach the hold will remove: the particle's normal speed into the plane before the solve.
        const Real approach = std::max(Real(0), -pl.normal.dot(b.p.v[pl.particle] - pl.velocity));
        c.contacts.push_back({std::uint32_t(k), pl.particle, r, pl.normal, double(pl.normal.dot(pl.point)) + double(b.def.thickness),
                              0.0, approach, pl.friction, false});
        if (!(pl.friction > 0) || c.soft_at[pl.particle]) continue;
        // Friction: tangent rows holding the particle where it started the step, moved with the surface
        // (static friction), clamped to the Coulomb cone after the solve (hold_contacts). A particle on
        // two planes is held along their common edge only, by its second plane's row (the normals hold the
        // rest), and on three by the normals alone.
        Vec3 t[2];
        int rows = 2;
        if (c.planes_at[pl.particle] == 1) {
            tangent_basis(pl.normal, t[0], t[1]);
        } else {
            if (c.planes_at[pl.particle] > 2 || c.first_plane[pl.particle] == k) continue;
            const Vec3 edge = collision.plane(c.first_plane[pl.particle]).normal.cross(pl.normal);
            if (!(edge.norm() > Real(0.1))) continue;  // nearly parallel planes: no edge to slide along
            t[0] = edge.normalized();
            rows = 1;
        }
        const Vec3 stuck = b.p.x_prev[pl.particle] + h * pl.velocity;
        for (int q = 0; q < rows; ++q)
            c.contacts.push_back({std::uint32_t(k), pl.particle, r, t[q], double(t[q].dot(stuck)), 0.0, 0, 0, true});
    }
}

// A contact row's direction d against a vector of 3 values per system row: d · v_row, and v_row += s d.
double row_dot(const FastMassSpringCache::ContactRow& ct, const std::vector<double>& v) {
    const double* x = &v[3 * std::size_t(ct.row)];
    return double(ct.normal[0]) * x[0] + double(ct.normal[1]) * x[1] + double(ct.normal[2]) * x[2];
}
void row_add(const FastMassSpringCache::ContactRow& ct, double s, std::vector<double>& v) {
    for (int a = 0; a < 3; ++a) v[3 * std::size_t(ct.row) + a] += s * double(ct.normal[a]);
}

// The contact forces so far, N λ (signed), on the right-hand side: each local/global iteration's global
// step starts from them.
void add_contact_forces(FastMassSpringCache& c) {
    for (const FastMassSpringCache::ContactRow& k : c.contacts)
        if (k.force != 0) row_add(k, k.force, c.rhs);
}

// One conjugate-gradient solve over the active rows (with or without the tangent rows; rows left out keep
// their forces), from the residuals at X = c.rhs. Returns the products it took.
int contact_cg(FastMassSpringCache& c, double tolerance, int max_iterations, bool tangents, ParallelRegion* region) {
    const std::size_t m = c.contacts.size();
    const auto in_solve = [&](std::size_t k) { return c.cg_active[k] && (tangents || !c.contacts[k].tangent); };
    // Residual r = offset - d · X over the rows in the solve (0 elsewhere: they stay out of it).
    double rr = 0, worst = 0;
    for (std::size_t k = 0; k < m; ++k) {
        const double gap = row_dot(c.contacts[k], c.rhs) - c.contacts[k].offset;
        c.cg_r[k] = in_solve(k) ? -gap : 0.0;
        c.cg_p[k] = c.cg_r[k];
        rr += c.cg_r[k] * c.cg_r[k];
        worst = std::max(worst, std::abs(c.cg_r[k]));
    }
    int it = 0;
    for (; it < max_iterations && worst > tolerance; ++it) {
        // u = A⁻¹ N p, q = Nᵀ u.
        std::fill(c.cg_u.begin(), c.cg_u.end(), 0.0);
        for (std::size_t k = 0; k < m; ++k)
            if (c.cg_p[k] != 0) row_add(c.contacts[k], c.cg_p[k], c.cg_u);
        solve_in_place(c, c.cg_u, region);
        double pq = 0;
        for (std::size_t k = 0; k < m; ++k) {
            c.cg_q[k] = c.cg_p[k] == 0 ? 0.0 : row_dot(c.contacts[k], c.cg_u);
            pq += c.cg_p[k] * c.cg_q[k];
        }
        if (!(pq > 0)) break;
        const double alpha = rr / pq;
        double rr_next = 0;
        worst = 0;
        for (std::size_t k = 0; k < m; ++k) {
            c.contacts[k].force += alpha * c.cg_p[k];
            c.cg_r[k] -= alpha * c.cg_q[k];
            rr_next += c.cg_r[k] * c.cg_r[k];
            worst = std::max(worst, std::abs(c.cg_r[k]));
        }
        for (std::size_t i = 0; i < c.rhs.size(); ++i) c.rhs[i] += alpha * c.cg_u[i];
        const double beta = rr_next / rr;
        rr = rr_next;
        for (std::size_t k = 0; k < m; ++k) c.cg_p[k] = c.cg_r[k] + beta * c.cg_p[k];
    }
    return it;
}

// Holds the global step's solution X (in c.rhs) on the collision planes: the contacts that X penetrates,
// or that already hold a force, get force changes Δλ with n_k · (X + A⁻¹ N Δλ)_k = offset_k, solved by
// conjugate gradients on the Schur complement S = Nᵀ A⁻¹ N (symmetric positive definite: A is), each
// product one more pair of triangular solves. A contact force spreads through A⁻¹ over the whole body:
// the links carry the reaction in the same step, where a projection after the solve stops the touching
// particle alone and its links learn of it a step later (a fast mass-spring pressure ball crumpled to a
// quarter of its volume on landing that way). The forces stay signed, and X agrees with them: clamping a
// pulling force here would leave its pushing neighbours unbalanced (CG's forces on a stiff body alternate
// in sign between neighbours) and launch the body; a pull is released for the next step instead.
//
// Friction the same way: an active contact's tangent rows hold its particle where it started the step
// (static friction) in the same solve; each contact's tangential force is then clamped to the Coulomb
// cone, mu times its normal force (sliding: kinetic friction along the force the stick would have
// needed), X follows the clamped forces, and the normal rows are solved again with the tangential forces
// held (not clamped again: a normal force that falls in that pass may leave its friction a little outside
// the cone for the step). Applied after the solve instead, as a velocity change with the step's
// tangential motion taken back, friction moved particles the links did not see: a tablecloth's sides
// climbed back over the table's edges.
//
// Each pass stops when every active row is within `tolerance` (m) or after `max_iterations` products;
// with friction there are two passes and one more product between them.
int hold_contacts(FastMassSpringCache& c, double tolerance, int max_iterations, ParallelRegion* region) {
    const std::size_t m = c.contacts.size();
    c.cg_r.resize(m);
    c.cg_p.resize(m);
    c.cg_q.resize(m);
    c.cg_active.resize(m);
    c.cg_u.resize(c.rhs.size());
    // Active: the normal rows X penetrates or that hold a force, and the tangent rows of those.
    bool normal_active = false;
    bool any_tangent = false;
    for (std::size_t k = 0; k < m; ++k) {
        const FastMassSpringCache::ContactRow& ct = c.contacts[k];
        if (ct.tangent) {
            c.cg_active[k] = normal_active;
            any_tangent = any_tangent || normal_active;
            continue;
        }
        normal_active = row_dot(ct, c.rhs) - ct.offset < 0 || ct.force != 0;
        c.cg_active[k] = normal_active;
    }
    int it = contact_cg(c, tolerance, max_iterations, true, region);
    if (!any_tangent) return it;
    // The Coulomb cone: |f_t| <= mu max(f_n, 0).
    bool clamped = false;
    std::fill(c.cg_u.begin(), c.cg_u.end(), 0.0);
    for (std::size_t k = 0; k < m; ++k) {
        const FastMassSpringCache::ContactRow& ct = c.contacts[k];
        if (ct.tangent) continue;
        std::size_t end = k + 1;  // its tangent rows: [k + 1, end)
        double len2 = 0;
        for (; end < m && c.contacts[end].tangent; ++end) len2 += c.contacts[end].force * c.contacts[end].force;
        const double limit = double(ct.mu) * std::max(ct.force, 0.0);
        const double len = std::sqrt(len2);
        if (len <= limit) continue;
        const double scale = len > 0 ? limit / len : 0.0;
        for (std::size_t j = k + 1; j < end; ++j) {
            FastMassSpringCache::ContactRow& t = c.contacts[j];
            const double d = t.force * (scale - 1);
            t.force += d;
            row_add(t, d, c.cg_u);
        }
        clamped = true;
    }
    if (!clamped) return it;
    solve_in_place(c, c.cg_u, region);
    for (std::size_t i = 0; i < c.rhs.size(); ++i) c.rhs[i] += c.cg_u[i];
    return it + 1 + contact_cg(c, tolerance, max_iterations, false, region);
}

}  // namespace

void predict_fast_mass_spring(SoftBody& b, Real h) {
    if (!(is_finite(h) && h > 0))
        throw SoftError("step_fast_mass_spring: time step h must be finite and > 0, got " + std::to_string(h));
    if (!b.fms_cache) b.fms_cache = std::make_unique<FastMassSpringCache>();
    FastMassSpringCache& c = *b.fms_cache;
    if (!factorization_is_current(b, c, double(h))) factor(b, c, double(h));

    Particles& p = b.p;
    const std::size_t n = p.size();

    // Explicit forces that change with the state (pressure), at x_n.
    const bool pressure = b.def.pressure != 0;
    if (pressure) {
        for (Vec3& f : c.force) f.setZero();
        add_pressure_forces(b, p.x, c.force);
    }

    // y, the first iterate, and the inertial part of the right-hand side, M' y / h².
    const Real keep = Real(1) / (Real(1) + h * b.def.drag);
    const double mass_scale = (1.0 + double(h) * double(b.def.drag)) / (double(h) * double(h));
    for_ranges(parallel_region(b, c), n, 256, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) {
            p.x_prev[i] = p.x[i];
            const int r = c.row[i];
            if (r < 0) {
                p.v[i].setZero();
                continue;
            }
            Vec3 fext = p.f[i];
            if (pressure) fext += c.force[i];
            const Vec3 y = p.x[i] + (h * keep) * (p.v[i] + h * (b.gravity + p.inv_mass[i] * fext));
            p.x[i] += (h * keep) * p.v[i];
            const double s = double(p.mass[i]) * mass_scale;
            for (int k = 0; k < 3; ++k) c.inertia[3 * std::size_t(r) + k] = s * double(y[k]);
        }
    });
}

void solve_fast_mass_spring(SoftBody& b, Real h, ParticleCollision* collision) {
    FastMassSpringCache& c = *b.fms_cache;  // made by predict_fast_mass_spring
    Particles& p = b.p;
    const std::size_t n = p.size(), m = b.links.size();
    ParallelRegion* const region = parallel_region(b, c);
    // The pinned ends' share of the right-hand side, here rather than in the prediction: attached
    // particles are placed on their rigid points again just before this stage.
    for (const std::uint32_t j : c.pinned_links) {
        const Link& l = b.links[j];
        const int ra = c.row[l.a], rb = c.row[l.b];
        if (ra >= 0 && rb < 0)
            for (int k = 0; k < 3; ++k) c.inertia[3 * std::size_t(ra) + k] += double(l.stiffness) * double(p.x[l.b][k]);
        if (rb >= 0 && ra < 0)
            for (int k = 0; k < 3; ++k) c.inertia[3 * std::size_t(rb) + k] += double(l.stiffness) * double(p.x[l.a][k]);
    }
    if (b.fem) {
        // A free node's coupling to a pinned one moves to the right: -(w_s + w_v) (g_a · g_b) x_b.
        const FemState& s = *b.fem;
        for (std::size_t e = 0; e < s.size(); ++e) {
            const std::uint32_t* tet = &s.tets[4 * e];
            Vec3 g[4];
            bool mixed = false;
            for (int a = 0; a < 4; ++a) mixed = mixed || c.row[tet[a]] < 0;
            if (!mixed) continue;
            shape_gradients(s.dm_inv[e], g);
            const double w = tet_weight(s, e);
            for (int a = 0; a < 4; ++a) {
                const int ra = c.row[tet[a]];
                if (ra < 0) continue;
                for (int q = 0; q < 4; ++q)
                    if (c.row[tet[q]] < 0)
                        for (int k = 0; k < 3; ++k)
                            c.inertia[3 * std::size_t(ra) + k] -= w * double(g[a].dot(g[q])) * double(p.x[tet[q]][k]);
            }
        }
    }
    const int iterations = c.factor.empty() ? 0 : b.def.iterations;  // no free particle: nothing to solve
    // Contacts inside the global step for mass-spring bodies only. A tet body under projective dynamics
    // keeps the projection after the solve: held inside, the 20k-tet block of `sinew bench fem` collapsed
    // on landing (11,187 inverted tets, volume 0.035, against 765 and 0.66) and ball-drop likewise, at
    // five times the cost, while the 1k and 5k blocks improved (accuracy 0.98 against 0.96 and 0.90):
    // not understood yet (docs/fem.md).
    c.contacts.clear();
    if ((collision || !b.soft_planes.empty()) && iterations > 0 && !b.fem) gather_contacts(b, c, collision, h);
    // A release lasts one step, whether this step gathered planes or not (airborne, the flags of the last
    // contact would otherwise wait for the next one).
    std::fill(c.released.begin(), c.released.end(), std::uint8_t(0));
    c.contact_iterations = 0;
    for (int it = 0; it < iterations; ++it) {
        // Local step: the rest-length vector of each link along its current direction.
        for_ranges(region, m, 256, [&](std::size_t begin, std::size_t end) {
            for (std::size_t j = begin; j < end; ++j) {
                const Link& l = b.links[j];
                const Vec3 d = p.x[l.a] - p.x[l.b];
                const Real len = d.norm();
                if (len >= kMinLinkLength)
                    c.dir[j] = (l.rest / len) * d;
                else if (c.dir[j].squaredNorm() == 0)
                    c.dir[j] = Vec3(l.rest, 0, 0);  // no direction yet: any one is optimal
            }
        });
        // Global step: (M'/h² + L) x = M' y/h² + J p (+ pinned terms), three coordinates at once. J p is
        // gathered row by row, each row's links ascending: the sums of a scatter over the links in order.
        for_ranges(region, c.factor.rows(), 256, [&](std::size_t begin, std::size_t end) {
            for (std::size_t r = begin; r < end; ++r) {
                double a0 = c.inertia[3 * r], a1 = c.inertia[3 * r + 1], a2 = c.inertia[3 * r + 2];
                // End b subtracts k d, as the scatter did (adding (-k) d is the same only when rounding
                // to nearest).
                for (std::uint32_t q = c.link_rows.start[r]; q < c.link_rows.start[r + 1]; ++q) {
                    const double sk = c.row_link_k[q];
                    const Vec3& d = c.dir[c.link_rows.entry[q] / 2];
                    if (std::signbit(sk)) {
                        const double k = -sk;
                        a0 -= k * double(d[0]), a1 -= k * double(d[1]), a2 -= k * double(d[2]);
                    } else {
                        a0 += sk * double(d[0]), a1 += sk * double(d[1]), a2 += sk * double(d[2]);
                    }
                }
                c.rhs[3 * r] = a0, c.rhs[3 * r + 1] = a1, c.rhs[3 * r + 2] = a2;
            }
        });
        if (b.fem) add_tet_projections(b, c);
        add_contact_forces(c);
        solve_in_place(c, c.rhs, region);
        if (!c.contacts.empty())
            c.contact_iterations +=
                hold_contacts(c, kContactTolerance * double(b.def.thickness), kContactIterations, region);
        for_ranges(region, n, 256, [&](std::size_t begin, std::size_t end) {
            for (std::size_t i = begin; i < end; ++i) {
                const int r = c.row[i];
                if (r >= 0) {
                    const double* xr = &c.rhs[3 * std::size_t(r)];
                    p.x[i] = Vec3(Real(xr[0]), Real(xr[1]), Real(xr[2]));
                }
            }
        });
    }

    // The impulse each plane held its particle with, for the contact pass (friction budget, restitution,
    // reports); one that pulled is released for the next step. A plane's friction was applied here too
    // (whatever its normal force ended at: the tangential forces are in the positions): the contact pass
    // applies none there and reports this one, so a coupling layer sends the whole impulse back.
    for (std::size_t k = 0; k < c.contacts.size(); ++k) {
        const FastMassSpringCache::ContactRow& ct = c.contacts[k];
        if (ct.tangent) continue;
        if (ct.force < 0) c.released[ct.particle] = 1;
        if (ct.plane == FastMassSpringCache::kSoftPlane) continue;  // the soft contact pass reports these contacts
        collision->set_held(ct.plane, Real(ct.force * double(h)), ct.approach);
        // Planes the solve held (a force on the normal row or its tangent rows); a particle on two or more
        // planes has its friction from the rows too (an edge row, or the normals alone), so none of its
        // held planes gets the contact pass's.
        Vec3 friction = Vec3::Zero();
        bool held = ct.force != 0;
        for (std::size_t j = k + 1; j < c.contacts.size() && c.contacts[j].tangent; ++j) {
            friction += Real(c.contacts[j].force * double(h)) * c.contacts[j].normal;
            held = held || c.contacts[j].force != 0;
        }
        const bool rows = !c.soft_at[ct.particle] &&
                          ((k + 1 < c.contacts.size() && c.contacts[k + 1].tangent) || c.planes_at[ct.particle] > 1);
        if (held && rows && ct.mu > 0) collision->set_held_friction(ct.plane, friction);
    }

    const Real inv_h = Real(1) / h;
    for_ranges(region, n, 256, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i)
            if (c.row[i] >= 0) p.v[i] = (p.x[i] - p.x_prev[i]) * inv_h;
    });
}

void shift_fast_mass_spring_prediction(SoftBody& b, std::uint32_t i, const Vec3& dv, Real h) {
    Particles& p = b.p;
    p.x_next[i] += h * dv;  // the first iterate (set aside by the soft system until its solve)
    p.v[i] += dv;
    FastMassSpringCache& c = *b.fms_cache;  // made by predict_fast_mass_spring
    const int r = c.row[i];
    if (r < 0) return;
    // M' y / h^2 with y = x + h keep (v + ...) and M' = m (1 + h drag): y moves by h keep dv, so the
    // term moves by m (1 + h drag) keep dv / h = m dv / h.
    const double s = double(p.mass[i]) / double(h);
    for (int k = 0; k < 3; ++k) c.inertia[3 * std::size_t(r) + k] += s * double(dv[k]);
}

Vec3 fast_mass_spring_target(const SoftBody& b, std::uint32_t i, Real h) {
    const Particles& p = b.p;
    const FastMassSpringCache* c = b.fms_cache.get();
    const int r = c && i < c->row.size() ? c->row[i] : -1;
    if (r < 0) return p.x[i];
    const double s = double(p.mass[i]) * (1.0 + double(h) * double(b.def.drag)) / (double(h) * double(h));
    const double* y = &c->inertia[3 * std::size_t(r)];
    return Vec3(Real(y[0] / s), Real(y[1] / s), Real(y[2] / s));
}

void step_fast_mass_spring(SoftBody& b, Real h) {
    predict_fast_mass_spring(b, h);
    solve_fast_mass_spring(b, h);
}

}  // namespace sinew
