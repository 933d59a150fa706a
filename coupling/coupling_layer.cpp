// The coupling layer (coupling/coupling_layer.hpp): hooks, strategy choice, reactions and reports.
#include "coupling/coupling_layer.hpp"

#include <string>

namespace sinew {

CouplingLayer::CouplingLayer(Pipeline& pipeline, RigidSystem& rigid, SoftSystem& soft)
    : pipeline_(pipeline), rigid_(rigid), soft_(soft), kinematics_(pipeline, rigid, soft), rows_(soft, settings_) {
    rigid_.add_rows(&rows_);
    const int soft_index = pipeline.find_system(soft.name());
    hooks_[0] = pipeline.add_hook(soft_index, Stage::SolveVelocities, HookWhen::Before,
                                  [this](const StepContext& ctx) { before_soft_solve(ctx.h); }, "coupling: rows -> soft");
    hooks_[1] = pipeline.add_hook(soft_index, Stage::SolveVelocities, HookWhen::After,
                                  [this](const StepContext&) { after_soft_solve(); }, "coupling: soft -> rigid");
    hooks_[2] = pipeline.add_hook(soft_index, Stage::IntegratePositions, HookWhen::After,
                                  [this](const StepContext&) { after_step(); }, "coupling: report");
}

CouplingLayer::~CouplingLayer() {
    for (int h : hooks_) pipeline_.remove_hook(h);
    rigid_.remove_rows(&rows_);
}

void CouplingLayer::set_settings(const CouplingSettings& s) {
    const std::string problem = coupling_settings_problem(s);
    if (!problem.empty()) throw CouplingError(problem);
    for (std::size_t k = 0; k < s.pairs.size(); ++k) {
        const CouplingPair& p = s.pairs[k];
        if (!soft_.valid(p.soft))
            throw CouplingError("coupling pair " + std::to_string(k) + ": soft body " + std::to_string(p.soft.index) +
                                " (generation " + std::to_string(p.soft.generation) + ") does not exist");
        if (!p.rigid.is_null() && !rigid_.valid(p.rigid))
            throw CouplingError("coupling pair " + std::to_string(k) + ": rigid body " + std::to_string(p.rigid.index) +
                                " (generation " + std::to_string(p.rigid.generation) + ") does not exist");
    }
    settings_ = s;
}

bool CouplingLayer::any(CouplingStrategy s) const {
    if (settings_.strategy == s) return true;
    for (const CouplingPair& p : settings_.pairs)
        if (p.strategy == s) return true;
    return false;
}

void CouplingLayer::before_soft_solve(Real h) {
    sent_back_.clear();
    rows_.hand_to_soft_prediction(h);
}

void CouplingLayer::after_soft_solve() {
    // Every velocity is solved and no position has moved (seed 001 Figure 9): the reactions go back now,
    // so the rigid bodies' positions of this step already feel them.
    if (any(CouplingStrategy::Hybrid)) send_back_contact_impulses(CouplingStrategy::Hybrid, settings_.gain);
    if (rows_.empty()) return;
    send_back_contact_impulses(CouplingStrategy::TwoWay, 1);
    rows_.take_soft_velocities();
    for (int i = 1; i < settings_.exchange_iterations; ++i) rows_.exchange_pass(rigid_);
}

void CouplingLayer::send_back_contact_impulses(CouplingStrategy strategy, Real gain) {
    const std::vector<ParticleContact>& contacts = soft_.contacts();
    const std::vector<Collider>& colliders = soft_.colliders();
    RigidSystem::State& st = rigid_.state();
    std::uint32_t last_body = kNoOwner, last_collider = kNoOwner;
    bool coupled = false;
    for (const ParticleContact& pc : contacts) {
        const Collider& c = colliders[pc.collider];
        if (pc.body != last_body || pc.collider != last_collider) {
            last_body = pc.body;
            last_collider = pc.collider;
            coupled = c.dynamic && c.owner < st.inv_mass.size() &&
                      coupling_strategy_of(settings_, soft_.id_of_slot(pc.body), rigid_.id_of_slot(c.owner)) == strategy;
        }
        if (!coupled || pc.impulse.isZero()) continue;
        const std::uint32_t o = c.owner;
        const Vec3 j = -gain * pc.impulse;
        if (st.inv_mass[o] == 0) {
            // Asleep: a push that would move it faster than it may sleep wakes it for the next step.
            const BodyId id = rigid_.id_of_slot(o);
            if (j.norm() > rigid_.mass(id) * rigid_.settings().sleep_linear_velocity) rigid_.wake(id);
            continue;
        }
        st.v[o] += st.inv_mass[o] * j;
        st.w[o] += st.inv_inertia_world[o] * (pc.point - st.x[o]).cross(j);
        CouplingImpulse out;
        out.rigid = o;
        out.soft = pc.body;
        out.particle = pc.particle;
        out.point = pc.point;
        out.normal = pc.normal;
        out.impulse = j;
        sent_back_.push_back(out);
    }
}

void CouplingLayer::after_step() {
    impulses_.clear();
    rows_.report(impulses_);
    impulses_.insert(impulses_.end(), sent_back_.begin(), sent_back_.end());
}

}  // namespace sinew
