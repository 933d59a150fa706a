// The coupling layer (coupling/coupling_layer.hpp): hooks, strategy choice, reactions and reports.
#include "coupling/coupling_layer.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace sinew {

CouplingLayer::CouplingLayer(Pipeline& pipeline, RigidSystem& rigid, SoftSystem& soft)
    : pipeline_(pipeline), rigid_(rigid), soft_(soft), kinematics_(pipeline, rigid, soft), rows_(soft, settings_),
      embedding_(pipeline, rigid, soft), fem_embedding_(rigid, soft, embedding_) {
    embedding_.set_before_step([this] { resolve_if_changed(); });
    rigid_.add_rows(&rows_);
    const int soft_index = pipeline.find_system(soft.name());
    hooks_[0] = pipeline.add_hook(soft_index, Stage::SolveVelocities, HookWhen::Before,
                                  [this](const StepContext& ctx) { before_soft_solve(ctx.h); }, "coupling: rows -> soft");
    hooks_[1] = pipeline.add_hook(soft_index, Stage::SolveVelocities, HookWhen::After,
                                  [this](const StepContext& ctx) { after_soft_solve(ctx.h); }, "coupling: soft -> rigid");
    hooks_[2] = pipeline.add_hook(soft_index, Stage::IntegratePositions, HookWhen::After,
                                  [this](const StepContext&) { after_step(); }, "coupling: report");
    hooks_[3] = pipeline.add_hook(soft_index, Stage::IntegrateVelocities, HookWhen::Before,
                                  [this](const StepContext& ctx) { begin_step(ctx.h); }, "coupling: rigid ties");
    const int rigid_index = pipeline.find_system(rigid.name());
    hooks_[4] = pipeline.add_hook(rigid_index, Stage::SolveVelocities, HookWhen::Before,
                                  [this](const StepContext&) { send_back_tie_impulses(); }, "coupling: ties -> rigid");
    hooks_[5] = pipeline.add_hook(rigid_index, Stage::IntegrateVelocities, HookWhen::Before,
                                  [this](const StepContext&) {
                                      apply_interleaved_forces();
                                      apply_late_impulses();
                                  },
                                  "interleaved and sub-stepped hybrid: last step's reactions -> rigid");
    hooks_[7] = pipeline.add_hook(soft_index, Stage::IntegratePositions, HookWhen::Before,
                                  [this](const StepContext&) { keep_tied_bodies_awake(); }, "two-way: tied bodies sleep together");
    hooks_[6] = pipeline.add_hook(soft_index, Stage::DetectCollisions, HookWhen::After,
                                  [this](const StepContext&) {
                                      snapshot_colliders();
                                      fem_embedding_.wake_touched();
                                  },
                                  "interleaved: predicted poses; embed-fem: woken proxies wake their bodies");
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
    fem_embedding_.check(s);  // before the picks join the pairs: an error names the pair as set
    if (s.strategy == CouplingStrategy::Auto) {
        apply_auto(s);
    } else {
        apply(s);
        picks_.clear();
    }
    requested_ = s;
}

void CouplingLayer::apply_auto(const CouplingSettings& requested) {
    std::vector<StrategyPick> picks;
    apply(resolve(requested, picks));
    picks_ = std::move(picks);
}

CouplingSettings CouplingLayer::resolve(const CouplingSettings& requested, std::vector<StrategyPick>& picks) {
    held_.erase(std::remove_if(held_.begin(), held_.end(), [&](SoftBodyId id) { return !soft_.valid(id); }), held_.end());
    picks = pick_strategies(rigid_, soft_, embedding_, fem_embedding_, requested.tolerance, held_);
    CouplingSettings out = requested;
    out.strategy = CouplingStrategy::OneWay;  // a body created since the pick, until the next one
    out.embed_proxies = EmbedProxies::Body;   // the granularity the rules were measured with
    out.pairs.clear();
    for (const StrategyPick& p : picks) out.pairs.push_back({p.soft, BodyId{}, p.strategy});
    out.pairs.insert(out.pairs.end(), requested.pairs.begin(), requested.pairs.end());  // the user's win
    for (StrategyPick& p : picks)  // and the picks say so
        for (const CouplingPair& q : requested.pairs)
            if (q.soft == p.soft && q.rigid.is_null()) {
                p.strategy = q.strategy;
                p.reason = "a pair of the settings names it";
            }
    return out;
}

