// Two-way coupling's particle rows (coupling/particle_rows.hpp).
#include "coupling/particle_rows.hpp"

#include <algorithm>
#include <cmath>

#include "rigid/soft_constraint.hpp"
#include "soft/particle_collision.hpp"

namespace sinew {

namespace {
// A penetrating particle is pushed out at most this fast by the bias (m/s), as the rigid contacts'
// contact_push_velocity caps theirs: a deep start must not launch the rigid body.
constexpr Real kMaxPushVelocity = 2;
// Baumgarte rows leave this much penetration uncorrected (m), so a resting contact does not jitter.
constexpr Real kSlop = Real(0.001);
// Below this length a link's direction is undefined and its row is skipped for the pass (as Verlet does).
constexpr Real kMinLinkLength = Real(1e-9);
// round_body_normal keeps the found normal unless the one under the particle now faces within about 25
// degrees of it (the same side of the body).
constexpr Real kSameFacing = Real(0.9);
}  // namespace

bool round_body_normal(const Shape& shape, const Transform& xf, const Vec3& point, const Vec3& found, Real reach,
                       Vec3& normal, Vec3& surface) {
    if (shape.type != ShapeType::Sphere && shape.type != ShapeType::Capsule) return false;
    Vec3 n, p;
    Real distance = 0;
    if (!point_shape_distance(point, shape, xf, reach, p, n, distance) || !(n.dot(found) > kSameFacing)) return false;
    normal = n;
    surface = p;
    return true;
}

void ParticleRows::add_whole_body(const RigidSystem& sys, std::uint32_t slot, const SoftBody& b, Real h) {
    const Real inv_h = 1 / h;
    const auto base = std::uint32_t(particles_.size());
    // A sub-stepping solver adds gravity per sub-step, to the particles as to the rigid bodies: the
    // prediction's h g is given a sub-step's part at a time (positions_advanced). All at once, the soft
    // step's relax left a hanging particle with a velocity that was not its motion (0.06 m/s at rest).
    const int parts = std::max(1, step_.substeps);
    const Vec3 g_part = b.gravity * step_.h;
    const Vec3 g_held = Real(parts - 1) * g_part;
    const std::size_t n = b.p.size();
    // Springs by particle (both ends list each), for the block Gauss-Seidel sweep.
    degree_.assign(n, 0);
    for (const Link& l : b.links) {
        ++degree_[l.a];
        ++degree_[l.b];
    }
    auto next = std::uint32_t(spring_ends_.size());
    // The sweep's starting guess (Chen et al. 2024's adaptive initialisation): each particle's gravity
    // only as far as it accelerated along it in the last step, between 0 (resting: it starts where it
    // ended, the solve has nothing to undo) and g (falling freely: the prediction). The reference the
    // residual measures inertia against stays the prediction. Started from the prediction, a hanging
    // 20-segment rope came to rest 3.3 cm low after 10 iterations a step (each step's sweep had to
    // carry the whole weight up the rope again).
    if (previous_v_.size() <= slot) previous_v_.resize(slot + 1);
    Previous& last = previous_v_[slot];
    const std::uint64_t stamp = (std::uint64_t(soft_.id_of_slot(slot).generation) << 32) | std::uint32_t(step_count_);
    // Only the same body's velocities from the step just before (not another body's in a reused slot, nor
    // those of a step it slept through or was not swept in).
    const bool known = last.v.size() == n && last.stamp + 1 == stamp;
    std::vector<Vec3>& previous = last.v;
    const Real g_norm = b.gravity.norm();
    const Vec3 g_dir = g_norm > 0 ? Vec3(b.gravity / g_norm) : Vec3::Zero();
    for (std::uint32_t i = 0; i < n; ++i) {
        Particle p;
        p.soft = slot;
        p.index = i;
        p.inv_mass = b.p.inv_mass[i];
        // Free particles start from their predicted velocity; pinned and attached ones move with their target.
        p.v = p.inv_mass != 0 ? Vec3((b.p.x_next[i] - b.p.x[i]) * inv_h - g_held) : b.p.v[i];
        p.v_handed = p.v;
        p.v_ref = p.v;
        if (p.inv_mass != 0 && g_norm > 0) {
            const Real a = known ? std::clamp((b.p.v[i] - previous[i]).dot(g_dir) * inv_h, Real(0), g_norm) : g_norm;
            p.gravity_shortfall = (step_.h * (g_norm - a)) * g_dir;
            p.v -= p.gravity_shortfall;
        }
        // A held particle was placed at its target's end-of-step pose; the sweep starts where the target is
        // now and moves it on with the target's velocity (positions_advanced), as the free ones move.
        p.x = p.inv_mass != 0 ? b.p.x[i] : Vec3(b.p.x[i] - h * b.p.v[i]);
        p.whole = true;
        p.gravity_part = p.inv_mass != 0 ? g_part : Vec3::Zero();
        p.ends_begin = p.ends_fill = next;
        next += degree_[i];
        p.ends_end = next;
        particle_of_[i] = std::int32_t(base + i);
        particles_.push_back(p);
    }
    previous.assign(b.p.v.begin(), b.p.v.end());
    last.stamp = stamp;
    add_attachment_rows(sys, slot, b, base);
    WholeBody wb;
    wb.begin = base;
    wb.end = base + std::uint32_t(n);
    for (std::uint32_t i = wb.begin; i < wb.end; ++i) {
        if (particles_[i].inv_mass == 0) wb.held = true;
        else wb.mass += 1 / particles_[i].inv_mass;
    }
    whole_bodies_.push_back(wb);
    spring_ends_.resize(next);
    for (const Link& l : b.links) {
        if (!(l.stiffness > 0 || l.damping > 0)) continue;
        Particle& a = particles_[base + l.a];
        Particle& c = particles_[base + l.b];
        spring_ends_[a.ends_fill++] = {base + l.b, l.rest, l.stiffness, l.damping};
        spring_ends_[c.ends_fill++] = {base + l.a, l.rest, l.stiffness, l.damping};
    }
    for (std::uint32_t i = 0; i < n; ++i) particles_[base + i].ends_end = particles_[base + i].ends_fill;
}

void ParticleRows::add_attachment_rows(const RigidSystem& sys, std::uint32_t slot, const SoftBody& b, std::uint32_t base) {
    // An attachment to an awake dynamic body: the particle is free here with its own mass, and its block in
    // the springs' sweep carries the body's effective mass at the point, K^-1 (solve_springs), so the body
    // and the soft body move each other in the same loop. A point row (a ball joint between the particle
    // and the point) beside the sweep was tried first: with the row's effective mass from the particle's
    // 1/m, while the stiff springs hold the particle far harder, a 0.1 kg crate on a 1e6 N/m rope
    // diverged within 30 steps.
    const RigidSystem::State& st = sys.state();
    const SoftBodyId sid = soft_.id_of_slot(slot);
    for (const Attachment& a : b.attachments) {
        if (!a.frame_valid) continue;
        const BodyId rid = unpack_body_id(a.target);
        if (!sys.valid(rid) || sys.slot_type(rid.index) != BodyType::Dynamic || st.inv_mass[rid.index] == 0) continue;
        // The body is solved here (one-solver): a pair that asks for two-way gets the same merge.
        const CouplingStrategy strategy = coupling_strategy_of(settings_, sid, rid);
        if (strategy != CouplingStrategy::OneSolver && strategy != CouplingStrategy::TwoWay) continue;
        Particle& p = particles_[base + a.particle];
        const std::uint32_t o = rid.index;
        AttachRow r;
        r.particle = base + a.particle;
        r.rigid = o;
        r.arm = sys.slot_transform(o).apply(a.local_point) - st.x[o];
        p.inv_mass = 1 / b.p.mass[a.particle];
        p.x = st.x[o] + r.arm;  // where the point is now (the soft system placed it at the step's end)
        // Its own weight a sub-step at a time, as the free particles', where the rigid solver adds gravity
        // per sub-step (the soft step); the others have added this step's already to the body's velocity,
        // which the particle starts from.
        p.gravity_part = sys.gravity_in_solve() ? Vec3(b.gravity * step_.h) : Vec3::Zero();
        p.v = st.v[o] + st.w[o].cross(r.arm) + p.gravity_part;
        p.v_ref = p.v;
        p.v_handed = p.v;
        const Mat3 rx = skew(r.arm);
        const Mat3 k = st.inv_mass[o] * Mat3::Identity() - rx * st.inv_inertia_world[o] * rx;
        r.share = k.inverse();
        r.inv_mb = st.inv_mass[o];
        r.inv_inertia = st.inv_inertia_world[o];
        p.attach = std::int32_t(attach_rows_.size());
        attach_rows_.push_back(r);
    }
}

void ParticleRows::build(RigidSystem& sys, Real h) {
    particles_.clear();
    rows_.clear();
    attach_rows_.clear();
    whole_bodies_.clear();
    ++step_count_;
    const RigidSystem::State& st = sys.state();
    const std::vector<Collider>& colliders = soft_.colliders();
    const Real inv_h = 1 / h;
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        const SoftBody& b = soft_.slot_body(s);
        const ParticleCollision* col = soft_.collision(s);
        const bool whole = b.solved_by_rows && b.stepping;
        if (!whole && (!col || col->plane_count() == 0)) continue;
        particle_of_.assign(b.p.size(), -1);
        if (whole) add_whole_body(sys, s, b, h);
        if (!col) continue;
        const SoftBodyId sid = soft_.id_of_slot(s);
        const Real r = b.def.thickness;
        std::uint32_t last = kNoOwner, now_slot = kNoOwner;
        bool coupled = false;
        Transform back;  // maps the collider's predicted pose to its current one
        for (std::size_t k = 0; k < col->plane_count(); ++k) {
            const ParticleCollision::PlaneView pl = col->plane(k);
            const Collider& c = colliders[pl.collider];
            if (pl.collider != last) {
                // Planes come grouped by collider: decide once per (soft body, collider).
                last = pl.collider;
                const CouplingStrategy strategy =
                    c.owner < st.inv_mass.size() ? coupling_strategy_of(settings_, sid, sys.id_of_slot(c.owner))
                                                 : CouplingStrategy::OneWay;
                const bool moving = c.dynamic && c.owner < st.inv_mass.size() && st.inv_mass[c.owner] > 0;
                // A whole body meets static and kinematic bodies in the same loop too (their rows move
                // only the particle); a sleeping one is left to the contact pass, which wakes it.
                coupled = (moving && (strategy == CouplingStrategy::TwoWay || strategy == CouplingStrategy::OneSolver)) ||
                          (whole && !c.dynamic && c.owner < st.inv_mass.size());
            }
            if (!coupled) continue;
            const std::uint32_t i = pl.particle;
            if (b.p.inv_mass[i] == 0) continue;
            // Separation where the particle and the body are predicted to end the step.
            const Real gap_end = pl.normal.dot(b.p.x_next[i] - pl.point) - r;
            if (gap_end > r) continue;  // out of reach this step (the contact pass would skip it too)
            const Vec3 v = (b.p.x_next[i] - b.p.x[i]) * inv_h;
            Row row;
            row.rigid = c.owner;
            // The plane was found at the body's predicted end-of-step pose; the rows start from now, and
            // the body's velocity may have changed since (gravity, the mass shares' impulses). Moved
            // back rigidly to the current pose, the separation now is exact whatever the velocities.
            if (c.owner != now_slot) {
                now_slot = c.owner;
                back = sys.slot_transform(c.owner) * c.xf.inverse();
            }
            row.n = back.q * pl.normal;
            row.point = back.apply(pl.point);
            // A round body: the normal where the particle is now (round_body_normal).
            Vec3 surface, normal;
            if (round_body_normal(*c.shape, back * c.xf, b.p.x[i], row.n, 2 * r + 2 * (b.p.x_next[i] - b.p.x[i]).norm(),
                                  normal, surface)) {
                row.n = normal;
                row.point = surface;
            }
            tangent_basis(row.n, row.t1, row.t2);
            // The body is pushed along the normal through the particle where both are now (not at the
            // surface point under its predicted end-of-step position): the two impulses then share one
            // line of action at the configuration the positions are integrated from, and angular momentum
            // is exchanged exactly. Along n the velocity there equals the surface point's.
            row.arm = b.p.x[i] - st.x[c.owner];
            row.gap = row.n.dot(b.p.x[i] - row.point) - r;  // separation now
            row.mu = std::sqrt(std::max(Real(0), b.def.friction * c.friction));  // as the contact pass mixes them
            if (particle_of_[i] < 0) {
                particle_of_[i] = std::int32_t(particles_.size());
                Particle p;
                p.soft = s;
                p.index = i;
                p.inv_mass = b.p.inv_mass[i];
                p.v = v;
                p.v_handed = v;
                p.x = b.p.x[i];
                particles_.push_back(p);
            }
            row.particle = std::uint32_t(particle_of_[i]);
            rows_.push_back(row);
        }
    }
    assign_contact_shares(st);
}

