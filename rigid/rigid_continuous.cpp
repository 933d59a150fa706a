// Continuous collision after the step: a fast body whose centre passed into a static or kinematic body
// (and, for a bullet, into a dynamic one) is put back where its shape first touched it.
//
// Speculative contacts (every solver's manifolds reach as far as the pair can close in a step) stop most
// fast bodies at the surface. They cannot stop what detection does not see: the Newtonian solver detects
// at candidate poses x + h v, which for a 100 m/s body lie 1.7 m past a 0.1 m wall, so a tumbling cube
// flew through it (sinew bench robustness, hard-fast). Box2D v3 runs a time-of-impact pass for every
// fast dynamic body against static ones; Sinew does the same in two stages: (1) a ray from the body's
// centre at the start of the step to its centre at the end, against the static and kinematic bodies
// near the segment (only a body whose centre crossed into one is treated, so a body sliding fast along
// a floor it touches is never held back), then (2) a shape cast of the body along its translation, with
// its start orientation, against the body the ray hit, for where the shape first touched it. The body is
// moved there (orientation interpolated to the same fraction) and keeps its velocity: the next step's
// speculative contact takes the velocity off, as in Box2D. Pairs the pre-solve callback disabled this
// step are left alone. Bullets (BodyDef::bullet) are also checked against awake dynamic bodies that are
// not bullets, at those bodies' end-of-step poses: the sequential-impulse solvers' speculative contacts
// already stop fast bodies at dynamic ones, the Newtonian solver's detection at candidate poses does not.
#include <algorithm>
#include <cmath>

#include "engine/core/ray_cast.hpp"
#include "engine/core/shape_cast.hpp"
#include "rigid/rigid_system.hpp"

namespace sinew {

void RigidSystem::continuous_collisions() {
    // A pair whose contact the pre-solve callback turned off this step (a one-way platform letting a body
    // through from below) is not stopped here either.
    auto disabled_pair = [&](std::uint32_t a, std::uint32_t b) {
        for (const auto& d : disabled_) {
            if (d.first >= contacts_.size()) continue;
            const ContactManifold& c = contacts_[d.first];
            if ((c.body_a == a && c.body_b == b) || (c.body_a == b && c.body_b == a)) return true;
        }
        return false;
    };
    for (std::uint32_t s = 0; s < slots_.size(); ++s) {
        if (!slots_.alive(s) || type_[s] != BodyType::Dynamic || !awake_[s] || sensor_[s] || proxy_[s] < 0) continue;
        if (s >= start_x_.size()) continue;
        const Vec3 from = start_x_[s], to = state_.x[s], d = to - from;
        if (d.squaredNorm() < Real(1e-6)) continue;  // under a millimetre: resting stacks cost nothing more
        // Slow bodies cannot skip through anything their contacts have not already seen: half the smallest
        // extent of the shape's local bounds (Box2D v3's safety factor).
        const Aabb local = shape_[s].bounds(Transform::identity());
        const Real min_extent = (local.hi - local.lo).minCoeff() / 2;
        if (d.squaredNorm() <= Real(0.25) * min_extent * min_extent) continue;
        Aabb segment{from.cwiseMin(to), from.cwiseMax(to)};
        std::uint32_t hit_slot = 0;
        Real best = 1;
        bool found = false;
        tree_.query(segment, [&](std::int32_t proxy) {
            const std::uint32_t o = tree_.user_data(proxy);
            // Dynamic bodies are targets only for a bullet, and never another bullet (Box2D's rule).
            if (o == s || (type_[o] == BodyType::Dynamic && (!bullet_[s] || bullet_[o] || !awake_[o])) ||
                !may_touch(s, o) || disabled_pair(s, o))
                return true;
            RayHit hit;
            if (sinew::ray_cast(shape_[o], origin_transform(o), from, to, best, hit) && (!found || hit.fraction < best)) {
                best = hit.fraction;
                hit_slot = o;
                found = true;
            }
            return true;
        });
        if (!found) continue;
        // Where the shape itself first touched that body on the way (no earlier than the start).
        const Transform start{from - start_q_[s] * local_com_[s], start_q_[s]};
        ShapeCastHit cast;
        Real t = 0;
        if (sinew::shape_cast(shape_[s], start, d, shape_[hit_slot], origin_transform(hit_slot), best, cast))
            t = cast.fraction;
        state_.x[s] = from + t * d;
        state_.q[s] = start_q_[s].slerp(t, state_.q[s]).normalized();
        w_frame_[s] = state_.q[s];  // the angular velocity is kept as it is (gyroscopic frame, rigid_integration.cpp)
    }
}

}  // namespace sinew