void CouplingLayer::apply(const CouplingSettings& s) {
    fem_embedding_.check(s);
    embedding_.update_membership(s);  // CouplingError (a body no proxy can be made of) changes nothing
    if (s.substeps != settings_.substeps) {
        soft_.set_substeps(s.substeps, [this](int j, Real) { before_soft_substep(j); });
        kinematics_.set_substeps(s.substeps);
    }
    settings_ = s;
    picked_revision_[0] = rigid_.structure_revision();
    picked_revision_[1] = soft_.structure_revision();
}

void CouplingLayer::refresh_embedding() {
    if (requested_.strategy == CouplingStrategy::Auto) apply_auto(requested_);
    else embedding_.update_membership(settings_);
}

void CouplingLayer::need_proxy(SoftBodyId soft) {
    if (requested_.strategy != CouplingStrategy::Auto || !soft_.valid(soft) ||
        std::find(held_.begin(), held_.end(), soft) != held_.end()) {
        refresh_embedding();
        return;
    }
    held_.push_back(soft);
    try {
        apply_auto(requested_);
    } catch (const CouplingError&) {
        held_.pop_back();  // as it was
        throw;
    }
}

void CouplingLayer::resolve_if_changed() {
    if (requested_.strategy != CouplingStrategy::Auto) return;
    if (rigid_.structure_revision() == picked_revision_[0] && soft_.structure_revision() == picked_revision_[1]) return;
    try {
        apply_auto(requested_);
    } catch (const CouplingError&) {
        // A body whose proxy cannot be made (a node not finite): the last picks stay; the soft step's
        // faults tell.
    }
}

bool CouplingLayer::any(CouplingStrategy s) const {
    if (settings_.strategy == s) return true;
    for (const CouplingPair& p : settings_.pairs)
        if (p.strategy == s) return true;
    return false;
}

void CouplingLayer::begin_step(Real h) {
    fem_embedding_.place(settings_, any(CouplingStrategy::EmbedFem), h);
    rows_.reset();
    attach_ties_.clear();
    // Implicit Euler bodies under two-way coupling record their contacts (FEM bodies always do): the
    // next solve holds those against static colliders and ties them to the dynamic bodies.
    const bool world_two_way = settings_.strategy == CouplingStrategy::TwoWay;
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        SoftBody& b = soft_.slot_body(s);
        bool two_way = world_two_way;
        bool one_solver = settings_.strategy == CouplingStrategy::OneSolver;
        const SoftBodyId id = soft_.id_of_slot(s);
        for (const CouplingPair& p : settings_.pairs)
            if (p.soft == id) {
                two_way = two_way || p.strategy == CouplingStrategy::TwoWay;
                one_solver = one_solver || p.strategy == CouplingStrategy::OneSolver;
            }
        // One solver: a mass-spring body's whole solve moves into the rigid solver (ParticleRows). FEM
        // bodies (their elements are not swept there) and Verlet bodies (hard links: as rows they converged
        // too slowly without warm starting and diverged with it) are coupled as under two-way.
        b.solved_by_rows = one_solver && !b.fem && b.def.method != SoftMethod::Verlet;
        two_way = (two_way || one_solver) && !b.solved_by_rows;  // a body solved in the rigid solver has no ties
        if (b.solved_by_rows) b.contact_tie_impulse.clear();
        b.hold_contacts = two_way;
        if (two_way && b.awake) tie_rigid_bodies(b, id, s, h);
        else b.coupled_rigids.clear();
        ask_attachment_reactions(b, id);
    }
    sent_back_.clear();
}

