// One-way particle contacts: projection of positions (Jakobsen 2003), then a velocity pass for
// restitution and Coulomb friction, recorded as ParticleContact for coupling layers.
#include "soft/particle_collision.hpp"
#include "soft/soft_methods.hpp"
#include "engine/core/ray_cast.hpp"

#include <algorithm>
#include <cmath>

namespace sinew {
namespace {

// Restitution only acts above this approach speed (m/s), as in the rigid solvers: slow contacts
// (a resting particle gains g h per step) must not bounce.
constexpr Real kRestitutionThreshold = Real(1);

Aabb particle_box(const Particles& p, Real pad) {
    Aabb box;
    for (const Vec3& x : p.x) box.grow(x);
    return box.fattened(pad);
}

}  // namespace

void ParticleCollision::begin(const SoftBody& b, const std::vector<Collider>& colliders, Real h) {
    colliders_ = &colliders;
    candidates_.clear();
    planes_.clear();
    held_.clear();
    held_approach_.clear();
    held_friction_.clear();
    friction_held_.clear();
    body_friction_ = b.def.friction;
    correction_.assign(b.p.size(), Vec3::Zero());
    if (colliders.empty() || b.p.size() == 0) return;
    // How far a particle may get this step: its speed and the largest acceleration (gravity plus the
    // external force per mass) over h.
    Real vmax2 = 0;
    for (const Vec3& v : b.p.v) vmax2 = std::max(vmax2, v.squaredNorm());
    Real amax = b.gravity.norm();
    for (std::size_t i = 0; i < b.p.size(); ++i)
        if (b.p.inv_mass[i] > 0) amax = std::max(amax, b.gravity.norm() + b.p.f[i].norm() * b.p.inv_mass[i]);
    const Real travel = std::sqrt(vmax2) * h + amax * h * h;
    const Real r = b.def.thickness;
    // A particle gets a plane against a collider if it can come within the contact distance of it.
    const Real reach = travel + r * (1 + kContactSlop);
    const Aabb box = particle_box(b.p, travel + 2 * r);
    // Each collider's box over the step: where it ends and where it started (a fast paddle may pass
    // the whole body in one step).
    swept_.resize(colliders.size());
    for (std::size_t c = 0; c < colliders.size(); ++c) {
        const Collider& col = colliders[c];
        Aabb& sw = swept_[c];
        sw = col.box;
        if (col.v != Vec3::Zero() || col.w != Vec3::Zero()) {
            sw.grow(col.box.lo - h * col.v);
            sw.grow(col.box.hi - h * col.v);
            sw = sw.fattened(col.w.norm() * h * Real(0.5) * (col.box.hi - col.box.lo).norm());
        }
    }
    for (std::size_t c = 0; c < colliders.size(); ++c)
        if (swept_[c].overlaps(box) && should_collide(b.def.filter, colliders[c].filter) &&
            std::find(b.ignored_owners.begin(), b.ignored_owners.end(), colliders[c].owner) == b.ignored_owners.end())
            candidates_.push_back(static_cast<std::uint32_t>(c));
    // Planes are found where the particles are predicted to end the step (Particles::x_next, written by
    // the method's IntegrateVelocities part), where the contact pass will test them; the reach keeps a
    // plane for particles the constraint solve moves by up to a step's travel from there.
    const std::vector<Vec3>& at = b.p.x_next.size() == b.p.size() ? b.p.x_next : b.p.x;
    if (found_at_.size() < colliders.size()) found_at_.resize(colliders.size());
    // Each candidate's pose at the start of the step, from its end pose and velocities (the sweep above
    // follows the particle in the collider's frame).
    std::vector<Transform>& start = start_at_;
    if (start.size() < colliders.size()) start.resize(colliders.size());
    for (std::uint32_t c : candidates_) {
        const Collider& col = colliders[c];
        const Quat back = integrate_rotation(Quat::Identity(), col.w, -h);
        start[c].q = (back * col.xf.q).normalized();
        start[c].p = (col.com - h * col.v) + back * (col.xf.p - col.com);
    }
    for (std::uint32_t c : candidates_) {
        const Collider& col = colliders[c];
        found_at_[c] = col.xf;
        const Aabb near = col.box.fattened(reach);
        for (std::uint32_t i = 0; i < b.p.size(); ++i) {
            if (b.p.inv_mass[i] == 0) continue;
            const Vec3& x = at[i];
            Vec3 s, n;
            Real d;
            const bool found = near.contains(x) && point_shape_distance(x, *col.shape, col.xf, reach, s, n, d);
            // Continuous collision: a particle that moves more than its thickness this step relative to
            // the collider, and is not in front of the plane found at its predicted end (none, or one it
            // lay behind at the start of the step), may have crossed the shape: the first face its path
            // enters, in the collider's frame, is its plane instead. A particle at 50 m/s crosses 0.8 m a
            // step at 60 Hz, and a 0.1 m wall's nearest face from beyond it is the far one; a paddle
            // swung at that speed passes a resting cloth the same way.
            const Vec3 from = start[c].apply_inverse(b.p.x[i]), to = col.xf.apply_inverse(x);
            if ((to - from).squaredNorm() > r * r &&
                (!found || col.xf.rotate_inverse(n).dot(from - col.xf.apply_inverse(s)) < 0)) {
                Aabb path;
                path.grow(b.p.x[i]);
                path.grow(x);
                RayHit hit;
                if (path.overlaps(swept_[c].fattened(r)) && ray_cast(*col.shape, Transform{}, from, to, 1, hit)) {
                    planes_.push_back({i, c, col.xf.apply(hit.point), col.xf.rotate(hit.normal)});
                    continue;
                }
            }
            if (found) planes_.push_back({i, c, s, n});
        }
    }
    held_.assign(planes_.size(), Real(0));
    held_approach_.assign(planes_.size(), Real(0));
    held_friction_.assign(planes_.size(), Vec3::Zero());
    friction_held_.assign(planes_.size(), 0);
}

Real ParticleCollision::world_plane(const Plane& pl, const Collider& col, const Vec3& x, Vec3& normal,
                                    Vec3& surface) const {
    const Transform& then = found_at_[pl.collider];
    Real d;
    if (col.xf.p == then.p && col.xf.q.coeffs() == then.q.coeffs()) {
        normal = pl.normal;  // the collider has not moved since: the plane as found
        d = normal.dot(x - pl.point);
    } else {
        // A coupling layer refined the collider's pose: the plane moves rigidly with it.
        normal = col.xf.q * then.rotate_inverse(pl.normal);
        d = normal.dot(x - col.xf.apply(then.apply_inverse(pl.point)));
    }
    surface = x - d * normal;
    return d;
}

ParticleCollision::PlaneView ParticleCollision::plane(std::size_t k) const {
    const Plane& pl = planes_[k];
    const Collider& col = (*colliders_)[pl.collider];
    PlaneView out;
    out.particle = pl.particle;
    out.collider = pl.collider;
    // The plane as found, moved rigidly with the collider if a coupling layer changed its pose since.
    const Transform& then = found_at_[pl.collider];
    if (col.xf.p == then.p && col.xf.q.coeffs() == then.q.coeffs()) {
        out.point = pl.point;
        out.normal = pl.normal;
    } else {
        out.point = col.xf.apply(then.apply_inverse(pl.point));
        out.normal = col.xf.q * then.rotate_inverse(pl.normal);
    }
    out.velocity = col.point_velocity(out.point);
    out.friction = std::sqrt(std::max(Real(0), body_friction_ * col.friction));  // as finish() mixes them
    return out;
}

int ParticleCollision::project_positions(SoftBody& b, Real h) {
    int moved = 0;
    const Real r = b.def.thickness;
    for (const Plane& pl : planes_) {
        const Collider& col = (*colliders_)[pl.collider];
        Vec3& x = b.p.x[pl.particle];
        Vec3 n, s;
        const Real d = world_plane(pl, col, x, n, s);
        if (d >= r) continue;
        const Real mu = std::sqrt(std::max(Real(0), b.def.friction * col.friction));  // geometric mean
        const Real push = r - d;
        Vec3 dx = push * n;
        // Friction: the particle's tangential motion this step relative to the surface point.
        const Vec3 moved_by = x + dx - b.p.x_prev[pl.particle] - h * col.point_velocity(s);
        const Vec3 tangential = moved_by - moved_by.dot(n) * n;
        const Real t_len = tangential.norm();
        if (t_len > 0) dx -= std::min(Real(1), mu * push / t_len) * tangential;
        x += dx;
        correction_[pl.particle] += dx;
        ++moved;
    }
    return moved;
}

void ParticleCollision::finish(SoftBody& b, std::uint32_t body_slot, Real h, std::vector<ParticleContact>& out) {
    const Real r = b.def.thickness;
    const bool position_friction = soft_stages_of(b).position_friction;  // project_positions
    for (std::size_t k = 0; k < planes_.size(); ++k) {
        const Plane& pl = planes_[k];
        const Collider& col = (*colliders_)[pl.collider];
        const std::uint32_t i = pl.particle;
        Vec3& x = b.p.x[i];
        Vec3 n, s;
        const Real d = world_plane(pl, col, x, n, s);
        // What the contact did to the particle this step: `dv` from this pass, the position corrections
        // of the relaxation (as a velocity change over h), counted once, by the particle's first contact,
        // and the impulse a solve held it with on this plane (set_held).
        const auto record = [&](const Vec3& dv, Real depth) {
            ParticleContact pc;
            pc.body = body_slot;
            pc.particle = i;
            pc.collider = pl.collider;
            pc.normal = n;
            pc.point = s;
            pc.depth = std::max(Real(0), depth);
            pc.impulse = b.p.mass[i] * (dv + correction_[i] / h) + held_[k] * n + held_friction_[k];
            correction_[i].setZero();
            out.push_back(pc);
        };
        if (d > r * (1 + kContactSlop)) {
            // Out of reach now, but the relaxation pushed it during the step (its links pulled it away
            // since): that push is in its velocity, so it is reported, or a coupling layer sending the
            // reactions back would lose it (0.2% of a Verlet cloth's momentum per impact).
            if (!correction_[i].isZero() || held_[k] != 0 || friction_held_[k]) record(Vec3::Zero(), 0);
            continue;
        }
        const Real mu = std::sqrt(std::max(Real(0), b.def.friction * col.friction));  // geometric mean
        const Real e = std::max(b.def.restitution, col.restitution);
        const Real depth = r - d;
        if (depth > 0) x += depth * n;
        // Velocity relative to the collider's surface point.
        Vec3& v = b.p.v[i];
        const Vec3 vs = col.point_velocity(s);
        const Vec3 vrel = v - vs;
        const Real vn = vrel.dot(n);
        // Approach already removed by the relaxation's pushes: the net position correction along this
        // normal, over h (net, not the sum of every sweep's push: links pulling a resting particle back in
        // each sweep must not look like an impact).
        const Real pushed_speed = std::max(Real(0), correction_[i].dot(n)) / h;
        // Normal velocity change the solve's constraint already made: an implicit solve's per particle
        // (SoftBody::contact_dvn), a fast mass-spring solve's per plane (set_held).
        const Real held_here = held_[k] * b.p.inv_mass[i];
        const Real held_approach = held_here > 0 ? held_approach_[k] : Real(0);
        const Real held = (b.contact_dvn.empty() ? Real(0) : b.contact_dvn[i]) + std::max(Real(0), held_here);
        if (vn >= 0 && depth <= 0 && correction_[i].isZero() && held == 0 && held_here == 0 && !friction_held_[k])
            continue;  // near but separating: not a contact
        Vec3 dv = Vec3::Zero();
        const Real removed = std::max(Real(0), -vn);  // approach this pass removes
        // A plane held inside the solve took the approach there: it counts for restitution as the
        // relaxation's pushes do (the particle's own approach, not the held impulse over its mass, which
        // also carries what its links press it down with: a resting cloth's particles would bounce).
        const Real approach = removed + pushed_speed + held_approach;
        // Remove the approach; above the threshold reflect it scaled by e (Jakobsen reflects the old
        // position across the contact plane).
        const Real dvn = removed + (approach > kRestitutionThreshold ? e * approach : Real(0));
        dv += dvn * n;
        // Coulomb friction: the tangential velocity change is at most mu times the normal one.
        const Vec3 vt = vrel - vn * n;
        const Real vt_len = vt.norm();
        if (vt_len > 0 && !position_friction && !friction_held_[k]) {
            // The budget counts the normal change an implicit solve's contact constraint already made.
            const Real dvt_max = mu * (removed + pushed_speed + held);
            const Vec3 dvt = -std::min(Real(1), dvt_max / vt_len) * vt;
            dv += dvt;
            // The step already moved the particle with its pre-friction velocity: take back the
            // tangential part of that motion, as if friction had acted before the position update
            // (otherwise a particle held by static friction still creeps g sin(theta) h^2 per step).
            x += h * dvt;
        }
        v += dv;
        record(dv, depth);
    }
}

}  // namespace sinew