void ParticleRows::prepare(RigidSystem& sys, const RowStep& step) {
    step_ = step;
    h_ = step.h * Real(step.substeps);
    const RigidSystem::State& st = sys.state();
    for (Push& q : pushes_) {
        q.dv = st.inv_mass[q.rigid] * q.j;
        q.dw = st.inv_inertia_world[q.rigid] * q.arm.cross(q.j);
    }
    push_parts_left_ = pushes_.empty() ? 0 : std::max(1, step.substeps);
    push_pending_ = true;
    substeps_done_ = 0;
    springs_active_ = true;
    spring_ends_.clear();
    build(sys, h_);
    for (Row& r : rows_) {
        const Particle& p = particles_[r.particle];
        r.inv_mb = st.inv_mass[r.rigid];
        const Mat3& inv_i = st.inv_inertia_world[r.rigid];
        const Vec3 rn = r.arm.cross(r.n), rt1 = r.arm.cross(r.t1), rt2 = r.arm.cross(r.t2);
        r.irn = inv_i * rn;
        r.irt1 = inv_i * rt1;
        r.irt2 = inv_i * rt2;
        r.mass_n = 1 / (p.inv_mass + r.inv_mb + rn.dot(r.irn));
        r.mass_t1 = 1 / (p.inv_mass + r.inv_mb + rt1.dot(r.irt1));
        r.mass_t2 = 1 / (p.inv_mass + r.inv_mb + rt2.dot(r.irt2));
        r.lambda_n = r.lambda_t1 = r.lambda_t2 = 0;
        r.total.setZero();
        if (!step.warm_starting || kept_.empty()) continue;
        Kept probe;
        probe.key = key(p, r.rigid);
        const auto it = std::lower_bound(kept_.begin(), kept_.end(), probe);
        if (it == kept_.end() || it->key != probe.key) continue;
        // The normal impulse as it was; the tangential one as a world vector projected on the new tangents.
        r.lambda_n = it->n;
        const Vec3 t = it->t1 * it->tangent + it->t2 * it->t2dir;
        r.lambda_t1 = t.dot(r.t1);
        r.lambda_t2 = t.dot(r.t2);
    }
}