void CouplingLayer::tie_rigid_bodies(SoftBody& b, SoftBodyId id, std::uint32_t slot, Real h) {
    // Each particle the last contact pass (or the rows) found on a dynamic rigid body is tied to that body
    // in this step's implicit solve (soft/implicit_euler.cpp, "Rigid bodies in the solve"): the body's
    // velocity and angular velocity join the solve's unknowns (starting where the body is now, gravity
    // over the step included if the solver adds it later), and the particle moves with the body's point
    // along the normal, or in all three directions where friction holds it; the body then takes what it
    // gave the particles (send_back_tie_impulses). Coulomb a step late: a particle whose impulse left the
    // cone is tied along the normal only in the next step, under kinetic friction (send_back_tie_impulses),
    // and so is a particle new to the contact set.
    // Tried before and replaced:
    //  - the body's mass split evenly over the particles touching it as independent shares, each moving
    //    with its particle: their impulses did not agree with one body velocity, and a ball resting in a
    //    cloth rocked at 1-3 cm/s and never slept, the set of particles carrying it alternating sides every
    //    step; four corner shares of a box sum to less than its mass where the whole point inertia was used;
    //  - a prescribed speed with the reaction sent explicitly (Baraff-Witkin's filter): it made energy
    //    (a 1 kg ball bounced 12% above its drop height off a 0.5 kg cloth) and diverged once the cloth's
    //    damping passed about 2 M / (h N) (20 N s/m here);
    //  - shares along the normal only, friction left to the rows and the contact pass: the ball resting
    //    in the cloth spun up (to 7 rad/s in 3 s) and rolled off, the cloth's tangential pull reaching its
    //    small rotational inertia a step late.
    b.coupled_rigids.clear();
    // The friction state of last step's ties; none once a step goes by without ties (a bounce), or for a
    // body new in the slot.
    if (slip_.size() <= slot) slip_.resize(slot + 1);
    if (tied_before_.size() <= slot) tied_before_.resize(slot + 1);
    std::vector<Vec3>& slip = slip_[slot];
    std::vector<std::uint8_t>& tied_before = tied_before_[slot];
    const auto forget_ties = [&] {
        slip.assign(b.p.size(), Vec3::Zero());
        tied_before.assign(b.p.size(), 0);
    };
    if (slip.size() != b.p.size() || tied_before.size() != b.p.size()) forget_ties();
    const bool contacts_known = b.contact_owner.size() == b.p.size() && b.contact_normal.size() == b.p.size();
    if (!contacts_known && b.attachments.empty()) return forget_ties();
    const RigidSystem::State& st = rigid_.state();
    const bool gravity_pending = rigid_.gravity_in_solve();
    const auto eligible = [&](std::uint32_t i) {
        if (!contacts_known) return false;
        const std::uint32_t o = b.contact_owner[i];
        if (b.p.inv_mass[i] == 0 || b.contact_normal[i].isZero() || o >= rigid_.slot_count() || !rigid_.slot_alive(o))
            return false;
        if (rigid_.slot_type(o) != BodyType::Dynamic || st.inv_mass[o] == 0) return false;
        return ties_with(b, coupling_strategy_of(settings_, id, rigid_.id_of_slot(o)));
    };
    // Per rigid slot, its index in b.coupled_rigids (kNoRigid: none yet); the slots used are reset at the end.
    if (rigid_index_.size() < rigid_.slot_count()) rigid_index_.resize(rigid_.slot_count(), SoftBody::kNoRigid);
    const auto body_index = [&](std::uint32_t o) {
        if (rigid_index_[o] != SoftBody::kNoRigid) return rigid_index_[o];
        const BodyId rid = rigid_.id_of_slot(o);
        SoftBody::CoupledRigid c;
        c.owner = o;
        c.com = st.x[o];
        c.v = st.v[o];
        if (gravity_pending) c.v += h * rigid_.gravity_scale(rid) * rigid_.settings().gravity;
        c.w = st.w[o];
        c.mass = rigid_.mass(rid);
        const Mat3& inv_i = st.inv_inertia_world[o];
        const Real scale = inv_i.trace();
        c.rotates = scale > 0 && inv_i.determinant() > Real(1e-9) * scale * scale * scale;
        if (c.rotates) c.inertia = inv_i.inverse();
        rigid_index_[o] = std::uint32_t(b.coupled_rigids.size());
        coupled_slots_.push_back(o);
        b.coupled_rigids.push_back(c);
        return rigid_index_[o];
    };
    // Attachments to a dynamic body under two-way coupling: the attached particle moves with the body's
    // point in all three directions and joins the solve (soft/implicit_euler.cpp): the rope's springs
    // then pull the body implicitly, which a heavy body on a light rope (1:1000) needs. Only implicit
    // Euler solves with bodies; a sleeping body is woken first, since a soft body that moves pulls on it.
    const std::size_t first_attachment = attach_ties_.size();
    if (b.def.method == SoftMethod::ImplicitEuler)
        for (const Attachment& a : b.attachments) {
            BodyId rid;
            if (!dynamic_target(a, rid)) continue;
            if (!ties_with(b, coupling_strategy_of(settings_, id, rid))) continue;
            if (st.inv_mass[rid.index] == 0) rigid_.wake(rid);
            if (st.inv_mass[rid.index] == 0) continue;
            const Vec3 arm = rigid_.slot_transform(rid.index).apply(a.local_point) - st.x[rid.index];
            attach_ties_.push_back({slot, a.particle, rid.index, arm});
        }
    bool any_tie = attach_ties_.size() > first_attachment;
    for (std::uint32_t i = 0; i < b.p.size() && !any_tie; ++i) any_tie = eligible(i);
    if (!any_tie) return forget_ties();
    b.contact_rigid.assign(b.p.size(), SoftBody::kNoRigid);
    b.contact_stick.assign(b.p.size(), 0);
    b.contact_gap.assign(b.p.size(), Real(0));
    b.contact_arm.assign(b.p.size(), Vec3::Zero());
    b.contact_friction.assign(b.p.size(), Vec3::Zero());
    for (std::size_t k = first_attachment; k < attach_ties_.size(); ++k) {
        const AttachTie& a = attach_ties_[k];
        b.contact_rigid[a.particle] = body_index(a.rigid);
        b.contact_stick[a.particle] = 1;
        b.contact_arm[a.particle] = a.arm;
    }
    for (std::uint32_t i = 0; i < b.p.size(); ++i) {
        if (!eligible(i)) continue;
        const std::uint32_t o = b.contact_owner[i];
        const Vec3 r = b.p.x[i] - st.x[o];
        const SoftBody::CoupledRigid& body = b.coupled_rigids[body_index(o)];
        // Tied along the line through the particle: on a round body, through its axis.
        Vec3 round_normal, surface;
        if (round_body_normal(rigid_.slot_shape(o), rigid_.slot_transform(o), b.p.x[i], b.contact_normal[i],
                              3 * b.def.thickness, round_normal, surface))
            b.contact_normal[i] = round_normal;
        Vec3 closest, normal;
        Real distance = 0;
        if (point_shape_distance(b.p.x[i], rigid_.slot_shape(o), rigid_.slot_transform(o), 3 * b.def.thickness, closest,
                                 normal, distance))
            b.contact_gap[i] = distance - b.def.thickness;
        const Vec3& n = b.contact_normal[i];
        b.contact_speed[i] = n.dot(body.point_velocity(r));
        b.contact_rigid[i] = rigid_index_[o];
        b.contact_arm[i] = r;
        const bool friction = tie_friction(b, o) > 0;
        b.contact_stick[i] = friction && slip[i].isZero() && tied_before[i] ? 1 : 0;
        // Across this step's normal (last step's may have turned a little).
        b.contact_friction[i] = friction ? Vec3(slip[i] - slip[i].dot(n) * n) : Vec3::Zero();
    }
    for (const std::uint32_t o : coupled_slots_) rigid_index_[o] = SoftBody::kNoRigid;
    coupled_slots_.clear();
}

