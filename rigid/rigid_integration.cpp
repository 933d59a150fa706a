// Integration in the rigid system: masses of the step, velocities from forces and gravity, positions
// from velocities, and the solver's and outside rows' end-of-step work.
#include "rigid/rigid_system.hpp"

#include "rigid/constraint_rows.hpp"
#include "rigid/rigid_solver.hpp"

namespace sinew {

void RigidSystem::prepare_mass_state() {
    const std::size_t n = slots_.size();
    for (std::size_t s = 0; s < n; ++s) {
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
}

void RigidSystem::integrate_velocities(Real h) {
    const std::size_t n = slots_.size();
    for (std::size_t s = 0; s < n; ++s) {
        if (state_.inv_mass[s] == 0) continue;
        Vec3 v = state_.v[s] + h * (gravity_scale_[s] * settings_.gravity + body_inv_mass_[s] * state_.force[s]);
        Vec3 w = state_.w[s] + h * (state_.inv_inertia_world[s] * state_.torque[s]);
        // Implicit damping factor 1/(1 + h c): unconditionally stable, as Box2D does.
        state_.v[s] = v / (1 + h * linear_damping_[s]);
        state_.w[s] = w / (1 + h * angular_damping_[s]);
    }
}

void RigidSystem::integrate_positions(Real h) {
    const bool integrate = !solver_->integrates_itself();
    for (std::uint32_t s = 0; s < slots_.size(); ++s) {
        if (!slots_.alive(s) || type_[s] == BodyType::Static || !awake_[s]) continue;
        if (integrate) {
            state_.x[s] += h * state_.v[s];
            state_.q[s] = integrate_rotation(state_.q[s], state_.w[s], h);
        }
        state_.force[s].setZero();
        state_.torque[s].setZero();
    }
    if (integrate) {
        // The soft step tells the sources after each of its sub-steps; the others move once per step.
        const BodyVelocities vel = BodyVelocities::of_arrays(state_.v, state_.w);
        for (ConstraintRows* rows : row_sources_) rows->positions_advanced(*this, vel, h);
    }
    solver_->finish_step(*this, h);
    for (ConstraintRows* rows : row_sources_) rows->finish(*this, h);
    if (settings_.sleeping) update_sleep(h);
}

}  // namespace sinew