void ParticleRows::apply(Row& r, Particle& p, const BodyVelocities& vel, const Vec3& impulse) const {
    p.v += p.inv_mass * impulse;
    p.ext += impulse;
    vel.set_linear(r.rigid, vel.linear(r.rigid) - r.inv_mb * impulse);
    // I^-1 (r x J) from the prepared products: J = a n + b t1 + c t2.
    const Vec3 dw = impulse.dot(r.n) * r.irn + impulse.dot(r.t1) * r.irt1 + impulse.dot(r.t2) * r.irt2;
    vel.set_angular(r.rigid, vel.angular(r.rigid) - dw);
    r.total += impulse;
}

void ParticleRows::warm_start(const RigidSystem&, const BodyVelocities& vel) {
    for (Row& r : rows_) {
        const Vec3 j = r.lambda_n * r.n + r.lambda_t1 * r.t1 + r.lambda_t2 * r.t2;
        if (!j.isZero()) apply(r, particles_[r.particle], vel, j);
    }
}

void ParticleRows::solve(const RigidSystem&, const BodyVelocities& vel, bool use_bias) {
    if (push_pending_ && push_parts_left_ > 0) apply_pushes(vel);
    solve_rows(vel, use_bias);
}

void ParticleRows::apply_pushes(const BodyVelocities& vel) {
    const Real share = Real(1) / Real(std::max(1, step_.substeps));
    for (const Push& q : pushes_) {
        vel.set_linear(q.rigid, vel.linear(q.rigid) + share * q.dv);
        vel.set_angular(q.rigid, vel.angular(q.rigid) + share * q.dw);
    }
    --push_parts_left_;
    push_pending_ = false;
}