bool CouplingLayer::dynamic_target(const Attachment& a, BodyId& out) const {
    out = unpack_body_id(a.target);
    return a.frame_valid && rigid_.valid(out) && rigid_.slot_type(out.index) == BodyType::Dynamic;
}

void CouplingLayer::ask_attachment_reactions(SoftBody& b, SoftBodyId id) {
    // Hybrid and interleaved attachments to dynamic bodies send back what holding the particle took;
    // implicit Euler reports it (SoftBody::attachment_impulse).
    bool wanted = false;
    if (b.def.method == SoftMethod::ImplicitEuler)
        for (const Attachment& a : b.attachments) {
            BodyId rid;
            if (!dynamic_target(a, rid)) continue;
            const CouplingStrategy st = coupling_strategy_of(settings_, id, rid);
            wanted = wanted || st == CouplingStrategy::Hybrid || st == CouplingStrategy::Interleaved;
        }
    if (wanted) b.attachment_impulse.assign(b.attachments.size(), Vec3::Zero());
    else b.attachment_impulse.clear();
}

void CouplingLayer::send_back_attachment_reactions(Real h) {
    RigidSystem::State& st = rigid_.state();
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        const SoftBody& b = soft_.slot_body(s);
        if (!b.stepping || b.attachment_impulse.size() != b.attachments.size()) continue;
        const SoftBodyId id = soft_.id_of_slot(s);
        for (std::size_t k = 0; k < b.attachments.size(); ++k) {
            const Attachment& a = b.attachments[k];
            BodyId rid;
            if (!dynamic_target(a, rid)) continue;
            const CouplingStrategy strategy = coupling_strategy_of(settings_, id, rid);
            const std::uint32_t o = rid.index;
            const Vec3 point = rigid_.slot_transform(o).apply(a.local_point);
            if (strategy == CouplingStrategy::Hybrid) {
                const Vec3 j = -settings_.gain * b.attachment_impulse[k];
                if (j.isZero()) continue;
                if (st.inv_mass[o] == 0) {
                    if (j.norm() > rigid_.mass(rid) * rigid_.settings().sleep_linear_velocity) rigid_.wake(rid);
                    continue;
                }
                st.v[o] += st.inv_mass[o] * j;
                st.w[o] += st.inv_inertia_world[o] * (point - st.x[o]).cross(j);
                sent_back_.push_back({o, s, a.particle, point, Vec3::Zero(), j});
            } else if (strategy == CouplingStrategy::Interleaved) {
                const Vec3 j = -b.attachment_impulse[k];
                if (j.isZero()) continue;
                pending_forces_.push_back({o, rid.generation, a.local_point, j / h});  // next step, as a force
                sent_back_.push_back({o, s, a.particle, point, Vec3::Zero(), j});
            }
        }
    }
}

