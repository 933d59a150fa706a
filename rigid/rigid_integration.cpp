// Integration in the rigid system: masses of the step, velocities from forces and gravity, positions
// from velocities, and the solver's and outside rows' end-of-step work.
#include "rigid/rigid_system.hpp"

#include <atomic>
#include <cmath>
#include <limits>

#include "engine/core/format.hpp"
#include "rigid/constraint_rows.hpp"
#include "rigid/joint_set.hpp"
#include "rigid/rigid_solver.hpp"

namespace sinew {

namespace {
/// Contacts in the last solve from which the step's per-body stages open a region with helpers (below,
/// waking them costs more than the loops).
constexpr std::size_t kParallelBodies = 128;
}  // namespace

const TaskSystem* RigidSystem::body_stage_tasks() const {
    return active_contacts_.size() >= kParallelBodies ? tasks_ : nullptr;
}

void RigidSystem::prepare_mass_state() {
    // The smallest and largest inverse mass of any dynamic body, asleep or not (a body woken later in
    // the step counts too), per worker and then over the workers: min and max are exact, so the same on
    // any worker count. compute_support_levels reads them.
    const std::size_t workers = std::size_t(region_.workers());
    if (inv_mass_range_.size() < workers) inv_mass_range_.resize(workers);
    for (std::size_t k = 0; k < workers; ++k) inv_mass_range_[k] = {std::numeric_limits<Real>::infinity(), Real(0)};
    region_.for_each(int(slots_.size()), 512, [&](int begin, int end, int worker) {
        std::pair<Real, Real>& range = inv_mass_range_[std::size_t(worker)];
        for (std::size_t s = std::size_t(begin); s < std::size_t(end); ++s) {
            if (slots_.alive(s) && type_[s] == BodyType::Dynamic) {
                range.first = std::min(range.first, body_inv_mass_[s]);
                range.second = std::max(range.second, body_inv_mass_[s]);
            }
            if (!(slots_.alive(s) && type_[s] == BodyType::Dynamic && awake_[s])) {
                // Static, kinematic and sleeping bodies are immovable in this step's solve.
                state_.inv_mass[s] = 0;
                state_.inv_inertia_world[s].setZero();
                continue;
            }
            Mat3 r = state_.q[s].toRotationMatrix();
            state_.inv_mass[s] = body_inv_mass_[s];
            state_.inv_inertia_world[s] = r * inv_inertia_local_[s] * r.transpose();
        }
    });
    dynamic_inv_mass_ = {std::numeric_limits<Real>::infinity(), Real(0)};
    for (std::size_t k = 0; k < workers; ++k) {
        dynamic_inv_mass_.first = std::min(dynamic_inv_mass_.first, inv_mass_range_[k].first);
        dynamic_inv_mass_.second = std::max(dynamic_inv_mass_.second, inv_mass_range_[k].second);
    }
}

namespace {

// The gyroscopic term (docs/theory.md#gyroscopic). Between two velocity updates a body turns freely, and
// a free body keeps its angular momentum in the world: L = I_world(q_then) w. Its angular velocity at the
// orientation it has now is therefore w' = I_world(q_now)^-1 L, the inertia turned with the body while
// the momentum stays; that is all Euler's w x (I w) does. This form keeps L exactly (in direction and
// size), and |w'| <= |L| / I_min cannot grow, so it is stable at any spin.
//
// Measured against Catto's implicit step (GDC 2015: backward Euler of I dw/dt = -w x (I w) in the body
// frame, one Newton step), on a 0.6 x 0.3 x 0.1 m box spun at 10 rad/s about its intermediate axis for
// 3 s at h = 1/60 (tests/test_rigid_rotation.cpp): the implicit step lets the world angular momentum drift
// by 20% (4% with the soft step's five sub-steps); this form by float rounding only. Both flip the box.
Vec3 keep_angular_momentum(const Quat& q_then, const Quat& q_now, const Mat3& inertia, const Mat3& inv_inertia,
                           const Vec3& w) {
    const Vec3 l = q_then * Vec3(inertia * (q_then.conjugate() * w));
    return q_now * Vec3(inv_inertia * (q_now.conjugate() * l));
}

}  // namespace

Quat RigidSystem::turned(std::uint32_t s, const Vec3& w, Real h) const {
    const Quat& q = state_.q[s];
    if (!settings_.gyroscopic || spherical_inertia_[s]) return integrate_rotation(q, w, h);
    // Turned about w held fixed, a body drifts from its free motion by a second-order term in its own
    // spin, and keep_angular_momentum turns that drift into spin about the axis of least inertia: a free
    // 1 m x 6 cm bar tumbling at 3 rad/s with 0.01 rad/s about its long axis reached 96 rad/s there in
    // 4 s under the soft step (356 rad/s at 1/60, its kinetic energy 0.42 -> 38 J), growing at about
    // h w_perp^2 I_perp / I_min. Turned about the angular velocity the kept momentum has at the mid-step
    // orientation (the implicit midpoint of dq/dt = w(q) q, to first order in the half step), the spin
    // stays at 0.010 rad/s and the energy within 1e-4 at either step.
    const Quat mid = integrate_rotation(q, w, h / 2);
    return integrate_rotation(q, keep_angular_momentum(q, mid, inertia_local_[s], inv_inertia_local_[s], w), h);
}

void RigidSystem::follow_rotation(std::uint32_t s) {
    if (settings_.gyroscopic && !spherical_inertia_[s] && w_frame_[s].coeffs() != state_.q[s].coeffs())
        state_.w[s] = keep_angular_momentum(w_frame_[s], state_.q[s], inertia_local_[s], inv_inertia_local_[s], state_.w[s]);
    w_frame_[s] = state_.q[s];
}

void RigidSystem::follow_turn(std::uint32_t s) {
    // A body of equal principal inertias (cubes, spheres) has a frame-free inertia: nothing to turn.
    if (state_.inv_mass[s] == 0 || spherical_inertia_[s]) return;
    follow_rotation(s);
    const Mat3 r = state_.q[s].toRotationMatrix();
    state_.inv_inertia_world[s] = r * inv_inertia_local_[s] * r.transpose();
}

void RigidSystem::integrate_velocity(std::uint32_t s, Real h) {
    if (state_.inv_mass[s] == 0) return;
    Vec3 v = state_.v[s] + h * (gravity_scale_[s] * settings_.gravity + body_inv_mass_[s] * state_.force[s]);
    follow_rotation(s);  // the gyroscopic effect of the rotation since the last velocity update
    Vec3 w = state_.w[s] + h * (state_.inv_inertia_world[s] * state_.torque[s]);
    // Implicit damping factor 1/(1 + h c): unconditionally stable, as Box2D does.
    state_.v[s] = v / (1 + h * linear_damping_[s]);
    state_.w[s] = w / (1 + h * angular_damping_[s]);
}

void RigidSystem::integrate_velocities(Real h) {
    // Each body on its own: split among the workers when called inside a parallel region (the soft
    // step's sub-steps), one loop otherwise.
    region_.for_each(int(slots_.size()), 512, [&](int begin, int end, int) {
        for (std::uint32_t s = std::uint32_t(begin); s < std::uint32_t(end); ++s) integrate_velocity(s, h);
    });
}

void RigidSystem::integrate_velocities_of(const std::uint32_t* slots, std::size_t count, Real h) {
    for (std::size_t i = 0; i < count; ++i) integrate_velocity(slots[i], h);
}

void RigidSystem::integrate_positions(Real h) {
    // One region for the step's end, which the solver's finish joins (the soft step's relax and
    // restitution passes).
    region_.run(body_stage_tasks(), [&] { integrate_positions_in_region(h); });
    if (settings_.continuous) continuous_collisions();
    if (settings_.sleeping) update_sleep(h);
}

void RigidSystem::integrate_positions_in_region(Real h) {
    const bool integrate = !solver_->integrates_itself();
    region_.for_each(int(slots_.size()), 512, [&](int begin, int end, int) {
        for (std::uint32_t s = std::uint32_t(begin); s < std::uint32_t(end); ++s) {
            if (!slots_.alive(s) || type_[s] == BodyType::Static || !awake_[s]) continue;
            if (integrate) {
                state_.x[s] += h * state_.v[s];
                state_.q[s] = turned(s, state_.w[s], h);
                // The step's rotation turned the body's inertia: its angular velocity at the new orientation
                // keeps the angular momentum (so what the step reports agrees with where the body now is).
                if (settings_.gyroscopic && state_.inv_mass[s] != 0) follow_rotation(s);
            }
            state_.force[s].setZero();
            state_.torque[s].setZero();
        }
    });
    if (integrate) {
        // The soft step tells the sources after each of its sub-steps; the others move once per step.
        const BodyVelocities vel = BodyVelocities::of_arrays(state_.v, state_.w);
        for (ConstraintRows* rows : row_sources_) rows->positions_advanced(*this, vel, h);
    }
    solver_->finish_step(*this, h);
    for (ConstraintRows* rows : row_sources_) rows->finish(*this, h);
    // Position corrections since (split impulses' pseudo velocities, joint projection) turned some
    // bodies further. That turn is not motion: the angular velocity turns with the body, keeping its
    // body-frame value and so its kinetic energy. Kept as angular momentum instead, a ball-jointed loop
    // of 1 m x 6 cm bars (inertia 140:1) under split impulses spun up about the bars' long axes to
    // 830 rad/s within 10 s, its energy from -18 J to +327 J: each correction's small turn of a long
    // axis moved part of the tumbling momentum onto it, where the small inertia makes it fast.
    // Then every body is checked, in the same stage, and the rare unsound one put back on this thread.
    const bool gyroscopic = settings_.gyroscopic;
    std::atomic<bool> unsound{false};
    region_.for_each(int(slots_.size()), 512, [&](int begin, int end, int) {
        for (std::uint32_t s = std::uint32_t(begin); s < std::uint32_t(end); ++s) {
            if (gyroscopic && state_.inv_mass[s] != 0 && w_frame_[s].coeffs() != state_.q[s].coeffs()) {
                state_.w[s] = (state_.q[s] * w_frame_[s].conjugate()) * state_.w[s];
                w_frame_[s] = state_.q[s];
            }
            if (!state_is_sound(s)) unsound.store(true, std::memory_order_relaxed);
        }
    });
    if (unsound.load(std::memory_order_relaxed)) contain_non_finite();
}

bool RigidSystem::state_is_sound(std::uint32_t s) const {
    // A sleeping body has not moved since it was checked awake.
    if (!slots_.alive(s) || type_[s] == BodyType::Static || !awake_[s]) return true;
    // A finite orientation far from unit length (zero, after normalising an overflowed one) is as
    // broken as a NaN: every later rotation of the body is.
    const Real fast = Real(kBlowUpSpeed * kBlowUpSpeed);
    return state_.x[s].allFinite() && std::abs(state_.q[s].squaredNorm() - 1) < Real(0.1) &&
           state_.v[s].squaredNorm() < fast && state_.w[s].squaredNorm() < fast;
}

void RigidSystem::contain_non_finite() {
    for (std::uint32_t s = 0; s < slots_.size(); ++s) {
        if (state_is_sound(s)) continue;
        const Real q2 = state_.q[s].squaredNorm();
        const Real fast = Real(kBlowUpSpeed * kBlowUpSpeed);
        std::string what;
        if (!state_.x[s].allFinite())
            what = "position " + to_text(state_.x[s]) + " is not finite";
        else if (!(std::abs(q2 - 1) < Real(0.1)))
            what = "orientation is not a unit quaternion (|q|^2 = " + to_text(q2) + ")";
        else if (!(state_.v[s].squaredNorm() < fast))
            what = "speed " + to_text(state_.v[s].stableNorm()) + " m/s is not finite or beyond " + to_text(kBlowUpSpeed);
        else
            what = "spin " + to_text(state_.w[s].stableNorm()) + " rad/s is not finite or beyond " + to_text(kBlowUpSpeed);
        // Back where the step found it, at rest (a body created during the step: where it was created,
        // create_body writes its start pose).
        if (s < start_x_.size() && start_x_[s].allFinite() && std::abs(start_q_[s].squaredNorm() - 1) < Real(0.1)) {
            state_.x[s] = start_x_[s];
            state_.q[s] = start_q_[s];
        }
        state_.v[s].setZero();
        state_.w[s].setZero();
        state_.force[s].setZero();
        state_.torque[s].setZero();
        w_frame_[s] = state_.q[s];
        // Impulses accumulated against it would start the next step's solve from the same values.
        for (ContactManifold& c : contacts_) {
            if (c.body_a != s && c.body_b != s) continue;
            for (int k = 0; k < c.manifold.count; ++k) {
                ContactPoint& p = c.manifold.points[k];
                p.normal_impulse = p.total_normal_impulse = 0;  // what events and coupling layers read too
                p.tangent_impulse[0] = p.tangent_impulse[1] = 0;
            }
        }
        joints_->forget_impulses(s);
        StepFault f;
        f.system = StepFault::System::Rigid;
        f.index = s;
        f.generation = slots_.generation(s);
        f.what = std::move(what);
        f.hint = "the solver could not hold what acts on it (a joint motor or force far beyond the bodies' "
                 "masses, a mass ratio of many orders): lower the force or motor limit, or use a smaller step";
        faults_.push_back(std::move(f));
    }
}

}  // namespace sinew