void ParticleRows::solve_springs(const BodyVelocities& vel) {
    // Block Gauss-Seidel on the springs' implicit Euler step, linearised at the (sub-)step's positions
    // (Baraff & Witkin 1998's system, which implicit Euler solves by CG; here always backward Euler,
    // lambda = 1, with the transverse part clamped, i.e. without the body's implicit_lambda and
    // isotropic_blend), a particle at a time as vertex
    // block descent does (Chen et al. 2024). Particle i's block row is
    //   (m + h c n n^T + h^2 K) dv = J_ext + h (f0 + h K (v_j - v_i) + c n n^T (v_j - v_i)) - m (v - v_ref)
    // summed over its springs, with K the spring's stiffness including its tension's transverse part
    // (clamped at zero in compression, as Volino's isotropic blend keeps the system positive definite).
    // Each block is positive definite and the system linear, so the sweep converges from any start, and
    // a sub-stepping solver linearises anew at every sub-step. Tried first and dropped:
    //  - springs as rows, one impulse per link along its direction: the tension's transverse part then
    //    acts a fixed-point iteration that converges only while h^2 T / (m L) < 1/2; a warm-started
    //    24 x 24 cloth (0.9 g particles, 4000 N/m) diverged at any iteration count;
    //  - the nonlinear block at the predicted positions x + h v (Newton per particle): a 0.1 kg crate on a
    //    stiff rope overshot and diverged, each block's step unbounded without a line search.
    const Real h = step_.h, h2 = h * h;
    for (Particle& p : particles_) {
        if (!p.whole || p.inv_mass == 0 || (p.ends_begin == p.ends_end && p.attach < 0 && p.share_row < 0)) continue;
        const Real m = 1 / p.inv_mass;
        Vec3 rhs = p.ext - m * (p.v - p.v_ref);
        Mat3 a = m * Mat3::Identity();
        Vec3 v_point = Vec3::Zero();
        if (p.attach >= 0) {
            const AttachRow& r = attach_rows_[std::size_t(p.attach)];
            v_point = vel.linear(r.rigid) + vel.angular(r.rigid).cross(r.arm);
            rhs += r.share * (v_point - p.v);
            a += r.share;
        }
        // A pushing contact's share: the body's velocity at the particle starts the merge.
        Row* contact = p.share_row >= 0 ? &rows_[std::size_t(p.share_row)] : nullptr;
        if (contact && contact->lambda_n <= 0) contact = nullptr;
        Vec3 v_surface = Vec3::Zero();
        if (contact) v_surface = vel.linear(contact->rigid) + vel.angular(contact->rigid).cross(contact->arm);
        for (std::uint32_t e = p.ends_begin; e < p.ends_end; ++e) {
            const SpringEnd& s = spring_ends_[e];
            const Particle& q = particles_[s.other];
            const Vec3 d = q.x - p.x;
            const Real len = d.norm();
            if (len < kMinLinkLength) continue;
            const Vec3 n = d / len;
            const Vec3 vrel = q.v - p.v;
            // K = k n n^T + k max(0, 1 - L/|d|) (I - n n^T): the spring's stiffness at the (sub-)step's start,
            // its tension's transverse part included and none in compression.
            const Real transverse = s.k * std::max(Real(0), 1 - s.rest / len);
            const Real along = s.k - transverse;
            const Vec3 k_vrel = along * n.dot(vrel) * n + transverse * vrel;
            rhs += h * ((s.k * (len - s.rest) + s.c * n.dot(vrel)) * n + h * k_vrel);
            a += (h * s.c + h2 * along) * (n * n.transpose());
            a.diagonal().array() += h2 * transverse;
        }
        Vec3 dv = a.llt().solve(rhs);
        if (contact) {
            // Merged with the share; only a push, and Coulomb's cone: a share that would pull the body is
            // dropped for this pass, one that would grip outside the cone keeps its normal part.
            const auto merged = [&](const Mat3& share, Vec3& out) {
                out = (a + share).llt().solve(rhs + share * (v_surface - p.v));
                return Vec3(share * (p.v + out - v_surface));  // what the body takes
            };
            Vec3 dv_merged;
            Vec3 j = merged(p.share, dv_merged);
            Real jn = j.dot(contact->n);
            if (jn <= 0 && (j - jn * contact->n).norm() > -contact->mu * jn) {
                j = merged(p.share_normal, dv_merged);
                jn = j.dot(contact->n);
            }
            if (jn <= 0 && is_finite(dv_merged)) {
                dv = dv_merged;
                vel.set_linear(contact->rigid, vel.linear(contact->rigid) + contact->inv_mb * j);
                const Vec3 dw = jn * contact->irn + j.dot(contact->t1) * contact->irt1 + j.dot(contact->t2) * contact->irt2;
                vel.set_angular(contact->rigid, vel.angular(contact->rigid) + dw);
                p.ext -= j;
                contact->total -= j;
            }
        }
        if (!is_finite(dv)) continue;
        p.v += dv;
        if (p.attach >= 0) {
            AttachRow& r = attach_rows_[std::size_t(p.attach)];
            const Vec3 j = r.share * (p.v - v_point);  // what the body takes
            vel.set_linear(r.rigid, vel.linear(r.rigid) + r.inv_mb * j);
            vel.set_angular(r.rigid, vel.angular(r.rigid) + r.inv_inertia * r.arm.cross(j));
            p.ext -= j;
            r.total -= j;
        }
    }
    // A sweep stopped before converging leaves the springs' impulses unbalanced (each particle took its
    // own side only): a 0.5 kg cloth thrown at a free box changed the total momentum by 11% in a second.
    // Springs do not see a uniform velocity shift, so one per body restores its momentum balance: what
    // the particles gained since the (sub-)step began is exactly the outside impulses (rows, shares, the
    // contact pass), as implicit Euler's momentum_correction does for CG. Bodies with pinned or kinematically
    // attached particles are held by them and keep the sweep's result.
    for (const WholeBody& wb : whole_bodies_) {
        if (wb.held || !(wb.mass > 0)) continue;
        Vec3 net = Vec3::Zero();
        for (std::uint32_t i = wb.begin; i < wb.end; ++i) {
            const Particle& p = particles_[i];
            net += (p.v - p.v_ref) / p.inv_mass - p.ext;
        }
        const Vec3 shift = -net / wb.mass;
        for (std::uint32_t i = wb.begin; i < wb.end; ++i) particles_[i].v += shift;
    }
}