void CouplingLayer::send_back_tie_impulses() {
    if (!any(CouplingStrategy::TwoWay) && !any(CouplingStrategy::OneSolver)) return;
    const RigidSystem::State& st = rigid_.state();
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        const SoftBody& b = soft_.slot_body(s);
        const std::size_t n = b.p.size();
        if (!b.stepping || b.coupled_rigids.empty() || b.contact_rigid.size() != n || b.contact_tie_impulse.size() != n)
            continue;
        std::vector<Vec3>& slip = slip_[s];
        for (std::uint32_t i = 0; i < n; ++i) {
            if (b.p.inv_mass[i] == 0) continue;  // attachments below
            const Vec3& jp = b.contact_tie_impulse[i];  // what the body gave the particle
            // In the contact set this step, whether or not the solve gave it a row: one it left out for a
            // step (moving away, or released after pulling) is not a new impact. Counted only with a row,
            // the ball in the cloth kept rocking at up to 0.95 rad/s under Newton in double, for 40 s.
            tied_before_[s][i] = b.contact_rigid[i] != SoftBody::kNoRigid;
            if (!tied_before_[s][i] || jp.isZero()) {
                slip[i].setZero();
                continue;
            }
            const SoftBody::CoupledRigid& body = b.coupled_rigids[b.contact_rigid[i]];
            const std::uint32_t o = body.owner;
            const Vec3& arm = b.contact_arm[i];
            const Vec3& nrm = b.contact_normal[i];
            // Coulomb, a step late. A particle held in all three directions whose tangential impulse left
            // the cone slides in the next step, tied along the normal, under kinetic friction mu jn along
            // that impulse. A sliding one keeps sliding, friction against its motion relative to the
            // body's point, until friction has stopped it (its end velocity there no longer runs against
            // the friction), and is held again. Without the kinetic friction (a sliding particle free
            // across the normal) the particles under a ball resting in a cloth held and slid in turns,
            // every other step, and the ball rolled in place at 0.24 rad/s.
            const Real jn = jp.dot(nrm);
            const Vec3 jt = jp - jn * nrm;
            const Real bound = tie_friction(b, o) * std::max(jn, Real(0));
            if (b.contact_stick[i]) {
                const Real t = jt.norm();
                slip[i] = t > bound ? Vec3((bound / t) * jt) : Vec3::Zero();
            } else if (!slip[i].isZero()) {
                Vec3 u = b.p.v[i] - body.end_point_velocity(arm);
                u -= u.dot(nrm) * nrm;
                const Real speed = u.norm();
                slip[i] = u.dot(slip[i]) < 0 && speed > 0 ? Vec3((-bound / speed) * u) : Vec3::Zero();
            }
            // Along the line through the particle; given inside the rigid solve, a part per sub-step
            // (ParticleRows::queue_push). A body whose rotation the solve left out (rotates: false) takes
            // no moment either.
            const Vec3 j = -jp;
            rows_.queue_push(o, j, body.rotates ? arm : Vec3::Zero());
            sent_back_.push_back({o, s, i, b.p.x[i] - b.def.thickness * nrm, nrm, j, true});
        }
    }
    // Attachments: what the tie gave the attached particle, taken from the body at the attachment point.
    for (const AttachTie& a : attach_ties_) {
        const SoftBody& b = soft_.slot_body(a.soft);
        if (!b.stepping || b.contact_tie_impulse.size() != b.p.size()) continue;
        const Vec3 j = -b.contact_tie_impulse[a.particle];
        if (j.isZero() || b.contact_rigid.size() != b.p.size() || b.contact_rigid[a.particle] >= b.coupled_rigids.size()) continue;
        rows_.queue_push(a.rigid, j, b.coupled_rigids[b.contact_rigid[a.particle]].rotates ? a.arm : Vec3::Zero());
        sent_back_.push_back({a.rigid, a.soft, a.particle, st.x[a.rigid] + a.arm, Vec3::Zero(), j, true});
    }
}

