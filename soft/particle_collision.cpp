// One-way particle contacts: projection of positions (Jakobsen 2003), then a velocity pass for
// restitution and Coulomb friction, recorded as ParticleContact for coupling layers.
#include "soft/particle_collision.hpp"
#include "soft/soft_methods.hpp"

#include <algorithm>
#include <cmath>

namespace sinew {
namespace {

// A resting particle is reported as touching while it is this close to the surface (fraction of its
// thickness), so contacts do not flicker on and off between steps.
constexpr Real kContactSlop = Real(0.1);
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
    correction_.assign(b.p.size(), Vec3::Zero());
    if (colliders.empty() || b.p.size() == 0) return;
    // Box of where the particles may be at the end of the step: current positions, padded by the
    // furthest a particle moves in one step (speed and gravity) and by the thickness.
    Real vmax2 = 0;
    for (const Vec3& v : b.p.v) vmax2 = std::max(vmax2, v.squaredNorm());
    Real amax = b.gravity.norm();  // largest acceleration: gravity plus the external force per mass
    for (std::size_t i = 0; i < b.p.size(); ++i)
        if (b.p.inv_mass[i] > 0) amax = std::max(amax, b.gravity.norm() + b.p.f[i].norm() * b.p.inv_mass[i]);
    const Real reach = std::sqrt(vmax2) * h + amax * h * h + 2 * b.def.thickness;
    const Aabb box = particle_box(b.p, reach);
    for (std::size_t c = 0; c < colliders.size(); ++c)
        if (colliders[c].box.overlaps(box)) candidates_.push_back(static_cast<std::uint32_t>(c));
}

int ParticleCollision::project_positions(SoftBody& b, Real h) {
    int moved = 0;
    const Real r = b.def.thickness;
    for (std::uint32_t c : candidates_) {
        const Collider& col = (*colliders_)[c];
        const Aabb reach = col.box.fattened(r);
        const Real mu = std::sqrt(std::max(Real(0), b.def.friction * col.friction));  // geometric mean
        for (std::size_t i = 0; i < b.p.size(); ++i) {
            if (b.p.inv_mass[i] == 0) continue;
            Vec3& x = b.p.x[i];
            if (!reach.contains(x)) continue;
            Vec3 s, n;
            Real d;
            if (!point_shape_distance(x, *col.shape, col.xf, r, s, n, d) || d >= r) continue;
            const Real push = r - d;
            Vec3 dx = push * n;
            // Friction: the particle's tangential motion this step relative to the surface point.
            const Vec3 moved_by = x + dx - b.p.x_prev[i] - h * col.point_velocity(s);
            const Vec3 tangential = moved_by - moved_by.dot(n) * n;
            const Real t_len = tangential.norm();
            if (t_len > 0) dx -= std::min(Real(1), mu * push / t_len) * tangential;
            x += dx;
            correction_[i] += dx;
            ++moved;
        }
    }
    return moved;
}

void ParticleCollision::finish(SoftBody& b, std::uint32_t body_slot, Real h, std::vector<ParticleContact>& out) {
    const Real r = b.def.thickness;
    for (std::uint32_t c : candidates_) {
        const Collider& col = (*colliders_)[c];
        const Aabb reach = col.box.fattened(r * (1 + kContactSlop));
        const Real mu = std::sqrt(std::max(Real(0), b.def.friction * col.friction));  // geometric mean
        const Real e = std::max(b.def.restitution, col.restitution);
        for (std::uint32_t i = 0; i < b.p.size(); ++i) {
            if (b.p.inv_mass[i] == 0) continue;
            Vec3& x = b.p.x[i];
            if (!reach.contains(x)) continue;
            Vec3 s, n;
            Real d;
            if (!point_shape_distance(x, *col.shape, col.xf, r * (1 + kContactSlop), s, n, d)) continue;
            const Real depth = r - d;
            if (depth > 0) x += depth * n;
            // Velocity relative to the collider's surface point.
            Vec3& v = b.p.v[i];
            const Vec3 vs = col.point_velocity(s);
            const Vec3 vrel = v - vs;
            const Real vn = vrel.dot(n);
            // Approach already removed by the relaxation's pushes: the net position correction along this
            // normal, over h (net, not the sum of every sweep's push: links pulling a resting particle
            // back in each sweep must not look like an impact).
            const Real pushed_speed = std::max(Real(0), correction_[i].dot(n)) / h;
            const bool position_friction = soft_method_stages(b.def.method).position_friction;  // project_positions
            if (vn >= 0 && depth <= 0 && pushed_speed == 0) continue;  // near but separating: not a contact
            Vec3 dv = Vec3::Zero();
            const Real removed = std::max(Real(0), -vn);  // approach this pass removes
            const Real approach = removed + pushed_speed;
            // Remove the approach; above the threshold reflect it scaled by e (Jakobsen reflects the old
            // position across the contact plane).
            const Real dvn = removed + (approach > kRestitutionThreshold ? e * approach : Real(0));
            dv += dvn * n;
            // Coulomb friction: the tangential velocity change is at most mu times the normal one.
            const Vec3 vt = vrel - vn * n;
            const Real vt_len = vt.norm();
            if (vt_len > 0 && !position_friction) {
                const Vec3 dvt = -std::min(Real(1), mu * (removed + pushed_speed) / vt_len) * vt;
                dv += dvt;
                // The step already moved the particle with its pre-friction velocity: take back the
                // tangential part of that motion, as if friction had acted before the position update
                // (otherwise a particle held by static friction still creeps g sin(theta) h^2 per step).
                x += h * dvt;
            }
            v += dv;
            ParticleContact pc;
            pc.body = body_slot;
            pc.particle = i;
            pc.collider = c;
            pc.normal = n;
            pc.point = s;
            pc.depth = std::max(Real(0), depth);
            // What the contact did to the particle this step: this pass's velocity change and the
            // position corrections of the relaxation (as a velocity change over h).
            pc.impulse = b.p.mass[i] * (dv + correction_[i] / h);
            correction_[i].setZero();  // counted once, by the particle's first contact
            out.push_back(pc);
        }
    }
}

}  // namespace sinew