void ParticleRows::assign_contact_shares(const RigidSystem::State& st) {
    // One-solver: a whole body's particle touching a dynamic body carries a share of its mass along the
    // normal in its block of the sweep (while the contact pushes), as two-way's implicit solve does: the
    // springs then hold the body in the sweep itself. With the rows alone a heavy body on light particles
    // sank through them (the 1 kg ball on 0.9 g particles reached the ground). Split evenly over the
    // particles touching the body; a particle on two bodies shares the first.
    share_count_.assign(st.inv_mass.size(), 0);
    for (std::size_t k = 0; k < rows_.size(); ++k) {
        Row& r = rows_[k];
        Particle& p = particles_[r.particle];
        if (!p.whole || st.inv_mass[r.rigid] == 0 || p.share_row >= 0) continue;
        p.share_row = std::int32_t(k);
        ++share_count_[r.rigid];
    }
    for (Particle& p : particles_)
        if (p.share_row >= 0) {
            // Along the normal the body's mass; across it, where friction acts, the tangential part of its
            // effective mass at the point, K^-1 (a ball can spin under it): two-way's shares, whose normal
            // part alone let the resting ball spin up and roll off.
            const Row& r = rows_[std::size_t(p.share_row)];
            const Real split = 1 / Real(share_count_[r.rigid]);
            const Mat3 nn = r.n * r.n.transpose();
            p.share_normal = split / st.inv_mass[r.rigid] * nn;
            p.share = p.share_normal;
            if (r.mu > 0) {
                const Mat3 rx = skew(r.arm);
                const Mat3 k = st.inv_mass[r.rigid] * Mat3::Identity() - rx * st.inv_inertia_world[r.rigid] * rx;
                const Mat3 k_inv = k.inverse();
                const Mat3 t = Mat3::Identity() - nn;
                p.share += split * (t * k_inv * t);
            }
        }
}