void CouplingLayer::before_soft_solve(Real h) {
    keep_previous_poses();
    rows_.hand_to_soft_prediction(h, rigid_.unintegrated_time());
}

void CouplingLayer::after_soft_solve(Real h) {
    // Every velocity is solved and no position has moved (seed 001 Figure 9): the reactions go back now,
    // so the rigid bodies' positions of this step already feel them.
    fem_embedding_.send_back(sent_back_);
    if (any(CouplingStrategy::Hybrid)) send_back_contact_impulses(CouplingStrategy::Hybrid, settings_.gain);
    if (any(CouplingStrategy::Interleaved)) gather_interleaved_forces(h);
    if (any(CouplingStrategy::Hybrid) || any(CouplingStrategy::Interleaved)) send_back_attachment_reactions(h);
    if (rows_.empty()) return;
    send_back_contact_impulses(CouplingStrategy::TwoWay, 1);
    send_back_contact_impulses(CouplingStrategy::OneSolver, 1);
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
        // On the normal through the particle, where the particle is now (as the rows do).
        st.w[o] += st.inv_inertia_world[o] * (soft_.slot_body(pc.body).p.x[pc.particle] - st.x[o]).cross(j);
        sent_back_.push_back({o, pc.body, pc.particle, pc.point, pc.normal, j});
    }
}

void CouplingLayer::before_soft_substep(int j) {
    // Sub-step j has finished (the first one's reaction went back after its solve): hybrid keeps what its
    // contacts gave, for the next step.
    if (j >= 2) collect_hybrid_reaction();
    kinematics_.place_substep(j);
}

