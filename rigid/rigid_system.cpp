// The rigid-body system: its settings and solver, its stages, and the sources of outside rows. The other
// jobs live beside it: the body store (rigid_bodies.cpp), contact detection and warm-start matching
// (rigid_contacts.cpp), integration (rigid_integration.cpp), islands and sleeping (rigid_sleep.cpp),
// queries (rigid_queries.cpp).
#include "rigid/rigid_system.hpp"

#include <algorithm>

#include "engine/core/format.hpp"
#include "rigid/joint_set.hpp"
#include "rigid/rigid_solver.hpp"

namespace sinew {

RigidSystem::RigidSystem(const RigidSettings& settings) : joints_(std::make_unique<JointSet>()) {
    row_sources_.push_back(joints_.get());
    set_settings(settings);
}

RigidSystem::~RigidSystem() = default;

void RigidSystem::set_settings(const RigidSettings& s) {
    auto bad = [](const std::string& field, const std::string& why) {
        throw RigidError("rigid settings: " + field + " " + why);
    };
    if (!is_finite(s.gravity)) bad("gravity", "must be finite");
    if (s.velocity_iterations < 1 || s.velocity_iterations > 1000)
        bad("velocity_iterations", "must be in [1, 1000], got " + std::to_string(s.velocity_iterations));
    if (!(s.baumgarte >= 0 && s.baumgarte <= 1)) bad("baumgarte", "must be in [0, 1], got " + to_text(s.baumgarte));
    if (!(s.linear_slop >= 0 && s.linear_slop < 1)) bad("linear_slop", "must be in [0, 1) m, got " + to_text(s.linear_slop));
    if (!(s.restitution_threshold >= 0) || !is_finite(s.restitution_threshold))
        bad("restitution_threshold", "must be finite and >= 0, got " + to_text(s.restitution_threshold));
    if (!(s.contact_margin > 0 && s.contact_margin < 1))
        bad("contact_margin", "must be in (0, 1) m, got " + to_text(s.contact_margin));
    if (!(s.max_correction_velocity > 0) || !is_finite(s.max_correction_velocity))
        bad("max_correction_velocity", "must be finite and > 0, got " + to_text(s.max_correction_velocity));
    if (!(s.sleep_linear_velocity >= 0) || !(s.sleep_angular_velocity >= 0) || !(s.sleep_time >= 0) ||
        !is_finite(s.sleep_time))
        bad("sleep thresholds", "must be finite and >= 0");
    if (s.newton_collision_iterations < 0 || s.newton_contact_iterations < 1)
        bad("newton iterations", "must be >= 0 (collision) and >= 1 (contact)");
    if (!(s.newton_projection_fraction >= 0 && s.newton_projection_fraction <= 1))
        bad("newton projection_fraction", "must be in [0, 1], got " + to_text(s.newton_projection_fraction));
    if (s.substeps < 0 || s.substeps > 64)
        bad("substeps", "must be in [0, 64] (0 = velocity_iterations / 2), got " + std::to_string(s.substeps));
    if (!(s.contact_hertz > 0) || !is_finite(s.contact_hertz)) bad("contact_hertz", "must be finite and > 0");
    if (!(s.contact_damping_ratio >= 0) || !is_finite(s.contact_damping_ratio))
        bad("contact_damping_ratio", "must be finite and >= 0");
    if (!(s.contact_push_velocity > 0) || !is_finite(s.contact_push_velocity))
        bad("contact_push_velocity", "must be finite and > 0");
    if (!(s.contact_mass_ratio == 0 || (s.contact_mass_ratio >= 1 && is_finite(s.contact_mass_ratio))))
        bad("contact_mass_ratio", "must be 0 (no bound) or finite and >= 1, got " + to_text(s.contact_mass_ratio));
    if (!(s.solver < RigidSolverKind::Count)) bad("solver", "is not a RigidSolverKind (" + std::to_string(int(s.solver)) + ")");
    // The solver object follows the method (split impulses and Baumgarte share one); impulses cached by one
    // are not meaningful to another.
    auto method = [](RigidSolverKind k) { return k == RigidSolverKind::Baumgarte ? RigidSolverKind::SplitImpulse : k; };
    if (!solver_ || method(s.solver) != method(settings_.solver)) {
        switch (s.solver) {
            case RigidSolverKind::Newton: solver_ = make_newton_impulse_solver(); break;
            case RigidSolverKind::SoftStep: solver_ = make_soft_step_solver(); break;
            default: solver_ = make_sequential_impulse_solver(); break;
        }
        for (ContactManifold& c : contacts_)
            for (int k = 0; k < c.manifold.count; ++k) {
                c.manifold.points[k].normal_impulse = 0;
                c.manifold.points[k].tangent_impulse[0] = c.manifold.points[k].tangent_impulse[1] = 0;
            }
    }
    settings_ = s;
}

// ---- stages -------------------------------------------------------------------------------------

void RigidSystem::run_stage(Stage stage, const StepContext& ctx) {
    switch (stage) {
        case Stage::IntegrateVelocities:
            faults_.clear();
            start_x_ = state_.x;  // no allocation once the arrays have grown
            start_q_ = state_.q;
            unintegrated_time_ = ctx.h;
            // One region for the stage: the masses and velocities body by body on the workers.
            region_.run(body_stage_tasks(), [&] {
                prepare_mass_state();
                solver_->before_integrate_velocities(*this, ctx.h);
                if (!solver_->integrates_itself()) integrate_velocities(ctx.h);
            });
            break;
        case Stage::DetectCollisions: detect_collisions(ctx.h); break;
        case Stage::SolveVelocities:
            refresh_active_contacts();  // a coupling hook may have woken an island since detection
            compute_support_levels();
            solver_->solve_velocities(*this, ctx.h);
            unintegrated_time_ = solver_->unintegrated_time_after_solve(ctx.h);
            break;
        case Stage::IntegratePositions:
            integrate_positions(ctx.h);
            unintegrated_time_ = 0;
            break;
        default: break;
    }
}

bool RigidSystem::gravity_in_solve() const { return solver_->integrates_itself(); }

const std::vector<JointId>& RigidSystem::broken_joints() const { return joints_->broken(); }

void RigidSystem::add_rows(ConstraintRows* rows) {
    if (!rows) throw RigidError("add_rows: rows is null");
    if (std::find(row_sources_.begin(), row_sources_.end(), rows) != row_sources_.end())
        throw RigidError("add_rows: this source of rows was already added");
    row_sources_.push_back(rows);
}

void RigidSystem::remove_rows(ConstraintRows* rows) {
    if (rows == joints_.get()) return;  // the joints stay
    row_sources_.erase(std::remove(row_sources_.begin(), row_sources_.end(), rows), row_sources_.end());
}

JointId RigidSystem::create_joint(const JointDef& def) {
    JointId id = joints_->create(def, *this);
    if (valid(def.body_a)) wake_island(def.body_a.index);
    if (valid(def.body_b)) wake_island(def.body_b.index);
    return id;
}

void RigidSystem::destroy_joint(JointId id) {
    if (!joints_->valid(id)) throw RigidError("destroy_joint: stale or unknown joint id");
    const JointDef d = joints_->def(id);
    joints_->destroy(id);
    if (valid(d.body_a)) wake_island(d.body_a.index);
    if (valid(d.body_b)) wake_island(d.body_b.index);
}

}  // namespace sinew