void ParticleRows::solve_rows(const BodyVelocities& vel, bool use_bias) {
    if (springs_active_) solve_springs(vel);
    if (rows_.empty()) return;
    const Real h = step_.h, inv_h = 1 / h;
    const RowSoftness& soft = step_.softness;
    const SoftCoefficients sc = soft.soft ? soft_coefficients(soft.hertz, soft.damping_ratio, h) : SoftCoefficients{};
    for (Row& r : rows_) {
        Particle& p = particles_[r.particle];
        // Normal row.
        Vec3 vb = vel.linear(r.rigid) + vel.angular(r.rigid).cross(r.arm);
        const Real vn = r.n.dot(p.v - vb);
        Real d;
        if (r.gap > 0) {
            d = -r.mass_n * (vn + r.gap * inv_h);  // speculative: it may close the gap, no more
        } else if (!use_bias) {
            d = -r.mass_n * vn;
        } else if (soft.soft) {
            // Catto 2011 soft contact (rigid/soft_constraint.hpp), the push capped.
            const Real bias = std::max(sc.bias_rate * r.gap, -kMaxPushVelocity);
            d = -r.mass_n * sc.mass_scale * (vn + bias) - sc.impulse_scale * r.lambda_n;
        } else {
            const Real error = std::min(Real(0), r.gap + kSlop);
            const Real bias = soft.projection ? Real(0) : std::max(soft.baumgarte * inv_h * error, -kMaxPushVelocity);
            d = -r.mass_n * (vn + bias);
        }
        const Real next = std::max(Real(0), r.lambda_n + d);
        d = next - r.lambda_n;
        r.lambda_n = next;
        if (d != 0) apply(r, p, vel, d * r.n);
        // Friction, both tangents bounded together by mu times the normal impulse.
        if (r.mu <= 0 || r.lambda_n <= 0) {
            if (r.lambda_t1 != 0 || r.lambda_t2 != 0) {
                apply(r, p, vel, -r.lambda_t1 * r.t1 - r.lambda_t2 * r.t2);
                r.lambda_t1 = r.lambda_t2 = 0;
            }
            continue;
        }
        vb = vel.linear(r.rigid) + vel.angular(r.rigid).cross(r.arm);
        const Vec3 dv = p.v - vb;
        Real l1 = r.lambda_t1 - r.mass_t1 * r.t1.dot(dv);
        Real l2 = r.lambda_t2 - r.mass_t2 * r.t2.dot(dv);
        const Real limit = r.mu * r.lambda_n;
        const Real len2 = l1 * l1 + l2 * l2;
        if (len2 > limit * limit) {
            const Real s = limit / std::sqrt(len2);
            l1 *= s;
            l2 *= s;
        }
        const Vec3 j = (l1 - r.lambda_t1) * r.t1 + (l2 - r.lambda_t2) * r.t2;
        r.lambda_t1 = l1;
        r.lambda_t2 = l2;
        if (!j.isZero()) apply(r, p, vel, j);
    }
}

