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
}  // namespace

void ParticleRows::build(RigidSystem& sys, Real h) {
    particles_.clear();
    rows_.clear();
    const RigidSystem::State& st = sys.state();
    const std::vector<Collider>& colliders = soft_.colliders();
    const Real inv_h = 1 / h;
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        const ParticleCollision* col = soft_.collision(s);
        if (!col || col->plane_count() == 0) continue;
        const SoftBody& b = soft_.slot_body(s);
        const SoftBodyId sid = soft_.id_of_slot(s);
        const Real r = b.def.thickness;
        particle_of_.assign(b.p.size(), -1);
        std::uint32_t last = kNoOwner, now_slot = kNoOwner;
        bool coupled = false;
        Transform back;  // maps the collider's predicted pose to its current one
        for (std::size_t k = 0; k < col->plane_count(); ++k) {
            const ParticleCollision::PlaneView pl = col->plane(k);
            const Collider& c = colliders[pl.collider];
            if (pl.collider != last) {
                // Planes come grouped by collider: decide once per (soft body, collider).
                last = pl.collider;
                coupled = c.dynamic && c.owner < st.inv_mass.size() && st.inv_mass[c.owner] > 0 &&
                          coupling_strategy_of(settings_, sid, sys.id_of_slot(c.owner)) == CouplingStrategy::TwoWay;
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
            tangent_basis(row.n, row.t1, row.t2);
            row.point = back.apply(pl.point);
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
                particles_.push_back(p);
            }
            row.particle = std::uint32_t(particle_of_[i]);
            rows_.push_back(row);
        }
    }
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
    build(sys, h_);
    if (rows_.empty()) return;
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

void ParticleRows::solve_rows(const BodyVelocities& vel, bool use_bias) {
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
    // The bodies moved by h: each row's separation follows the relative normal motion (linearised, as
    // Box2D v3 tracks its contacts' separations between sub-steps).
    for (Row& r : rows_) {
        const Particle& p = particles_[r.particle];
        const Vec3 vb = vel.linear(r.rigid) + vel.angular(r.rigid).cross(r.arm);
        r.gap += h * r.n.dot(p.v - vb);
    }
}

void ParticleRows::hand_to_soft_prediction(Real h) {
    for (Particle& p : particles_) {
        const Vec3 dv = p.v - p.v_handed;
        if (!dv.isZero()) soft_.change_predicted_velocity(p.soft, p.index, dv, h);
        p.v_handed = p.v;
    }
}

void ParticleRows::take_soft_velocities() {
    for (Particle& p : particles_) {
        p.v = soft_.slot_body(p.soft).p.v[p.index];
        p.v_handed = p.v;
    }
}

void ParticleRows::exchange_pass(RigidSystem& sys) {
    if (rows_.empty()) return;
    RigidSystem::State& st = sys.state();
    solve_rows(BodyVelocities::of_arrays(st.v, st.w), false);
    // After the soft solve: the change moves this step's positions (SoftSystem::integrate_positions).
    for (Particle& p : particles_) {
        soft_.slot_body(p.soft).p.v[p.index] += p.v - p.v_handed;
        p.v_handed = p.v;
    }
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
        if (!dv.isZero()) soft_.slot_body(p.soft).p.v[p.index] += dv;
        p.v_handed = p.v;
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
    for (const Row& r : rows_) {
        if (r.total.isZero()) continue;
        const Particle& p = particles_[r.particle];
        out.push_back({r.rigid, p.soft, p.index, r.point, r.n, -r.total});
    }
}

}  // namespace sinew