void CouplingLayer::collect_hybrid_reaction() {
    if (!any(CouplingStrategy::Hybrid)) return;
    const std::vector<Collider>& colliders = soft_.colliders();
    for (const ParticleContact& pc : soft_.contacts()) {
        const Collider& c = colliders[pc.collider];
        if (!c.dynamic || c.owner >= rigid_.slot_count() || !rigid_.slot_alive(c.owner) || pc.impulse.isZero()) continue;
        const BodyId rid = rigid_.id_of_slot(c.owner);
        if (coupling_strategy_of(settings_, soft_.id_of_slot(pc.body), rid) != CouplingStrategy::Hybrid) continue;
        const Vec3 j = -settings_.gain * pc.impulse;
        // In the body's frame at the pose the sub-step met it; applied next step where the body is then.
        late_impulses_.push_back({c.owner, rid.generation, c.xf.apply_inverse(pc.point), j});
        sent_back_.push_back({c.owner, pc.body, pc.particle, pc.point, pc.normal, j});
    }
    // And what the sub-step's hybrid attachments took.
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        const SoftBody& b = soft_.slot_body(s);
        if (!b.stepping || b.attachment_impulse.size() != b.attachments.size()) continue;
        for (std::size_t k = 0; k < b.attachments.size(); ++k) {
            const Attachment& a = b.attachments[k];
            BodyId rid;
            if (!dynamic_target(a, rid)) continue;
            if (coupling_strategy_of(settings_, soft_.id_of_slot(s), rid) != CouplingStrategy::Hybrid) continue;
            const Vec3 j = -settings_.gain * b.attachment_impulse[k];
            if (j.isZero()) continue;
            late_impulses_.push_back({rid.index, rid.generation, a.local_point, j});
            sent_back_.push_back({rid.index, s, a.particle, rigid_.slot_transform(rid.index).apply(a.local_point), Vec3::Zero(), j});
        }
    }
}

void CouplingLayer::apply_late_impulses() {
    for (const PendingForce& f : late_impulses_) {
        if (f.rigid >= rigid_.slot_count() || !rigid_.slot_alive(f.rigid)) continue;
        const BodyId id = rigid_.id_of_slot(f.rigid);
        if (id.generation != f.generation) continue;
        if (!is_finite(f.force)) continue;  // as apply_interleaved_forces
        rigid_.apply_impulse(id, f.force, rigid_.slot_transform(f.rigid).apply(f.local_point));
    }
    late_impulses_.clear();
}

void CouplingLayer::keep_tied_bodies_awake() {
    // After the rigid bodies' sleep update, before the soft bodies': a soft body whose solve carried an
    // awake rigid body this step must not fall asleep under it. Measured on ball-on-trampoline: the cloth,
    // its particles slower than the sleep speed, slept while the ball on it was still settling at 1-2
    // cm/s; the ball then fell through one step untied (0.34 m/s) and woke the cloth again.
    for (std::uint32_t s = 0; s < soft_.slot_count(); ++s) {
        if (!soft_.slot_alive(s)) continue;
        SoftBody& b = soft_.slot_body(s);
        if (!b.stepping) continue;
        for (const SoftBody::CoupledRigid& c : b.coupled_rigids)
            if (rigid_.slot_alive(c.owner) && rigid_.awake(rigid_.id_of_slot(c.owner))) b.kept_awake = true;
    }
}

void CouplingLayer::after_step() {
    if (settings_.substeps > 1) collect_hybrid_reaction();  // the last sub-step's
    repair_interleaved();
    // A particle the rows pushed is in contact even if the contact pass, which looks at the particle's
    // final position, found it just outside its slop (the soft step's rows settle a box about 0.2
    // thicknesses above a block, and with rows alone the block sank ten times its static depth): it
    // is tied to the body in the next step's implicit solve too.
    rows_.for_each_pushing([&](std::uint32_t s, std::uint32_t i, std::uint32_t rigid, const Vec3& n) {
        SoftBody& b = soft_.slot_body(s);
        if (b.contact_normal.size() != b.p.size() || b.contact_owner.size() != b.p.size()) return;
        if (!b.contact_normal[i].isZero()) return;
        b.contact_normal[i] = n;
        b.contact_owner[i] = rigid;
    });
    impulses_.clear();
    rows_.report(impulses_);
    impulses_.insert(impulses_.end(), sent_back_.begin(), sent_back_.end());
}

}  // namespace sinew