void ParticleRows::positions_advanced(const RigidSystem&, const BodyVelocities& vel, Real h) {
    push_pending_ = true;
    for (Particle& p : particles_) p.x += h * p.v;
    // A new sub-step for whole bodies (none after the last): its gravity and its own inertia reference.
    springs_active_ = ++substeps_done_ < step_.substeps;
    if (springs_active_) {
        for (Particle& p : particles_) {
            if (!p.whole) continue;
            p.v += p.gravity_part;
            p.v_ref = p.v;
            p.v -= p.gravity_shortfall;
            p.ext.setZero();
        }
    }
    // The bodies moved by h: each row's separation follows the relative normal motion (linearised, as
    // Box2D v3 tracks its contacts' separations between sub-steps).
    for (Row& r : rows_) {
        const Particle& p = particles_[r.particle];
        const Vec3 vb = vel.linear(r.rigid) + vel.angular(r.rigid).cross(r.arm);
        r.gap += h * r.n.dot(p.v - vb);
    }
}

void ParticleRows::give_soft_velocity(Particle& p, const Vec3& dv, Real moves) {
    Particles& q = soft_.slot_body(p.soft).p;
    p.v_handed = p.v;
    if (q.inv_mass[p.index] == 0) return;  // pinned or attached: its target decides
    q.v[p.index] += dv;
    if (p.whole) {
        // Solved here: the change moves the position only over the time still to integrate, and not at all
        // after the positions (the soft step's relax pass changes velocities only, as for rigid bodies).
        q.x_next[p.index] += moves * dv;
        q.v_solved[p.index] += dv;
    }
}

void ParticleRows::hand_to_soft_prediction(Real h, Real remaining) {
    remaining_ = remaining;
    for (Particle& p : particles_) {
        if (p.whole) {
            // Solved here: the body ends where the rows' (sub-)steps took it, plus what is still to come.
            Particles& q = soft_.slot_body(p.soft).p;
            if (q.inv_mass[p.index] != 0) {
                q.x_next[p.index] = p.x + remaining * p.v;
                q.v[p.index] = p.v;
            }
            p.v_handed = p.v;
            continue;
        }
        const Vec3 dv = p.v - p.v_handed;
        if (!dv.isZero()) soft_.change_predicted_velocity(p.soft, p.index, dv, h);
        p.v_handed = p.v;
    }
}

void ParticleRows::take_soft_velocities() {
    for (Particle& p : particles_) {
        const Particles& q = soft_.slot_body(p.soft).p;
        const Vec3 v = q.v[p.index];
        if (q.inv_mass[p.index] == 0) continue;  // pinned or attached: the rows keep their own
        // What the soft contact pass did is an outside impulse for the springs' sweep.
        if (p.whole) p.ext += (v - p.v) / p.inv_mass;
        p.v = v;
        p.v_handed = p.v;
    }
}

void ParticleRows::exchange_pass(RigidSystem& sys) {
    if (rows_.empty()) return;
    RigidSystem::State& st = sys.state();
    solve_rows(BodyVelocities::of_arrays(st.v, st.w), false);
    // After the soft solve: the change moves this step's positions (SoftSystem::integrate_positions; a
    // whole body's over the time the rigid solver still integrates).
    for (Particle& p : particles_) give_soft_velocity(p, p.v - p.v_handed, remaining_);
}

void ParticleRows::finish(RigidSystem& sys, Real) {
    // Shares a solver did not hand out (it ran fewer passes than sub-steps) go to the bodies now.
    if (push_parts_left_ > 0) {
        RigidSystem::State& st = sys.state();
        const BodyVelocities vel = BodyVelocities::of_arrays(st.v, st.w);
        while (push_parts_left_ > 0) apply_pushes(vel);
    }
    pushes_.clear();
    kept_.clear();
    for (Particle& p : particles_) {
        // What the rigid solver's last passes (the soft step's relax) did after the exchange.
        const Vec3 dv = p.v - p.v_handed;
        if (!dv.isZero()) give_soft_velocity(p, dv, 0);
    }
    for (const Row& r : rows_) {
        if (r.lambda_n == 0 && r.lambda_t1 == 0 && r.lambda_t2 == 0) continue;
        Kept k;
        k.key = key(particles_[r.particle], r.rigid);
        k.n = r.lambda_n;
        k.t1 = r.lambda_t1;
        k.t2 = r.lambda_t2;
        k.tangent = r.t1;
        k.t2dir = r.t2;
        kept_.push_back(k);
    }
    std::sort(kept_.begin(), kept_.end());
}

void ParticleRows::report(std::vector<CouplingImpulse>& out) const {
    for (const AttachRow& r : attach_rows_) {
        if (r.total.isZero()) continue;
        const Particle& p = particles_[r.particle];
        out.push_back({r.rigid, p.soft, p.index, p.x, Vec3::Zero(), -r.total});
    }
    for (const Row& r : rows_) {
        if (r.total.isZero() || r.inv_mb == 0) continue;  // static and kinematic bodies take nothing
        const Particle& p = particles_[r.particle];
        out.push_back({r.rigid, p.soft, p.index, r.point, r.n, -r.total});
    }
}

}  // namespace sinew
